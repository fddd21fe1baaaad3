"""Reading labelled board photos and tallying what the board reader got right: the figures
`bench_real_boards.py` prints for real photos and `bench_composite.py` for composed ones.

A labelled photo is a row of a `labels.csv` (file, board, split, paper, ink, grid fraction, the
9 cell labels row by row from the upper left, notes; `bench/data/real_boards/SOURCES.md`).
`measure` reads it once with `oxbot.read_board`'s reader and adds what came of it to a `Tally`;
`report` prints a tally: boards fully right, refusals, cells, empty cells, symbols, symbols read
wrong as surely as the move tracker needs, and one line per photo not fully right.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from oxbot.config import PerceptionConfig, TrackerConfig
from oxbot.errors import NoGridFound
from oxbot.perception.board import default_reader, refuse_cells_out_of_view
from oxbot.perception.sources import load_image

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
    sure_wrong: int = 0  # symbols read wrong that the move tracker would take (see measure)
    seconds: float = 0.0
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


def measure(
    row: dict[str, str], image_dir: Path, tally: Tally, config: PerceptionConfig | None = None
) -> None:
    """Read one photo and add its outcome to `tally`."""
    path = image_dir / row["file"]
    if not path.is_file():
        tally.missing += 1
        print(f"  missing: {path} (restore it as SOURCES.md says); skipped")
        return
    truth = [row[c] for c in CELLS]
    readable = [i for i, label in enumerate(truth) if label != "unreadable"]
    tally.photos += 1
    tally.boards.add(row["board"])
    whole = len(readable) == 9
    tally.scorable += whole
    frame = load_image(path)
    started = time.perf_counter()
    sure = TrackerConfig().min_confidence
    try:
        reading = default_reader(config).read(frame)  # read_board, with the confidences
        refuse_cells_out_of_view(reading.grid)
        got = list(reading.labels)
    except NoGridFound as err:
        tally.seconds += time.perf_counter() - started
        tally.no_grid += 1
        tally.failures.append(f"{row['file']:<26} NoGridFound: {err}")
        got = None
    except Exception as err:  # any other refusal is counted, not raised
        tally.seconds += time.perf_counter() - started
        tally.other_refusals += 1
        tally.failures.append(f"{row['file']:<26} {type(err).__name__}: {err}")
        got = None
    else:
        tally.seconds += time.perf_counter() - started
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
        f"{row['file']:<26} truth {short(truth)}  read {short(got)}  ({', '.join(wrong)})"
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
    print(f"  mean read time         {1000 * tally.seconds / tally.photos:.1f} ms")
    for line in tally.failures:
        print(f"  FAIL {line}")
