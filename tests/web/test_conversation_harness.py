"""The whole-conversation harness (bench/bench_conversations.py) against the real server: a
simulated person's voice reaches the robot over the page's WebSocket, push-to-talk and
hands-free, their moves drawn on the page's sheet, and the judge reads the conversation."""

import asyncio

import numpy as np
import pytest

from oxbot.config import load_config
from oxbot.dialogue.domain import ACCEPT, DECLINE
from oxbot.testing.personas import FAMILIES, Persona, judge
from oxbot.testing.rooms import Room
from oxbot.testing.talking import converse
from oxbot.web.server import create_app, serving_in_background

pytestmark = pytest.mark.realtime  # a real server, Whisper and the wall clock

SPEED = 4.0
CONFIG = load_config(
    None,
    [
        f"robot.speed_factor={SPEED}",
        f"robot.answer_timeout={2 * SPEED}",
        f"robot.question_timeout={30 * SPEED}",  # a busy machine never loses the turn
        "robot.pause_timeout=0",
        "robot.hang_seconds=10",
    ],
)
PLAIN = {family: ("yes",) for family in FAMILIES} | {
    "decline": ("no thank you",),
    "farewell": ("no thank you",),
}
"""Answers the robot knows, in a voice it was tuned on: what fails here is the harness."""


@pytest.fixture(scope="module")
def socket_url():
    with serving_in_background(create_app(CONFIG)) as url:
        yield url.replace("http://", "ws://") + "/ws"


def talk(url: str, kind: str, hands_free: bool):
    persona = Persona(kind, PLAIN, np.random.default_rng(0))
    room = Room("quiet", None, None, np.random.default_rng(0))
    return asyncio.run(converse(url, persona, "en-us", room, seed=2, hands_free=hands_free))


def test_a_keen_person_plays_a_whole_game_by_push_to_talk(socket_url):
    conversation = talk(socket_url, "keen", hands_free=False)
    assert judge(conversation) == []
    assert conversation.outcome in ("win", "draw", "loss")
    assert ("accept", ACCEPT) in conversation.understood
    assert conversation.game.accepted == conversation.game.drawn
    assert conversation.latencies and max(conversation.latencies) < 10


def test_a_person_who_declines_hands_free_is_let_go(socket_url):
    conversation = talk(socket_url, "declines", hands_free=True)
    assert judge(conversation) == []
    assert conversation.outcome == "declined"
    assert conversation.understood[0] == ("decline", DECLINE)
    assert conversation.latencies  # the words went through the page's hands-free stream
