"""Benchmark of the board reader on boards composed from real handwriting on real paper photos
(issue 15's independent test where real board photos are too few; `oxbot.testing.composite`).

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
import csv
from collections import defaultdict
from pathlib import Path

from bench.bench_real_boards import Tally, measure, report
from oxbot.config import load_config
from oxbot.testing.composite import HandwritingSource, PaperSource, write_set

DATA = Path(__file__).resolve().parent / "data" / "composite_boards"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", choices=("dev", "test"), default="test")
    parser.add_argument("--photos", type=int, default=200, help="photos to make and read")
    parser.add_argument("--seed", type=int, default=15)
    parser.add_argument("--hands", type=Path, default=DATA / "sources" / "handwriting")
    parser.add_argument("--papers", type=Path, default=DATA / "sources" / "paper")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="SECTION.FIELD=VALUE",
        help="a config setting, e.g. perception.plus_is_cross=true",
    )
    args = parser.parse_args()
    try:
        hands = HandwritingSource.load(args.hands, DATA / "handwriting_manifest.csv")
        papers = PaperSource.load(args.papers, DATA / "paper_regions.csv", args.split)
    except FileNotFoundError as err:
        raise SystemExit(f"bench_composite: {err}") from None
    out = DATA / args.split
    labels = write_set(out, hands, papers, args.photos, args.seed, args.split)
    with labels.open(newline="", encoding="utf-8") as handle:
        rows = [r for r in csv.DictReader(handle) if r["split"] == args.split]
    config = load_config(assignments=args.set).perception
    tally = Tally()
    by_kind: dict[str, Tally] = defaultdict(Tally)
    for row in rows:
        measure(row, out / "images", tally, config)
        kind = row["paper"].split(" ", 1)[0] + (", pencil" if "pencil" in row["ink"] else "")
        measure(row, out / "images", by_kind[kind], config)
    print(f"{len(rows)} composed photos, seed {args.seed}, in {out}")
    report(args.split, tally)
    print("\nby paper (and pencil apart):")
    for kind, part in sorted(by_kind.items()):
        print(
            f"  {kind:<20} {part.photos:>4} photos, fully right {part.fully_right:>4}, "
            f"NoGridFound {part.no_grid:>3}, empty as empty {part.empty_right}/{part.empty}, "
            f"symbols right {part.symbols_right}/{part.symbols}, sure wrong {part.sure_wrong}"
        )


if __name__ == "__main__":
    main()
