import numpy as np
import pytest

from oxbot.errors import ConfigError, OpponentError
from oxbot.game import (
    OPPONENTS,
    USER,
    checked_move,
    is_winning_move,
    legal_moves,
    make_opponent,
    outcome,
    play,
)


def random_positions(n: int, seed: int = 0):
    """Unfinished positions reached by random play from either start, the person to move."""
    rng = np.random.default_rng(seed)
    positions = []
    while len(positions) < n:
        board, mover = (0,) * 9, int(rng.integers(1, 3))
        for _ in range(rng.integers(1, 9)):
            board = play(board, int(rng.choice(legal_moves(board))), mover)
            mover = 3 - mover
            if outcome(board) is not None:
                break
        if outcome(board) is None and mover == USER:
            positions.append(board)
    return positions


@pytest.mark.parametrize("name", list(OPPONENTS))
def test_every_opponent_returns_an_empty_cell(name):
    opponent = make_opponent(name, np.random.default_rng(0))
    for board in random_positions(300):
        assert board[checked_move(opponent, board)] == 0


def test_random_is_uniform_over_empty_cells():
    opponent = make_opponent("random", np.random.default_rng(0))
    board = (1, 0, 2, 0, 0, 0, 1, 0, 0)
    counts = np.bincount([opponent(board) for _ in range(6000)], minlength=9)
    assert counts[[0, 2, 6]].sum() == 0
    assert counts[[1, 3, 4, 5, 7, 8]].min() > 850  # each about 1000


def test_blocker_always_takes_an_immediate_win():
    blocker = make_opponent("blocker", np.random.default_rng(0))
    checked = 0
    for board in random_positions(2000, seed=1):
        wins = [c for c in legal_moves(board) if is_winning_move(board, c, USER)]
        if wins:
            assert blocker(board) in wins
            checked += 1
    assert checked > 100


def test_blocker_always_blocks_a_single_threat():
    blocker = make_opponent("blocker", np.random.default_rng(0))
    checked = 0
    for board in random_positions(2000, seed=2):
        own = [c for c in legal_moves(board) if is_winning_move(board, c, USER)]
        threats = [c for c in legal_moves(board) if is_winning_move(board, c, 1)]
        if not own and len(threats) == 1:
            assert blocker(board) == threats[0]
            checked += 1
    assert checked > 100


def test_same_seed_same_moves():
    boards = random_positions(50)
    a = make_opponent("minimax", np.random.default_rng(3))
    b = make_opponent("minimax", np.random.default_rng(3))
    assert [a(x) for x in boards] == [b(x) for x in boards]


def test_unknown_opponent_names_the_choices():
    with pytest.raises(ConfigError, match="random, blocker, minimax"):
        make_opponent("perfect")


@pytest.mark.parametrize("bad", [4, 9, -1, "4", None])
def test_checked_move_rejects_an_occupied_or_out_of_range_cell(bad):
    board = (0, 0, 0, 0, 1, 0, 0, 0, 0)
    with pytest.raises(OpponentError, match=r"returned|taken"):
        checked_move(lambda b: bad, board)


def test_an_opponent_asked_to_move_on_a_full_board_says_so():
    with pytest.raises(OpponentError, match="full board"):
        make_opponent("random")((1, 2, 1, 1, 2, 2, 2, 1, 1))
