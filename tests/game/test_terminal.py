import io

import numpy as np
from rich.console import Console

from oxbot.game import ROBOT, USER, as_robot, make_opponent
from oxbot.game.terminal import TerminalGame


class Script:
    """Feeds lines to the game like a person typing; EOF when they run out."""

    def __init__(self, lines):
        self.lines = list(lines)

    def __call__(self, prompt: str) -> str:
        if not self.lines:
            raise EOFError
        return self.lines.pop(0)


class FirstFreeCell:
    """A predictable robot that records every board it was shown."""

    def __init__(self):
        self.seen = []

    def __call__(self, board):
        self.seen.append(board)
        return board.index(0)


def make_game(lines, robot, robot_starts=True):
    out = io.StringIO()
    game = TerminalGame(
        robot,
        robot_starts=robot_starts,
        read_line=Script(lines),
        console=Console(file=out, width=100, color_system=None),
    )
    return game, out


def test_garbage_and_occupied_cells_are_refused_without_changing_the_board():
    robot = FirstFreeCell()
    game, out = make_game(["", "banana", "0", "10", "1", "middle", "q"], robot)
    assert game.play_game() is None
    text = out.getvalue()
    assert "Type a cell" in text
    assert "'banana' is not a cell" in text
    assert "'0' is not a cell" in text and "'10' is not a cell" in text
    assert "upperleft is already taken" in text
    # Only the middle was accepted: the robot's second look shows exactly that board.
    assert robot.seen == [(0,) * 9, (ROBOT, 0, 0, 0, USER, 0, 0, 0, 0)]


def test_end_of_input_ends_the_game_cleanly():
    game, out = make_game([], FirstFreeCell())
    assert game.play_game() is None
    assert "Good bye!" in out.getvalue()


def test_the_person_wins_on_the_diagonal_and_the_robot_says_so():
    # Robot takes 1, person 5, robot 2, person 3, robot 4, person 7: diagonal 3-5-7.
    game, out = make_game(["5", "3", "7"], FirstFreeCell())
    assert game.play_game() == "loss"
    assert "Well done, you won." in out.getvalue()
    assert "[who=rob what=draw where=upperleft]" in out.getvalue()
    assert "[who=usr what=draw where=lowerleft]" in out.getvalue()


def test_a_full_game_against_minimax_never_ends_in_a_loss():
    order = ["5", "1", "3", "7", "9", "2", "4", "6", "8"]
    for seed in range(5):
        robot = as_robot(make_opponent("minimax", np.random.default_rng(seed)))
        game, out = make_game(order * 2, robot)
        result = game.play_game()
        assert result in {"win", "draw"}
        assert ("It is a draw." if result == "draw" else "Yes, I won.") in out.getvalue()


def test_the_person_can_start_with_circles():
    robot = FirstFreeCell()
    game, out = make_game(["5", "3", "7"], robot, robot_starts=False)
    # Person 5, robot 1, person 3, robot 2, person 7: the person wins on the diagonal.
    assert game.play_game() == "loss"
    assert "You start, with circles" in out.getvalue()
    assert " X | X | O" in out.getvalue()


def test_new_starts_another_game_and_quit_leaves_as_in_play_terminal():
    lines = ["5", "3", "7", "again?", "new", "5", "3", "7", "quit"]
    game, out = make_game(lines, FirstFreeCell())
    assert game.play_session() == ["loss", "loss"]
    text = out.getvalue()
    assert text.count("Game over: you won. Type 'new' or 'quit'.") == 2
    assert "Type 'new' for a new game or 'quit' to leave." in text  # "again?" is neither
    assert "Rob: Your turn." in text and "Usr: [who=usr what=draw where=middle]" in text


def test_play_again_stops_at_end_of_input():
    game, _ = make_game(["5", "3", "7"], FirstFreeCell())
    assert game.play_session() == ["loss"]
