"""The Recorder: a component that keeps what the robot saw and heard, when the person agreed.

It only listens (it publishes nothing), and only while it is on (`enabled`, switched by a
RecordingSwitch message: the page's toggle); switched on mid-game, it keeps the game from that
turn on; switched off, it closes the session under way ("stopped") and keeps nothing more.
The manager's GameState opens a session when a game starts (the empty board) and tells which
cells are settled; BoardSeen carries the 9 crops the
tracker read; SpeechHypotheses what was heard (SpeechAudio its recording, kept only with
`keep_audio`); DialogueAct the transcript; DialogueEnded closes the session.

Writes are buffered and committed one transaction per turn (each DialogueAct, and the
goodbye), so a crash loses at most the turn under way. When another connection holds the
database's lock, a turn waits at most `BUSY_WAIT` seconds (well under the robot's hang deadline),
then stays buffered, session and all, and is written with the next turn that gets the lock:
recording resumes, nothing is dropped. Stopping waits the store's whole `busy_timeout` once.

Labels come from the finished game, never from the classifier: when the dialogue ends, a crop
of a cell still empty at the end gets "nothing", and a crop of a cell the person played gets
their symbol when it shows that cell's last ink (`ink_change` below `SAME_INK`) and the last
ink is a drawing (it differs from the cell's first crop by `SOME_INK` or more). So the crops
read before the move was accepted count once the drawing was whole: those the robot could not
read, and the person typed instead, are the ones active learning wants most. A drawing under
way, a hand over the cell, a move typed without drawing, and the robot's own cells (on the web
page its ink is on an overlay the camera image does not show) get no label. An interrupted
dialogue (a new game before the goodbye) labels only the person's settled cells.
"""

from __future__ import annotations

import copy
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from oxbot.dialogue.domain import ASK_AGAIN
from oxbot.errors import DatabaseBusy
from oxbot.game.board import EMPTY, EMPTY_BOARD, USER, Board, symbol_of
from oxbot.recording.store import RecordingStore
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import (
    BoardSeen,
    DialogueAct,
    DialogueEnded,
    GameState,
    Message,
    RecordingSwitch,
    SpeechAudio,
    SpeechHypotheses,
)

log = logging.getLogger(__name__)

NOTICE = (
    "Recording: this game's cell images, what you said (as text{audio}), the transcript, "
    "outcome and timings are kept on this computer in {path}; `oxbot data forget` deletes them."
)
"""The one-line notice shown wherever recording is on."""


BUSY_WAIT = 0.5
"""Seconds a turn waits for a locked database before it stays buffered for the next turn."""
INK_LEVELS = 64
"""Grey levels by which a pixel must differ to count as ink added or removed."""
SAME_INK = 0.01
"""Two crops of a cell show the same ink when fewer than this share of pixels differ."""
SOME_INK = 0.02
"""A cell's last crop shows a drawing when at least this share differs from its first."""


def ink_change(a: np.ndarray | None, b: np.ndarray | None) -> float:
    """Share of pixels that differ by more than `INK_LEVELS` between two gray crops (1 when
    either could not be decoded or their sizes differ)."""
    if a is None or b is None or a.shape != b.shape:
        return 1.0
    return float((np.abs(a.astype(np.int16) - b) > INK_LEVELS).mean())


def notice(store: RecordingStore, keep_audio: bool = False) -> str:
    return NOTICE.format(path=store.path, audio=" and audio" if keep_audio else "")


@dataclass
class _Open:
    """The session being recorded and what waits for the next turn's transaction."""

    id: int | None
    """None until the session's row is written (the database may be busy at first)."""
    start: float
    robot_starts: bool
    started_at: float = 0.0
    board: Board = EMPTY_BOARD
    turn: int = 0
    reading: int = 0
    answer: int = 0
    last_sys_act: str = ""
    crops: list[tuple[Any, ...]] = field(default_factory=list)
    answers: list[dict[str, Any]] = field(default_factory=list)
    turns: list[tuple[Any, ...]] = field(default_factory=list)
    repeats: list[str] = field(default_factory=list)
    """The robot acts said since the last write, each telling whether it asked again."""
    closing: tuple[str, str | None] | None = None
    """(status, outcome) once the session is closed but not yet written."""


class Recorder(Component):
    """Records each dialogue into a `RecordingStore` (see the module docstring)."""

    listens_to = (
        GameState,
        BoardSeen,
        SpeechHypotheses,
        SpeechAudio,
        DialogueAct,
        DialogueEnded,
        RecordingSwitch,
    )
    part = "memory"
    essential = False

    def __init__(
        self,
        bus: Bus,
        store: RecordingStore | Callable[[], RecordingStore],
        mode: str = "",
        keep_audio: bool = False,
        enabled: bool = True,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        self._store = store
        self.mode = mode
        self.keep_audio = keep_audio
        self.enabled = enabled
        self.current: _Open | None = None
        self.unwritten: list[_Open] = []
        """Closed sessions whose last rows wait for the database (it was busy)."""
        self._game: tuple[bool, Board] | None = None  # who started, the board: no one's data
        self._audio: bytes | None = None
        self.sessions: list[int] = []
        """Ids of the sessions this recorder opened, oldest first."""

    @property
    def store(self) -> RecordingStore:
        """The database, opened at the first recording (a callable is called then)."""
        if not isinstance(self._store, RecordingStore):
            self._store = self._store()
        return self._store

    def take_over(self, old: Component) -> None:
        assert isinstance(old, Recorder)
        self.current = copy.deepcopy(old.current)
        self.unwritten = copy.deepcopy(old.unwritten)
        self.sessions, self.enabled, self._game = list(old.sessions), old.enabled, old._game

    def handle(self, message: Message) -> None:
        if isinstance(message, RecordingSwitch):
            self._switch(message.on)
            return
        if isinstance(message, GameState):
            self._game = (message.robot_starts, message.board)
            if self.enabled:
                self._game_state(message)
            return
        if not self.enabled:
            return
        current = self.current
        if isinstance(message, SpeechAudio):
            self._audio = message.audio if self.keep_audio else None
        if current is None:
            return
        if isinstance(message, BoardSeen):
            self._seen(current, message)
        elif isinstance(message, SpeechHypotheses):
            self._heard(current, message)
        elif isinstance(message, DialogueAct):
            self._turn(current, message)
        elif isinstance(message, DialogueEnded):
            self._close(current, "ended", message.outcome)

    def stop(self, timeout: float = 2.0) -> None:
        super().stop(timeout)
        if self.abandoned:
            return
        for message in self.waiting():  # a goodbye published just before the robot stopped
            self.handle(message)
        if self.current is not None:  # the robot stops before the goodbye: the person left
            self._close(self.current, "left", None)
        if self.unwritten:  # the last chance: wait the store's whole busy timeout once
            self._write_waiting(self.store.busy_timeout)
        for session in self.unwritten:
            log.error("recording: session %s was not written: the database stayed busy", session.id)

    # --- the session ---

    def _switch(self, on: bool) -> None:
        if on == self.enabled:
            return
        self.enabled = on
        if not on and self.current is not None:
            self._close(self.current, "stopped", None)
        elif on and self._game is not None:  # before the first game, its GameState opens one
            robot_starts, board = self._game
            self._open(robot_starts, board, time.monotonic())

    def _game_state(self, message: GameState) -> None:
        if message.board == EMPTY_BOARD:  # the manager's new game: a new session
            if self.current is not None:
                self._close(self.current, "interrupted", None)
            self._open(message.robot_starts, message.board, message.stamp)
        elif self.current is not None:
            self.current.board = message.board

    def _open(self, robot_starts: bool, board: Board, stamp: float) -> None:
        self.current = _Open(None, stamp, robot_starts, time.time(), board)
        self._write(self.current)

    def _seen(self, current: _Open, message: BoardSeen) -> None:
        if len(message.cells) != len(message.labels) or not message.cells:
            return  # no grid: nothing was read
        current.reading += 1
        t = message.stamp - current.start
        readings = message.readings or message.labels
        confidences = message.confidences or (1.0,) * len(message.cells)
        for cell, (image, read_as, confidence) in enumerate(
            zip(message.cells, readings, confidences, strict=True)
        ):
            state = current.board[cell]
            current.crops.append((current.reading, cell, t, image, read_as, confidence, state))

    def _heard(self, current: _Open, message: SpeechHypotheses) -> None:
        current.answer += 1
        audio = self._audio if message.source == "microphone" else None
        self._audio = None
        current.answers.append(
            {
                "seq": current.answer,
                "t": message.stamp - current.start,
                "source": message.source,
                "nbest": json.dumps([list(h) for h in message.nbest]),
                "words": json.dumps([list(w) for w in message.words]),
                "text": message.nbest[0][0] if message.nbest else "",
                "understood": None,
                "after_act": current.last_sys_act,
                "audio": audio,
            }
        )

    def _turn(self, current: _Open, message: DialogueAct) -> None:
        current.turn += 1
        if message.speaker == "usr":
            for answer in current.answers:
                if answer["understood"] is None and answer["text"] == message.text:
                    answer["understood"] = message.act
        else:
            current.repeats.append(message.act)
            current.last_sys_act = message.act
        t = message.stamp - current.start
        current.turns.append((current.turn, t, message.speaker, message.act, message.text))
        self._write_waiting(BUSY_WAIT)
        self._write(current)

    def _write(self, session: _Open, wait: float = BUSY_WAIT) -> bool:
        """Write what `session` buffered in one transaction (its row first, if not yet written;
        its closing, if closed); False, everything kept for the next try, if the database
        stayed busy for `wait` seconds."""
        new = session.id is None
        try:
            with self.store.transaction(timeout=wait) as db:
                if new:
                    session.id = self.store.new_session(
                        db, session.robot_starts, self.mode, self.keep_audio, session.started_at
                    )
                self._write_pending(db, session)
                if session.closing is not None:
                    self._write_closing(db, session)
        except BaseException as exc:
            if new:  # rolled back: the row is not there
                session.id = None
            if not isinstance(exc, DatabaseBusy):
                raise
            if session not in self.unwritten and session is not self.current:
                self.unwritten.append(session)
            log.warning("recording: %s; keeping the turn to write it with the next", exc)
            return False
        if new:
            self.sessions.append(session.id)
            log.info("recording session %d", session.id)
        self._written(session)
        if session.closing is not None:
            log.info("session %d %s (%s)", session.id, *session.closing)
            if session in self.unwritten:
                self.unwritten.remove(session)
        return True

    def _write_waiting(self, wait: float) -> None:
        """Write the closed sessions the database was too busy for, oldest first."""
        for session in list(self.unwritten):
            if not self._write(session, wait):
                return

    def _write_pending(self, db: Any, current: _Open) -> None:
        sid = current.id
        db.executemany(
            "INSERT INTO turns (session_id, seq, t, speaker, act, text) VALUES (?,?,?,?,?,?)",
            [(sid, *turn) for turn in current.turns],
        )
        db.executemany(
            "INSERT OR REPLACE INTO crops (session_id, reading, cell, t, image, read_as, "
            "confidence, cell_state) VALUES (?,?,?,?,?,?,?,?)",
            [(sid, *crop) for crop in current.crops],
        )
        db.executemany(
            "INSERT OR REPLACE INTO answers (session_id, seq, t, source, nbest, words, "
            "understood, after_act, audio) VALUES (?,?,?,?,?,?,?,?,?)",
            [
                (
                    sid,
                    a["seq"],
                    a["t"],
                    a["source"],
                    a["nbest"],
                    a["words"],
                    a["understood"],
                    a["after_act"],
                    a["audio"],
                )
                for a in current.answers
            ],
        )
        for act in current.repeats:  # the robot's next act says if it had to ask again
            db.execute(
                "UPDATE answers SET repeated = (? = ? OR ? = after_act) "
                "WHERE session_id = ? AND repeated IS NULL",
                (act, ASK_AGAIN, act, sid),
            )

    @staticmethod
    def _written(current: _Open) -> None:
        """Empty the buffers of what a committed transaction wrote."""
        current.turns, current.crops, current.repeats = [], [], []
        # answers stay until understood, then are rewritten once more (INSERT OR REPLACE)
        current.answers = [a for a in current.answers if a["understood"] is None]

    @staticmethod
    def _label_drawing(db: Any, session_id: int, cell: int, person: str) -> None:
        """Give the person's symbol to the crops of their `cell` that show its last ink, if
        that is a drawing (see the module docstring)."""
        rows = db.execute(
            "SELECT reading, image FROM crops WHERE session_id = ? AND cell = ? ORDER BY reading",
            (session_id, cell),
        ).fetchall()
        gray = cv2.IMREAD_GRAYSCALE
        crops = [cv2.imdecode(np.frombuffer(png, np.uint8), gray) for _, png in rows]
        if len(crops) < 2 or ink_change(crops[0], crops[-1]) < SOME_INK:
            return
        db.executemany(
            "UPDATE crops SET label = ? WHERE session_id = ? AND reading = ? AND cell = ?",
            [
                (person, session_id, reading, cell)
                for (reading, _), crop in zip(rows, crops, strict=True)
                if ink_change(crop, crops[-1]) < SAME_INK
            ],
        )

    def _close(self, current: _Open, status: str, outcome: str | None) -> None:
        """Close the session: write what is left, the outcome and final board, and the labels
        the game confirms (now, or with the next turn if the database is busy)."""
        current.closing = (status, outcome)
        self.current = None
        self._write(current)  # a busy database keeps it in `unwritten`

    def _write_closing(self, db: Any, current: _Open) -> None:
        """The outcome, final board and labels of a closed session (inside its transaction)."""
        assert current.closing is not None
        status, outcome = current.closing
        board = current.board
        person = symbol_of(USER, current.robot_starts)
        person_cells = [i for i, v in enumerate(board) if v == USER]
        empty_cells = [i for i, v in enumerate(board) if v == EMPTY] if status == "ended" else []
        db.executemany(
            "UPDATE crops SET label = ? WHERE session_id = ? AND cell = ? AND cell_state = ?",
            [("nothing", current.id, cell, EMPTY) for cell in empty_cells],
        )
        for cell in person_cells:
            self._label_drawing(db, current.id, cell, person)
        db.execute(
            "UPDATE sessions SET ended_at = ?, status = ?, outcome = ?, final_board = ? "
            "WHERE id = ?",
            (time.time(), status, outcome, ",".join(map(str, board)), current.id),
        )


def joining(
    store: RecordingStore | Callable[[], RecordingStore],
    mode: str = "",
    keep_audio: bool = False,
    enabled: bool = True,
) -> Callable[[Bus], Recorder]:
    """A Recorder for `Robot(..., joining=[...])`: it records every game into `store` (with the
    person's recorded answers if `keep_audio`; `mode` says where it was played); with `enabled`
    False, only once a RecordingSwitch message switches it on. The robot makes it on its own bus,
    so the robot needs to know nothing of recording."""
    return lambda bus: Recorder(bus, store, mode, keep_audio, enabled)
