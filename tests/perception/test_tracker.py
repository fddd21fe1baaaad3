import cv2
import numpy as np
import pytest

from oxbot.config import TrackerConfig
from oxbot.errors import InvalidInputError, NoGridFound
from oxbot.game.board import LABELS
from oxbot.perception.board import read_board
from oxbot.perception.classifier import CellReading
from oxbot.perception.sources import PushedFrames, VideoFileSource
from oxbot.perception.tracker import AcceptedDrawing, ImpossibleEvent, MoveTracker, watch
from oxbot.testing.render import TUNING_STYLE, random_scene

EMPTY = ["nothing"] * 9


def board(**cells: str) -> list[str]:
    """A reading with the named cells set, e.g. board(middle="cross")."""
    from oxbot.game.board import CELL_NAMES

    labels = list(EMPTY)
    for name, label in cells.items():
        labels[CELL_NAMES.index(name)] = label
    return labels


def feed(tracker: MoveTracker, *readings) -> list:
    return [tracker.update(r) for r in readings]


def test_tracker_needs_three_identical_readings():
    tracker = MoveTracker(robot_starts=True, check_turns=False)
    seen = board(middle="cross")
    events = feed(tracker, seen, seen, seen, seen)
    assert events[:2] == [None, None]
    assert isinstance(events[2], AcceptedDrawing)
    assert events[3] is None  # accepted once, not again
    move = events[2]
    assert (move.who, move.what, move.where, move.symbol) == ("usr", "draw", "middle", "cross")
    assert move.reading == 3
    assert str(move) == "[who=usr ∧ what=draw ∧ where=middle]"
    assert tracker.board[4] == "cross"


def test_tracker_period_and_count_come_from_the_paper():
    config = TrackerConfig()
    assert config.period_s == pytest.approx(0.1)
    assert config.stable_readings == 3
    tracker = MoveTracker(config=TrackerConfig(stable_readings=5), check_turns=False)
    seen = board(lowerleft="cross")
    assert feed(tracker, *[seen] * 4) == [None] * 4
    assert isinstance(tracker.update(seen), AcceptedDrawing)


def test_tracker_ignores_flicker_and_missing_frames():
    tracker = MoveTracker(robot_starts=True, check_turns=False)
    seen = board(upperleft="cross")
    # Two readings, a misread, two readings, a frame without a grid, two readings: no move.
    events = feed(tracker, seen, seen, EMPTY, seen, seen, None, seen, seen)
    assert events == [None] * 8
    assert tracker.update(seen) is not None  # the third in a row at last


def test_tracker_ignores_a_symbol_that_disappears():
    tracker = MoveTracker(robot_starts=True, check_turns=False)
    feed(tracker, *[board(middle="cross")] * 3)
    # A hand covers the cross for a while: the board keeps it, nothing is reported.
    assert feed(tracker, *[EMPTY] * 5) == [None] * 5
    assert tracker.board[4] == "cross"
    assert feed(tracker, *[board(middle="cross")] * 5) == [None] * 5


def test_tracker_ignores_the_robots_drawings():
    tracker = MoveTracker(robot_starts=True)
    tracker.robot_draws("upperright")
    # The arm draws a circle; while half drawn it may read as nothing or flicker.
    readings = [EMPTY, board(upperright="circle"), EMPTY] + [board(upperright="circle")] * 5
    assert feed(tracker, *readings) == [None] * len(readings)
    # The person's cross next to it is a move; the robot's circle is not in it.
    events = feed(tracker, *[board(upperright="circle", middle="cross")] * 3)
    assert [type(e) for e in events] == [type(None), type(None), AcceptedDrawing]
    assert events[2].where == "middle"


def test_a_move_made_in_words_is_no_new_move_when_drawn_later():
    """The person said "top left" (the manager took it); drawing it afterwards makes no second
    move, and the turns count it: their next drawing is in turn."""
    tracker = MoveTracker(robot_starts=True)
    tracker.robot_draws("middle")
    tracker.person_drew("upperleft")
    tracker.person_drew(0)  # told twice (every GameState tells it): no change
    assert tracker.board[0] == "cross"
    assert feed(tracker, *[board(middle="circle", upperleft="cross")] * 4) == [None] * 4
    tracker.robot_draws("lowerright")
    seen = board(middle="circle", upperleft="cross", lowerright="circle", upperright="cross")
    assert isinstance(feed(tracker, seen, seen, seen)[2], AcceptedDrawing)
    with pytest.raises(InvalidInputError, match="does not exist"):
        tracker.person_drew(9)


def test_tracker_reports_two_new_symbols_once_and_accepts_neither():
    tracker = MoveTracker(robot_starts=True, check_turns=False)
    two = board(upperleft="cross", lowerright="cross")
    events = feed(tracker, *[two] * 6)
    reported = [e for e in events if e is not None]
    assert len(reported) == 1
    assert isinstance(reported[0], ImpossibleEvent)
    assert reported[0].kind == "two_new_symbols"
    assert reported[0].cells == (0, 8)
    assert "2 new symbols" in reported[0].message
    assert tracker.board == tuple(EMPTY)


def test_tracker_reports_a_symbol_in_an_occupied_cell():
    tracker = MoveTracker(robot_starts=True)
    tracker.robot_draws(4)
    events = feed(tracker, *[board(middle="cross")] * 3)
    assert isinstance(events[2], ImpossibleEvent)
    assert events[2].kind == "occupied_cell"
    assert "the robot's circle" in events[2].message
    assert tracker.board[4] == "circle"


def test_an_occupied_cell_misread_in_one_frame_does_not_hold_up_the_persons_move():
    # A still camera's frames differ by sensor noise: the robot's thin circle read as a cross
    # in one frame of three broke the run that showed the person's cross (composed dev games).
    tracker = MoveTracker(robot_starts=True)
    tracker.robot_draws(4)
    move = board(middle="circle", upperleft="cross")
    flicker = board(middle="cross", upperleft="cross")
    events = feed(tracker, move, flicker, move)
    assert isinstance(events[2], AcceptedDrawing) and events[2].where == "upperleft"
    assert tracker.board[4] == "circle"


def test_tracker_reports_the_wrong_symbol_for_the_person():
    tracker = MoveTracker(
        robot_starts=True, check_turns=False
    )  # the robot starts: it draws circles
    events = feed(tracker, *[board(middle="circle")] * 3)
    assert isinstance(events[2], ImpossibleEvent)
    assert events[2].kind == "wrong_symbol"
    assert "the person draws crosses" in events[2].message
    assert tracker.board[4] == "nothing"


def test_tracker_refuses_drawings_out_of_turn_and_after_the_game():
    tracker = MoveTracker(robot_starts=True)  # the robot draws first
    events = feed(tracker, *[board(middle="cross")] * 3)
    assert isinstance(events[2], ImpossibleEvent) and events[2].kind == "out_of_turn"
    assert tracker.board == tuple(EMPTY)
    tracker.robot_draws("middle")
    events = feed(tracker, *[board(middle="circle", upperleft="cross")] * 3)
    assert isinstance(events[2], AcceptedDrawing) and events[2].where == "upperleft"
    # A second cross before the robot has answered is out of turn.
    events = feed(tracker, *[board(middle="circle", upperleft="cross", lowerleft="cross")] * 3)
    assert isinstance(events[2], ImpossibleEvent) and events[2].kind == "out_of_turn"
    # The robot completes the diagonal: nothing more is a move.
    tracker.robot_draws("upperright")
    tracker.robot_draws("lowerleft")
    after = list(tracker.board)
    after[1] = "cross"
    events = feed(tracker, *[after] * 3)
    assert isinstance(events[2], ImpossibleEvent) and events[2].kind == "game_over"


def test_tracker_counts_agreeing_readings():
    tracker = MoveTracker(robot_starts=False)
    seen = board(middle="circle")
    counts = []
    for reading in [seen, seen, EMPTY, seen, seen, seen]:
        tracker.update(reading)
        counts.append(tracker.agreeing)
    assert counts == [1, 2, 0, 1, 2, 0]  # back to 0 once the move is accepted


def test_the_starter_draws_circles():
    tracker = MoveTracker(robot_starts=False, check_turns=False)  # the person starts, with circles
    events = feed(tracker, *[board(middle="circle")] * 3)
    assert isinstance(events[2], AcceptedDrawing) and events[2].symbol == "circle"
    events = feed(tracker, *[board(middle="circle", upperleft="cross")] * 3)
    assert isinstance(events[2], ImpossibleEvent) and events[2].kind == "wrong_symbol"


def test_tracker_refuses_malformed_readings():
    tracker = MoveTracker()
    with pytest.raises(InvalidInputError, match="9 labels"):
        tracker.update(["cross"] * 8)
    with pytest.raises(InvalidInputError, match="9 labels"):
        tracker.update(["square"] * 9)
    with pytest.raises(InvalidInputError, match="does not exist"):
        tracker.robot_draws(9)


def test_tracker_never_emits_a_move_it_has_not_seen_three_times():
    rng = np.random.default_rng(0)
    moves = 0
    for _ in range(300):
        tracker = MoveTracker(robot_starts=bool(rng.integers(2)))
        history: list[list[str] | None] = []
        for _step in range(40):
            if rng.random() < 0.1:
                reading = None
            else:
                # Mostly the previous reading with a few cells flipped: noisy, sometimes stable.
                base = history[-1] if history and history[-1] is not None else EMPTY
                reading = list(base)
                for cell in rng.choice(9, size=int(rng.integers(0, 3)), replace=False):
                    reading[cell] = LABELS[int(rng.integers(3))]
            history.append(reading)
            event = tracker.update(reading)
            if isinstance(event, AcceptedDrawing):
                moves += 1
                last_three = history[-3:]
                assert len(last_three) == 3
                assert all(r is not None and r[event.cell] == event.symbol for r in last_three)
    assert moves > 50  # the property was exercised, not vacuously true


# --- a video of a person drawing a cross, stroke by stroke, through the real pipeline ---


def test_video_of_a_cross_drawn_stroke_by_stroke_yields_one_move(tmp_path):
    rng = np.random.default_rng(7)
    scene = random_scene(rng, TUNING_STYLE).with_symbol(4, "circle", rng)
    scene = scene.with_symbol(0, "cross", rng)
    while len(scene.symbols[0].strokes) != 2:  # a cross of two strokes, not gone over again
        scene = scene.with_symbol(0, "cross", rng)
    # Every 100 ms: the sheet with the robot's circle, the first stroke of the cross, a pause
    # with the cross half drawn, the second stroke, then the finished cross. The camera films
    # at 30 frames a second, so each moment lasts 3 frames of the video.
    progress = [0.0] * 3 + [0.3, 0.7, 1.0] + [1.0] * 6 + [1.4, 1.8] + [2.0] * 6
    half_drawn = [i for i, p in enumerate(progress) if 0 < p <= 1.0]
    path = tmp_path / "drawing.avi"
    width, height = TUNING_STYLE.size
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30, (width, height))
    assert writer.isOpened()
    for p in progress:
        frame = cv2.cvtColor(scene.photo(rng, drawn={0: p}), cv2.COLOR_RGB2BGR)
        for _ in range(3):
            writer.write(frame)
    writer.release()

    readings: list[list[str] | None] = []

    def read(frame: np.ndarray) -> list[str]:
        try:
            readings.append(read_board(frame))
        except NoGridFound:
            readings.append(None)
            raise
        return readings[-1]

    tracker = MoveTracker(robot_starts=True)
    tracker.robot_draws("middle")
    with VideoFileSource(path) as video:
        events = [(len(readings) - 1, e) for e in watch(video, tracker, read=read)]

    assert len(readings) == len(progress), "one reading per 100 ms of video"
    assert all(r is not None for r in readings), "the grid must be found in every frame"
    assert [r[0] for r in readings[:3]] == ["nothing"] * 3
    assert all(readings[i][0] == "nothing" for i in half_drawn[-6:]), "half-drawn read as symbol"
    assert len(events) == 1, events
    index, move = events[0]
    assert isinstance(move, AcceptedDrawing)
    assert (move.who, move.what, move.where) == ("usr", "draw", "upperleft")
    # Emitted on the third reading in a row that shows the cross, never earlier.
    assert index > half_drawn[-1]
    assert [r[0] for r in readings[index - 2 : index + 1]] == ["cross"] * 3
    assert readings[index - 3][0] != "cross"
    assert all(r[0] == "cross" for r in readings[index:])


def test_watch_reads_a_live_source_once_per_period():
    now = [0.0]
    naps: list[float] = []

    def sleep(seconds: float) -> None:
        naps.append(seconds)
        now[0] += seconds

    frames = PushedFrames(capacity=16)
    for _ in range(5):
        frames.push(np.zeros((64, 64, 3), np.uint8))
    frames.finish()
    seen = board(middle="cross")
    tracker = MoveTracker(robot_starts=True, check_turns=False)
    with frames:
        events = list(
            watch(frames, tracker, read=lambda _: seen, clock=lambda: now[0], sleep=sleep)
        )
    assert [e.where for e in events] == ["middle"]
    assert naps == pytest.approx([0.1] * 5)  # one reading every 100 ms (paper §2.1)


def cell_readings(labels, confidence=0.99, ink=None):
    """CellReadings for a board reading: each cell's label, one confidence, ink 0.1 where a
    symbol or partial ink is (or as given per cell)."""
    ink = ink or {}
    return [
        CellReading(label, confidence, ink.get(i, 0.0 if label == "nothing" else 0.1))
        for i, label in enumerate(labels)
    ]


def test_tracker_never_accepts_a_partial_cell():
    tracker = MoveTracker(robot_starts=False, check_turns=False)
    half = board(middle="partial")
    assert feed(tracker, *[half] * 10) == [None] * 10
    assert [tracker.update(half, cell_readings(half)) for _ in range(10)] == [None] * 10
    assert tracker.board == tuple(EMPTY)


def test_tracker_needs_a_confident_whole_symbol():
    config = TrackerConfig(min_confidence=0.9)
    tracker = MoveTracker(robot_starts=False, config=config, check_turns=False)
    seen = board(middle="circle")
    unsure = [tracker.update(seen, cell_readings(seen, confidence=0.6)) for _ in range(6)]
    assert unsure == [None] * 6 and tracker.agreeing == 0
    events = [tracker.update(seen, cell_readings(seen, confidence=0.95)) for _ in range(3)]
    assert isinstance(events[2], AcceptedDrawing) and events[2].where == "middle"


def test_tracker_waits_until_the_ink_stops_changing():
    tracker = MoveTracker(robot_starts=False, config=TrackerConfig(ink_tolerance=0.1))
    seen = board(middle="circle")
    # The pen is still going round: the circle's ink grows at every reading.
    growing = [
        tracker.update(seen, cell_readings(seen, ink={4: 0.10 + 0.02 * k})) for k in range(6)
    ]
    assert growing == [None] * 6 and tracker.agreeing == 1
    # The pen has lifted: three readings of the same ink (within 10%) make the move.
    still = [tracker.update(seen, cell_readings(seen, ink={4: v})) for v in (0.3, 0.305, 0.298)]
    assert still[:2] == [None, None] and isinstance(still[2], AcceptedDrawing)


def test_tracker_settings_are_checked():
    from oxbot.errors import ConfigError

    with pytest.raises(ConfigError, match="min_confidence"):
        TrackerConfig(min_confidence=1.5)
    with pytest.raises(ConfigError, match="ink_tolerance"):
        TrackerConfig(ink_tolerance=-0.1)


def test_still_ink_that_is_not_a_whole_symbol_is_reported_once_a_turn():
    # A plus drawn for a cross: the person waits, the robot must say it cannot tell.
    tracker = MoveTracker(robot_starts=True, config=TrackerConfig(unclear_seconds=4.0))
    tracker.robot_draws("upperleft")
    plus = board(middle="partial")
    events = [tracker.update(plus, cell_readings(plus, ink={4: 0.1})) for _ in range(100)]
    reported = [e for e in events if e is not None]
    assert [e.kind for e in reported] == ["unclear_symbol"] and reported[0].cells == (4,)
    assert events.index(reported[0]) == 39  # 4 s at 10 readings a second
    # more ink, still no whole symbol: not told again this turn
    more = [tracker.update(plus, cell_readings(plus, ink={4: 0.2})) for _ in range(100)]
    assert more == [None] * 100 and tracker.board[4] == "nothing"
    # the person's cross elsewhere, the robot's circle: the next turn, it is told again
    cross = board(middle="partial", lowerright="cross")
    moved = [tracker.update(cross, cell_readings(cross, ink={4: 0.2})) for _ in range(3)]
    assert isinstance(moved[2], AcceptedDrawing)
    tracker.robot_draws("lowerleft")
    later = [tracker.update(cross, cell_readings(cross, ink={4: 0.2})) for _ in range(40)]
    assert [e.kind for e in later if e is not None] == ["unclear_symbol"]


def test_the_pause_between_a_crosss_strokes_is_not_unclear():
    tracker = MoveTracker(robot_starts=True)  # the robot starts: the person draws crosses
    tracker.robot_draws("upperleft")
    one_stroke, cross = board(middle="partial"), board(middle="cross")
    pause = [tracker.update(one_stroke, cell_readings(one_stroke)) for _ in range(15)]
    done = [tracker.update(cross, cell_readings(cross, ink={4: 0.2})) for _ in range(3)]
    assert pause == [None] * 15 and isinstance(done[2], AcceptedDrawing)
    after = [tracker.update(cross, cell_readings(cross, ink={4: 0.2})) for _ in range(60)]
    assert after == [None] * 60


def test_unclear_ink_is_not_reported_out_of_turn_or_before_the_game():
    plus = board(middle="partial")
    robots_turn = MoveTracker(robot_starts=True)
    assert {robots_turn.update(plus, cell_readings(plus)) for _ in range(60)} == {None}
    not_started = MoveTracker(robot_starts=False)
    not_started.playing = False
    assert {not_started.update(plus, cell_readings(plus)) for _ in range(60)} == {None}
    game_over = MoveTracker(robot_starts=True)
    for cell in ("upperleft", "upperright", "uppermiddle"):
        game_over.robot_draws(cell)
    assert {game_over.update(plus, cell_readings(plus)) for _ in range(60)} == {None}
