"""The move tracker: from a stream of board readings to the person's game moves.

Paper §2.1: the classifier runs every 100 ms, and "we accept a new drawing if it has been
recognised at least 3 times in a row"; the perception component then outputs a game move
`[who=usr ∧ what=draw ∧ where=middle]`. The drawn symbol is inferred from who started: the
starter draws circles (paper, footnote).

The tracker keeps the board it has accepted. Each reading is compared with it:

- a symbol in an empty cell is a *new drawing*; the same new drawing(s) must be read
  `stable_readings` times in a row before anything happens, so a half-drawn symbol that the
  classifier reads differently from one frame to the next, or a one-frame flicker, is ignored;
- given the classifier's `CellReading`s, a new drawing counts only as a whole,
  confident symbol (confidence ≥ `min_confidence`; "partial" ink never counts), and the
  readings agree only while its ink stays the same (within `ink_tolerance`): a symbol still
  being drawn keeps changing, so it is accepted once the pen has stopped;
- a symbol that disappears (a hand over it, a misread frame) is ignored: paper does not
  forget, and the accepted board keeps it;
- while a new drawing is seen in an empty cell, an occupied cell read as another symbol is
  ignored: a frame's noise on the robot's thin circle must not hold up the person's move;
- the robot's own drawings are known in advance (`robot_draws`), so they never become the
  person's moves, and so are the person's moves made without drawing (`person_drew`: typed, or
  said in words), so that drawing them afterwards makes no second move;
- a stable change that is not a legal move — two new symbols at once, a symbol drawn over an
  occupied cell, the other player's symbol, a symbol drawn out of turn or after the game
  ended — is reported as an `ImpossibleEvent` once, and never accepted.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from oxbot.config import TrackerConfig
from oxbot.errors import InvalidInputError, NoGridFound
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY,
    N_CELLS,
    PLURALS,
    ROBOT,
    USER,
    cell_index,
    outcome,
    symbol_of,
    to_move,
)
from oxbot.perception.sources import FrameSource
from oxbot.perception.synth import OUTPUTS, PARTIAL

if TYPE_CHECKING:
    from oxbot.perception.classifier import CellReading


@dataclass(frozen=True)
class AcceptedDrawing:
    """A drawing accepted as a move: the paper's `[who=usr ∧ what=draw ∧ where=middle]`."""

    who: Literal["usr", "rob"]
    what: Literal["draw"]
    where: str
    """The cell's name (`CELL_NAMES`), e.g. "middle"."""
    cell: int
    """The cell's index 0-8, row-major from the upper left."""
    symbol: str
    """"circle" or "cross"."""
    reading: int
    """How many readings the tracker had been fed when it accepted the move (1-based)."""

    def __str__(self) -> str:
        return f"[who={self.who} ∧ what={self.what} ∧ where={self.where}]"


ImpossibleKind = Literal[
    "two_new_symbols",
    "occupied_cell",
    "wrong_symbol",
    "out_of_turn",
    "game_over",
    "not_started",
    "unclear_symbol",
]


@dataclass(frozen=True)
class ImpossibleEvent:
    """A stable change on the sheet that is not a legal move; reported, never accepted."""

    kind: ImpossibleKind
    cells: tuple[int, ...]
    """The cells involved, by index."""
    symbols: tuple[str, ...]
    """What was read in each of those cells."""
    message: str
    """What happened, in words a person understands."""
    reading: int
    """How many readings the tracker had been fed when it reported this (1-based)."""

    def __str__(self) -> str:
        return self.message


TrackerEvent = AcceptedDrawing | ImpossibleEvent


class MoveTracker:
    """Turns board readings, one every `config.period_s`, into the person's game moves.

    `update(labels)` takes one reading (9 labels, row-major) and returns the event it
    completes, if any; `update(None)` records a frame in which no board could be read, which
    breaks any run of identical readings. `update(labels, cells)` also takes the 9 cells'
    `CellReading`s, for the confidence and ink checks.
    """

    def __init__(
        self,
        robot_starts: bool = True,
        config: TrackerConfig | None = None,
        check_turns: bool = True,
    ) -> None:
        self.config = config if config is not None else TrackerConfig()
        self.robot_starts = robot_starts
        self.check_turns = check_turns
        """Refuse a drawing out of turn or after the game ended (off: track drawings only)."""
        self.playing = True
        """False while the dialogue has not started the game (the person has not agreed): a
        drawing then is refused as `not_started`, never kept as a move."""
        self.user_symbol = symbol_of(USER, robot_starts)
        self.robot_symbol = symbol_of(ROBOT, robot_starts)
        self.reset()

    def reset(self) -> None:
        """Start again from an empty sheet."""
        self._board: list[str] = ["nothing"] * N_CELLS
        self._robot_cells: set[int] = set()
        self._candidate: tuple[tuple[int, str], ...] = ()
        self._candidate_ink: tuple[float, ...] = ()
        self._count = 0
        self._readings = 0
        self._unclear: dict[int, tuple[float, int]] = {}  # cell -> (first ink, readings)
        self._unclear_told: dict[int, int] = {}  # cell -> the turn (symbols drawn) it was told

    @property
    def board(self) -> tuple[str, ...]:
        """The accepted labels of the 9 cells, the robot's announced drawings included."""
        return tuple(self._board)

    @property
    def agreeing(self) -> int:
        """How many readings in a row have shown the same new drawing(s) (0: none)."""
        return self._count

    def robot_draws(self, cell: int | str) -> None:
        """Tell the tracker that the robot draws (or drew) its symbol in `cell`.

        The cell counts as the robot's from now on, while the arm is still drawing, so the
        half-drawn symbol is never taken for the person's move.
        """
        index = cell if isinstance(cell, int) else cell_index(cell)
        if not 0 <= index < N_CELLS:
            raise InvalidInputError(f"cell {cell!r} does not exist; cells are 0-{N_CELLS - 1}")
        if self._board[index] != "nothing" and index not in self._robot_cells:
            raise InvalidInputError(
                f"the robot cannot draw in {CELL_NAMES[index]}: the person's "
                f"{self._board[index]} is there"
            )
        self._board[index] = self.robot_symbol
        self._robot_cells.add(index)

    def person_drew(self, cell: int | str) -> None:
        """Tell the tracker that the person's move is in `cell`, given another way than by
        drawing it (typed, or said in words): the cell counts as theirs from now on, so that the
        symbol they may draw there later is no new move. A cell the tracker already holds is
        left as it is."""
        index = cell if isinstance(cell, int) else cell_index(cell)
        if not 0 <= index < N_CELLS:
            raise InvalidInputError(f"cell {cell!r} does not exist; cells are 0-{N_CELLS - 1}")
        if self._board[index] == "nothing":
            self._board[index] = self.user_symbol
            self._candidate, self._count = (), 0

    def update(
        self, labels: Sequence[str] | None, cells: Sequence[CellReading] | None = None
    ) -> TrackerEvent | None:
        """Feed one reading; return the move or impossible event it completes, else None.

        `labels` are 9 of OUTPUTS ("partial" counts as nothing); `cells`, if given, the 9
        cells' readings: a new symbol then also needs their confidence and still ink.
        """
        self._readings += 1
        if labels is None:
            self._candidate, self._count = (), 0
            return None
        if cells is not None and len(cells) != N_CELLS:
            raise InvalidInputError(f"a board reading has {N_CELLS} cells; got {len(cells)}")
        changes = self._changes(labels, cells)
        # A drawing in an empty cell is judged on its own: an occupied cell read as the other
        # symbol in one frame of three (sensor noise on a thin pen) must not break the run of
        # readings that shows the person's move. Without one, such a reading is reported.
        drawn = tuple(change for change in changes if self._board[change[0]] == "nothing")
        changes = drawn or changes
        if not changes:
            self._candidate, self._count = (), 0
            return self._unclear_ink(cells) if cells is not None else None
        ink = tuple(cells[c].ink for c, _ in changes) if cells is not None else ()
        if changes == self._candidate and self._ink_still(ink):
            self._count += 1
        else:
            self._candidate, self._candidate_ink, self._count = changes, ink, 1
        if self._count != self.config.stable_readings:
            return None  # not yet seen often enough, or already dealt with
        return self._judge(changes)

    def taken_as(self, reading: CellReading) -> str:
        """A cell's reading as the tracker takes it: a circle or cross less sure than
        `min_confidence` is partial ink, no symbol yet (its own label, not a public one, where
        partial is "nothing")."""
        if reading.label in ("circle", "cross") and reading.confidence < self.config.min_confidence:
            return PARTIAL
        return reading.label

    def _ink_still(self, ink: tuple[float, ...]) -> bool:
        """Whether the new drawing's ink is what it was at the run's first reading."""
        return all(
            self._same_ink(now, first) for now, first in zip(ink, self._candidate_ink, strict=True)
        )

    def _same_ink(self, now: float, first: float) -> bool:
        return abs(now - first) <= self.config.ink_tolerance * max(first, 1e-6)

    def _unclear_ink(self, cells: Sequence[CellReading]) -> ImpossibleEvent | None:
        """An `unclear_symbol` event for ink in an empty cell that has stayed still for
        `unclear_seconds` without being a whole, confident symbol, when it is the person's
        turn; told once a turn for each cell (a mark on the sheet the reader cannot make out
        is told too, once a turn: the robot cannot tell it from a drawing)."""
        needed = max(1, round(self.config.unclear_seconds / self.config.period_s))
        turn = sum(label != "nothing" for label in self._board)
        report = None
        for cell, known in enumerate(self._board):
            if known != "nothing" or self.taken_as(cells[cell]) != PARTIAL:
                self._unclear.pop(cell, None)
                continue
            ink = cells[cell].ink
            first, count = self._unclear.get(cell, (ink, 0))
            if not self._same_ink(ink, first):
                first, count = ink, 0
            self._unclear[cell] = (first, count + 1)
            if count + 1 < needed or self._unclear_told.get(cell) == turn:
                continue
            if report is None and self._persons_turn():
                self._unclear_told[cell] = turn
                report = self._impossible(
                    "unclear_symbol",
                    (cell,),
                    (cells[cell].label,),
                    f"ink in {CELL_NAMES[cell]} has stayed still for "
                    f"{self.config.unclear_seconds:g} s without being a whole "
                    f"{self.user_symbol}",
                )
        return report

    def _persons_turn(self) -> bool:
        if not self.check_turns:
            return True
        board = self._game_board()
        return self.playing and outcome(board) is None and to_move(board, self.robot_starts) == USER

    def _game_board(self) -> tuple[int, ...]:
        """The accepted board as the game's EMPTY, ROBOT and USER marks."""
        return tuple(
            EMPTY if label == "nothing" else ROBOT if i in self._robot_cells else USER
            for i, label in enumerate(self._board)
        )

    def _changes(
        self, labels: Sequence[str], cells: Sequence[CellReading] | None
    ) -> tuple[tuple[int, str], ...]:
        """The (cell, label) pairs where the reading adds a whole, confident symbol to the
        accepted board."""
        if len(labels) != N_CELLS or any(label not in OUTPUTS for label in labels):
            raise InvalidInputError(
                f"a board reading is {N_CELLS} labels from {', '.join(OUTPUTS)}; "
                f"got {list(labels)!r}"
            )
        changes = []
        for cell, (seen, known) in enumerate(zip(labels, self._board, strict=True)):
            if seen in ("nothing", "partial") or seen == known:
                continue  # unchanged, or a symbol that disappeared: paper does not forget
            if cells is not None and cells[cell].confidence < self.config.min_confidence:
                continue  # not sure it is a whole symbol: no drawing yet
            changes.append((cell, seen))
        return tuple(changes)

    def _judge(self, changes: tuple[tuple[int, str], ...]) -> TrackerEvent:
        cells = tuple(cell for cell, _ in changes)
        symbols = tuple(label for _, label in changes)
        occupied = [(c, s) for c, s in changes if self._board[c] != "nothing"]
        if occupied:
            c, s = occupied[0]
            owner = "the robot's" if c in self._robot_cells else "the person's"
            return self._impossible(
                "occupied_cell",
                cells,
                symbols,
                f"a {s} appeared in {CELL_NAMES[c]}, which already holds {owner} "
                f"{self._board[c]}; a cell can be played only once",
            )
        if len(changes) > 1:
            where = ", ".join(f"{s} in {CELL_NAMES[c]}" for c, s in changes)
            return self._impossible(
                "two_new_symbols",
                cells,
                symbols,
                f"{len(changes)} new symbols appeared at once ({where}); a turn is one symbol",
            )
        cell, symbol = changes[0]
        board = self._game_board()
        if self.check_turns and not self.playing:
            return self._impossible(
                "not_started",
                cells,
                symbols,
                f"a {symbol} appeared in {CELL_NAMES[cell]} before the game started",
            )
        if self.check_turns and outcome(board) is not None:
            return self._impossible(
                "game_over",
                cells,
                symbols,
                f"a {symbol} appeared in {CELL_NAMES[cell]}, but the game is over",
            )
        if self.check_turns and to_move(board, self.robot_starts) != USER:
            return self._impossible(
                "out_of_turn",
                cells,
                symbols,
                f"a {symbol} appeared in {CELL_NAMES[cell]} while it is not the person's turn",
            )
        if symbol != self.user_symbol:
            starter = "the robot" if self.robot_starts else "the person"
            return self._impossible(
                "wrong_symbol",
                cells,
                symbols,
                f"a {symbol} appeared in {CELL_NAMES[cell]}, but the person draws "
                f"{PLURALS[self.user_symbol]} ({starter} started, and the starter draws circles)",
            )
        self._board[cell] = symbol
        self._candidate, self._count = (), 0
        return AcceptedDrawing("usr", "draw", CELL_NAMES[cell], cell, symbol, self._readings)

    def _impossible(
        self, kind: ImpossibleKind, cells: tuple[int, ...], symbols: tuple[str, ...], text: str
    ) -> ImpossibleEvent:
        return ImpossibleEvent(kind, cells, symbols, text, self._readings)


def watch(
    source: FrameSource,
    tracker: MoveTracker,
    read: Callable[[np.ndarray], Sequence[str]] | None = None,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> Iterator[TrackerEvent]:
    """Read the board from an open `source` once per `tracker.config.period_s` and yield the
    tracker's events, until the source ends.

    A video file is sampled by its own clock (one frame per period of video time, however fast
    it decodes); a camera, an image folder or pushed frames are read once per period of wall
    time. A frame without a readable grid (a hand over the sheet) counts as a missed reading.
    """
    if read is None:
        from oxbot.perception.board import read_board

        read = read_board
    period = tracker.config.period_s
    fps = getattr(source, "fps", 0.0)
    step = max(1, round(fps * period)) if fps > 0 else 0
    index, next_tick = 0, clock()
    while True:
        if step == 0:  # live: wait for the next tick of the wall clock
            delay = next_tick - clock()
            if delay > 0:
                sleep(delay)
            next_tick = max(next_tick + period, clock())
        frame = source.read()
        if frame is None:
            return
        index += 1
        if step and (index - 1) % step:
            continue  # a video frame between two ticks of the video's clock
        try:
            labels: Sequence[str] | None = read(frame)
        except NoGridFound:
            labels = None
        event = tracker.update(labels)
        if event is not None:
            yield event
