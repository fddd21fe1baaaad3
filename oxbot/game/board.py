"""The noughts-and-crosses board: cells, names, symbols, legal moves and outcomes.

A board is a tuple of 9 ints, row-major from the upper left (SPEC §5): 0 empty, 1 the robot's
mark, 2 the person's mark. Boards are immutable so they can key caches and replay buffers.
Which *symbol* a mark is drawn with depends on who started: the starter draws circles
(paper §2.1, footnote).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Literal

from oxbot.errors import IllegalMoveError

Board = tuple[int, ...]
Outcome = Literal["win", "draw", "loss"]

EMPTY, ROBOT, USER = 0, 1, 2
EMPTY_BOARD: Board = (EMPTY,) * 9

CELL_NAMES: tuple[str, ...] = (
    "upperleft",
    "uppermiddle",
    "upperright",
    "middleleft",
    "middle",
    "middleright",
    "lowerleft",
    "lowermiddle",
    "lowerright",
)
"""SPEC §2: the paper's cell names, row-major from the upper left."""

LABELS: tuple[str, ...] = ("circle", "cross", "nothing")
"""SPEC §1: the perceiver's labels, in this order when indexed 0, 1, 2."""

LINES: tuple[tuple[int, int, int], ...] = (
    (0, 1, 2),
    (3, 4, 5),
    (6, 7, 8),
    (0, 3, 6),
    (1, 4, 7),
    (2, 5, 8),
    (0, 4, 8),
    (2, 4, 6),
)


def other(player: int) -> int:
    """The other player's mark."""
    return USER if player == ROBOT else ROBOT


def cell_index(name: str) -> int:
    """The index 0-8 of a cell given by its paper name (`middle`) or its number 1-9."""
    text = name.strip().lower()
    if text.isdigit() and 1 <= int(text) <= 9:
        return int(text) - 1
    word = re.sub(r"[\s_-]", "", text)
    if word.isalpha() and word in CELL_NAMES:
        return CELL_NAMES.index(word)
    raise IllegalMoveError(
        f"{name!r} is not a cell; use 1-9 (row by row from the upper left) or one of "
        f"{', '.join(CELL_NAMES)}"
    )


def check_board(board: Sequence[int]) -> Board:
    """`board` as a Board tuple, or IllegalMoveError if it is not 9 cells of 0, 1 or 2."""
    cells = tuple(board)
    if len(cells) != 9 or any(c not in (EMPTY, ROBOT, USER) for c in cells):
        raise IllegalMoveError(
            f"a board is 9 cells of 0 (empty), 1 (robot) or 2 (person); got {board!r}"
        )
    return cells


def legal_moves(board: Board) -> list[int]:
    """The indices of the empty cells, in order."""
    return [i for i, c in enumerate(board) if c == EMPTY]


def play(board: Board, cell: int, player: int) -> Board:
    """The board after `player` marks `cell`; IllegalMoveError if the cell is not empty."""
    if not isinstance(cell, int) or isinstance(cell, bool) or not 0 <= cell < 9:
        raise IllegalMoveError(f"cell {cell!r} is out of range; cells are numbered 0-8")
    if board[cell] != EMPTY:
        raise IllegalMoveError(f"cell {CELL_NAMES[cell]} is already taken; pick an empty cell")
    return (*board[:cell], player, *board[cell + 1 :])


def winner(board: Board) -> int:
    """ROBOT or USER if that player has three in a row, else EMPTY."""
    for a, b, c in LINES:
        if board[a] != EMPTY and board[a] == board[b] == board[c]:
            return board[a]
    return EMPTY


def is_full(board: Board) -> bool:
    """True when no cell is empty."""
    return EMPTY not in board


def is_over(board: Board) -> bool:
    """True when someone has won or the board is full."""
    return winner(board) != EMPTY or is_full(board)


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
    """True if `player` marking `cell` completes a line: the agent is *about to win* (SPEC §3)."""
    return board[cell] == EMPTY and winner(play(board, cell, player)) == player


def is_drawing_move(board: Board, cell: int, player: int) -> bool:
    """True if `player` marking `cell` fills the board with no line: *about to draw* (SPEC §3)."""
    if board[cell] != EMPTY:
        return False
    after = play(board, cell, player)
    return is_full(after) and winner(after) == EMPTY


def symbol_of(player: int, robot_starts: bool) -> str:
    """The label (`circle` or `cross`) that `player` draws: the starter draws circles."""
    starter = ROBOT if robot_starts else USER
    return "circle" if player == starter else "cross"


def render(board: Board, robot_starts: bool = True, numbered: bool = True) -> str:
    """The board as three text rows, O for circles, X for crosses, empty cells by number."""
    marks = {
        ROBOT: "O" if symbol_of(ROBOT, robot_starts) == "circle" else "X",
        USER: "O" if symbol_of(USER, robot_starts) == "circle" else "X",
    }
    cells = [
        marks[c] if c != EMPTY else (str(i + 1) if numbered else " ") for i, c in enumerate(board)
    ]
    rows = [" " + " | ".join(cells[r * 3 : r * 3 + 3]) for r in range(3)]
    return "\n---+---+---\n".join(rows)
