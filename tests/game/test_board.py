import pytest

from oxbot.errors import IllegalMoveError
from oxbot.game import (
    CELL_NAMES,
    EMPTY_BOARD,
    ROBOT,
    USER,
    cell_index,
    is_drawing_move,
    is_winning_move,
    legal_moves,
    outcome,
    play,
    render,
    symbol_of,
    to_move,
    winner,
)


def board_of(text: str) -> tuple[int, ...]:
    """'o' robot, 'x' person, '.' empty, row-major."""
    return tuple({"o": ROBOT, "x": USER, ".": 0}[ch] for ch in text.replace(" ", ""))


def test_cell_names_are_row_major_from_the_upper_left():
    assert CELL_NAMES[0] == "upperleft"
    assert CELL_NAMES[4] == "middle"
    assert CELL_NAMES[8] == "lowerright"
    assert [cell_index(name) for name in CELL_NAMES] == list(range(9))


@pytest.mark.parametrize("text,index", [("1", 0), ("9", 8), (" Middle ", 4), ("lower-left", 6)])
def test_cell_index_accepts_numbers_and_names(text, index):
    assert cell_index(text) == index


@pytest.mark.parametrize("text", ["0", "10", "", "centre", "-1", "1.5"])
def test_cell_index_rejects_garbage_with_a_hint(text):
    with pytest.raises(IllegalMoveError, match="1-9"):
        cell_index(text)


def test_play_refuses_an_occupied_cell_and_leaves_the_board_alone():
    board = play(EMPTY_BOARD, 4, ROBOT)
    with pytest.raises(IllegalMoveError, match="middle is already taken"):
        play(board, 4, USER)
    assert board == (0, 0, 0, 0, 1, 0, 0, 0, 0)


@pytest.mark.parametrize("cell", [-1, 9, 2.0, True])
def test_play_refuses_out_of_range_cells(cell):
    with pytest.raises(IllegalMoveError):
        play(EMPTY_BOARD, cell, ROBOT)


def test_winner_finds_rows_columns_and_diagonals():
    assert winner(board_of("ooo x.x ...")) == ROBOT
    assert winner(board_of("xo. xo. x..")) == USER
    assert winner(board_of("o.x .ox ..o")) == ROBOT
    assert winner(board_of("o.x .xo x..")) == USER
    assert winner(board_of("ox. ... ...")) == 0


def test_outcome_is_from_the_robots_side():
    assert outcome(board_of("ooo xx. ...")) == "win"
    assert outcome(board_of("xxx oo. o..")) == "loss"
    assert outcome(board_of("oxo oxx xox")) == "draw"
    assert outcome(board_of("ox. ... ...")) is None


def test_legal_moves_are_the_empty_cells():
    assert legal_moves(board_of("ox. ..o x..")) == [2, 3, 4, 7, 8]


def test_about_to_win_and_about_to_draw():
    board = board_of("oo. xx. ...")
    assert is_winning_move(board, 2, ROBOT)
    assert not is_winning_move(board, 8, ROBOT)
    assert not is_winning_move(board, 0, ROBOT)  # occupied
    last = board_of("oxo oxx xo.")
    assert is_drawing_move(last, 8, USER) and not is_winning_move(last, 8, USER)
    assert not is_drawing_move(board, 2, ROBOT)  # that one wins instead
    assert not is_drawing_move(board_of("oxo oxx x.."), 7, ROBOT)  # board not full yet


def test_the_starter_draws_circles_and_moves_alternate():
    assert symbol_of(ROBOT, robot_starts=True) == "circle"
    assert symbol_of(USER, robot_starts=True) == "cross"
    assert symbol_of(USER, robot_starts=False) == "circle"
    assert to_move(EMPTY_BOARD, robot_starts=False) == USER
    assert to_move(play(EMPTY_BOARD, 0, USER), robot_starts=False) == ROBOT


def test_render_draws_the_right_symbols():
    text = render(board_of("o.. .x. ..."), robot_starts=True)
    assert text.splitlines()[0] == " O | 2 | 3"
    assert " X " in text.splitlines()[2]
    assert render(board_of("o.. ... ..."), robot_starts=False).startswith(" X")
