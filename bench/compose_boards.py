"""Write boards composed from real handwriting on real paper, with where each grid lies, to
fine-tune the learned grid finder on (`oxbot train reader --finetune OUT`).

    PYTHONPATH=.:bench .venv/bin/python bench/compose_boards.py --split dev --photos 1500 \\
        --seed 115 --out runs/composed-dev

Writes `OUT/images/*.png`, `OUT/labels.csv` and `OUT/lattices.json`. Only the development
part's writers and paper photos are ever for training; the seed should differ from
`bench_composite.py`'s and `bench_readers.py`'s (15), whose composed development boards
measure what the fine-tuning did. The sources are git-ignored: restore them first
(`bench/restore_composite.py`).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from composite_sources import add_source_options, load_sources

from oxbot.testing.composite import write_set


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_source_options(parser)
    parser.set_defaults(split="dev", seed=115)
    parser.add_argument("--photos", type=int, default=1500)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if args.split != "dev":
        parser.error("the test part's writers and papers are for measuring, never for training")
    hands, papers = load_sources(args.hands, args.papers, args.split, parser.prog)
    tick = time.perf_counter()
    labels = write_set(args.out, hands, papers, args.photos, args.seed, args.split)
    print(
        f"wrote {args.photos} photos and their lattices beside {labels} "
        f"in {time.perf_counter() - tick:.0f} s"
    )


if __name__ == "__main__":
    main()
