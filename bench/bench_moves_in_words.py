"""Benchmark of moves said in words: how surely the recogniser hears "top left", and what a gate
on that (`speech.min_move_confidence`) plays, asks about, or plays wrongly.

    PYTHONPATH=. .venv/bin/python bench/bench_moves_in_words.py            # ~5 min
    PYTHONPATH=. .venv/bin/python bench/bench_moves_in_words.py --voices 3 --conditions clean
    PYTHONPATH=. .venv/bin/python bench/bench_moves_in_words.py --set speech.recognizer=pkg:make
    PYTHONPATH=. .venv/bin/python bench/bench_moves_in_words.py --held-out   # never tuned on

Three sets, each spoken by espeak-ng in the 12 voices the project tunes on
(`oxbot.speech.evaluation.VOICES`), clean and in white noise at 20 dB, and heard by the shipped
recogniser (the config's, `--set` to choose another) as the robot hears an answer at the
person's turn (`move_in_words` over its N-best). `--held-out` speaks them in the voices the
project never tunes on instead (`HELD_OUT_ESPEAK` and `HELD_OUT_FLITE`, 15 voices): choose the
gate on the tuning voices, then read the held-out figures once.

  domain    the moves of the domain's phrase file (user_phrases.txt), which the recogniser
            listens for
  other     moves said in other words, written here and in no domain file
  not moves what else people say when asked for their move: the domain's stops, chatter, the
            words said with a drawing ("I pick this one"); each one heard as a move is a move
            nobody made

For each threshold it prints the share of moves played on the right cell, played on a wrong
cell, and asked about ("Which cell do you mean?", or no move heard at all), and how many of
the not-moves it would play, then the lowest threshold at which nothing is played on a wrong
cell (none, with pocketsphinx: see `speech.min_move_confidence` for how its default was chosen
from these figures). Not a test.
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

from oxbot.config import load_config
from oxbot.dialogue.cells_in_words import move_in_words, read_cell
from oxbot.dialogue.domain import GAME_MOVE_TEMPLATE, STOP, UNKNOWN, load_domain
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes
from oxbot.speech.evaluation import (
    CLEAN,
    HELD_OUT_ESPEAK,
    HELD_OUT_FLITE,
    VOICES,
    speak,
    white_noise,
)
from oxbot.speech.recognition import Recognizer, load_recognizer

OTHER_MOVES = (
    "the top left one",
    "upper right corner please",
    "I'll take number three",
    "the bottom middle one",
    "the centre one",
    "row three column two please",
    "the lower left one",
    "middle right please",
    "top middle please",
    "I'll go bottom right",
    "number seven please",
    "the left middle one",
)
"""Moves in words of no domain file (the recogniser never saw these phrasings)."""
SETS = ("domain", "other", "not moves")
THRESHOLDS = tuple(round(t, 2) for t in np.arange(0.0, 1.0001, 0.05))


def sets() -> dict[str, list[str]]:
    """The phrasings of each set."""
    domain = load_domain()
    moves = [t for t in domain.phrasings[GAME_MOVE_TEMPLATE] if read_cell(t) is not None]
    drawing_words = [t for t in domain.phrasings[GAME_MOVE_TEMPLATE] if read_cell(t) is None]
    others = [*domain.phrasings[STOP][:20], *domain.phrasings[UNKNOWN][:20], *drawing_words]
    return {"domain": moves, "other": list(OTHER_MOVES), "not moves": others}


def hear(
    recognizer: Recognizer, phrases: list[str], voices: list[str], conditions: list
) -> list[tuple[str, object]]:
    """(phrase, the MoveHeard or None) for every phrase in every voice under every condition."""
    heard = []
    for voice in voices:
        for phrase in phrases:
            clean = pcm16(speak(phrase, voice))
            for condition in conditions:
                samples = condition.heard(clean, f"{voice}|{phrase}")
                hypotheses = recognizer.recognize(to_wav_bytes(Audio(samples, RATE)))
                heard.append((phrase, move_in_words((h.text, h.confidence) for h in hypotheses)))
    return heard


def report(name: str, heard: list[tuple[str, object]]) -> dict[float, tuple[int, int]]:
    """Print the set's figures by threshold; return threshold -> (wrong, right) played."""
    n = len(heard)
    played: dict[float, tuple[int, int]] = {}
    print(f"\n{name}: {n} utterances")
    if name == "not moves":
        print("threshold  played as a move (a move nobody made)")
    else:
        print("threshold  right cell  wrong cell  asked (or no move heard)")
    for t in THRESHOLDS:
        counts = Counter()
        for phrase, move in heard:
            if move is None or move.score < t:
                counts["asked"] += 1
                continue
            expected = read_cell(phrase)
            right = expected is not None and move.cell == expected.cell
            counts["right" if right else "wrong"] += 1
        played[t] = (counts["wrong"], counts["right"])
        if name == "not moves":
            print(f"  {t:4.2f}     {counts['wrong']:5d}")
        else:
            shares = [100 * counts[k] / n for k in ("right", "wrong", "asked")]
            print(f"  {t:4.2f}     {shares[0]:6.1f}%    {shares[1]:6.1f}%     {shares[2]:6.1f}%")
    wrong = [
        (p, m)
        for p, m in heard
        if m is not None and (read_cell(p) is None or read_cell(p).cell != m.cell)
    ]
    for phrase, move in sorted(wrong, key=lambda pm: -pm[1].score)[:10]:
        print(f"    {phrase!r} heard as {move.words!r} at {move.score:.2f}")
    often = Counter(phrase for phrase, _ in wrong).most_common(8)
    print("  most often played on a wrong cell: " + ", ".join(f"{p!r} {n}" for p, n in often))
    return played


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voices", type=int, default=15, help="how many voices (at most)")
    parser.add_argument(
        "--conditions", nargs="+", default=["clean", "20 dB"], choices=["clean", "20 dB"]
    )
    parser.add_argument("--sets", nargs="+", default=list(SETS), choices=SETS)
    parser.add_argument("--set", action="append", default=[], help="a config override")
    parser.add_argument(
        "--held-out", action="store_true", help="the held-out espeak-ng and Flite voices"
    )
    args = parser.parse_args()
    config = load_config(None, args.set)
    recognizer = load_recognizer(config.speech)
    conditions = [{"clean": CLEAN, "20 dB": white_noise(20.0)}[c] for c in args.conditions]
    voices = list(((*HELD_OUT_ESPEAK, *HELD_OUT_FLITE) if args.held_out else VOICES)[: args.voices])
    phrases = sets()
    played = {
        name: report(name, hear(recognizer, phrases[name], voices, conditions))
        for name in args.sets
    }
    if {"domain", "not moves"} <= set(played):
        safe = next(
            (
                t
                for t in THRESHOLDS
                if played["domain"][t][0] == 0 and played["not moves"][t][0] == 0
            ),
            None,
        )
        print(f"\nlowest threshold with no wrong cell and no move nobody made: {safe}")
    print(f"the config's gate, speech.min_move_confidence: {config.speech.min_move_confidence}")


if __name__ == "__main__":
    main()
