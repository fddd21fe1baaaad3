"""The Recorder's rules, message by message on a real bus and a real database."""

from __future__ import annotations

import sqlite3

import cv2
import numpy as np

from oxbot.game.board import EMPTY_BOARD, USER
from oxbot.recording import Recorder, RecordingStore
from oxbot.robot.bus import LocalBus
from oxbot.robot.messages import (
    BoardSeen,
    DialogueAct,
    DialogueEnded,
    GameState,
    RecordingSwitch,
    SpeechAudio,
    SpeechHypotheses,
)
from tests.robot.helpers import wait_for

ASK = DialogueAct(speaker="sys", act="Request(playGame)", text="Shall we play?")
HEARD = SpeechHypotheses(nbest=(("yes", 0.8), ("yeah", 0.1)), words=(("yes", 0.8),))
YES = DialogueAct(speaker="usr", act="Confirm(playGame=yes)", text="yes")


def play(recorder: Recorder, *messages) -> None:
    for message in messages:
        recorder.handle(message)


def test_audio_is_kept_only_when_asked(tmp_path):
    with RecordingStore(tmp_path) as store:
        for keep in (False, True):
            recorder = Recorder(LocalBus(), store, keep_audio=keep)
            start = GameState(board=EMPTY_BOARD, robot_starts=True)
            play(recorder, start, ASK, SpeechAudio(audio=b"RIFF-the-wav"), HEARD, YES)
            (answer,) = store.query(
                "SELECT audio, understood, nbest FROM answers WHERE session_id = ?",
                (recorder.sessions[-1],),
            )
            assert answer["audio"] == (b"RIFF-the-wav" if keep else None)
            assert answer["understood"] == "Confirm(playGame=yes)"
            assert '"yeah"' in answer["nbest"]  # the whole N-best list


def test_asking_again_marks_the_answer_as_repeated(tmp_path):
    with RecordingStore(tmp_path) as store:
        recorder = Recorder(LocalBus(), store)
        again = DialogueAct(speaker="sys", act="Request(repeat)", text="Sorry?")
        play(recorder, GameState(board=EMPTY_BOARD, robot_starts=True), ASK, HEARD, YES, again)
        play(
            recorder,
            HEARD,
            YES,
            DialogueAct(speaker="sys", act="Reply(playGame=yes)", text="Nice."),
        )
        repeated = [r["repeated"] for r in store.query("SELECT repeated FROM answers ORDER BY seq")]
    assert repeated == [1, 0]


def test_nothing_is_kept_until_switched_on_and_nothing_after_switched_off(tmp_path):
    store = RecordingStore(tmp_path / "data")
    recorder = Recorder(LocalBus(), store, enabled=False)
    play(recorder, GameState(board=EMPTY_BOARD, robot_starts=True), ASK, HEARD, YES)
    assert store.sessions() == []
    play(recorder, RecordingSwitch(on=True), ASK, HEARD, YES)  # from this turn on
    play(recorder, RecordingSwitch(on=False), ASK, HEARD, YES, DialogueEnded(outcome=None))
    (session,) = store.sessions()
    assert session.status == "stopped" and session.turns == 2 and session.answers == 1
    store.close()


def test_a_new_game_before_the_goodbye_interrupts_the_session(tmp_path):
    with RecordingStore(tmp_path) as store:
        recorder = Recorder(LocalBus(), store)
        start = GameState(board=EMPTY_BOARD, robot_starts=True)
        play(recorder, start, ASK, start, ASK, DialogueEnded(outcome="draw"))
        statuses = [(s.status, s.outcome) for s in store.sessions()]
    assert statuses == [("interrupted", None), ("ended", "draw")]


def test_a_robot_stopped_before_the_goodbye_leaves_its_session_closed_as_left(tmp_path):
    with RecordingStore(tmp_path) as store:
        bus = LocalBus()
        recorder = Recorder(bus, store)
        recorder.start()
        bus.publish(GameState(board=EMPTY_BOARD, robot_starts=True))
        bus.publish(ASK)
        bus.publish(HEARD)
        bus.publish(YES)
        assert wait_for(lambda: recorder.current is not None and recorder.current.answer == 1)
        recorder.stop()  # quit in the terminal: no goodbye was said
        (session,) = store.sessions()
    assert (session.status, session.outcome, session.turns, session.answers) == (
        "left",
        None,
        2,
        1,
    )


def crop(strokes: int, smudge: int = 0) -> bytes:
    """A 40x40 cell crop as the tracker sends it: `strokes` of a cross drawn (0-2), plus light
    camera noise."""
    image = np.full((40, 40), 235, np.uint8)
    for (x0, y0), (x1, y1) in [((8, 8), (32, 32)), ((32, 8), (8, 32))][:strokes]:
        cv2.line(image, (x0, y0), (x1, y1), 20, 3)
    image = cv2.add(image, np.full_like(image, smudge))
    return cv2.imencode(".png", image)[1].tobytes()


def seen(cell_crops: dict[int, bytes]) -> BoardSeen:
    cells = tuple(cell_crops.get(i, crop(0)) for i in range(9))
    return BoardSeen(labels=("nothing",) * 9, cells=cells)


def test_a_drawing_is_labelled_from_when_it_was_whole_a_typed_blank_cell_never(tmp_path):
    """Cell 0: drawn in two strokes, read whole twice before the robot took it (as when the
    person types a move the robot could not read), then once after. Cell 4: a move typed with
    nothing drawn. Cell 8 stays empty."""
    played_0 = tuple(USER if i == 0 else 0 for i in range(9))
    played_both = tuple(USER if i in (0, 4) else 0 for i in range(9))
    with RecordingStore(tmp_path) as store:
        recorder = Recorder(LocalBus(), store)
        play(
            recorder,
            GameState(board=EMPTY_BOARD, robot_starts=True),
            ASK,
            HEARD,
            YES,
            seen({0: crop(0)}),
            seen({0: crop(1)}),  # under way
            seen({0: crop(2)}),
            seen({0: crop(2, smudge=6)}),  # the same drawing, the light changed a little
            GameState(board=played_0, robot_starts=True),
            seen({0: crop(2)}),
            GameState(board=played_both, robot_starts=True),
            seen({0: crop(2)}),
            DialogueEnded(outcome="stopped"),
        )
        labels = {
            (r["reading"], r["cell"]): r["label"]
            for r in store.query("SELECT reading, cell, label FROM crops")
        }
    assert [labels[(k, 0)] for k in range(1, 7)] == [None, None, *["cross"] * 4]
    assert {labels[(k, 4)] for k in range(1, 7)} == {None}
    assert {labels[(k, 8)] for k in range(1, 7)} == {"nothing"}


def test_a_busy_database_is_waited_for_and_recording_resumes(tmp_path, monkeypatch):
    monkeypatch.setattr("oxbot.recording.recorder.BUSY_WAIT", 0.05)
    with RecordingStore(tmp_path, busy_timeout=0.05) as store:
        recorder = Recorder(LocalBus(), store)
        other = sqlite3.connect(tmp_path / "recordings.sqlite3", timeout=0)
        other.execute("BEGIN IMMEDIATE")  # another program holds the lock from the start
        play(recorder, GameState(board=EMPTY_BOARD, robot_starts=True), ASK, HEARD, YES)
        play(recorder, ASK, DialogueEnded(outcome="win"))  # closed while still busy
        play(recorder, GameState(board=EMPTY_BOARD, robot_starts=False), ASK)
        assert recorder.unwritten and recorder.sessions == []
        other.rollback()  # the lock goes: the next turn writes everything kept
        play(recorder, HEARD, YES)
        sessions = store.sessions()
        turns = store.query("SELECT session_id, seq, act FROM turns ORDER BY session_id, seq")
    assert [(s.status, s.outcome, s.turns, s.answers) for s in sessions] == [
        ("ended", "win", 3, 1),
        ("playing", None, 2, 1),
    ]
    assert [t["seq"] for t in turns] == [1, 2, 3, 1, 2] and not recorder.unwritten
