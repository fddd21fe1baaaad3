import pytest

from oxbot.config import RewardConfig
from oxbot.dialogue.domain import SYSTEM_ACTS
from oxbot.dialogue.reward import bonus_reward, end_reward, step_reward
from oxbot.game.board import EMPTY_BOARD, play

CFG = RewardConfig()
NAME = SYSTEM_ACTS.index("Provide(name)")


def board_of(robot, person):
    board = EMPTY_BOARD
    for cell in robot:
        board = play(board, cell, 1)
    for cell in person:
        board = play(board, cell, 2)
    return board


def test_bonus_is_five_when_about_to_win():
    board = board_of([0, 1], [3, 4])
    assert bonus_reward(board, 2, CFG) == 5.0
    assert step_reward(board, 2, 0.0, CFG) == pytest.approx(5 * 0.5 - 0.1)


def test_bonus_is_one_when_about_to_draw():
    board = board_of([0, 2, 3, 7], [1, 4, 5, 6])  # one cell left, no line for anyone
    assert bonus_reward(board, 8, CFG) == 1.0
    assert step_reward(board, 8, 0.0, CFG) == pytest.approx(1 * 0.5 - 0.1)


def test_bonus_is_zero_otherwise():
    assert bonus_reward(board_of([0, 1], [3, 4]), 8, CFG) == 0.0  # a move that does not win
    assert bonus_reward(board_of([0, 1], [3, 4]), NAME, CFG) == 0.0  # not a move at all


def test_data_reward_is_weighted_by_one_minus_w():
    assert step_reward(EMPTY_BOARD, NAME, 0.8, CFG) == pytest.approx(0.8 * 0.5 - 0.1)
    heavier = RewardConfig(bonus_weight=0.25)
    assert step_reward(EMPTY_BOARD, NAME, 0.8, heavier) == pytest.approx(0.8 * 0.75 - 0.1)


def test_length_penalty_is_charged_every_step():
    assert step_reward(EMPTY_BOARD, NAME, 0.0, CFG) == pytest.approx(-0.1)
    assert step_reward(EMPTY_BOARD, NAME, 0.0, RewardConfig(length_penalty=0.3)) == -0.3


def test_end_of_dialogue_reward_is_zero_for_a_loss_else_five():
    assert end_reward("loss", CFG) == 0.0
    assert end_reward("abandoned", CFG) == 0.0  # walking away from a person who wanted to play
    assert end_reward("draw", CFG) == 5.0
    assert end_reward("win", CFG) == 5.0
