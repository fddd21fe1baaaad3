"""Benchmark of the board reader on real photos of hand-drawn boards, per split (dev / test).

    .venv/bin/python bench/bench_real_boards.py
    .venv/bin/python bench/bench_real_boards.py --split dev
    .venv/bin/python bench/bench_real_boards.py --split dev --set perception.plus_is_cross=true
    .venv/bin/python bench/bench_real_boards.py --labels other/labels.csv --images other/images

Reads `bench/data/real_boards/labels.csv` (one row per photo: file, board, split, paper, ink,
grid fraction, the 9 cell labels row by row from the upper left, notes; see
`bench/data/real_boards/SOURCES.md`), runs `oxbot.read_board` once on every photo found in
`bench/data/real_boards/images/`, and prints per split: boards fully right, refusals
(NoGridFound and any other error), cells right, empty cells read as empty, symbols right, how
many cells hold a symbol read wrong at least as surely as the move tracker needs (`[tracker]
min_confidence`: a camera held still on such a sheet would have the tracker take a wrong
move), and one line per photo not fully right. The photos are not in git: a missing one is
skipped with a message saying how to restore it. A cell labelled `unreadable` (a human cannot
tell what it is) is left out of the cell counts, and a photo with such a cell out of "fully
right" (it is counted apart). Measurement only: nothing here tunes anything, and nobody
tunes on `test`.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

from board_tally import REAL_BOARDS, Tally, labelled_rows, measure, report
from config_option import add_set_option

from oxbot.config import load_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels", type=Path, default=REAL_BOARDS / "labels.csv")
    parser.add_argument("--images", type=Path, default=REAL_BOARDS / "images")
    parser.add_argument("--split", choices=("dev", "test"), default=None, help="one split only")
    add_set_option(parser, "perception.plus_is_cross=true")
    args = parser.parse_args()
    rows = labelled_rows(args.labels)
    tallies: dict[str, Tally] = defaultdict(Tally)
    print(f"{len(rows)} labelled photos in {args.labels}")
    config = load_config(assignments=args.set).perception
    for row in rows:
        if args.split is None or row["split"] == args.split:
            measure(row, args.images, tallies[row["split"]], config)
    for split in ("dev", "test"):
        if split in tallies:
            report(split, tallies[split])


if __name__ == "__main__":
    main()
