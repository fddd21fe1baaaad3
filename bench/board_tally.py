"""Reading labelled board photos and tallying what the board reader got right: the figures
`bench_real_boards.py` prints for real photos and `bench_composite.py` for composed ones.

A labelled photo is a row of a `labels.csv` (file, board, split, paper, ink, grid fraction, the
9 cell labels row by row from the upper left, notes; `bench/data/real_boards/SOURCES.md`;
`labelled_rows` reads them). `measure` reads it once with `oxbot.read_board`'s reader and adds
what came of it to a `Tally`; `read_frame` does the same for a frame in memory with its labels
(or none: a frame without a grid, right when refused); `report` prints a tally: boards fully
right, refusals, cells, empty cells, symbols, symbols read wrong as surely as the move tracker
needs, and one line per photo not fully right.
"""

from __future__ import annotations

import csv
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from oxbot.config import PerceptionConfig, TrackerConfig
from oxbot.errors import NoGridFound
from oxbot.perception.board import BoardReader, default_reader, refuse_cells_out_of_view
from oxbot.perception.sources import load_image

REAL_BOARDS = Path(__file__).resolve().parent / "data" / "real_boards"
"""The real photos of hand-drawn boards: `labels.csv`, and `images/` once restored."""
CELLS = tuple(f"c{r}{c}" for r in range(3) for c in range(3))
SHORT = {"circle": "O", "cross": "X", "nothing": ".", "unreadable": "?"}


@dataclass
class Tally:
    """Counts of one split."""

    photos: int = 0
    boards: set[str] = field(default_factory=set)
    missing: int = 0
    scorable: int = 0  # photos whose 9 cells a human can all read
    fully_right: int = 0
    no_grid: int = 0
    other_refusals: int = 0
    cells: int = 0
    cells_right: int = 0
    empty: int = 0
    empty_right: int = 0
    symbols: int = 0
    symbols_right: int = 0
    sure_wrong: int = 0  # symbols read wrong that the move tracker would take (see read_frame)
    wall_ms: list[float] = field(default_factory=list)  # each read's time
    cpu_ms: list[float] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)

    def add(self, other: Tally) -> None:
        """Count `other`'s photos in this tally too."""
        for name, value in vars(other).items():
            mine = getattr(self, name)
            if isinstance(mine, set):
                mine |= value
            elif isinstance(mine, list):
                mine.extend(value)
            else:
                setattr(self, name, mine + value)


def short(labels: list[str]) -> str:
    """The 9 labels as `XO.|...|..O`, row by row."""
    marks = "".join(SHORT.get(label, "!") for label in labels)
    return "|".join(marks[i : i + 3] for i in (0, 3, 6))


def pct(part: int, whole: int) -> str:
    return f"{part}/{whole} ({100 * part / whole:.1f}%)" if whole else f"{part}/0"


def labelled_rows(labels: Path, split: str | None = None) -> list[dict[str, str]]:
    """The rows of a `labels.csv`, those of one split only when `split` is given."""
    with labels.open(newline="", encoding="utf-8") as handle:
        return [r for r in csv.DictReader(handle) if split is None or r["split"] == split]


def measure(
    row: dict[str, str], image_dir: Path, tally: Tally, config: PerceptionConfig | None = None
) -> None:
    """Read one photo and add its outcome to `tally`."""
    path = image_dir / row["file"]
    if not path.is_file():
        tally.missing += 1
        print(f"  missing: {path} (restore it as SOURCES.md says); skipped")
        return
    tally.boards.add(row["board"])
    truth = [row[c] for c in CELLS]
    sure = TrackerConfig().min_confidence
    read_frame(load_image(path), truth, row["file"], tally, default_reader(config), sure)


def read_frame(
    frame: np.ndarray,
    truth: Sequence[str] | None,
    name: str,
    tally: Tally,
    reader: BoardReader,
    sure: float,
) -> None:
    """Read `frame` with `reader` as `oxbot.read_board` does and add the outcome to `tally`.

    `truth` is the 9 cells' labels (an `unreadable` cell is left out of the counts), or None for
    a frame that holds no grid, which is right when refused. A cell read as a symbol it is not
    with a confidence of `sure` or more (the tracker's `min_confidence`) is a sure misread.
    """
    readable = [] if truth is None else [i for i, lab in enumerate(truth) if lab != "unreadable"]
    tally.photos += 1
    whole = len(readable) == 9
    tally.scorable += whole
    started, started_cpu = time.perf_counter(), time.process_time()
    try:
        reading = reader.read(frame)  # read_board, with the confidences
        refuse_cells_out_of_view(reading.grid)
        got = list(reading.labels)
    except NoGridFound as err:
        tally.no_grid += 1
        tally.failures.append(f"{name:<26} NoGridFound: {err}")
        got = None
    except Exception as err:  # any other refusal is counted, not raised
        tally.other_refusals += 1
        tally.failures.append(f"{name:<26} {type(err).__name__}: {err}")
        got = None
    tally.wall_ms.append(1000 * (time.perf_counter() - started))
    tally.cpu_ms.append(1000 * (time.process_time() - started_cpu))
    if truth is None:
        if got is not None:
            tally.sure_wrong += sum(
                got[i] in ("circle", "cross") and reading.readings[i].confidence >= sure
                for i in range(len(got))
            )
            tally.failures.append(f"{name:<26} no grid in it, read {short(got)}")
        return
    for i in readable:
        right = got is not None and got[i] == truth[i]
        tally.cells += 1
        tally.cells_right += right
        if truth[i] == "nothing":
            tally.empty += 1
            tally.empty_right += right
        else:
            tally.symbols += 1
            tally.symbols_right += right
    if got is None:
        return
    # A camera still on this sheet gives this reading frame after frame; the move tracker
    # takes a new whole symbol read `sure` or surer three times running as a move. A symbol
    # read wrong that surely is a wrong move waiting to happen.
    tally.sure_wrong += sum(
        1
        for i in readable
        if got[i] in ("circle", "cross")
        and got[i] != truth[i]
        and reading.readings[i].confidence >= sure
    )
    if all(got[i] == truth[i] for i in readable):
        if whole:
            tally.fully_right += 1
        return
    wrong = [f"{CELLS[i][1:]}:{truth[i]}->{got[i]}" for i in readable if got[i] != truth[i]]
    tally.failures.append(
        f"{name:<26} truth {short(truth)}  read {short(got)}  ({', '.join(wrong)})"
    )


def report(split: str, tally: Tally) -> None:
    print(f"\n{split}: {tally.photos} photos of {len(tally.boards)} boards", end="")
    print(f" ({tally.missing} missing)" if tally.missing else "")
    if not tally.photos:
        return
    print(f"  boards fully right     {pct(tally.fully_right, tally.scorable)}", end="")
    unscorable = tally.photos - tally.scorable
    print(f"  ({unscorable} photo(s) with an unreadable cell left out)" if unscorable else "")
    print(f"  NoGridFound            {pct(tally.no_grid, tally.photos)}")
    print(f"  other refusals         {pct(tally.other_refusals, tally.photos)}")
    print(f"  cells right            {pct(tally.cells_right, tally.cells)}  (refused: wrong)")
    print(f"  empty cells as empty   {pct(tally.empty_right, tally.empty)}")
    print(f"  symbols right          {pct(tally.symbols_right, tally.symbols)}")
    print(f"  wrong symbols, sure    {tally.sure_wrong}  (read wrong at the tracker's confidence)")
    print(f"  mean read time         {sum(tally.wall_ms) / tally.photos:.1f} ms")
    for line in tally.failures:
        print(f"  FAIL {line}")
