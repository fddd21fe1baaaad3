"""A stop said while the robot is still saying "Your move" is acted on when it has said it, not
after the move timeout (the interaction manager driven in the test's thread)."""

from oxbot.dialogue.domain import GRANT_STOP, MOVE_REQUEST
from oxbot.game.board import CELL_NAMES, USER, symbol_of
from oxbot.robot.messages import (
    ArmCommand,
    ArmDone,
    GameMove,
    SpeakingFinished,
    SpeechHypotheses,
    Utterance,
)
from tests.robot.helpers import ManagerAtHand


def speak_until_move_request(hand: ManagerAtHand, words: str) -> list[str]:
    """Play the robot's acts on until it says "Your move"; `words` are heard while it says it.
    The acts it then says without waiting (no tick after it: the move timeout never runs out)."""
    manager, heard, after = hand.manager, False, []
    for _ in range(100):
        message = hand.out.get(0)
        if message is None and heard:
            break
        if message is None:  # an act nobody answers said: the wait is over at once
            manager.tick()
            continue
        if isinstance(message, Utterance):
            if heard:
                after.append(message.act)
            if message.act == MOVE_REQUEST and not heard:
                manager.handle(SpeechHypotheses(nbest=((words, 1.0),)))
                heard = True
            manager.handle(SpeakingFinished(text=message.text))
        elif isinstance(message, ArmCommand):
            manager.handle(ArmDone(where=message.where))
    return after


def person_draws(hand: ManagerAtHand) -> None:
    """The person's move, left for `speak_until_move_request` to answer."""
    cell = 4 if hand.manager.board[4] == 0 else 0
    symbol = symbol_of(USER, hand.manager.state.robot_starts)
    hand.manager.handle(GameMove(who="usr", what="draw", where=CELL_NAMES[cell], symbol=symbol))


def test_a_stop_said_over_your_move_is_answered_at_once():
    hand = ManagerAtHand(robot_starts=True, seed=1)
    hand.say("yes let's play")  # the robot plays its first move and asks for the person's
    person_draws(hand)
    after = speak_until_move_request(hand, "I want to stop")
    assert after and after[0] == GRANT_STOP


def test_chatter_over_your_move_does_not_make_the_robot_ask_again():
    hand = ManagerAtHand(robot_starts=True, seed=1)
    hand.say("yes let's play")
    person_draws(hand)
    assert speak_until_move_request(hand, "what time is it") == []


def test_the_whole_robot_acts_on_a_stop_said_over_your_move_within_a_second():
    import time

    from oxbot.config import load_config
    from oxbot.robot.messages import DialogueAct
    from oxbot.robot.session import Robot

    # waits a quarter as long: the move timeout (7.5 s) far longer than the second allowed
    config = load_config(None, ["robot.speed_factor=4"])
    with Robot(config, seed=2) as robot:
        events = robot.bus.subscribe(Utterance, SpeakingFinished, DialogueAct)
        robot.say("yes let's play")  # kept until the robot asks
        asking, said_at, deadline = None, None, time.monotonic() + 60
        while time.monotonic() < deadline:
            message = events.get(timeout=0.05)
            if isinstance(message, Utterance) and message.act == MOVE_REQUEST and not asking:
                asking = message.text
                robot.say("I want to stop")  # while the robot says "Your move"
            elif isinstance(message, SpeakingFinished) and message.text == asking:
                said_at = time.monotonic()
            elif (
                isinstance(message, DialogueAct)
                and said_at is not None
                and message.speaker == "sys"
            ):
                answered = (message.act, time.monotonic() - said_at)
                break
        else:
            raise AssertionError(f"no answer to the stop (asked: {asking!r})")
    assert answered[0] == GRANT_STOP and answered[1] <= 1.0, answered
