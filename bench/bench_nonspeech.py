"""Benchmark of what the robot makes of sounds that are not speech: none may become an answer.

    .venv/bin/python bench/bench_nonspeech.py                  # the test part: 169 real + 48 made
    .venv/bin/python bench/bench_nonspeech.py --part dev       # the part thresholds are tuned on
    .venv/bin/python bench/bench_nonspeech.py --recognizer pocketsphinx

Each real clip of `bench/data/nonspeech/<part>` (coughs, sneezes, laughter, breathing, music
with and without singing, rain, traffic, a fan, typing, ...; `bench/sound_sets.py`) is heard as
recorded and with its peak raised to -20 dBFS, the level a microphone near a person gives. To
them are added sounds made here: digital silence, white and pink noise at three levels, mains
hum, a tone, a swept tone, a train of clicks and a synthesised tune. Each recording goes through
the recogniser and the understanding, read as the answer to the invitation to play, to "Your
move" and to the end of a game (where a yes, a no, a stop or "again" changes what the robot
does), and as a move said in words at the person's turn (played at or above
`speech.min_move_confidence`). A clip becomes an answer when any of them reads it as an act
other than `Unknown` or `Silence`, or as a move. Printed: clips that produced words, clips that
became an answer (each one listed, with its words and confidence), per category. Not a test.
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

from oxbot.config import load_config
from oxbot.dialogue.cells_in_words import move_in_words
from oxbot.dialogue.domain import (
    FEEDBACK_WIN,
    INVITATION,
    MOVE_REQUEST,
    SILENCE,
    UNKNOWN,
    load_domain,
)
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.game.board import CELL_NAMES
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes
from oxbot.speech.recognition import shipped_recognizer

CONTEXTS = (INVITATION, MOVE_REQUEST, FEEDBACK_WIN)
PEAK_20_DBFS = 3277


def made_sounds(seed: int = 0) -> list[tuple[str, np.ndarray]]:
    """48 sounds made here (category, float samples in [-1, 1]): 6 of each of 8 kinds, at
    levels and lengths that vary."""
    rng = np.random.default_rng(seed)
    sounds = []
    for k in range(6):
        seconds = 1.0 + 0.5 * k
        n = int(seconds * RATE)
        t = np.arange(n) / RATE
        level = 10 ** (-(20 + 5 * (k % 3)) / 20)
        white = rng.standard_normal(n)
        pink = np.fft.irfft(np.fft.rfft(white) / np.sqrt(np.maximum(1, np.arange(n // 2 + 1))), n)
        hum = sum(np.sin(2 * np.pi * 50 * h * t) / h for h in (1, 2, 3, 5))
        tone = np.sin(2 * np.pi * (300 + 120 * k) * t)
        sweep = np.sin(2 * np.pi * (200 * t + (1500 / seconds) * t**2 / 2))
        clicks = np.zeros(n)
        clicks[rng.integers(0, n - 40, size=int(4 * seconds))] = 1.0
        clicks = np.convolve(clicks, np.hanning(40), mode="same")
        notes = 220 * 2 ** (rng.choice([0, 2, 4, 5, 7, 9, 11, 12], size=int(4 * seconds)) / 12)
        tune = np.concatenate(
            [
                np.sin(2 * np.pi * f * np.arange(RATE // 4) / RATE) * np.hanning(RATE // 4)
                for f in notes
            ]
        )[:n]
        for kind, x in (
            ("made: silence", np.zeros(n)),
            ("made: white noise", white),
            ("made: pink noise", pink),
            ("made: mains hum", hum),
            ("made: tone", tone),
            ("made: swept tone", sweep),
            ("made: clicks", clicks),
            ("made: tune", tune),
        ):
            peak = np.abs(x).max()
            sounds.append((kind, x * (level / peak) if peak > 0 else x))
    return sounds


def clips(part: str, with_made: bool) -> list[tuple[str, str, np.ndarray]]:
    """(category, name, int16 samples) of every recording the bench hears."""
    from sound_sets import nonspeech_clips

    out = []
    for path, category in nonspeech_clips(part):
        samples = pcm16(path)
        out.append((category, f"{path.name} as recorded", samples))
        peak = int(np.abs(samples.astype(np.int32)).max())
        if peak > 0:
            louder = np.clip(samples * (PEAK_20_DBFS / peak), -32768, 32767).astype(np.int16)
            out.append((category, f"{path.name} at -20 dBFS", louder))
    if with_made:
        for k, (kind, x) in enumerate(made_sounds()):
            out.append((kind, f"made {k}", np.round(x * 32767).astype(np.int16)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("dev", "test"), default="test")
    parser.add_argument("--recognizer", default="whisper", help="whisper or pocketsphinx")
    parser.add_argument("--no-made", action="store_true", help="only the real clips")
    args = parser.parse_args()

    recognizer = shipped_recognizer(args.recognizer)
    gate = load_config(None).speech.min_move_confidence
    classifier = UserActClassifier(load_domain())
    recordings = clips(args.part, not args.no_made)
    worded, answers = Counter(), []
    per_category = Counter()
    for category, name, samples in recordings:
        per_category[category] += 1
        nbest = recognizer.recognize(to_wav_bytes(Audio(samples, RATE)))
        if not nbest:
            continue
        worded[category] += 1
        acts = {context: classifier.intent_of(nbest, context).act for context in CONTEXTS}
        taken = {c: a for c, a in acts.items() if a not in (UNKNOWN, SILENCE)}
        move = move_in_words([(h.text, h.confidence) for h in nbest])
        if move is not None and move.played_at(gate):
            taken["a move in words"] = CELL_NAMES[move.cell]
        if taken:
            answers.append((category, name, nbest[0].text, nbest[0].confidence, taken))

    real = sum(n for c, n in per_category.items() if not c.startswith("made"))
    print(
        f"{args.recognizer}, {args.part} part: {real} real recordings, "
        f"{len(recordings) - real} made here"
    )
    print(f"produced words: {sum(worded.values())} of {len(recordings)}")
    print(f"became an answer: {len(answers)} of {len(recordings)}")
    print(f"{'category':24} {'clips':>5} {'words':>5} {'answers':>7}")
    taken_by = Counter(category for category, *_ in answers)
    for category in sorted(per_category):
        print(
            f"{category:24} {per_category[category]:5d} {worded[category]:5d} "
            f"{taken_by[category]:7d}"
        )
    for category, name, words, confidence, taken in answers:
        print(f"  {category}: {name}: {words!r} ({confidence:.2f}) -> {taken}")


if __name__ == "__main__":
    main()
