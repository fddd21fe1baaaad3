"""The noughts-and-crosses board: cells, names, symbols, legal moves and outcomes.

A board is a tuple of 9 ints, row-major from the upper left, as opponents see it: 0 empty, 1
the robot's mark, 2 the person's mark. Boards are immutable so they can key caches and replay
buffers. Which *symbol* a mark is drawn with depends on who started: the starter draws circles
(paper §2.1, footnote).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Sequence
from typing import Literal

from oxbot.errors import IllegalMoveError

Board = tuple[int, ...]
Outcome = Literal["win", "draw", "loss"]
Ending = Literal["win", "draw", "loss", "declined", "stopped"]
"""How a dialogue around a game ended as the robot saw it: the game's outcome, or no game
because the person declined, or a game the person asked to stop."""

SIZE = 3
"""Cells along each side of the grid. Everything below is derived from it and from the row and
column names: a 4x4 game is a change of these three, then retraining."""
ROW_NAMES: tuple[str, ...] = ("upper", "middle", "lower")
COLUMN_NAMES: tuple[str, ...] = ("left", "middle", "right")
N_CELLS = SIZE * SIZE

EMPTY, ROBOT, USER = 0, 1, 2
EMPTY_BOARD: Board = (EMPTY,) * N_CELLS

CELL_NAMES: tuple[str, ...] = tuple(
    "middle" if row == column == "middle" else row + column
    for row in ROW_NAMES
    for column in COLUMN_NAMES
)
"""The paper's cell names, row-major from the upper left (`upperleft` ... `lowerright`,
the centre is `middle`)."""

LABELS: tuple[str, ...] = ("circle", "cross", "nothing")
"""The perceiver's labels, in this order when indexed 0, 1, 2."""
PLURALS = {"circle": "circles", "cross": "crosses"}

_ROWS = tuple(tuple(range(r * SIZE, (r + 1) * SIZE)) for r in range(SIZE))
LINES: tuple[tuple[int, ...], ...] = (
    *_ROWS,
    *(tuple(row[c] for row in _ROWS) for c in range(SIZE)),
    tuple(_ROWS[i][i] for i in range(SIZE)),
    tuple(_ROWS[i][SIZE - 1 - i] for i in range(SIZE)),
)
"""The rows, the columns and the two diagonals: SIZE in one of them wins."""


def symmetries() -> tuple[tuple[int, ...], ...]:
    """The 8 rotations and reflections of the board as cell permutations, identity first:
    under permutation p the new board is `tuple(board[i] for i in p)`."""
    rotate = tuple((SIZE - 1 - c) * SIZE + r for r in range(SIZE) for c in range(SIZE))
    mirror = tuple(r * SIZE + (SIZE - 1 - c) for r in range(SIZE) for c in range(SIZE))
    turns = [tuple(range(N_CELLS))]
    for _ in range(3):
        turns.append(tuple(turns[-1][i] for i in rotate))
    return (*turns, *(tuple(p[i] for i in mirror) for p in turns))


def other(player: int) -> int:
    """The other player's mark."""
    return USER if player == ROBOT else ROBOT


def cell_index(name: str) -> int:
    """The index of a cell given by its paper name (`middle`) or its number, 1 for the first."""
    text = name.strip().lower()
    if text.isdigit() and 1 <= int(text) <= N_CELLS:
        return int(text) - 1
    word = re.sub(r"[\s_-]", "", text)
    if word.isalpha() and word in CELL_NAMES:
        return CELL_NAMES.index(word)
    raise IllegalMoveError(
        f"{name!r} is not a cell; use 1-{N_CELLS} (row by row from the upper left) or one of "
        f"{', '.join(CELL_NAMES)}"
    )


def legal_moves(board: Board) -> list[int]:
    """The indices of the empty cells, in order."""
    return [i for i, c in enumerate(board) if c == EMPTY]


def play(board: Board, cell: int, player: int) -> Board:
    """The board after `player` marks `cell`; IllegalMoveError if the cell is not empty."""
    if not isinstance(cell, int) or isinstance(cell, bool) or not 0 <= cell < N_CELLS:
        raise IllegalMoveError(f"cell {cell!r} is out of range; cells are numbered 0-{N_CELLS - 1}")
    if board[cell] != EMPTY:
        raise IllegalMoveError(f"cell {CELL_NAMES[cell]} is already taken; pick an empty cell")
    return (*board[:cell], player, *board[cell + 1 :])


@functools.lru_cache(maxsize=1 << 16)  # 3^9 boards at most; asked every turn of every dialogue
def winner(board: Board) -> int:
    """ROBOT or USER if that player has three in a row, else EMPTY."""
    for line in LINES:
        first = board[line[0]]
        if first != EMPTY and all(board[i] == first for i in line):
            return first
    return EMPTY


def is_full(board: Board) -> bool:
    """True when no cell is empty."""
    return EMPTY not in board


@functools.lru_cache(maxsize=1 << 16)
def outcome(board: Board) -> Outcome | None:
    """The finished game's result from the robot's side, or None while it goes on."""
    w = winner(board)
    if w == ROBOT:
        return "win"
    if w == USER:
        return "loss"
    return "draw" if is_full(board) else None


def to_move(board: Board, robot_starts: bool) -> int:
    """Whose turn it is, given who started."""
    starter = ROBOT if robot_starts else USER
    placed = sum(c != EMPTY for c in board)
    return starter if placed % 2 == 0 else other(starter)


def is_winning_move(board: Board, cell: int, player: int) -> bool:
    """True if `player` marking `cell` completes a line: the agent is *about to win*."""
    return board[cell] == EMPTY and winner(play(board, cell, player)) == player


def winning_cells(board: Board, player: int) -> list[int]:
    """The empty cells, in order, where `player` would complete a line."""
    return [cell for cell in legal_moves(board) if is_winning_move(board, cell, player)]


def is_drawing_move(board: Board, cell: int, player: int) -> bool:
    """True if `player` marking `cell` fills the board with no line: *about to draw*."""
    if board[cell] != EMPTY:
        return False
    after = play(board, cell, player)
    return is_full(after) and winner(after) == EMPTY


def symbol_of(player: int, robot_starts: bool) -> str:
    """The label (`circle` or `cross`) that `player` draws: the starter draws circles."""
    starter = ROBOT if robot_starts else USER
    return "circle" if player == starter else "cross"


def render(board: Board, robot_starts: bool = True, numbered: bool = True) -> str:
    """The board as text rows, O for circles, X for crosses, empty cells by number."""
    labels = [
        symbol_of(c, robot_starts) if c != EMPTY else (str(i + 1) if numbered else "")
        for i, c in enumerate(board)
    ]
    return render_labels(labels)


MARKS = {"circle": "O", "cross": "X", "nothing": " "}
"""How a label is written in text: O circle, X cross, blank for nothing."""


def render_labels(labels: Sequence[str]) -> str:
    """One mark per cell as text rows: a label is written as its MARKS entry, any other text
    (a cell number) as itself."""
    marks = [MARKS.get(label, label) or " " for label in labels]
    rows = [" " + " | ".join(marks[r * SIZE : (r + 1) * SIZE]) for r in range(SIZE)]
    return ("\n" + "+".join(["---"] * SIZE) + "\n").join(rows)
