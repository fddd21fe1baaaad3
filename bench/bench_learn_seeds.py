"""Benchmark of `learn perceiver` over many seeds: at how many does it meet its goal?

    .venv/bin/python bench/bench_learn_seeds.py --seeds 0-29
    .venv/bin/python bench/bench_learn_seeds.py --seeds 100-111 --keep /tmp/dev --learn epochs=6

Each seed runs `bench_learn.py --part perceiver --seed S` (3 recorded games of the plus-shaped
hand, `learn perceiver`, 60 later sheets) and prints one line: the later drawings' cells and
symbols before and after, the generated and font sets before -> after, accepted or refused, and
whether the goal is met. The goal: the shipped classifier reads the hand below 97% of its
later cells; the learnt model reads >= 99.5% of them and is accepted (no project test set
worse). Last, "met at K of N seeds".

`--learn FIELD=VALUE` changes a field of `LearnPerceiverConfig` (for development seeds only);
`--keep DIR` keeps each seed's recordings in DIR/seed-S and reuses them when there, so that
settings are compared on the same games.

Not a test: it plays real games (about 15 s each) and trains for real.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import torch
from bench_learn import perceiver_run

from oxbot.recording.perceiver import LearnPerceiverConfig

GOAL = 0.995
"""The learnt model's share of the later cells read right."""
NEW_HAND = 0.97
"""A hand is new when the shipped classifier reads less than this share of its cells."""


def seed_range(text: str) -> list[int]:
    """'0-29' or '3,5,8-9' as a list of seeds."""
    seeds: list[int] = []
    for part in text.split(","):
        low, _, high = part.partition("-")
        seeds += range(int(low), int(high or low) + 1)
    return seeds


def learn_config(settings: list[str]) -> LearnPerceiverConfig:
    """`LearnPerceiverConfig` with FIELD=VALUE settings, each converted to its field's type."""
    config = LearnPerceiverConfig()
    for setting in settings:
        name, _, value = setting.partition("=")
        kind = type(getattr(config, name))
        config = dataclasses.replace(config, **{name: kind(value)})
    return config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seed_range, default=seed_range("0-29"))
    parser.add_argument("--games", type=int, default=3, help="recorded games to learn from")
    parser.add_argument("--sheets", type=int, default=60, help="later sheets to measure on")
    parser.add_argument("--learn", action="append", default=[], help="FIELD=VALUE (dev only)")
    parser.add_argument("--keep", type=Path, help="keep (and reuse) recordings in DIR/seed-S")
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = learn_config(args.learn)
    print(f"learn perceiver with {config}")
    met = 0
    for seed in args.seeds:
        started = time.perf_counter()
        keep = args.keep / f"seed-{seed}" if args.keep is not None else None
        run = perceiver_run(args.games, args.sheets, seed, lambda _: None, config, keep)
        b, a = run["before"], run["after"]
        ok = b["later"][0] < NEW_HAND and a["later"][0] >= GOAL and not run["refused"]
        met += ok
        print(
            f"seed {seed:3d}: later cells {b['later'][0]:.2%} -> {a['later'][0]:.2%}, "
            f"symbols {b['later'][1]:.2%} -> {a['later'][1]:.2%}; "
            f"generated {b['generated']:.2%} -> {a['generated']:.2%}, "
            f"fonts {b['fonts']:.2%} -> {a['fonts']:.2%}; "
            f"{'refused' if run['refused'] else 'accepted'}, {'met' if ok else 'NOT met'} "
            f"({run['recorded'][1]} labelled crops, {time.perf_counter() - started:.0f} s)",
            flush=True,
        )
    print(f"met at {met} of {len(args.seeds)} seeds")


if __name__ == "__main__":
    main()
