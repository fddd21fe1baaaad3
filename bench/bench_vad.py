"""Benchmark of hands-free listening: the VAD's false starts, clipped onsets and CPU.

    .venv/bin/python bench/bench_vad.py                 # Silero VAD, as oxbot runs it
    .venv/bin/python bench/bench_vad.py --webrtc        # and the WebRTC VAD at modes 0-3
                                                        # (pip install webrtcvad-wheels)

Runs `oxbot.speech.vad.UtteranceCutter` (the segmentation the page's hands-free mode and the
terminal's `listen` use) with each detector over:

- 60 s of noise only (`oxbot.testing.sounds.noise_only`: a quiet room's hiss, a loud fan,
  pink and brown noise, mains hum, keyboard clicks, 10 s each): every utterance cut from it
  is a false start, which the robot would hand to the recogniser;
- the person's answers (espeak-ng, no leading silence, 4 voices), each with 1 s of room
  noise before and after, in a quiet room (-50 dBFS hiss), at 10 dB SNR in fan and pink
  noise, and among keyboard clicks: an answer is found when one utterance overlaps it; its
  onset is clipped by the milliseconds between the speech's first sound and the utterance's
  first sample (0 when the utterance starts before it).

CPU is the detection's and segmentation's process time per second of audio. Prints a table;
not a test.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from oxbot.config import ListeningConfig
from oxbot.speech.audio import RATE, pcm16
from oxbot.speech.synthesis import Voice, synthesize
from oxbot.speech.vad import SileroVad, UtteranceCutter
from oxbot.testing.sounds import in_noise, noise_only, onset

ANSWERS = ("yes let's play", "okay", "no not now", "hello", "top left", "middle")
VOICES = ("en-us", "en-gb", "en-us+f2", "en-gb-scotland")
SETTINGS = (
    ("quiet", "hiss", None),
    ("fan 10 dB", "fan", 10),
    ("pink 10 dB", "pink", 10),
    ("clicks", "clicks", None),
)
CHUNK = 1600  # the page sends 100 ms at a time


class WebRtcVad:
    """The WebRTC VAD (`pip install webrtcvad-wheels`: Google's GMM detector compiled in) on
    30 ms frames; `mode` 0 (most audio counts as speech) to 3 (the strictest)."""

    frame_samples = 480

    def __init__(self, mode: int) -> None:
        import webrtcvad

        self._vad = webrtcvad.Vad(mode)

    def reset(self) -> None:
        pass

    def is_speech(self, frame: np.ndarray) -> bool:
        return self._vad.is_speech(frame.astype("<i2").tobytes(), RATE)


def cut(cutter: UtteranceCutter, stream: np.ndarray):
    """Every utterance in `stream`, fed as the page feeds it, and the seconds it took."""
    started = time.process_time()
    heard = []
    for at in range(0, len(stream), CHUNK):
        heard += cutter.feed(stream[at : at + CHUNK])
    last = cutter.flush()
    return heard + ([last] if last else []), time.process_time() - started


def measure(name: str, make_vad, config: ListeningConfig, answers, rng_seed: int) -> dict:
    rng = np.random.default_rng(rng_seed)
    noise = noise_only(60.0, rng)
    false_starts, cpu = cut(UtteranceCutter(config, vad=make_vad()), noise)
    clipped, found, missed, extra, audio = [], 0, 0, 0, 0.0
    for speech in answers:
        for _, kind, snr in SETTINGS:
            clip, lead = in_noise(speech, rng, noise=kind, snr_db=snr)
            heard, seconds = cut(UtteranceCutter(config, vad=make_vad()), clip)
            cpu += seconds
            audio += len(clip) / RATE
            first = lead + onset(speech)
            end = lead + len(speech)
            over = [u for u in heard if u.start < end and u.start + len(u.samples) > first]
            extra += len(heard) - min(1, len(over))
            if not over:
                missed += 1
                continue
            found += 1
            clipped.append(max(0.0, 1000 * (over[0].start - first) / RATE))
    return {
        "name": name,
        "false starts": len(false_starts),
        "false seconds": sum(u.seconds for u in false_starts),
        "found": found,
        "missed": missed,
        "extra": extra,
        "clipped": clipped,
        "cpu": cpu / (60.0 + audio),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--webrtc", action="store_true", help="the WebRTC VAD too")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--pre-roll", type=float, default=None, help="seconds (default: the config's)"
    )
    args = parser.parse_args()
    config = ListeningConfig()
    if args.pre_roll is not None:
        config = dataclasses.replace(config, pre_roll_seconds=args.pre_roll)
    answers = [pcm16(synthesize(a, Voice(v))) for a in ANSWERS for v in VOICES]
    candidates = [(f"silero {config.threshold}", lambda: SileroVad(config.threshold))]
    if args.webrtc:
        candidates += [(f"webrtc mode {m}", lambda m=m: WebRtcVad(m)) for m in (0, 1, 2, 3)]
    print(
        f"{len(answers)} answers x {len(SETTINGS)} rooms ({', '.join(s for s, _, _ in SETTINGS)}),"
        f" 60 s of noise only; start {config.start_seconds} s, end after "
        f"{config.end_silence_seconds} s quiet, pre-roll {config.pre_roll_seconds} s"
    )
    print(
        f"{'detector':16s} {'false starts/60 s':>17s} {'found':>7s} {'extra':>6s} "
        f"{'clipped: n>0':>12s} {'median':>7s} {'max':>6s} {'CPU':>7s}"
    )
    for name, make in candidates:
        r = measure(name, make, config, answers, args.seed)
        c = r["clipped"]
        total = r["found"] + r["missed"]
        print(
            f"{name:16s} {r['false starts']:6d} ({r['false seconds']:5.1f} s) "
            f"{r['found']:3d}/{total:<3d} {r['extra']:6d} {sum(x > 0 for x in c):12d} "
            f"{np.median(c) if c else 0:5.0f}ms {max(c) if c else 0:4.0f}ms "
            f"{100 * r['cpu']:6.2f}%"
        )


if __name__ == "__main__":
    main()
