"""Talking over the robot in Debian's Chromium, hands-free, in real time: the microphone hears
the robot's own voice back (10 dB down, as the page plays it) and never takes it for the
person; a "stop" said over the robot's question cuts its audio short at once, and the robot
acts on it."""

from __future__ import annotations

from base64 import b64encode as base64_of
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import Page

from oxbot.config import load_config
from oxbot.dialogue.domain import INVITATION
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes, trim_silence
from oxbot.speech.evaluation import speak
from oxbot.testing.browser import CHROMIUM, conversation_page, log_items
from oxbot.web.server import create_app

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts" / "web"
CONFIG = load_config(
    None, ["robot.speed_factor=1", "robot.question_timeout=30", "robot.hang_seconds=10"]
)
"""Real time: the robot's clock and the page's audio agree, as with a person."""
ECHO_DB = -10.0
APP = create_app(CONFIG)
CUT_WITHIN = 1.0
"""Seconds from the first sound of the person's "stop" to the robot's audio stopped: cut short,
not played to its end (how soon is bench/bench_barge_in.py's to measure: a median of 178 ms)."""


@pytest.fixture(scope="module")
def page() -> Iterator[Page]:
    assert Path(CHROMIUM).exists(), f"{CHROMIUM} is missing: run `make setup`"
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    with conversation_page(APP, echo_db=ECHO_DB) as tab:
        yield tab


def test_the_robots_echo_is_never_the_person_and_a_stop_over_it_cuts_it_short(page: Page):
    try:
        talk_over(page)
    except Exception as exc:
        page.screenshot(path=ARTIFACTS / "talking-over-failure.png", full_page=True)
        acts = page.evaluate("window.oxbot.stats.acts.map((a) => a.act)")
        notes = page.evaluate(
            "[document.getElementById('status').textContent, window.oxbot.stats.closed,"
            " ...[...document.querySelectorAll('li.note')].map((n) => n.textContent)]"
        )
        acts = f"{acts}\nthe page's notes: {notes}"
        raise AssertionError(
            f"{exc}\nthe page's log: {log_items(page)}\nacts: {acts}\nthe server: {server()}"
        ) from exc


def server() -> list[str]:
    """What each session's robot and listener were doing, for a failure's message."""
    seen = []
    for session in APP.state.sessions.values():
        for component in session.robot.components:
            state = getattr(component, "phase", None) or getattr(component, "speaking", None)
            seen.append(f"{type(component).__name__}: {state}")
        listener = session.listener
        if listener is not None:
            echo = listener.echo
            seen.append(
                f"listener: heard {[round(u.seconds, 2) for u in listener.heard]}, cuts "
                f"{len(listener.cuts)}, echo delay {echo.delay} gain {echo.gain:.3f} "
                f"correlation {echo.correlation:.2f}, speaking {listener._speaking}"
            )
    return seen


def talk_over(page: Page) -> None:
    stop = trim_silence(pcm16(speak("stop", "en-us+m3")), 0.2)
    assert stop is not None
    first_sound = int(np.argmax(np.abs(stop) > 1_000)) / RATE
    page.get_by_test_id("hands-free").click()
    page.wait_for_function("window.oxbot.mic.handsFree", timeout=10_000)
    page.get_by_test_id("start").click()
    # the greeting and the introduction are heard back in the microphone, and left alone
    page.wait_for_function(
        """(act) => window.oxbot.stats.acts.some((a) => a.act === act)""",
        arg=INVITATION,
        timeout=60_000,
    )
    assert page.evaluate("window.__room.echoes") >= 2
    heard_before = [t for t in log_items(page) if t[0] == "usr"]
    assert heard_before == [], heard_before
    # 0.8 s into the question, the person says "stop" over it
    page.wait_for_function("window.oxbot.speaking", timeout=10_000)
    page.wait_for_timeout(800)
    page.evaluate(
        "(b64) => window.__room.say(b64)", base64_of(to_wav_bytes(Audio(stop, RATE))).decode()
    )
    page.wait_for_function("window.oxbot.stats.cuts.length > 0", timeout=5_000)
    said_at, cut_at = page.evaluate("[window.__room.said.at(-1), window.oxbot.stats.cuts[0]]")
    assert page.evaluate("window.oxbot.sources.length") == 0  # nothing of it plays on
    page.wait_for_function(
        """() => [...document.querySelectorAll('[data-testid=log] li[data-act]')]
                   .some((li) => li.dataset.speaker === 'usr')""",
        timeout=20_000,
    )
    page.screenshot(path=ARTIFACTS / "talking-over.png", full_page=True)
    took = (cut_at - said_at) / 1e3 - first_sound
    items = log_items(page)
    heard = [t for t in items if t[0] == "usr"]
    for session in APP.state.sessions.values():  # what the server cut, to listen to after
        for k, utterance in enumerate(session.listener.heard):
            wav = to_wav_bytes(Audio(utterance.samples, RATE))
            (ARTIFACTS / f"talking-over-heard-{k}.wav").write_bytes(wav)
    shown = page.get_by_test_id("heard").inner_text()
    assert heard[0][1] == "Reject(playGame=no)" and "stop" in heard[0][2].lower(), (items, shown)
    assert took <= CUT_WITHIN, f"the robot's audio stopped {took:.3f} s after the word began"
    # and it acts on it: no more questions, it lets the person go
    page.wait_for_function(
        """() => window.oxbot.stats.acts.some((a) => a.act.startsWith('Acknowledge('))""",
        timeout=20_000,
    )
