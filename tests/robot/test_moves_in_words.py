"""Moves said or typed in words ("top left") when it is the person's turn: played through the
path of a typed move, asked about below the confidence gate, refused in words on a taken cell,
never played to a cell the person did not name."""

import time

import pytest

from oxbot.config import SpeechConfig, load_config
from oxbot.dialogue.domain import INVITATION, MOVE_REQUEST
from oxbot.game.board import CELL_NAMES, EMPTY, ROBOT, USER, outcome
from oxbot.robot.manager import TAKEN_IN_WORDS, WHICH_CELL, cell_in_words
from oxbot.robot.messages import DialogueAct, DialogueEnded, GameMove
from oxbot.robot.session import Robot
from tests.robot.helpers import ManagerAtHand

IN_WORDS = {
    4: "the middle one",
    0: "top left",
    2: "top right please",
    6: "I'll take the bottom left",
    8: "bottom right corner",
    1: "the upper middle",
    3: "middle left",
    5: "row two column three",
    7: "number eight",
}
"""A way to say each cell, in the order a person prefers them."""


def asked_for_a_move(robot_starts: bool = True, settings: tuple = ()) -> ManagerAtHand:
    """A dialogue at the robot's first "Your turn" (the person agreed)."""
    robot = ManagerAtHand(robot_starts, seed=0, settings=settings)
    while robot.last_act != MOVE_REQUEST:
        assert not robot.done
        if robot.last_act == INVITATION:
            robot.say("yes let's play")
        else:
            robot.wait()
    return robot


def free(robot: ManagerAtHand, n: int = 1) -> list[int]:
    """The first `n` empty cells the person prefers."""
    return [c for c in IN_WORDS if robot.manager.board[c] == EMPTY][:n]


def test_a_move_in_words_is_played_like_a_typed_move():
    robot = asked_for_a_move()
    moves = robot.bus.subscribe(GameMove)
    (cell,) = free(robot)
    robot.say(IN_WORDS[cell])
    assert robot.manager.board[cell] == USER
    # the message a typed move makes (Robot.draw), which the eyes and the page read too
    move = moves.drain()[0]
    assert (move.who, move.where, move.symbol) == ("usr", CELL_NAMES[cell], "cross")
    turn = [t for t in robot.manager.transcript if t["speaker"] == "usr"][-1]
    assert turn["act"] == f"GameMove(gridloc={CELL_NAMES[cell]})"
    assert turn["text"] == IN_WORDS[cell]  # the words as heard, as for every answer
    assert robot.last_act.startswith("GameMove")  # the robot plays on


@pytest.mark.parametrize("torn", [False, True], ids=["heard unsurely", "two cells heard"])
def test_below_the_gate_the_robot_asks_which_cell_and_does_not_move(torn):
    robot = asked_for_a_move()
    board, said = robot.manager.board, len(robot.said)
    cell, other = free(robot, 2)
    if torn:
        robot.say(IN_WORDS[cell], 0.8, (IN_WORDS[other], 0.8))
    else:
        robot.say(IN_WORDS[cell], SpeechConfig().min_move_confidence / 2)
    assert robot.manager.board == board and robot.said[said:] == [WHICH_CELL]
    assert robot.last_act == MOVE_REQUEST  # still waiting for the move
    robot.say(IN_WORDS[cell])  # said again, surely
    assert robot.manager.board[cell] == USER


def test_the_gate_is_the_configs():
    strict = asked_for_a_move(settings=("speech.min_move_confidence=0.99",))
    (cell,) = free(strict)
    strict.say(IN_WORDS[cell], 0.97)
    assert strict.manager.board[cell] == EMPTY and strict.said[-1] == WHICH_CELL
    default = asked_for_a_move()
    default.say(IN_WORDS[cell], 0.97)
    assert default.manager.board[cell] == USER


def test_a_move_in_words_to_a_taken_cell_is_refused_in_words():
    robot = asked_for_a_move()
    board = robot.manager.board
    taken = board.index(ROBOT)
    robot.say(cell_in_words(taken))  # "the lower left"
    assert robot.manager.board == board
    assert robot.said[-1] == TAKEN_IN_WORDS.format(cell=cell_in_words(taken).capitalize())


@pytest.mark.parametrize("words", ["I'll go in the middle this time", "not the middle"])
def test_a_cell_among_other_words_is_asked_about_never_played(words):
    robot = asked_for_a_move()
    board = robot.manager.board
    robot.say(words)
    assert robot.manager.board == board and robot.said[-1] == WHICH_CELL


def test_a_cell_named_when_it_is_not_the_persons_turn_is_no_move():
    robot = ManagerAtHand(True, seed=0)
    moves = robot.bus.subscribe(GameMove)
    while robot.last_act != INVITATION:
        robot.wait()
    robot.say("top left")  # to "Shall we play?"
    assert not moves.drain() and USER not in robot.manager.board


def test_a_headless_game_with_every_move_typed_in_words():
    fast = ["robot.speed_factor=25", "robot.answer_timeout=2", "robot.move_timeout=10"]
    with Robot(load_config(None, fast), seed=3) as robot:
        events = robot.bus.subscribe(DialogueAct, DialogueEnded)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            message = events.get(0.5)
            if isinstance(message, DialogueEnded):
                break
            if isinstance(message, DialogueAct) and message.act == INVITATION:
                robot.say("Yes, let's play.")
            elif isinstance(message, DialogueAct) and message.act == MOVE_REQUEST:
                board = robot.board
                robot.say(next(words for c, words in IN_WORDS.items() if board[c] == EMPTY))
        else:
            raise AssertionError(f"no goodbye: {robot.transcript}")
        board, transcript = robot.board, robot.transcript
    moves = [t for t in transcript if t["speaker"] == "usr" and t["act"].startswith("GameMove")]
    assert len(moves) == sum(mark == USER for mark in board) >= 2
    assert all(t["text"] == IN_WORDS[CELL_NAMES.index(t["act"][17:-1])] for t in moves)
    assert message.outcome == outcome(board) is not None
