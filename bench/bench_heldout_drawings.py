"""Benchmark: what the board reader makes of drawings that are no move, on held-out sets.

    .venv/bin/python bench/bench_heldout_drawings.py              # 30 of each kind, seed 7
    .venv/bin/python bench/bench_heldout_drawings.py --per-kind 60 --seed 8

Two sets the reader was never tuned on:
- `oxbot.testing.heldout_drawings`: a generator written apart from the training synthesiser and
  from the development drawings (`oxbot.testing.dev_shapes`), without reading the reader: 29
  kinds that are no move (scribbles, stars, spirals, triangles, squares, letters, digits...)
  and whole circles and crosses;
- people's drawings from Google's Quick, Draw! (CC BY 4.0), when its files are restored
  (bench/data/quickdraw/SOURCES.md): its circles are symbols, every other category is not.
Each drawing goes in a cell of a page-like sheet (`oxbot.testing.sheet.Sheet`, up to nine a
sheet, one per cell) read by the real board reader, as the page's canvas is. A drawing that is
no move is refused when it reads as anything but a circle or a cross. The goal: at least 99%
refused, and whole symbols read right at least 99.5%. Prints each kind's share; not a test.
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict
from collections.abc import Iterable

import numpy as np
from config_option import add_set_option

from oxbot.config import load_config
from oxbot.errors import OxbotError
from oxbot.game.board import CELL_NAMES
from oxbot.perception import load_classifier
from oxbot.perception.board import BoardReader
from oxbot.testing.heldout_drawings import (
    NOT_MOVES,
    QUICKDRAW_SYMBOLS,
    SYMBOLS,
    heldout_set,
    quickdraw_categories,
    quickdraw_drawings,
)
from oxbot.testing.sheet import Sheet

MOVES = ("circle", "cross")


def read_all(
    reader: BoardReader, drawings: Iterable[tuple[str, list[np.ndarray]]]
) -> tuple[dict[str, Counter], int]:
    """Each kind's readings, nine drawings a sheet; and how many sheets showed no grid."""
    readings: dict[str, Counter] = defaultdict(Counter)
    batch: list[tuple[str, list[np.ndarray]]] = []
    unread = 0

    def flush(number: int) -> int:
        sheet = Sheet(number)
        for (_, strokes), cell in zip(batch, CELL_NAMES, strict=False):
            sheet.draw_strokes(cell, strokes)
        try:
            labels = [r.label for r in reader.read(sheet.image).readings]
        except OxbotError:  # drawings that hide the grid: a reading of nothing at all
            return 1
        for (kind, _), label in zip(batch, labels, strict=False):
            readings[kind][label] += 1
        return 0

    for number, item in enumerate(drawings):
        batch.append(item)
        if len(batch) == len(CELL_NAMES):
            unread += flush(number)
            batch.clear()
    if batch:
        unread += flush(len(CELL_NAMES) * 1000)
    return readings, unread


def report(title: str, readings: dict[str, Counter], symbols: tuple[str, ...]) -> None:
    print(title)
    refused = total = right = whole = 0
    for kind, labels in sorted(readings.items()):
        n = sum(labels.values())
        if kind in symbols:
            symbol = "circle" if kind not in MOVES else kind
            ok = labels[symbol]
            right, whole = right + ok, whole + n
            print(f"  {kind:<14} read right {ok:>4}/{n:<4} {dict(labels)}")
        else:
            ok = sum(v for label, v in labels.items() if label not in MOVES)
            refused, total = refused + ok, total + n
            print(f"  {kind:<14} refused    {ok:>4}/{n:<4} {dict(labels)}")
    if total:
        print(f"  no move refused: {refused}/{total} = {refused / total:.1%} (goal 99%)")
    if whole:
        print(f"  whole symbols read right: {right}/{whole} = {right / whole:.1%} (goal 99.5%)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--per-kind", type=int, default=30)
    parser.add_argument("--seed", type=int, default=7)
    add_set_option(parser, "perception.rejector=true")
    args = parser.parse_args()
    reader = BoardReader(load_classifier(), load_config(assignments=args.set).perception)

    drawn = [(kind, strokes) for kind, _, strokes in heldout_set(args.per_kind, args.seed)]
    readings, unread = read_all(reader, drawn)
    report(
        f"held-out generator, {args.per_kind} of each of {len(NOT_MOVES)} kinds that are no "
        f"move and {len(SYMBOLS)} symbols (seed {args.seed}); sheets without a grid: {unread}",
        readings,
        SYMBOLS,
    )
    categories = quickdraw_categories()
    if not categories:
        print("Quick, Draw!: not restored (bench/data/quickdraw/SOURCES.md)")
        return
    people = [(c, d) for c in categories for d in quickdraw_drawings(c)[: args.per_kind]]
    readings, unread = read_all(reader, people)
    report(
        f"Quick, Draw! people's drawings; sheets without a grid: {unread}",
        readings,
        QUICKDRAW_SYMBOLS,
    )


if __name__ == "__main__":
    main()
