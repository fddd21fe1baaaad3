"""Benchmark of the board reader on boards composed from real handwriting on real paper photos
(the independent test, since licensed real board photos are too few; `oxbot.testing.composite`).

    PYTHONPATH=. .venv/bin/python bench/bench_composite.py                   # test part, 200
    PYTHONPATH=. .venv/bin/python bench/bench_composite.py --split dev --photos 100
    PYTHONPATH=. .venv/bin/python bench/bench_composite.py --set perception.plus_is_cross=true

Makes the photos of one part (`dev`: the drawings of a quarter of the writers and the paper
regions that `paper_regions.csv` gives to dev; `test`: the rest; the parts share no writer, and
no paper photo but the one ruled sheet, whose two blank stretches go one to each part) into
`bench/data/composite_boards/<split>/` from the restored sources
(`bench/data/composite_boards/SOURCES.md`), then reads them as `bench/bench_real_boards.py`
reads real photos and prints the same figures. Measurement only: look at and debug on `dev`,
never tune on `test`.
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict

import numpy as np
from board_tally import Tally, measure, report
from composite_sources import add_source_options, composed_photos, load_sources, paper_kind
from config_option import add_set_option

from oxbot.config import OxbotConfig, load_config
from oxbot.perception.board import BoardReader, deepen_faint_ink
from oxbot.perception.cells import wipe_background
from oxbot.testing.composite import HandwritingSource, PaperSource, symbol_cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_source_options(parser)
    parser.add_argument("--photos", type=int, default=200, help="photos to make and read")
    parser.add_argument(
        "--cells",
        action="store_true",
        help="read every circle and cross of the part alone in a cell instead of boards",
    )
    add_set_option(parser, "perception.plus_is_cross=true")
    args = parser.parse_args()
    hands, papers = load_sources(args.hands, args.papers, args.split, "bench_composite")
    if args.cells:
        read_cells(hands.split(args.split), papers, args.seed, load_config(assignments=args.set))
        return
    rows, images = composed_photos(hands, papers, args.split, args.photos, args.seed)
    config = load_config(assignments=args.set).perception
    tally = Tally()
    by_kind: dict[str, Tally] = defaultdict(Tally)
    for row in rows:
        one = Tally()  # each photo read once, counted in all and in its kind
        measure(row, images, one, config)
        tally.add(one)
        by_kind[paper_kind(row)].add(one)
    print(f"{len(rows)} composed photos, seed {args.seed}, in {images.parent}")
    report(args.split, tally)
    print("\nby paper (and pencil apart):")
    for kind, part in sorted(by_kind.items()):
        print(
            f"  {kind:<20} {part.photos:>4} photos, fully right {part.fully_right:>4}, "
            f"NoGridFound {part.no_grid:>3}, empty as empty {part.empty_right}/{part.empty}, "
            f"symbols right {part.symbols_right}/{part.symbols}, sure wrong {part.sure_wrong}"
        )


def read_cells(
    hands: HandwritingSource, papers: PaperSource, seed: int, config: OxbotConfig
) -> None:
    """Each real circle and cross alone in a cell, read as the board reader reads a cell (the
    paper's pattern wiped, faint ink deepened, then `BoardReader.classify`)."""
    cells, labels, writers = symbol_cells(hands, papers, np.random.default_rng([seed, 2]))
    readings = BoardReader(config=config.perception).classify(
        deepen_faint_ink(wipe_background(cells))
    )
    sure = config.tracker.min_confidence
    print(f"{len(labels)} real symbols alone in a cell, seed {seed}")
    for source in ("quickdraw", "unipen", ""):
        for label in ("circle", "cross", ""):
            picked = [
                i
                for i, (w, lab) in enumerate(zip(writers, labels, strict=True))
                if w.startswith(source) and lab.startswith(label)
            ]
            if not picked:
                continue
            said = Counter(readings[i].label for i in picked)
            right = said[label] if label else sum(readings[i].label == labels[i] for i in picked)
            wrong_sure = sum(
                readings[i].label in ("circle", "cross")
                and readings[i].label != labels[i]
                and readings[i].confidence >= sure
                for i in picked
            )
            name = f"{source or 'all'} {label or 'symbols'}"
            print(
                f"  {name:<22} {right}/{len(picked)} right ({100 * right / len(picked):.2f}%), "
                f"read as {dict(said)}, wrong at the tracker's {sure:g}: {wrong_sure}"
            )


if __name__ == "__main__":
    main()
