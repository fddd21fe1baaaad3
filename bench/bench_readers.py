"""Benchmark of the board readers side by side, each grid finder on every set of board photos.

One table: each reader (`perception.grid_finder`) on every set of board photos the project has.

    PYTHONPATH=. .venv/bin/python bench/bench_readers.py        # classical and learned, all sets
    PYTHONPATH=. .venv/bin/python bench/bench_readers.py --readers classical --markdown
    PYTHONPATH=. .venv/bin/python bench/bench_readers.py --sets real,composite-dev,empty --photos 50
    PYTHONPATH=. .venv/bin/python bench/bench_readers.py --set perception.plus_is_cross=true

A reader is the configuration (with any `--set`) and `perception.grid_finder=<name>`; a reader
the configuration rejects, or whose model is missing, is reported so in its rows. The sets
(`--sets`: names, or the groups `real`, `composite`, `rendered` and `blank`):

- `real-dev`, `real-test`: the real whiteboard photos (`bench/data/real_boards/`, as
  `bench_real_boards.py` reads them; restored by `restore_composite.py --real-boards`);
- `composite-dev`, `composite-test`: boards composed from real handwriting on real paper photos,
  seed 15, 200 each (as `bench_composite.py`; made anew into `bench/data/composite_boards/`);
- each rendered style of `oxbot.testing.render` (`tuning` and its variants, seed 7000;
  `held-out` and `wide-held-out`, seed 2024; as `bench_board.py`), 100 each;
- `empty`: rendered sheets with a grid and no symbol, the styles in turn, seed 2025, 100: all 9
  cells must read nothing;
- `no-grid`: 100 frames with no grid, seed 2026 (a blank sheet, a sheet with symbols and no grid, a
  desk with no paper, in turn; the styles in turn): each must be refused.

`--photos N` makes every generated set N photos. Each frame is read once as `oxbot.read_board`
reads it (`board_tally.read_frame`) on one core (torch and OpenCV one thread each, as
`bench_board.py`). Columns: boards fully right (for `no-grid`: frames refused, which is right
there); empty cells read as nothing (a refused board's cells count wrong); refusals
(NoGridFound or any other error); sure misreads (a cell read as a symbol it is not, or any
symbol in a frame without a grid, at the tracker's `min_confidence` or surer: a wrong move the
tracker would take); the median time per frame, wall clock and CPU. Then how long the run took.
Measurement only: nothing here tunes anything; nobody tunes on a test part or a held-out style.
Not a test.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from board_tally import CELLS, REAL_BOARDS, Tally, labelled_rows, pct, read_frame
from composite_sources import DATA, composed_photos, load_sources
from config_option import add_set_option
from rendered_sets import (
    HELD_OUT_STYLES,
    RENDER_STYLES,
    empty_boards,
    gridless_frames,
    render_photos,
    usual_seed,
)
from timing import one_core

from oxbot.config import load_config
from oxbot.errors import OxbotError
from oxbot.perception.board import BoardReader, default_reader
from oxbot.perception.sources import load_image

COMPOSED_SEED = 15  # bench_composite.py's default
RENDERED = [s for s in RENDER_STYLES if s not in HELD_OUT_STYLES] + list(HELD_OUT_STYLES)
SETS = ["real-dev", "real-test", "composite-dev", "composite-test", *RENDERED, "empty", "no-grid"]
GROUPS = {
    "real": SETS[:2],
    "composite": SETS[2:4],
    "rendered": RENDERED,
    "blank": ["empty", "no-grid"],
}


@dataclass(frozen=True)
class Frame:
    """A frame to read (in memory, or a file read when its turn comes) and its truth: the 9
    labels, or None when it holds no grid."""

    name: str
    image: np.ndarray | Path
    truth: tuple[str, ...] | None


class Missing(Exception):
    """A set's data is not on this machine (the message says how to restore it)."""


def real_frames(split: str) -> list[Frame]:
    """The real photos of one split that are on this machine."""
    images = REAL_BOARDS / "images"
    frames = [
        Frame(r["file"], images / r["file"], tuple(r[c] for c in CELLS))
        for r in labelled_rows(REAL_BOARDS / "labels.csv", split)
    ]
    found = [f for f in frames if isinstance(f.image, Path) and f.image.is_file()]
    if len(found) < len(frames):
        print(f"  {len(frames) - len(found)} of the {split} photos missing", file=sys.stderr)
    if not found:
        raise Missing(f"no photo in {images}: bench/restore_composite.py --real-boards DIR")
    return found


def composed_frames(split: str, photos: int) -> list[Frame]:
    """`photos` composed photos of one part, made anew."""
    try:
        hands, papers = load_sources(
            DATA / "sources" / "handwriting", DATA / "sources" / "paper", split, "bench_readers"
        )
    except SystemExit as err:
        raise Missing(str(err)) from None
    rows, images = composed_photos(hands, papers, split, photos, COMPOSED_SEED)
    return [Frame(r["file"], images / r["file"], tuple(r[c] for c in CELLS)) for r in rows]


def make_frames(name: str, photos: int | None) -> list[Frame]:
    """The frames of the set `name`; `photos` (or the set's default) for generated sets."""
    if name.startswith("real-"):
        return real_frames(name.removeprefix("real-"))
    if name.startswith("composite-"):
        return composed_frames(name.removeprefix("composite-"), photos or 200)
    if name == "empty":
        nothing = ("nothing",) * len(CELLS)
        return [Frame(f"empty_{i}", f, nothing) for i, f in enumerate(empty_boards(photos or 100))]
    if name == "no-grid":
        return [
            Frame(f"no-grid_{i}", f, None) for i, f in enumerate(gridless_frames(photos or 100))
        ]
    shots = render_photos(name, photos or 100, usual_seed(name))
    return [Frame(f"{name}_{i}", p.image, p.labels) for i, p in enumerate(shots)]


def make_reader(name: str, assignments: list[str]) -> tuple[BoardReader, float] | str:
    """The board reader with grid finder `name` and the tracker's `min_confidence`, or why
    there is none (the configuration rejects it, its model is missing)."""
    try:
        config = load_config(assignments=[*assignments, f"perception.grid_finder={name}"])
        return default_reader(config.perception), config.tracker.min_confidence
    except OxbotError as err:
        return f"{type(err).__name__}: {err}"


def read_set(frames: list[Frame], reader: BoardReader, sure: float) -> Tally:
    """Every frame read once by `reader`, tallied."""
    tally = Tally()
    for frame in frames:
        image = load_image(frame.image) if isinstance(frame.image, Path) else frame.image
        read_frame(image, frame.truth, frame.name, tally, reader, sure)
    return tally


def figures(name: str, tally: Tally) -> list[str]:
    """A tally's columns: photos, fully right, empty cells, refused, sure misreads, ms."""
    refused = tally.no_grid + tally.other_refusals
    right = (
        pct(refused, tally.photos) if name == "no-grid" else pct(tally.fully_right, tally.scorable)
    )
    empty = f"{100 * tally.empty_right / tally.empty:.1f}%" if tally.empty else "-"
    return [
        str(tally.photos),
        right,
        empty,
        str(refused),
        str(tally.sure_wrong),
        f"{statistics.median(tally.wall_ms):.1f}",
        f"{statistics.median(tally.cpu_ms):.1f}",
    ]


HEADER = [
    "set",
    "reader",
    "frames",
    "fully right",
    "empty cells right",
    "refused",
    "sure misreads",
    "ms wall",
    "ms CPU",
]


def print_table(rows: list[list[str]], markdown: bool) -> None:
    """The table, aligned as text or as Markdown."""
    if markdown:
        for row in [HEADER, ["---"] * len(HEADER), *rows]:
            print("| " + " | ".join(row) + " |")
        return
    widths = [max(len(row[k]) for row in [HEADER, *rows]) for k in range(len(HEADER))]
    for row in [HEADER, *rows]:
        print(
            "  ".join(
                cell.ljust(w) if k < 2 else cell.rjust(w)
                for k, (cell, w) in enumerate(zip(row, widths, strict=True))
            ).rstrip()
        )


def names(text: str) -> list[str]:
    """A comma-separated list of set names or groups, checked, groups opened."""
    picked = []
    for name in (n.strip() for n in text.split(",") if n.strip()):
        if name not in SETS and name not in GROUPS:
            raise argparse.ArgumentTypeError(
                f"no set {name!r}; choose from {', '.join([*SETS, *GROUPS])}"
            )
        picked += [n for n in GROUPS.get(name, [name]) if n not in picked]
    return picked


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--readers", default="classical,learned", help="grid finders, by name")
    parser.add_argument(
        "--sets",
        type=names,
        default=SETS,
        help=f"comma-separated, of {', '.join([*SETS, *GROUPS])}",
    )
    parser.add_argument("--photos", type=int, default=None, help="photos of each generated set")
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    add_set_option(parser, "perception.plus_is_cross=true")
    args = parser.parse_args()
    started = time.monotonic()
    one_core()
    reader_names = [n.strip() for n in args.readers.split(",") if n.strip()]
    readers = {name: make_reader(name, args.set) for name in reader_names}
    rows: list[list[str]] = []
    notes = [f"{r}: not run: {why}" for r, why in readers.items() if isinstance(why, str)]
    for set_name in args.sets:
        begun = time.monotonic()
        try:
            frames = make_frames(set_name, args.photos)
        except Missing as err:
            rows += [[set_name, r, "-", "missing"] + [""] * 5 for r in readers]
            notes.append(f"{set_name}: missing: {err}")
            continue
        for reader_name, reader in readers.items():
            if isinstance(reader, str):
                rows.append([set_name, reader_name, "-", "not run"] + [""] * 5)
            else:
                tally = read_set(frames, *reader)
                rows.append([set_name, reader_name, *figures(set_name, tally)])
        print(f"  {set_name}: {time.monotonic() - begun:.0f} s", file=sys.stderr)
    print_table(rows, args.markdown)
    if "no-grid" in args.sets:
        print("\nno-grid: fully right = refused (no grid is in those frames)")
    for note in notes:
        print(note)
    print(f"\nthe whole run: {(time.monotonic() - started) / 60:.1f} min")


if __name__ == "__main__":
    main()
