"""Benchmark of the page's ears: how much of the first word push-to-talk loses.

    .venv/bin/python bench/bench_listen.py --trials 5

An espeak-ng WAV with no leading silence ("yes, let's play") is spoken into the page two ways,
and the recording the server hands the robot is aligned with the WAV by cross-correlation:
the WAV's samples missing before the recording's start are the milliseconds of the first
word lost.

- Chromium's fake microphone (`--use-file-for-fake-audio-capture=...%noloop`) plays the WAV
  once from the moment the page opens the microphone. For each trial the page is loaded
  afresh, Start is pressed, then push-to-talk is held for 2.5 s.
- A person who starts talking the moment the button says "Listening": the page's
  getUserMedia is replaced (before the page loads) by a "room", an AudioContext whose voice
  starts when the button's text changes, heard through a MediaStreamAudioDestinationNode. A
  real microphone hears the room whether the page has opened it or not, so what the page
  misses is what a person loses. Two presses per page: the first opens the microphone, the
  second finds it open (or, before the fix, opens it again). Chromium's fake devices open at
  once; `--open-ms` makes the room's microphone take that long, as real ones do.

Prints each trial and the medians; not a test.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.signal import correlate

from oxbot.config import load_config
from oxbot.robot.messages import SpeechAudio, SpeechHypotheses
from oxbot.robot.session import Robot
from oxbot.speech.audio import RATE, pcm16
from oxbot.testing.browser import CHROMIUM, FLAGS, room_script
from oxbot.web.server import create_app, serving_in_background

PHRASE = "yes, let's play"


def lost_ms(received: np.ndarray, source: np.ndarray) -> tuple[float, float]:
    """Milliseconds of `source` missing before `received` starts, and how well they match
    (normalised correlation at the best lag, 1 = identical)."""
    r, s = received.astype(np.float64), source.astype(np.float64)
    c = correlate(r, s, mode="full", method="fft")
    best = int(np.argmax(c))
    lag = best - (len(s) - 1)  # received[n + lag] ~ source[n]
    start = max(0, -lag)  # the source's first sample that the recording holds
    a = s[start:]
    b = r[max(0, lag) : max(0, lag) + len(a)]
    a = a[: len(b)]
    match = float(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b) + 1e-9))
    return 1000 * start / RATE, match


def person_talks(
    url: str, browser, heard: list, wav: Path, source, presses: int, hold_ms: int, open_ms: int
):
    """Losses of a person who starts at "Listening", per press, in one page."""
    page = browser.new_page()
    page.add_init_script(room_script(wav.read_bytes(), open_ms))
    page.goto(url + "/")
    page.get_by_test_id("start").click()
    page.wait_for_function("window.oxbot.hello !== null", timeout=30_000)
    losses = []
    for _ in range(presses):
        page.wait_for_timeout(500)
        page.get_by_test_id("talk").hover()
        page.mouse.down()
        page.wait_for_timeout(hold_ms)
        page.mouse.up()
        audio, words = received(heard[-1])
        losses.append(lost_ms(pcm16(audio), source) if audio else None)
        yield losses[-1], words
    page.close()


def received(subscription) -> tuple[bytes | None, str | None]:
    """The next recording a robot was handed, and the words it heard in it."""
    audio, words = None, None
    deadline = time.monotonic() + 30
    while words is None and time.monotonic() < deadline:
        message = subscription.get(timeout=0.5)
        if isinstance(message, SpeechAudio):
            audio = message.audio
        elif isinstance(message, SpeechHypotheses) and audio is not None:
            words = message.nbest[0][0] if message.nbest else ""
    return audio, words


def push_to_talk(trials: int, hold_ms: int, open_ms: int):
    from playwright.sync_api import sync_playwright

    config = load_config(None, ["robot.speed_factor=8", "robot.answer_timeout=16"])
    heard: list = []

    def make_robot() -> Robot:
        robot = Robot(config)
        heard.append(robot.bus.subscribe(SpeechAudio, SpeechHypotheses))
        return robot

    losses: list[float] = []
    person: tuple[list[float], list[float]] = ([], [])
    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "yes.wav"
        subprocess.run(["espeak-ng", "-w", str(wav), PHRASE], check=True)
        source = pcm16(wav)
        args = [
            *FLAGS,
            "--use-fake-ui-for-media-stream",
            "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-audio-capture={wav}%noloop",
        ]
        app = create_app(config, robot_factory=make_robot)
        with serving_in_background(app) as url, sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=args)
            for trial in range(trials):
                page = browser.new_page()
                page.goto(url + "/")
                page.get_by_test_id("start").click()
                page.wait_for_function("window.oxbot.hello !== null", timeout=30_000)
                page.get_by_test_id("talk").hover()
                page.mouse.down()
                page.wait_for_timeout(hold_ms)
                page.mouse.up()
                audio, words = received(heard[-1])
                page.close()
                if audio is None:
                    print(f"  trial {trial + 1}: the server received no recording")
                    continue
                ms, match = lost_ms(pcm16(audio), source)
                losses.append(ms)
                print(
                    f"  trial {trial + 1}: {ms:5.0f} ms of {PHRASE!r} lost "
                    f"(match {match:.2f}); heard {words!r}"
                )
            browser.close()
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=FLAGS)
            print(
                "a person who starts talking at 'Listening' (first press, second press), "
                f"a microphone that takes {open_ms} ms to open"
            )
            for trial in range(trials):
                for press, (result, words) in enumerate(
                    person_talks(url, browser, heard, wav, source, 2, hold_ms, open_ms), 1
                ):
                    if result is None:
                        print(f"  trial {trial + 1} press {press}: no recording")
                        continue
                    ms, match = result
                    person[press - 1].append(ms)
                    print(
                        f"  trial {trial + 1} press {press}: {ms:5.0f} ms lost "
                        f"(match {match:.2f}); heard {words!r}"
                    )
            browser.close()
    return losses, person


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=5)
    parser.add_argument("--hold-ms", type=int, default=2500)
    parser.add_argument(
        "--open-ms", type=int, default=0, help="the person's microphone's opening time"
    )
    args = parser.parse_args()
    assert shutil.which("espeak-ng"), "espeak-ng is missing: run `make setup`"
    print(f"push-to-talk through Chromium's fake microphone ({args.trials} trials)")
    losses, (first, second) = push_to_talk(args.trials, args.hold_ms, args.open_ms)
    for name, values in (
        ("fake microphone", losses),
        ("person, first press", first),
        ("person, second press", second),
    ):
        if values:
            print(
                f"  {name:22s} first word lost: median {statistics.median(values):.0f} ms, "
                f"min {min(values):.0f}, max {max(values):.0f} ({len(values)} trials)"
            )


if __name__ == "__main__":
    main()
