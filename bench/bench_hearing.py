"""Benchmark of the robot's ears during a game: from the end of speech to the robot's act.

    .venv/bin/python bench/bench_hearing.py [--answers 30] [--recognizers whisper pocketsphinx]

A whole robot (every component, `oxbot.robot.session.Robot`) runs while a camera shows it a
rendered sheet every 100 ms, as a webcam over paper does, so perception takes its share of the
two cores. At each question the robot asks, a spoken answer (espeak-ng, a tuning voice, its
silence trimmed so the recording ends where the speech ends, as push-to-talk released at the
last word) is handed to `Robot.hear`; the time from that hand-over to the robot's next act on
the bus is the hearing latency: decoding, understanding, the policy's choice. Printed per
recogniser: median and p90 in ms, how many answers were heard as the intended act, and the
process's resident memory once the recogniser is loaded. Not a test.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import threading
import time

import numpy as np

from oxbot.config import load_config
from oxbot.dialogue.domain import ACCEPT, DECLINE, INVITATION, MOVE_REQUEST
from oxbot.robot.messages import DialogueAct, DialogueEnded
from oxbot.robot.session import Robot
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes, trim_silence
from oxbot.speech.evaluation import TUNING_VOICES, speak
from oxbot.testing.render import TUNING_STYLE, random_scene

ANSWERS = {"yes let's play": ACCEPT, "sure": ACCEPT, "okay": ACCEPT, "no thanks": DECLINE}


class Camera(threading.Thread):
    """A webcam's view of an empty sheet: a fresh photo every 100 ms."""

    def __init__(self, robot: Robot, seed: int) -> None:
        super().__init__(daemon=True)
        self.robot, self.rng = robot, np.random.default_rng(seed)
        self.scene = random_scene(self.rng, TUNING_STYLE)
        self.stopped = threading.Event()

    def run(self) -> None:
        while not self.stopped.wait(0.1):
            self.robot.show(self.scene.photo(self.rng))


def spoken(text: str, voice: str) -> bytes:
    """`text` in `voice` as a WAV that ends where the speech ends."""
    samples = trim_silence(pcm16(speak(text, voice)), 0.05)
    return to_wav_bytes(Audio(samples if samples is not None else np.zeros(RATE, np.int16), RATE))


def measure(recognizer: str, answers: int, seed: int) -> dict:
    """Latencies (s) of `answers` spoken answers to the invitation, and how many were right."""
    config = load_config(
        None,
        [
            f"speech.recognizer={recognizer}",
            "robot.speed_factor=8",
            "robot.answer_timeout=30",
            "robot.move_timeout=30",
        ],
    )
    rng = np.random.default_rng(seed)
    latencies, right = [], 0
    texts = list(ANSWERS)
    while len(latencies) < answers:
        with Robot(config, seed=int(rng.integers(1 << 30))) as robot:
            camera = Camera(robot, seed)
            camera.start()
            events = robot.bus.subscribe(DialogueAct, DialogueEnded)
            try:
                while len(latencies) < answers:
                    message = events.get(30.0)
                    if message is None or isinstance(message, DialogueEnded):
                        break
                    if message.speaker != "sys" or message.act != INVITATION:
                        continue
                    text = texts[len(latencies) % len(texts)]
                    voice = TUNING_VOICES[len(latencies) % len(TUNING_VOICES)]
                    wav = spoken(text, voice)
                    time.sleep(0.3)  # the question has been asked; the person answers
                    handed = time.perf_counter()
                    robot.hear(wav)
                    heard = None
                    while True:
                        reply = events.get(30.0)
                        if reply is None or isinstance(reply, DialogueEnded):
                            break
                        if reply.speaker == "usr":
                            heard = reply.act
                        elif reply.speaker == "sys":
                            latencies.append(time.perf_counter() - handed)
                            right += heard == ANSWERS[text]
                            break
                    if heard == ACCEPT or (reply is not None and reply.act == MOVE_REQUEST):
                        break  # a game started: a fresh robot for the next answer
                    if reply is None or isinstance(reply, DialogueEnded):
                        break
            finally:
                camera.stopped.set()
                camera.join(1.0)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"latencies": latencies, "right": right, "rss_mb": rss_mb}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--answers", type=int, default=30)
    parser.add_argument("--recognizers", nargs="+", default=["whisper", "pocketsphinx"])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if len(args.recognizers) > 1:  # each in a process of its own: its memory is its own
        print("from the end of speech to the robot's act, during a game (camera at 10 Hz)")
        for name in args.recognizers:
            command = [sys.executable, __file__, "--answers", str(args.answers)]
            subprocess.run([*command, "--seed", str(args.seed), "--recognizers", name], check=True)
        return
    for name in args.recognizers:
        m = measure(name, args.answers, args.seed)
        ms = sorted(1000 * s for s in m["latencies"])
        p90 = ms[min(len(ms) - 1, int(np.ceil(0.9 * len(ms))) - 1)]
        print(
            f"{name:13s} n={len(ms)}  median {statistics.median(ms):6.0f} ms  p90 {p90:6.0f} ms"
            f"  max {ms[-1]:6.0f} ms  heard as meant {m['right']}/{len(ms)}"
            f"  peak resident memory {m['rss_mb']:.0f} MB"
        )


if __name__ == "__main__":
    main()
