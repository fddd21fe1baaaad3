"""A Zenoh peer that sends what it likes: malformed, deep, huge or out-of-range messages, floods,
a poisoned game record, a fake liveliness token; and launch files that are not what they seem.
Real sessions over loopback, in this process."""

from __future__ import annotations

import json
import re
import threading
import time

import pytest

from oxbot.errors import ConfigError, InvalidInputError
from oxbot.robot.bus import LocalBus
from oxbot.robot.launch import load_launch_file, run_component
from oxbot.robot.message_checks import MAX_DEPTH
from oxbot.robot.messages import (
    ArmCommand,
    GameState,
    NewGame,
    SpeechHypotheses,
    Utterance,
    from_json,
    to_json,
)
from oxbot.robot.zenoh_bus import FORMAT, ZenohBus
from tests.robot.test_zenoh import CONFIG, free_port, loopback, robot_name

HOSTILE = {
    "not a cell": to_json(ArmCommand(where="middle", symbol="cross")).replace("middle", "nowhere"),
    "200 KB to say": to_json(Utterance(text="a" * 200_000, act="Provide(name)")),
    "wrong type": '{"type": "NewGame", "topic": "game/new", "data": {"robot_starts": "yes"}}',
    "a stamp that is no number": to_json(NewGame()).replace('"stamp": ', '"stamp": "x", "_": '),
    "a board of 10": to_json(GameState(board=(0,) * 9, robot_starts=True)).replace(
        "[0, 0", "[0, 0, 0", 1
    ),
    "a confidence of 7": to_json(SpeechHypotheses(nbest=(("yes", 0.5),))).replace("0.5", "7"),
    "deep": '{"type": "NewGame", "topic": "game/new", "data": {"x": '
    + "[" * 100_000
    + "]" * 100_000
    + "}}",
    "not JSON": "\xff{",
}


@pytest.mark.parametrize("text", HOSTILE.values(), ids=HOSTILE.keys())
def test_a_malformed_or_out_of_range_message_is_refused_on_decode(text):
    with pytest.raises(InvalidInputError):
        from_json(text)


@pytest.fixture
def network():
    """Two sessions of one robot on loopback: the robot's side and a hostile peer's."""
    port, robot = free_port(), robot_name()
    with (
        ZenohBus(robot, loopback(port, listen=True)) as ours,
        ZenohBus(robot, loopback(port)) as theirs,
    ):
        yield ours, theirs


def _put(bus: ZenohBus, topic: str, text: str) -> None:
    bus.session.put(bus.prefix + topic, text.encode(), attachment=FORMAT)


def _received(subscription, wanted: int, seconds: float) -> list:
    got, deadline = [], time.monotonic() + seconds
    while len(got) < wanted and time.monotonic() < deadline:
        message = subscription.get(timeout=0.05)
        if message is not None:
            got.append(message)
    return got


def test_hostile_messages_from_a_peer_are_dropped_and_the_next_good_one_arrives(network):
    ours, theirs = network
    inbox = ours.subscribe(ArmCommand, Utterance, NewGame, GameState, SpeechHypotheses)
    time.sleep(0.3)  # the subscription has reached the peer
    topics = ["arm/command", "speech/say", "game/new", "game/new", "game/state"]
    topics += ["speech/hypotheses", "game/new", "game/new"]
    for topic, text in zip(topics, HOSTILE.values(), strict=True):
        _put(theirs, topic, text)
    theirs.publish(ArmCommand(where="middle", symbol="circle"))
    (good,) = _received(inbox, 1, 5.0)
    assert good == ArmCommand(where="middle", symbol="circle", stamp=good.stamp)
    assert _received(inbox, 1, 0.3) == []


def test_a_flood_of_new_games_leaves_at_most_a_few(network):
    ours, theirs = network
    inbox = ours.subscribe(NewGame)
    time.sleep(0.3)
    for _ in range(2_000):
        theirs.publish(NewGame())
    time.sleep(1.0)
    flood = inbox.drain()
    assert 1 <= len(flood) <= 5, len(flood)
    time.sleep(1.0)  # the rate has refilled: the next game starts as usual
    theirs.publish(NewGame(robot_starts=False))
    (after,) = _received(inbox, 1, 5.0)
    assert after.robot_starts is False


def test_a_poisoned_game_record_is_dropped_not_a_crash(network):
    ours, theirs = network
    deep = "[" * 200_000 + "]" * 200_000
    answers = [deep, json.dumps([to_json(GameState(board=(9,) * 9, robot_starts=True))])]

    def answer(query):
        query.reply(query.key_expr, answers.pop(0) if answers else "[]", attachment=FORMAT)

    queryable = theirs.session.declare_queryable(theirs.prefix + "state/evil", answer)
    try:
        assert ours.game_so_far() == []  # the deep one
        assert ours.game_so_far() == []  # a board of 9s
    finally:
        queryable.undeclare()


def test_a_fake_liveliness_token_does_not_block_a_launchers_respawn(network):
    ours, theirs = network
    port = int(re.search(r":(\d+)$", ours.endpoints.listen[0])[1])
    token = f"{theirs.prefix}alive/head-movement/{FORMAT}/0123456789abcdef/4242"
    fake = theirs.session.liveliness().declare_token(token)
    stop = threading.Event()
    errors: list[BaseException] = []

    def child() -> None:
        try:
            run_component(
                "head-movement", ours.robot, loopback(port), CONFIG, stop=stop, replace=True
            )
        except BaseException as exc:  # the test reports it
            errors.append(exc)

    thread = threading.Thread(target=child)
    thread.start()
    try:
        deadline = time.monotonic() + 20
        up = []
        while not up and not errors and time.monotonic() < deadline:
            up = [p for p in ours.alive() if p.name == "head-movement" and p.pid != 4242]
            time.sleep(0.1)
        assert up and not errors, errors
    finally:
        stop.set()
        thread.join(10)
        fake.undeclare()


def test_a_subscription_holds_a_bounded_backlog_dropping_the_oldest():
    bus = LocalBus()
    from oxbot.robot.bus import LocalSubscription

    inbox = LocalSubscription(bus, (NewGame,), limit=3)
    for i in range(5):
        inbox.put(NewGame(stamp=float(i)))
    assert [m.stamp for m in inbox.drain()] == [2.0, 3.0, 4.0] and inbox.dropped == 2


def test_the_check_refuses_json_nested_deeper_than_its_limit():
    from oxbot.robot.message_checks import check_json

    check_json("[" * MAX_DEPTH + "]" * MAX_DEPTH)
    check_json('"' + "[" * 1000 + '"')  # brackets inside a string are text
    with pytest.raises(InvalidInputError, match="nested deeper"):
        check_json("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1))


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ('respawn = "no"\n', "respawn must be true or false"),
        ('components = "manager"\n', "components must be a list"),
        ('components = ["arm", "arm"]\n', "lists arm twice"),
        ("components = [1]\n", "components is a list of strings"),
        ('robot = "a/b"\n', "robot 'a/b'"),
    ],
)
def test_a_launch_files_wrong_types_and_duplicates_are_named(tmp_path, text, says):
    bad = tmp_path / "robot.toml"
    bad.write_text(text)
    with pytest.raises(ConfigError, match=re.escape(says)):
        load_launch_file(bad)


def test_a_launch_file_that_is_a_device_is_refused_unread(tmp_path):
    started = time.monotonic()
    with pytest.raises(ConfigError, match="not a regular file"):
        load_launch_file("/dev/zero")
    big = tmp_path / "big.toml"
    big.write_bytes(b"# " + b"x" * 2_000_000)
    with pytest.raises(ConfigError, match="over 1,000,000 bytes"):
        load_launch_file(big)
    assert time.monotonic() - started < 2.0


def test_a_fake_liveliness_token_does_not_hide_a_parts_death(network):
    from oxbot.robot.messages import ComponentFailed, ComponentJoined
    from oxbot.robot.zenoh_bus import PartsWatcher

    ours, theirs = network
    port = int(re.search(r":(\d+)$", ours.endpoints.listen[0])[1])
    fake = theirs.session.liveliness().declare_token(
        f"{theirs.prefix}alive/head-movement/{FORMAT}/0123456789abcdef/4242"
    )
    news = ours.subscribe(ComponentFailed, ComponentJoined)
    real = ZenohBus(ours.robot, loopback(port))
    watcher = None
    try:
        real.join("head-movement", replace=True)
        parts = {"head-movement": ("HeadMovementComponent", "head", False)}
        watcher = PartsWatcher(ours, parts, rejoin_seconds=30).start()
        time.sleep(0.5)  # the watcher has seen both tokens up
        real.close()  # the real process dies; the fake token stays
        (failed,) = _received(news, 1, 5.0)
        assert isinstance(failed, ComponentFailed) and failed.component == "HeadMovementComponent"
    finally:
        if watcher is not None:
            watcher.stop()
        fake.undeclare()
        real.close()
