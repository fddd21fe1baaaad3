"""Benchmark of talking over the robot (barge-in) in the real page, hands-free, in real time.

    .venv/bin/python bench/bench_barge_in.py                  # 5 tries of each word
    .venv/bin/python bench/bench_barge_in.py --tries 2 --echo-db -20

Starts a real server (real robots, Piper's voice, Whisper, speed factor 1) on a free localhost
port and opens Debian's Chromium on it. Each try is a fresh tab whose microphone hears the
robot's own voice back (`--echo-db` down, as the page plays it) and a person (espeak-ng's
en-us+m3) who says a word over the robot's question "Shall we play ...?", at a random moment
0.5-0.9 s into it (a try where the question had ended by then is counted apart). Prints, for
each try: how long after the word's first sound the page's audio stopped (by the page's
clock), what the robot heard and understood, and whether any of its own sentences was taken
for the person's before; then the median and the 90th percentile of the time to the cut. The
goal: at most 300 ms. Not a test.
"""

from __future__ import annotations

import argparse
import base64
import logging
import statistics

import numpy as np

from oxbot.config import load_config
from oxbot.dialogue.domain import INVITATION
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes, trim_silence
from oxbot.speech.evaluation import speak
from oxbot.testing.browser import CHROMIUM, FLAGS, conversation_script, log_items
from oxbot.web.server import create_app, serving_in_background

WORDS = ("stop", "wait", "sorry?")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tries", type=int, default=5, help="tries of each word")
    parser.add_argument("--echo-db", type=float, default=-10.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--log", help="write the robot's debug log (its listener's) here")
    args = parser.parse_args()
    if args.log:
        logging.basicConfig(
            filename=args.log, level=logging.WARNING, format="%(asctime)s %(name)s %(message)s"
        )
        logging.getLogger("oxbot.robot.listening").setLevel(logging.DEBUG)
    rng = np.random.default_rng(args.seed)
    config = load_config(None, ["robot.speed_factor=1", "robot.question_timeout=30"])
    from playwright.sync_api import sync_playwright

    flags = [*FLAGS, "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream"]
    cuts, self_heard, late = [], 0, 0
    with serving_in_background(create_app(config)) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=flags)
        try:
            for k in range(args.tries * len(WORDS)):
                word = WORDS[k % len(WORDS)]
                samples = trim_silence(pcm16(speak(word, "en-us+m3")), 0.2)
                assert samples is not None
                first_sound = int(np.argmax(np.abs(samples) > 1_000)) / RATE
                wav = base64.b64encode(to_wav_bytes(Audio(samples, RATE))).decode()
                page = browser.new_page()
                page.add_init_script(conversation_script(echo_db=args.echo_db))
                page.goto(url + "/")
                page.get_by_test_id("hands-free").click()
                page.wait_for_function("window.oxbot.mic.handsFree", timeout=10_000)
                page.get_by_test_id("start").click()
                page.wait_for_function(
                    "(act) => window.oxbot.stats.acts.some((a) => a.act === act)",
                    arg=INVITATION,
                    timeout=60_000,
                )
                before = [t for t in log_items(page) if t[0] == "usr"]
                self_heard += bool(before)
                page.wait_for_function("window.oxbot.speaking", timeout=10_000)
                page.wait_for_timeout(int(rng.uniform(500, 900)))
                playing = page.evaluate(
                    "(b64) => { window.__room.say(b64); return window.oxbot.sources.length > 0; }",
                    wav,
                )
                try:
                    # the first cut after the word was said (one before it: its own voice)
                    said, cut = page.wait_for_function(
                        """() => { const said = window.__room.said.at(-1);
                                   const cut = window.oxbot.stats.cuts.find((c) => c >= said);
                                   return cut !== undefined && [said, cut]; }""",
                        timeout=5_000,
                    ).json_value()
                    took = (cut - said) / 1e3 - first_sound
                    cuts.append(took)
                    shown = f"cut {took * 1e3:.0f} ms after its first sound"
                except Exception:
                    shown = "never cut" if playing else "the question had ended"
                    late += not playing
                page.wait_for_timeout(3_000)
                heard = [t for t in log_items(page) if t[0] == "usr"][len(before) :]
                understood = f"{heard[0][2]!r} as {heard[0][1]}" if heard else "nothing heard"
                print(
                    f"try {k + 1} ({word!r}): {shown}; heard {understood}; "
                    f"own voice taken for the person before: {len(before)} {before or ''}",
                    flush=True,
                )
                page.close()
        finally:
            browser.close()
    tries = args.tries * len(WORDS)
    if cuts:
        p90 = statistics.quantiles(cuts, n=10)[-1] if len(cuts) >= 2 else cuts[0]
        print(
            f"cut short in {len(cuts)} of {tries - late} tries said over the robot: median "
            f"{statistics.median(cuts) * 1e3:.0f} ms, p90 {p90 * 1e3:.0f} ms, max "
            f"{max(cuts) * 1e3:.0f} ms after the word's first sound (goal: at most 300 ms); "
            f"the robot's own voice taken for the person in {self_heard} of {tries} openings"
        )
    else:
        print(f"never cut short in {tries} tries")


if __name__ == "__main__":
    main()
