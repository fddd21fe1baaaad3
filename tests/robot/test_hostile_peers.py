"""A Zenoh peer that sends what it likes: malformed, deep, huge or out-of-range messages, floods,
a poisoned game record, a fake liveliness token; and launch files that are not what they seem.
Real sessions over loopback, in this process."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import signal
import threading
import time
import uuid

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

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

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


@pytest.mark.parametrize("fake_format", [FORMAT, "999"])
def test_a_fake_liveliness_token_does_not_block_a_launchers_respawn(network, fake_format):
    """A token claiming the part is up already, or that the robot speaks another message
    format: a launcher's child starts anyway (the other format is nobody it launched)."""
    ours, theirs = network
    port = int(re.search(r":(\d+)$", ours.endpoints.listen[0])[1])
    token = f"{theirs.prefix}alive/head-movement/{fake_format}/0123456789abcdef/4242"
    fake = theirs.session.liveliness().declare_token(token)
    stop = threading.Event()
    errors: list[BaseException] = []

    def child() -> None:
        try:
            run_component(
                "head-movement",
                ours.robot,
                loopback(port),
                CONFIG,
                stop=stop,
                replace=True,
                siblings=("head-movement",),
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


@pytest.mark.slow
def test_a_token_flapping_under_the_arms_name_does_not_stall_a_launched_robot():
    """A peer that declares and withdraws tokens under the arm's name every 0.5 s (its own,
    a copy of the real arm's key, and one claiming the arm's pid): the launched robot plays on
    without a word about its arm, and a real death under a copy of its key is still seen."""
    from oxbot.dialogue.domain import ASK_AGAIN, INVITATION, MOVE_REQUEST
    from oxbot.game.board import EMPTY, outcome
    from oxbot.robot.launch import Launcher, LaunchFile
    from oxbot.robot.messages import (
        ComponentFailed,
        ComponentJoined,
        ComponentLost,
        DialogueAct,
        DialogueEnded,
    )
    from oxbot.robot.remote import RemoteRobot
    from tests.robot.helpers import collect
    from tests.robot.test_zenoh import wait_alive

    port, robot = free_port(), robot_name()
    names = ("manager", "voice", "arm")
    launch = LaunchFile(
        robot=robot, listen=(f"tcp/127.0.0.1:{port}",), scouting=False, components=names
    )
    config = dataclasses.replace(CONFIG, speech=dataclasses.replace(CONFIG.speech, voice="espeak"))
    stop = threading.Event()
    launcher = Launcher(launch, config).start()
    flapper = None
    try:
        with (
            ZenohBus(robot, launch.child_endpoints()) as bus,
            ZenohBus(robot, launch.child_endpoints()) as hostile,
        ):
            arm_pid = wait_alive(bus, set(names))["arm"]
            arm = None
            while arm is None:  # a liveliness query can miss a token: asked again
                arm = next((p for p in bus.alive() if p.pid == arm_pid), None)
            alive = f"{hostile.prefix}alive/arm/{FORMAT}"
            keys = [
                f"{alive}/{uuid.uuid4().hex}/4242",  # a process of its own
                f"{alive}/{arm.zid}/{arm.pid}",  # a copy of the real arm's key
                f"{alive}/{uuid.uuid4().hex}/{arm.pid}",  # the real arm's pid
            ]

            def flap() -> None:
                liveliness = hostile.session.liveliness()
                while not stop.is_set():
                    tokens = [liveliness.declare_token(key) for key in keys]
                    stop.wait(0.25)
                    for token in tokens:
                        token.undeclare()
                    stop.wait(0.25)

            flapper = threading.Thread(target=flap, daemon=True)
            flapper.start()
            news = bus.subscribe(ComponentFailed, ComponentLost, ComponentJoined)
            events = bus.subscribe(DialogueAct, DialogueEnded)
            ended = None
            with RemoteRobot(bus, config) as remote:  # it starts a game
                deadline = time.monotonic() + 90
                while ended is None and time.monotonic() < deadline:
                    message = events.get(0.05)
                    if isinstance(message, DialogueEnded):
                        ended = message
                    elif isinstance(message, DialogueAct) and message.speaker == "sys":
                        if message.act in (INVITATION, ASK_AGAIN):
                            remote.say("yes let's play")
                        elif message.act == MOVE_REQUEST and outcome(remote.board) is None:
                            board = remote.board
                            free = [c for c in (4, 0, 2, 6, 8, 1, 3, 5, 7) if board[c] == EMPTY]
                            remote.draw(free[0])
            assert ended is not None and ended.outcome is not None, "the game did not end"
            about_the_arm = [m for m in news.drain() if m.component == "ArmComponent"]
            assert about_the_arm == [], about_the_arm
            # the fake holds a copy of the arm's key when the arm dies: its death is seen
            stop.set()
            flapper.join(2)
            copy = hostile.session.liveliness().declare_token(keys[1])
            time.sleep(0.5)
            os.kill(arm.pid, signal.SIGKILL)
            got = collect(news, lambda m: isinstance(m, ComponentJoined), 15.0)
            assert [type(m) for m in got] == [ComponentFailed, ComponentJoined], got
            copy.undeclare()
    finally:
        stop.set()
        if flapper is not None:
            flapper.join(2)
        launcher.stop()
