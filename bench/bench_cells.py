"""Benchmark of the cells that must never be a move: half-drawn and wrong shapes,
and blank cells of used paper, drawn by `oxbot.testing.odd_cells` (not the training
synthesiser); and what the wholeness check costs whole symbols.

    .venv/bin/python bench/bench_cells.py                      # 1,400 of each, seed 15
    .venv/bin/python bench/bench_cells.py --cells 700 --model runs/perceiver/perceiver.pt
    .venv/bin/python bench/bench_cells.py --set perception.plus_is_cross=true
    .venv/bin/python bench/bench_cells.py --wiped   # first wiped and deepened, as cut_board does

Every cell is read by `BoardReader.classify`: the network, then the reader's rules. With
`--wiped` the paper's pattern is first wiped and faint ink deepened, as `cut_board` does to the
cells it cuts from a sheet; the generated and font sets were not made for that step (through it
the network reads 91.9% of the generated cells right), so the default reads the cells as drawn.
Prints, per kind, how many partial shapes read as a circle or a cross (goal:
0), by the network alone (`predict`) and with the reader's rules (the single-stroke rule and the
wholeness check, `oxbot.perception.wholeness`, as
`[perception]` sets it), how many of those the move tracker could accept (a symbol at or above
`[tracker] min_confidence`), and the share of blank cells read as "nothing" (goal: >= 99.5%).
Then the whole symbols the check turns into "partial" on the generated test set (1,000 cells,
SPEC §1) and on the handwriting-font set (1,500, another hand), with both sets' accuracy before
and after it. Not a test: tests/perception/test_odd_cells.py and test_wholeness.py assert the
goals on small sets.
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np
from config_option import add_set_option

from oxbot.config import load_config
from oxbot.perception.board import BoardReader, deepen_faint_ink
from oxbot.perception.cells import wipe_background
from oxbot.perception.classifier import load_classifier
from oxbot.perception.evaluation import FONT_STREAM, generated_test_set
from oxbot.perception.fonts import font_cells
from oxbot.perception.seeds import load_seeds
from oxbot.perception.synth import LABELS
from oxbot.testing.odd_cells import EMPTY_KINDS, PARTIAL_KINDS, empty_cell, odd_cells, partial_cell

SYMBOLS = ("circle", "cross")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=1400, help="cells of each set")
    parser.add_argument("--seed", type=int, default=15, help="seed of the two generators")
    parser.add_argument("--model", default=None, help="classifier file (default: shipped)")
    add_set_option(parser, "perception.max_circle_gap=80")
    parser.add_argument(
        "--wiped",
        action="store_true",
        help="wipe the paper's pattern and deepen faint ink first, as the board reader does",
    )
    args = parser.parse_args()
    config = load_config(assignments=args.set)
    clf = load_classifier(args.model)
    threshold = config.tracker.min_confidence
    perception = config.perception
    reader = BoardReader(clf, perception)

    def cut(cells: np.ndarray) -> np.ndarray:
        return deepen_faint_ink(wipe_background(cells)) if args.wiped else cells

    print(
        f"cells {'wiped and deepened as the board reader cuts them' if args.wiped else 'as drawn'}"
        f"; wholeness check: {'on' if perception.wholeness else 'off'}, max_circle_gap "
        f"{perception.max_circle_gap:g}, plus_is_cross {str(perception.plus_is_cross).lower()}"
    )
    cells, kinds = odd_cells(
        args.cells, np.random.default_rng([args.seed, 1]), PARTIAL_KINDS, partial_cell
    )
    cells = cut(cells)
    network, checked = clf.read(cells), reader.classify(cells)
    for name, readings in (("network alone", network), ("with the check", checked)):
        symbol = Counter(k for k, r in zip(kinds, readings, strict=True) if r.label in SYMBOLS)
        sure = Counter(
            k
            for k, r in zip(kinds, readings, strict=True)
            if r.label in SYMBOLS and r.confidence >= threshold
        )
        said = Counter(r.label for r in readings)
        total = sum(symbol.values())
        print(f"partial shapes, {name}: {args.cells:,}, read as circle or cross: {total} (goal 0)")
        print(
            f"  of which confident enough to become a move (>= {threshold}): {sum(sure.values())}"
        )
        print("  readings: " + ", ".join(f"{k} {v}" for k, v in sorted(said.items())))
        for kind in PARTIAL_KINDS:
            n = kinds.count(kind)
            print(f"  {kind:15s} {symbol[kind]:4d} of {n} as a symbol, {sure[kind]:4d} confident")

    cells, kinds = odd_cells(
        args.cells, np.random.default_rng([args.seed, 2]), EMPTY_KINDS, empty_cell
    )
    readings = reader.classify(cut(cells))
    right = sum(r.label not in SYMBOLS for r in readings)
    print(
        f"blank cells: {args.cells:,}, read as nothing (or partial, which is no move): {right} = "
        f"{right / args.cells:.2%} (goal >= 99.5%)"
    )
    for kind in EMPTY_KINDS:
        got = Counter(r.label for k, r in zip(kinds, readings, strict=True) if k == kind)
        print(f"  {kind:15s} " + ", ".join(f"{k} {v}" for k, v in sorted(got.items())))

    images, labels = generated_test_set(load_seeds(), 1000, 0)
    whole_sets = {
        "generated (1,000)": (images, [LABELS[i] for i in labels]),
        "fonts (1,500)": font_cells(1500, np.random.default_rng([0, FONT_STREAM]), 40),
    }
    for name, (cells, truth) in whole_sets.items():
        truth = [str(t) for t in truth]
        cells = cut(cells)
        network, checked = clf.read(cells), reader.classify(cells)
        before = sum(r.spec_label == t for r, t in zip(network, truth, strict=True))
        after = sum(r.spec_label == t for r, t in zip(checked, truth, strict=True))
        lost = Counter(
            t
            for r, c, t in zip(network, checked, truth, strict=True)
            if r.label == t and c.label != t
        )
        print(
            f"whole symbols, {name}: right {before / len(truth):.2%} by the network, "
            f"{after / len(truth):.2%} with the check; made partial: {sum(lost.values())} "
            f"({', '.join(f'{k} {v}' for k, v in sorted(lost.items())) or 'none'})"
        )


if __name__ == "__main__":
    main()
