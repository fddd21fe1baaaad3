"""What makes a dialogue well formed: the rules a finished dialogue is checked against.

The environment pays no end-of-dialogue reward for a dialogue that breaks them (`end_reward`);
a simulated person the robot ignores (`ignores_the_person`) walks away at once; the
evaluations count how many dialogues break them (`oxbot.dialogue.evaluation`).
"""

from __future__ import annotations

from collections.abc import Sequence

from oxbot.dialogue.domain import (
    ACCEPT,
    ASK_AGAIN,
    CLOSING,
    FEEDBACK_ACTS,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
    REFUSALS,
    STOP,
    game_move_cell,
    is_feedback,
    is_game_move,
    plays,
)
from oxbot.dialogue.state import Turn
from oxbot.game.board import EMPTY_BOARD, ROBOT, USER, Board, play
from oxbot.game.board import outcome as game_outcome


def check_dialogue(
    transcript: list[Turn], outcome: str | None, understood: Sequence[str] | None = None
) -> str | None:
    """Why a finished dialogue is not well formed, or None if it is.

    Well formed: it greets first and closes last, once. It plays only with a person who agreed
    (never a game nobody agreed to), asks to play at most once more after a no, and lets a
    person who declines or asks to stop go: it acknowledges (`Acknowledge(playGame=no)`,
    `Acknowledge(stop)`) and says goodbye, with no move after a stop (it may ask for the move
    once more, when it did not understand the stop). A game it plays, it plays
    properly: introduction and invitation before the first move, the person asked for their
    move after each robot move until the game is over, and exactly one feedback act, the one of
    the real outcome. It never walks away from a person who wanted to play. The person's turns
    are read as the acts they meant (the environment's transcript) or were understood as (the
    robot's); where `understood` gives, for each turn, the act the robot understood, asking
    again after a no or a stop it did not understand is allowed: it asked because it could not
    tell (a no it understood twice, or a stop it understood twice, it must let go).
    """
    sys_acts = [t["act"] for t in transcript if t["speaker"] == "sys"]
    if not sys_acts or sys_acts[0] != GREETING:
        return "does not greet first"
    problem = ignores_the_person(transcript, understood)
    if problem is not None:
        return problem
    if sys_acts[-1] != CLOSING or sys_acts.count(CLOSING) != 1:
        return "does not close with a goodbye"
    if outcome in ("declined", "stopped"):
        return None
    return _played_properly(transcript, outcome)


def ignores_the_person(
    transcript: list[Turn], understood: Sequence[str] | None = None
) -> str | None:
    """The first rule about the person's will the dialogue so far breaks, or None: a game
    nobody agreed to, a no or a stop not let go. Each is decided as soon as the robot says the
    act that breaks it, so the simulated person can walk away there (`InteractiveGameEnv`)."""
    heard = list(understood) if understood is not None else [t["act"] for t in transcript]
    return (
        _agreed_before_playing(transcript)
        or _lets_a_no_go(transcript, heard)
        or _lets_a_stop_go(transcript, heard)
    )


def _agreed_before_playing(transcript: list[Turn]) -> str | None:
    agreed = False
    for turn in transcript:
        if turn["speaker"] == "usr":
            agreed = agreed or turn["act"] == ACCEPT
        elif plays(turn["act"]) and not agreed:
            return f"starts a game nobody agreed to ({turn['act']})"
    return None


def _lets_a_no_go(transcript: list[Turn], heard: list[str]) -> str | None:
    refused = asked_after = 0
    last_answer = ""
    for turn, understood in zip(transcript, heard, strict=True):
        act = turn["act"]
        if turn["speaker"] == "usr" and (understood in REFUSALS or understood == ACCEPT):
            refused += understood in REFUSALS
            last_answer = understood
        elif turn["speaker"] == "sys" and act in (INVITATION, ASK_AGAIN) and refused:
            asked_after += 1
            if asked_after > 1:
                return "asks to play again after being told no twice"
        elif turn["speaker"] == "sys" and last_answer in REFUSALS:
            if plays(act):
                return "plays with a person who said no"
            if act == CLOSING:
                return "says goodbye to a no without acknowledging it"
            if act == GRANT_REFUSAL:
                last_answer = ""  # acknowledged: the goodbye may follow
    return None


def _lets_a_stop_go(transcript: list[Turn], heard: list[str]) -> str | None:
    stops = understood_stops = 0
    acknowledged = False
    for turn, understood in zip(transcript, heard, strict=True):
        act = turn["act"]
        if turn["speaker"] == "usr":
            stops += act == STOP
            understood_stops += understood == STOP
        elif stops and is_game_move(act):
            return f"goes on playing after the person asked to stop ({act})"
        elif understood_stops >= 2 and act == MOVE_REQUEST:
            return "asks for a move again after being asked to stop twice"
        elif stops and act == GRANT_STOP:
            acknowledged = True
        elif stops and act == CLOSING and not acknowledged:
            return "says goodbye to a stop without acknowledging it"
    return None


def _played_properly(transcript: list[Turn], outcome: str | None) -> str | None:
    sys_acts = [t["act"] for t in transcript if t["speaker"] == "sys"]
    first_move = next((i for i, t in enumerate(transcript) if is_game_move(t["act"])), None)
    if first_move is None:
        return "walks away from a person who wanted to play"
    before = {t["act"] for t in transcript[:first_move] if t["speaker"] == "sys"}
    if INTRODUCTION not in before:
        return "does not introduce itself before the first move"
    if INVITATION not in before:
        return "does not invite the person before the first move"
    board: Board = EMPTY_BOARD
    sys_index = -1
    for turn in transcript:
        if turn["speaker"] == "sys":
            sys_index += 1
        cell = game_move_cell(turn["act"])
        if cell is None:
            continue
        board = play(board, cell, ROBOT if turn["speaker"] == "sys" else USER)
        if turn["speaker"] == "sys" and game_outcome(board) is None:
            following = sys_acts[sys_index + 1] if sys_index + 1 < len(sys_acts) else None
            if following != MOVE_REQUEST:
                return f"does not ask for the person's move after its move {turn['act']}"
    if outcome is None or game_outcome(board) is None:
        return "walks away from an unfinished game"
    feedback = [a for a in sys_acts if is_feedback(a)]
    if len(feedback) != 1:
        return f"gives {len(feedback)} feedback acts instead of one"
    if feedback[0] != FEEDBACK_ACTS[outcome]:
        return f"says {feedback[0]} but the outcome is a {outcome}"
    return None
