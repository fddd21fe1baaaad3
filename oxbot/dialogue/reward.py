"""The reward R(s,a,s') = BR*w + DR*(1-w) - DL, and the reward at the end of the dialogue.

Paper §2.2 "Reward Function": BR is 5 if the agent is about to win, 1 if it is about to
draw, else 0; w = 0.5; DR = Pr(a|s) from the action model; DL = 0.1. At the end of the dialogue
the agent also gets 0 if the robot lost the game and 5 otherwise; oxbot adds it to the reward of
the last step (the closing act). The values come from `RewardConfig`.
"""

from __future__ import annotations

from oxbot.config import RewardConfig
from oxbot.dialogue.domain import is_game_move
from oxbot.game.board import ROBOT, Board, is_drawing_move, is_winning_move


def bonus_reward(board: Board, action: int, config: RewardConfig) -> float:
    """BR: the win bonus if `action` is a GameMove that wins, the draw bonus if it draws.

    A GameMove's index in SYSTEM_ACTS is its cell's."""
    if not is_game_move(action):
        return 0.0
    if is_winning_move(board, action, ROBOT):
        return config.win_bonus
    if is_drawing_move(board, action, ROBOT):
        return config.draw_bonus
    return 0.0


def step_reward(board: Board, action: int, probability: float, config: RewardConfig) -> float:
    """R(s,a,s') for taking `action` on `board`, where Pr(a|s) = `probability` (the DR term)."""
    w = config.bonus_weight
    return bonus_reward(board, action, config) * w + probability * (1 - w) - config.length_penalty


def end_reward(outcome: str, config: RewardConfig) -> float:
    """The reward at the end of the dialogue: 0 if the robot lost (or walked away from a person
    who wanted to play), 5 after any other game (paper §2.2); oxbot: 3 when the person declined
    to play or asked to stop, and the robot let them."""
    return {
        "loss": config.end_reward_loss,
        "abandoned": config.end_reward_loss,
        "declined": config.end_reward_declined,
        "stopped": config.end_reward_stopped,
    }.get(outcome, config.end_reward_otherwise)
