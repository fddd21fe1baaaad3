"""The composed boards' sources, as `bench_composite.py`, `bench_composite_games.py` and
`bench_readers.py` take them: the options that choose them, their loading, the photos of a part
made from them, and the kind of paper a figure is told by.

The sources (real handwriting, photos of real paper) are not in git; restore them as
`bench/data/composite_boards/SOURCES.md` says (`bench/restore_composite.py`).
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path

from board_tally import labelled_rows

from oxbot.testing.composite import HandwritingSource, PaperSource, write_set

DATA = Path(__file__).resolve().parent / "data" / "composite_boards"


def add_source_options(parser: argparse.ArgumentParser) -> None:
    """--split, --seed, --hands and --papers."""
    parser.add_argument("--split", choices=("dev", "test"), default="test")
    parser.add_argument("--seed", type=int, default=15)
    parser.add_argument("--hands", type=Path, default=DATA / "sources" / "handwriting")
    parser.add_argument("--papers", type=Path, default=DATA / "sources" / "paper")


def load_sources(
    hands: Path, papers: Path, split: str, program: str
) -> tuple[HandwritingSource, PaperSource]:
    """The restored handwriting (both parts) and one part's paper photos; SystemExit saying how
    to restore them when they are missing."""
    try:
        return (
            HandwritingSource.load(hands, DATA / "handwriting_manifest.csv"),
            PaperSource.load(papers, DATA / "paper_regions.csv", split),
        )
    except FileNotFoundError as err:
        raise SystemExit(f"{program}: {err}") from None


def composed_photos(
    hands: HandwritingSource, papers: PaperSource, split: str, photos: int, seed: int
) -> tuple[list[dict[str, str]], Path]:
    """`photos` composed photos of the `split` part (`papers` being that part's), made anew
    into `DATA/<split>/images`: their `labels.csv` rows and that folder."""
    out = DATA / split
    labels = write_set(out, hands, papers, photos, seed, split)
    return labelled_rows(labels, split), out / "images"


def paper_kind(described: Mapping[str, str]) -> str:
    """What the figures "by paper (and pencil apart)" group a photo or game by: its paper's kind
    (`plain`, `ruled`, ...), with ", pencil" when it was drawn in pencil."""
    return described["paper"].split(" ", 1)[0] + (
        ", pencil" if "pencil" in described["ink"] else ""
    )
