"""A whole game by voice in Debian's Chromium: the person speaks every answer and every move,
hands-free, from the greeting to the goodbye, and turns down another game with "no thanks".

The person is espeak-ng WAVs played into the page's microphone (`conversation_script`: the
page's getUserMedia hears a room where the test makes the person speak). Chromium's own fake
microphone cannot hold a conversation: it plays one file, from the start, at each getUserMedia.
What the robot hears goes through the real recogniser (Whisper), understanding and manager.
The microphone also hears the robot's own voice back, 10 dB down, as the page plays it: none of
the robot's sentences may be taken for the person's answer.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import Page

from oxbot.config import load_config
from oxbot.dialogue.domain import PROBLEM
from oxbot.game.board import CELL_NAMES
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes, trim_silence
from oxbot.speech.evaluation import speak
from oxbot.testing.browser import CHROMIUM, conversation_page, log_items, say
from oxbot.web.server import create_app

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts" / "web"
CONFIG = load_config(
    None,
    [
        "robot.speed_factor=6",
        "robot.answer_timeout=60",
        "robot.pause_timeout=0",
        "robot.question_timeout=240",
        "robot.hang_seconds=10",
    ],
)
"""6x faster than real time, with 10 s to answer the greeting or the outcome and 40 s to answer
a question: a busy machine never loses the person's turn (nor calls Whisper hung before 10 s).
The person answers a second after the robot stops speaking, longer than the robot's pause at
this speed: it waits for every answer (no pause)."""
VOICE = "en-us+m3"
MOVE = "GameMove(gridloc="
SPOKEN_CELLS = {
    "upperleft": "top left",
    "uppermiddle": "top middle",
    "upperright": "top right",
    "middleleft": "middle left",
    "middle": "centre",
    "middleright": "middle right",
    "lowerleft": "bottom left",
    "lowermiddle": "bottom middle",
    "lowerright": "bottom right corner",
}


def spoken(text: str) -> bytes:
    """`text` said by the person: a WAV with a short silence either side."""
    samples = trim_silence(pcm16(speak(text, VOICE)), 0.3)
    assert samples is not None, text
    return to_wav_bytes(Audio(samples, RATE))


APP = create_app(CONFIG)


@pytest.fixture(scope="module")
def page() -> Iterator[Page]:
    assert Path(CHROMIUM).exists(), f"{CHROMIUM} is missing: run `make setup`"
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    with conversation_page(APP, echo_db=-10.0) as tab:
        yield tab


def wait_for(page: Page, act: str, speaker: str = "sys", after: int = 0, timeout=40_000) -> None:
    wait_for_either(page, [(act, speaker)], after, timeout)


def answer(page: Page, text: str) -> int:
    """Wait until the robot has finished speaking, pause as a person does (the robot does
    not listen to the echo of its own voice), then say `text`; the log's length before."""
    page.wait_for_function("!window.oxbot.speaking", timeout=20_000)
    page.wait_for_timeout(1_000)
    before = len(log_items(page))
    say(page, spoken(text))
    return before


def answer_until_understood(page: Page, phrasings: Sequence[str], act: str) -> int:
    """Say the first of `phrasings` until the robot understands it as `act` (the person's);
    when the robot asks again, say the next, as a person asked "Sorry?" puts it another way:
    how surely Whisper hears a short synthetic answer depends on where in its first 32 ms frame
    the speech begins ("hello": 0.43-0.99 over shifts of 64 samples), which the hands-free
    listener's cut and the machine's load decide; some phrasings are heard surely at every
    shift ("yes let's go", "no thanks"), others never ("okay yes"). The log's length before the
    answer understood."""
    for text in phrasings:
        before = answer(page, text)
        wait_for_either(page, [(act, "usr"), ("Request(repeat)", "sys")], before)
        items = log_items(page)[before:]
        if any(s == "usr" and a.startswith(act) for s, a, _ in items):
            return before
    raise AssertionError(f"none of {list(phrasings)} was understood as {act}")


def wait_for_either(
    page: Page, acts: list[tuple[str, str]], after: int, timeout: int = 40_000
) -> None:
    """Wait until the log shows, after its first `after` entries, one of `acts` (act, speaker)."""
    page.wait_for_function(
        """([acts, after]) =>
             [...document.querySelectorAll('[data-testid=log] li[data-act]')].slice(after)
               .some(li => acts.some(([act, speaker]) =>
                 li.dataset.act.startsWith(act) && li.dataset.speaker === speaker))""",
        arg=[acts, after],
        timeout=timeout,
    )


def test_a_whole_game_by_voice_then_no_thanks_to_another(page: Page):
    try:
        play_by_voice(page)
    except Exception as exc:
        page.screenshot(path=ARTIFACTS / "voice-game-failure.png", full_page=True)
        heard = page.get_by_test_id("heard").inner_text()
        raise AssertionError(
            f"{exc}\nthe page's log: {log_items(page)}\nlast heard: {heard}\n"
            f"the server's hands-free listener: {what_the_server_heard()}"
        ) from exc


def what_the_server_heard() -> list[str]:
    """Each utterance the server cut from the page's stream: its length, its peak, and the
    share of its speech in gaps of exact zeros (what a glitching audio path drops)."""
    heard = []
    for session in APP.state.sessions.values():
        listener = session.listener
        if listener is None:
            continue
        for utterance in listener.heard:
            samples = np.abs(utterance.samples.astype(np.int32))
            loud = np.flatnonzero(samples > 1_000)
            speech = samples[loud[0] : loud[-1] + 1] if len(loud) else samples[:0]
            edges = np.flatnonzero(np.diff(np.concatenate(([1], speech, [1])) == 0))
            gaps = sum(
                int(b - a) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= 32
            )
            heard.append(
                f"{utterance.seconds:.2f} s, peak {int(samples.max())}, "
                f"{gaps / max(1, len(speech)):.0%} of its speech in gaps"
            )
        heard.append(f"not listened to while the robot spoke: {listener.ignored_seconds:.1f} s")
        echo = listener.echo
        heard.append(f"echo delay {echo.delay}, gain {echo.gain:.3f} ({echo.correlation:.2f})")
    return heard


def play_by_voice(page: Page) -> None:
    page.get_by_test_id("start").click()
    wait_for(page, "Salutation(greeting)")
    page.get_by_test_id("hands-free").click()
    page.wait_for_function("window.oxbot.mic.handsFree", timeout=5_000)
    before = answer(page, "hello")
    # heard, as something; the robot goes on whether or not it made it out (it asks nothing)
    wait_for(page, "", speaker="usr", after=before)
    wait_for(page, "Request(playGame)", after=before)
    before = answer_until_understood(
        page,
        ("yes let's play", "yes let's go", "yes I want to play", "yes please"),
        "Confirm(playGame=yes)",
    )
    # what the robot heard is shown, with its confidence
    assert "yes" in page.get_by_test_id("heard").inner_text().lower()

    deadline, spoken_at, named = time.monotonic() + 180, 0, []
    while not any(a.startswith("Provide(feedback=") for _, a, _ in log_items(page)):
        assert time.monotonic() < deadline, "the game never ended"
        items = log_items(page)
        speaker, act, text = items[-1]
        asks = act == "Request(userGameMove)" or (act == PROBLEM and "Which cell" in text)
        if speaker != "sys" or not asks or len(items) <= spoken_at:
            page.wait_for_timeout(100)
            continue
        moves = [a[len(MOVE) : -1] for _, a, _ in items if a.startswith(MOVE) and "$" not in a]
        where = next(cell for cell in CELL_NAMES if cell not in moves)
        named.append(where)
        answer(page, SPOKEN_CELLS[where])
        # the robot heard it (a move, or words it asks about) before the person speaks again
        page.wait_for_function(
            """(n) => [...document.querySelectorAll('[data-testid=log] li[data-act]')]
                 .slice(n).some(li => li.dataset.speaker === 'usr')""",
            arg=len(items),
            timeout=40_000,
        )
        spoken_at = len(log_items(page))
    page.screenshot(path=ARTIFACTS / "voice-game-over.png", full_page=True)
    # the moves said in words are on the page's sheet too, in the person's ink
    strokes = page.evaluate("[...oxbot.committed, ...oxbot.pending].length")
    said = sum(
        1 for s, a, _ in log_items(page) if s == "usr" and a.startswith(MOVE) and "$" not in a
    )
    per_symbol = 2 if page.evaluate("oxbot.hello.user_symbol") == "cross" else 1
    assert strokes == per_symbol * said, (strokes, said)

    # another game is offered, and turned down
    wait_for(page, "Request(anotherGame)")
    for text in ("no thanks", "no I don't want to play"):
        before = answer(page, text)
        wait_for_either(
            page, [("Reject(playGame=no)", "usr"), ("Request(anotherGame)", "sys")], before
        )
        if ("usr", "Reject(playGame=no)") in [(s, a) for s, a, _ in log_items(page)[before:]]:
            break
    wait_for(page, "Salutation(closing)", after=before)
    items = log_items(page)
    assert items[-1][:2] == ("sys", "Salutation(closing)")
    assert ("usr", "Reject(playGame=no)") in [(s, a) for s, a, _ in items[before:]]
    # the person's moves are cells they named, each once
    theirs = [a[len(MOVE) : -1] for s, a, _ in items if s == "usr" and a.startswith(MOVE)]
    theirs = [cell for cell in theirs if "$" not in cell]
    assert len(theirs) >= 2 and len(set(theirs)) == len(theirs) and set(theirs) <= set(named)
    # the robot's voice, heard back all game long, was never taken for the person's: the
    # server heard no more utterances than the person said, and none of the robot's words
    assert page.evaluate("window.__room.echoes") >= len([s for s, _, _ in items if s == "sys"])
    # (a piece of audio a loaded page drops can split one answer in two, heard as nothing)
    turns = sum(1 for s, _, _ in items if s == "usr")
    said = page.evaluate("window.__room.said.length")
    assert turns <= said, f"{turns} turns of the person's, {said} said"
    robot_words = [set(t.lower().strip(".?!").split()) for s, _, t in items if s == "sys"]
    for speaker, _, text in items:
        words = set(text.lower().strip(".?!").split())
        if speaker == "usr" and len(words) >= 3:
            assert not any(len(words & said) >= 0.8 * len(words) for said in robot_words), text
    page.screenshot(path=ARTIFACTS / "voice-game-goodbye.png", full_page=True)
