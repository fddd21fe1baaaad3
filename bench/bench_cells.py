"""Benchmark of the cells that must never be a move (issue 15): half-drawn and wrong shapes,
and blank cells of used paper, drawn by `oxbot.testing.odd_cells` (not the training
synthesiser).

    .venv/bin/python bench/bench_cells.py                      # 1,400 of each, seed 15
    .venv/bin/python bench/bench_cells.py --cells 700 --model runs/perceiver/perceiver.pt

Prints, per kind, how many partial shapes `predict` read as a circle or a cross (goal: 0),
how many of those the move tracker could accept (a symbol at or above `[tracker]
min_confidence`), and the share of blank cells read as "nothing" (goal: >= 99.5%). Not a
test: tests/perception/test_odd_cells.py asserts the goals on a small set.
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

from oxbot.config import TrackerConfig
from oxbot.perception.classifier import load_classifier
from oxbot.testing.odd_cells import EMPTY_KINDS, PARTIAL_KINDS, empty_cell, odd_cells, partial_cell


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=1400, help="cells of each set")
    parser.add_argument("--seed", type=int, default=15, help="seed of the two generators")
    parser.add_argument("--model", default=None, help="classifier file (default: shipped)")
    args = parser.parse_args()
    clf = load_classifier(args.model)
    threshold = TrackerConfig().min_confidence

    cells, kinds = odd_cells(
        args.cells, np.random.default_rng([args.seed, 1]), PARTIAL_KINDS, partial_cell
    )
    readings = clf.read(cells)
    labels = clf.predict(cells)
    symbol = Counter(k for k, label in zip(kinds, labels, strict=True) if label != "nothing")
    sure = Counter(
        k
        for k, r in zip(kinds, readings, strict=True)
        if r.label in ("circle", "cross") and r.confidence >= threshold
    )
    said = Counter(r.label for r in readings)
    total = sum(symbol.values())
    print(f"partial shapes: {args.cells:,}, read as circle or cross: {total} (goal 0)")
    print(f"  of which confident enough to become a move (>= {threshold}): {sum(sure.values())}")
    print("  readings: " + ", ".join(f"{k} {v}" for k, v in sorted(said.items())))
    for kind in PARTIAL_KINDS:
        n = kinds.count(kind)
        print(f"  {kind:15s} {symbol[kind]:4d} of {n} as a symbol, {sure[kind]:4d} confident")

    cells, kinds = odd_cells(
        args.cells, np.random.default_rng([args.seed, 2]), EMPTY_KINDS, empty_cell
    )
    labels = clf.predict(cells)
    readings = clf.read(cells)
    right = sum(label == "nothing" for label in labels)
    print(
        f"blank cells: {args.cells:,}, read as nothing: {right} = {right / args.cells:.2%} "
        f"(goal >= 99.5%)"
    )
    for kind in EMPTY_KINDS:
        got = Counter(r.label for k, r in zip(kinds, readings, strict=True) if k == kind)
        print(f"  {kind:15s} " + ", ".join(f"{k} {v}" for k, v in sorted(got.items())))


if __name__ == "__main__":
    main()
