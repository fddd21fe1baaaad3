"""Benchmark of drawings that are no whole circle or cross (scribbles, letters, digits, stars,
spirals, polygons, dots, hatching, ticks, plus signs, arcs, strokes) and of whole circles and
crosses in many hands, drawn by `oxbot.testing.dev_shapes` (the wholeness check's development
drawings: tuned on, so not an acceptance figure).

    .venv/bin/python bench/bench_shapes.py                 # 60 of each kind, seed 1
    .venv/bin/python bench/bench_shapes.py --per-kind 200 --seed 2
    .venv/bin/python bench/bench_shapes.py --set perception.wholeness=false

Each drawing is read twice: alone in a 40x40 cell (`BoardReader.classify`: the network, the
single-stroke rule and the wholeness check) and drawn on the page's sheet, nine to a sheet, by
the board reader (`BoardReader.read`). Prints, per kind, the share refused (read as nothing or
partial: never a move; goal >= 99%) and, for whole circles and crosses, the share read as what
they are (goal >= 99.5%).
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np
from config_option import add_set_option

from oxbot.config import load_config
from oxbot.perception.board import BoardReader
from oxbot.perception.classifier import load_classifier
from oxbot.testing.dev_shapes import (
    REFUSED_KINDS,
    WHOLE_KINDS,
    cell_image,
    dev_kinds,
    draw_kind,
    on_sheets,
)

SYMBOLS = ("circle", "cross")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-kind", type=int, default=60, help="drawings of each kind")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--misses", action="store_true", help="list each miss's reading")
    add_set_option(parser, "perception.wholeness=false")
    args = parser.parse_args()
    config = load_config(assignments=args.set).perception
    reader = BoardReader(load_classifier(), config)
    kinds = dev_kinds(args.per_kind, (*REFUSED_KINDS, *WHOLE_KINDS))

    rng = np.random.default_rng([args.seed, 1])
    cells = np.stack([cell_image(draw_kind(k, rng), rng) for k in kinds])
    in_cells = [r.label for r in reader.classify(cells)]
    on_sheet: list[str] = []
    sheet_kinds: list[str] = []
    for sheet, placed in on_sheets(kinds, np.random.default_rng([args.seed, 2])):
        readings = reader.read(sheet.image).readings
        for kind, reading in zip(placed, readings, strict=True):
            if kind is not None:
                sheet_kinds.append(kind)
                on_sheet.append(reading.label)

    print(
        f"{args.per_kind} of each kind, seed {args.seed}; wholeness "
        f"{'on' if config.wholeness else 'off'}, max_circle_gap {config.max_circle_gap:g}, "
        f"plus_is_cross {str(config.plus_is_cross).lower()}"
    )
    print(f"{'kind':<14} {'cells':>8} {'sheets':>8}   (refused, or for whole kinds read right)")
    totals = {"refused": [0, 0, 0], "whole": [0, 0, 0]}
    for kind in (*REFUSED_KINDS, *WHOLE_KINDS):
        shares = []
        for got, where in ((in_cells, kinds), (on_sheet, sheet_kinds)):
            labels = [g for g, k in zip(got, where, strict=True) if k == kind]
            ok = sum((g == kind) if kind in WHOLE_KINDS else (g not in SYMBOLS) for g in labels)
            shares.append(ok / len(labels))
            group = totals["whole" if kind in WHOLE_KINDS else "refused"]
            group[0 if where is kinds else 1] += ok
            if where is kinds:
                group[2] += len(labels)
            if args.misses and ok < len(labels):
                wrong = Counter(g for g in labels if (g == kind) != (kind in WHOLE_KINDS))
                print(f"    {kind} {'cells' if where is kinds else 'sheets'}: {dict(wrong)}")
        print(f"{kind:<14} {shares[0]:>8.1%} {shares[1]:>8.1%}")
    for name, (cell_ok, sheet_ok, n) in totals.items():
        print(f"{'all ' + name:<14} {cell_ok / n:>8.2%} {sheet_ok / n:>8.2%}   of {n} each")


if __name__ == "__main__":
    main()
