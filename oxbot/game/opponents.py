"""The person's side in simulation: opponents as callables `f(board) -> cell`.

An opponent sees the board from the robot's side (1 the robot's marks, 2 its own) and returns
the index of an empty cell. Each factory takes the random generator it breaks ties with, so that
a seeded run is reproducible:

>>> import numpy as np
>>> opponent = make_opponent("blocker", np.random.default_rng(0))
>>> opponent((1, 0, 0, 0, 2, 0, 0, 0, 1)) in (1, 2, 3, 5, 6, 7)  # an empty cell
True
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from oxbot.errors import ConfigError, OpponentError
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY,
    N_CELLS,
    ROBOT,
    USER,
    Board,
    legal_moves,
    winning_cells,
)
from oxbot.game.solver import best_moves

Opponent = Callable[[Board], int]


def _empty_cells(board: Board) -> list[int]:
    cells = legal_moves(tuple(board))
    if not cells:
        raise OpponentError(f"the opponent was asked to move on a full board {tuple(board)}")
    return cells


def random_opponent(rng: np.random.Generator | None = None) -> Opponent:
    """Uniform over the empty cells."""
    rng = rng if rng is not None else np.random.default_rng()

    def move(board: Board) -> int:
        cells = _empty_cells(board)
        return int(cells[rng.integers(len(cells))])

    move.__name__ = "random"
    return move


def blocker_opponent(rng: np.random.Generator | None = None) -> Opponent:
    """Wins if it can, else blocks the robot's winning cell, else plays at random."""
    rng = rng if rng is not None else np.random.default_rng()

    def move(board: Board) -> int:
        board = tuple(board)
        cells = _empty_cells(board)
        for player in (USER, ROBOT):  # first our own win, then the robot's threat
            hits = winning_cells(board, player)
            if hits:
                return int(hits[rng.integers(len(hits))])
        return int(cells[rng.integers(len(cells))])

    move.__name__ = "blocker"
    return move


def minimax_opponent(rng: np.random.Generator | None = None) -> Opponent:
    """Perfect play: a random choice among the moves with the best minimax value."""
    rng = rng if rng is not None else np.random.default_rng()

    def move(board: Board) -> int:
        board = tuple(board)
        _empty_cells(board)
        choices = best_moves(board, USER)
        return int(choices[rng.integers(len(choices))])

    move.__name__ = "minimax"
    return move


OPPONENTS: dict[str, Callable[[np.random.Generator | None], Opponent]] = {
    "random": random_opponent,
    "blocker": blocker_opponent,
    "minimax": minimax_opponent,
}
"""The named opponents every part of oxbot accepts (`--opponent random|blocker|minimax`)."""


def make_opponent(name: str, rng: np.random.Generator | None = None) -> Opponent:
    """The opponent called `name`, breaking ties with `rng`."""
    try:
        factory = OPPONENTS[name]
    except KeyError:
        raise ConfigError(
            f"unknown opponent {name!r}; choose one of {', '.join(OPPONENTS)}"
        ) from None
    return factory(rng)


def as_robot(opponent: Opponent) -> Opponent:
    """The same strategy playing the robot's side (its marks are 1, the person's 2)."""

    def move(board: Board) -> int:
        swapped = tuple({ROBOT: USER, USER: ROBOT}.get(c, c) for c in board)
        return opponent(swapped)

    move.__name__ = getattr(opponent, "__name__", "opponent")
    return move


def checked_move(opponent: Opponent, board: Board) -> int:
    """Ask `opponent` for a move and make sure it names an empty cell of `board`."""
    cell = opponent(board)
    if isinstance(cell, np.integer):
        cell = int(cell)
    if not isinstance(cell, int) or isinstance(cell, bool) or not 0 <= cell < N_CELLS:
        raise OpponentError(
            f"opponent {getattr(opponent, '__name__', opponent)!r} returned {cell!r}; "
            f"it must return the index 0-{N_CELLS - 1} of an empty cell"
        )
    if board[cell] != EMPTY:
        raise OpponentError(
            f"opponent {getattr(opponent, '__name__', opponent)!r} chose {CELL_NAMES[cell]} "
            f"(cell {cell}), which is already taken on board {board}"
        )
    return cell
