"""Each game's metrics are measured from the messages on the robot's bus."""

from __future__ import annotations

import json
import time

import pytest

from oxbot.dialogue.domain import (
    ACCEPT,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    GRANT_REFUSAL,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
)
from oxbot.robot.bus import LocalBus
from oxbot.robot.messages import DialogueAct, DialogueEnded, SpeechHypotheses
from oxbot.study.metrics import GameWatcher, measure


def act(speaker: str, name: str, text: str, stamp: float) -> DialogueAct:
    return DialogueAct(speaker=speaker, act=name, text=text, stamp=stamp)


def declined_once_then_played() -> list:
    """The robot takes a yes for a no, the person corrects it, asks again once, plays one move."""
    return [
        act("sys", GREETING, "Hello!", 10.0),
        act("sys", INTRODUCTION, "I am oxbot.", 11.0),
        act("sys", INVITATION, "Shall we play?", 12.0),
        SpeechHypotheses(nbest=(("know thanks", 0.4),), source="microphone", stamp=13.0),
        act("usr", DECLINE, "know thanks", 13.5),
        act("sys", GRANT_REFUSAL, "Okay, maybe another time.", 14.0),
        SpeechHypotheses(nbest=(("yes i want to play", 0.9),), source="microphone", stamp=15.0),
        act("usr", ACCEPT, "yes I want to play", 15.5),
        act("sys", MOVE_REQUEST, "Your turn.", 16.0),
        SpeechHypotheses(nbest=(("blah", 0.2),), source="text", stamp=17.0),
        act("usr", "Unknown", "blah", 17.0),
        act("sys", ASK_AGAIN, "Sorry, say that again?", 18.0),
        act("usr", "GameMove(gridloc=1)", "", 21.0),
        DialogueEnded(outcome="stopped", stamp=30.0),
    ]


def test_measure_counts_what_a_study_reports():
    m = measure(declined_once_then_played())
    assert m["status"] == "ended"
    assert m["outcome"] == "stopped" and m["success"] == 0
    assert m["turns"] == 10 and m["moves"] == 1
    assert m["duration"] == pytest.approx(20.0)
    assert m["time_per_move"] == pytest.approx(3.0)  # from "say that again" at 18 to 21
    assert m["confidence"] == pytest.approx(0.65)  # spoken answers only: 0.4 and 0.9
    assert (m["spoken"], m["typed"]) == (2, 1)
    assert m["asked_again"] == 1
    assert m["corrected"] == 1  # the yes right after "Okay, maybe another time"
    assert m["well_formed"] == 0 and m["problem"]
    assert [t["speaker"] for t in json.loads(m["transcript"])][:3] == ["sys"] * 3


def test_a_polite_decline_is_well_formed_and_no_success():
    m = measure(
        [
            act("sys", GREETING, "Hello!", 0.0),
            act("sys", INTRODUCTION, "I am oxbot.", 1.0),
            act("sys", INVITATION, "Shall we play?", 2.0),
            act("usr", DECLINE, "no thanks", 3.0),
            act("sys", GRANT_REFUSAL, "Okay, maybe another time.", 4.0),
            act("sys", CLOSING, "Goodbye.", 5.0),
            DialogueEnded(outcome="declined", stamp=5.5),
        ]
    )
    assert (m["well_formed"], m["problem"], m["success"]) == (1, "", 0)
    assert m["corrected"] == 0 and m["time_per_move"] is None and m["confidence"] is None


def watch(*games: list) -> list[dict]:
    """The metrics a GameWatcher hands on for these messages, then stopped."""
    bus, kept = LocalBus(), []
    watcher = GameWatcher(bus, kept.append).start()
    messages = [m for game in games for m in game]
    try:
        for message in messages:
            bus.publish(message)
        deadline = time.monotonic() + 5
        # at the goodbye, or every message handled; stop() hands on whatever is left
        while not watcher.done and len(watcher.messages) < len(messages):
            assert time.monotonic() < deadline
            time.sleep(0.01)
    finally:
        watcher.stop()
    return kept


def test_the_watcher_keeps_one_game_a_session_at_its_goodbye():
    after = [act("sys", GREETING, "Hello again!", 40.0), act("usr", ACCEPT, "yes", 41.0)]
    games = watch(declined_once_then_played(), after)
    assert [(g["status"], g["turns"]) for g in games] == [("ended", 10)]


def test_the_watcher_keeps_a_game_left_before_its_goodbye():
    games = watch(declined_once_then_played()[:5])
    assert [(g["status"], g["turns"]) for g in games] == [("left", 4)]
    assert games[0]["problem"] == "left before the end" and games[0]["well_formed"] == 0
