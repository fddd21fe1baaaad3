"""Game-move recognition as a component: rendered sheet photos in, moves out (real perception)."""

import time

import cv2
import numpy as np
import pytest

from oxbot.config import TrackerConfig
from oxbot.errors import InvalidInputError
from oxbot.perception.sources import ImageFolderSource
from oxbot.robot.bus import LocalBus
from oxbot.robot.frames import frame_message, frame_pixels
from oxbot.robot.game_moves import GameMoveComponent
from oxbot.robot.messages import (
    ArmCommand,
    BoardProblem,
    BoardSeen,
    ComponentFailed,
    DialogueAct,
    Frame,
    GameMove,
    NewGame,
    SheetMode,
)
from oxbot.testing.render import TUNING_STYLE, random_scene
from tests.robot.helpers import collect


@pytest.fixture
def scene():
    rng = np.random.default_rng(21)
    return random_scene(rng, TUNING_STYLE), rng


def test_a_pushed_sheet_becomes_one_move_after_three_readings(scene):
    sheet, rng = scene
    bus = LocalBus()
    events = bus.subscribe(GameMove, BoardSeen, BoardProblem)
    with GameMoveComponent(bus, robot_starts=True) as vision:
        bus.publish(ArmCommand(where="middle", symbol="circle"))  # the robot's circle first
        time.sleep(0.05)
        sheet = sheet.with_symbol(4, "circle", rng)
        vision.push(sheet.photo(rng))
        sheet = sheet.with_symbol(0, "cross", rng)
        started = time.monotonic()
        vision.push(sheet.photo(rng))
        got = collect(events, lambda m: isinstance(m, GameMove))
        elapsed = time.monotonic() - started
    move = got[-1]
    assert (move.who, move.where, move.symbol) == ("usr", "upperleft", "cross")
    seen = [m for m in got if isinstance(m, BoardSeen)]
    assert [m.agreeing for m in seen[-3:]] == [1, 2, 3]
    assert seen[-1].labels[0] == "cross" and seen[-1].labels[4] == "circle"
    assert len(seen[-1].cells) == 9
    assert all(
        cv2.imdecode(np.frombuffer(c, np.uint8), 0).shape == (40, 40) for c in seen[-1].cells
    )
    assert 0.2 <= elapsed < 1.0  # 3 readings at 100 ms
    assert not [m for m in got if isinstance(m, BoardProblem)]


def test_a_cameras_frame_read_again_before_the_next_comes_is_no_second_reading(scene):
    sheet, rng = scene
    bus = LocalBus()
    events = bus.subscribe(GameMove, BoardSeen)
    with GameMoveComponent(bus, robot_starts=True) as vision:
        bus.publish(SheetMode(paper=True))
        bus.publish(ArmCommand(where="middle", symbol="circle"))
        time.sleep(0.05)
        photo = sheet.with_symbol(4, "circle", rng).with_symbol(0, "cross", rng).photo(rng)
        vision.push(photo)
        time.sleep(0.6)  # six ticks of one slow frame: one reading
        early = []
        while (message := events.get(timeout=0.05)) is not None:
            early.append(message)
        assert not [m for m in early if isinstance(m, GameMove)], early
        assert [m.agreeing for m in early if isinstance(m, BoardSeen)][-1] == 1
        for _ in range(2):  # the camera's next frames, the pen still: the 2nd and 3rd readings
            vision.push(photo)
            time.sleep(0.15)
        got = collect(events, lambda m: isinstance(m, GameMove))
    assert (got[-1].who, got[-1].where) == ("usr", "upperleft")


def test_a_frame_without_a_grid_is_seen_with_the_reason_and_then_with_confidences(scene):
    sheet, rng = scene
    bus = LocalBus()
    events = bus.subscribe(BoardSeen)
    with GameMoveComponent(bus, robot_starts=True, config=TrackerConfig(period_s=0.05)) as vision:
        vision.push(np.full((480, 640, 3), 235, np.uint8))  # a blank desk
        blank = collect(events, lambda m: isinstance(m, BoardSeen))[-1]
        vision.push(sheet.with_symbol(4, "circle", rng).photo(rng))
        seen = collect(events, lambda m: isinstance(m, BoardSeen) and bool(m.labels))[-1]
    assert blank.labels == () and "no grid in view" in blank.refusal
    assert seen.refusal == "" and seen.readings[4] == "circle"
    assert len(seen.confidences) == 9 and all(0.0 < c <= 1.0 for c in seen.confidences)


def test_a_frame_message_is_read_like_a_pushed_frame_and_problems_are_reported(scene):
    sheet, rng = scene
    bus = LocalBus()
    events = bus.subscribe(GameMove, BoardProblem)
    sheet = sheet.with_symbol(2, "cross", rng).with_symbol(6, "cross", rng)
    png = cv2.imencode(".png", sheet.photo(rng)[..., ::-1])[1].tobytes()
    with GameMoveComponent(bus, robot_starts=True, config=TrackerConfig(period_s=0.05)):
        bus.publish(Frame(image=png, format="png"))
        got = collect(events, lambda m: isinstance(m, BoardProblem))
    assert got[-1].kind == "two_new_symbols"
    assert not [m for m in got if isinstance(m, GameMove)]


def test_a_drawing_before_the_robot_starts_the_game_is_refused_not_kept(scene):
    """The person starts; they draw while the robot is still greeting: no move, a
    `not_started` problem, and the tracker's board stays empty; once the robot says "let's
    play", a drawing is a move."""
    sheet, rng = scene
    bus = LocalBus()
    events = bus.subscribe(GameMove, BoardProblem)
    with GameMoveComponent(bus, robot_starts=False, config=TrackerConfig(period_s=0.05)) as vision:
        bus.publish(DialogueAct(speaker="sys", act="Salutation(greeting)", text="Hello!"))
        time.sleep(0.1)
        early = sheet.with_symbol(4, "circle", rng)
        vision.push(early.photo(rng))
        (problem,) = collect(events, lambda m: isinstance(m, BoardProblem))
        assert problem.kind == "not_started" and "before the game started" in problem.reason
        assert vision.tracker.board == ("nothing",) * 9
        bus.publish(DialogueAct(speaker="sys", act="Reply(playGame=yes)", text="Let's play."))
        time.sleep(0.1)
        vision.push(sheet.with_symbol(0, "circle", rng).photo(rng))  # a clean sheet, a circle
        move = collect(events, lambda m: isinstance(m, GameMove))[-1]
        assert (move.who, move.where) == ("usr", "upperleft")


def test_a_new_game_forgets_the_sheet(scene):
    sheet, rng = scene
    bus = LocalBus()
    events = bus.subscribe(GameMove)
    sheet = sheet.with_symbol(4, "circle", rng)
    with GameMoveComponent(bus, robot_starts=False, config=TrackerConfig(period_s=0.05)) as vision:
        vision.push(sheet.photo(rng))
        assert collect(events, lambda m: isinstance(m, GameMove))[-1].where == "middle"
        bus.publish(NewGame(robot_starts=False))
        time.sleep(0.1)
        vision.push(sheet.photo(rng))  # the same circle on a new game is a new move
        assert collect(events, lambda m: isinstance(m, GameMove))[-1].where == "middle"


def test_a_camera_source_is_read_at_every_tick(scene, tmp_path):
    sheet, rng = scene
    sheet = sheet.with_symbol(8, "circle", rng)
    for i in range(5):
        cv2.imwrite(str(tmp_path / f"{i}.png"), sheet.photo(rng)[..., ::-1])
    bus = LocalBus()
    events = bus.subscribe(GameMove)
    source = ImageFolderSource(tmp_path)
    with GameMoveComponent(bus, robot_starts=False, source=source):
        assert collect(events, lambda m: isinstance(m, GameMove))[-1].where == "lowerright"


def test_bad_frames_are_refused_clearly():
    with pytest.raises(InvalidInputError, match="not a PNG image"):
        frame_pixels(Frame(image=b"\x89PNG nonsense", format="png"))
    with pytest.raises(InvalidInputError, match="does not have the shape"):
        frame_pixels(Frame(image=b"", format="raw"))
    with pytest.raises(InvalidInputError, match="does not have the shape"):
        frame_pixels(Frame(image=b"abc", format="raw", shape=(2, 2)))
    bus = LocalBus()
    failures = bus.subscribe(ComponentFailed)
    with GameMoveComponent(bus) as vision:
        with pytest.raises(InvalidInputError, match="uint8"):
            vision.push(np.zeros((4, 4), np.float64))
        with pytest.raises(InvalidInputError, match="shape"):
            vision.push(np.zeros((4, 4, 4), np.uint8))
        with pytest.raises(InvalidInputError, match="shape"):
            frame_message(np.zeros((4, 4, 4), np.uint8))
        bus.publish(Frame(image=b"junk", format="jpeg"))
        failure = collect(failures, lambda m: True)[-1]
        assert "not a JPEG image" in failure.error
        assert vision.running


def test_a_board_unreadable_for_a_while_is_told_once_per_reason_with_the_grid_shown_before():
    """BoardSeen carries the grid and the guidance at once; after `guidance_seconds`
    of refused frames one BoardProblem per kind, and again only after the board was read."""
    from oxbot.testing.webcam import PaperVideo

    video = PaperVideo(seed=2)
    for view in ("sheet", "dark", "blurred"):
        video.show(view, 0.1)
    sheet, dark, blurred = video.frames()
    bus = LocalBus()
    events = bus.subscribe(BoardSeen, BoardProblem)
    config = TrackerConfig(period_s=0.05, guidance_seconds=0.2)
    with GameMoveComponent(bus, robot_starts=True, config=config) as vision:
        vision.push(sheet)
        seen = collect(events, lambda m: isinstance(m, BoardSeen) and bool(m.grid))[-1]
        vision.push(dark)
        got = collect(events, lambda m: isinstance(m, BoardProblem))
        time.sleep(0.5)  # still dark: nothing more to say
        vision.push(blurred)
        got += collect(events, lambda m: isinstance(m, BoardProblem))
    assert len(seen.grid) == 32 and all(0.0 < v < 1.0 for v in seen.grid)
    told = [m.kind for m in got if isinstance(m, BoardProblem)]
    assert told == ["too_dark", "blurred"]
    refusals = {m.refusal for m in got if isinstance(m, BoardSeen) and m.refusal}
    assert any("too dark" in r for r in refusals) and any("blurred" in r for r in refusals)


def test_a_frame_waits_while_every_core_reads_another_robots_sheet(scene):
    from oxbot.robot import game_moves

    sheet, rng = scene
    bus = LocalBus()
    seen = bus.subscribe(BoardSeen)
    vision = GameMoveComponent(bus, robot_starts=True)
    vision.push(sheet.photo(rng))
    taken = 0
    while game_moves.READING_SLOTS.acquire(blocking=False):  # other robots hold every core
        taken += 1
    try:
        vision.tick()
        assert seen.get(0.2) is None  # not read, and no seconds-long wait for a core
    finally:
        for _ in range(taken):
            game_moves.READING_SLOTS.release()
    vision.tick()
    message = seen.get(2.0)
    assert message is not None and len(message.labels) == 9
