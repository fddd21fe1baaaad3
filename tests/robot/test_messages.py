import dataclasses

import pytest

from oxbot.errors import InvalidInputError
from oxbot.robot.messages import (
    MESSAGE_TYPES,
    ArmStroke,
    BoardSeen,
    ComponentLost,
    Decision,
    DialogueEnded,
    Frame,
    GameMove,
    NewGame,
    SpeakingContinued,
    SpeakingStarted,
    SpeechHypotheses,
    StopSpeaking,
    from_json,
    to_json,
)

EXAMPLES = [
    SpeechHypotheses(nbest=(("yes let's play", 0.9), ("yes", 0.4))),
    Frame(image=b"\x89PNG\r\n\x1a\n\x00\xff", format="png"),
    GameMove(who="usr", what="draw", where="middle", symbol="cross"),
    SpeakingStarted(text="Your turn.", audio=b"RIFF....WAVE", seconds=0.8),
    SpeakingContinued(text="Hi! Mom.", audio=b"RIFF", seconds=0.5, visemes=((0.0, "rest"),)),
    StopSpeaking(text="Would you like to play a game?"),
    ArmStroke(where="upperleft", points=((0.1, 0.2), (0.5, 0.5))),
    SpeechHypotheses(nbest=(("yes", 1.0),), source="text", words=(("yes", 1.0),)),
    BoardSeen(labels=("nothing",) * 8 + ("cross",), agreeing=2, cells=(b"\x89PNG",) * 9),
    Decision(offered=("Provide(name)",), q_values=(0.5,) * 18, chosen="Provide(name)"),
    DialogueEnded(outcome="draw"),
    DialogueEnded(outcome=None),
    NewGame(robot_starts=False),
    ComponentLost(component="ArmComponent", part="arm", error="hung for 5.1 s", essential=True),
]


@pytest.mark.parametrize("message", EXAMPLES, ids=lambda m: type(m).__name__)
def test_messages_round_trip_through_json(message):
    assert from_json(to_json(message)) == message


def test_every_message_type_has_its_own_topic():
    topics = [cls.topic for cls in MESSAGE_TYPES.values()]
    assert all(topics) and len(set(topics)) == len(topics)


def test_messages_are_immutable():
    with pytest.raises(dataclasses.FrozenInstanceError):
        EXAMPLES[2].where = "lowerleft"  # type: ignore[misc]


@pytest.mark.parametrize(
    "text",
    [
        "not json",
        '{"type": "Teleport", "data": {}}',
        '{"type": "GameMove", "data": {"who": "usr"}}',
        '{"type": "Frame", "data": {"image": "not base64!"}}',
        '{"type": "BoardSeen", "data": {"labels": [], "cells": [42]}}',
        "[" * 100_000 + "]" * 100_000,
        '{"type": "BoardSeen", "data": {"labels": ' + "[" * 5_000 + "]" * 5_000 + "}}",
    ],
    ids=["not json", "unknown type", "missing field", "not base64", "cells", "deep", "deep field"],
)
def test_malformed_messages_are_refused_clearly(text):
    with pytest.raises(InvalidInputError, match="message"):
        from_json(text)


def test_visemes_from_another_process_are_checked():
    from oxbot.robot.message_checks import check_message

    good = SpeakingStarted(text="Mom.", visemes=((0.0, "rest"), (0.06, "closed")))
    assert check_message(good) is good
    for bad in (((0.0, "grin"),), ((-1.0, "open"),)):
        with pytest.raises(InvalidInputError, match="visemes"):
            check_message(SpeakingStarted(text="Mom.", visemes=bad))
