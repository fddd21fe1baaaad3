"""Game-move recognition as a component: frames of the sheet in, the person's moves out.

Paper §3.1: the arm camera's image is classified every 100 ms and a drawing is accepted once
seen 3 times in a row. Here the frame source (`oxbot.perception.sources`: a webcam, a video, an
image folder) or frames pushed by other code (the web page's canvas, Frame messages) feed
`BoardReader` and `MoveTracker` at the tracker's period. A pushed frame stays the current view
of the sheet until the next one arrives, as a camera would keep seeing it, and is read again
at every tick; its labels are computed once, since the same image always reads the same.

Publishes: BoardSeen for every reading that differs from the previous one (labels, crops, the
tracker's count, where the grid is), GameMove for each accepted drawing, BoardProblem for
impossible ones. A frame without a readable board (a camera's) is diagnosed
(`oxbot.perception.guidance`: too dark, blurred, a hand in the way, the sheet out of the
picture): BoardSeen's `refusal` says what to do at once, and once the board has stayed
unreadable for `guidance_seconds` a BoardProblem of the guidance's kind says it again, once
per kind every GUIDANCE_REPEAT_SECONDS until the board is read again, for the robot to say out
loud. Listens
to ArmCommand, because the tracker must know the robot's own drawings before they appear, to
GameState, for the person's moves the interaction manager took without a drawing (typed, or said
in words: the sheet may show them later, or never), and to NewGame, which starts a clean sheet.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import os
import threading

import cv2
import numpy as np

from oxbot.config import PerceptionConfig, TrackerConfig
from oxbot.dialogue.domain import GREETING, starts_game
from oxbot.errors import FrameSourceError, NoGridFound
from oxbot.game.board import CELL_NAMES, EMPTY, EMPTY_BOARD, SIZE, USER, Board
from oxbot.perception.board import BoardReader, BoardReading, default_reader
from oxbot.perception.cells import CELL_SIZE, SHEET_CELL
from oxbot.perception.classifier import CellReading, ink_share
from oxbot.perception.guidance import Guidance, diagnose
from oxbot.perception.sources import FrameSource
from oxbot.perception.tracker import AcceptedDrawing, ImpossibleEvent, MoveTracker
from oxbot.robot.bus import Bus, Component
from oxbot.robot.frames import check_frame, frame_pixels
from oxbot.robot.messages import (
    ArmCommand,
    BoardProblem,
    BoardSeen,
    ComponentJoined,
    DialogueAct,
    Frame,
    GameMove,
    GameState,
    Message,
    NewGame,
    SheetMode,
    SourceEnded,
)

log = logging.getLogger(__name__)


def encode_cells(cells: np.ndarray) -> tuple[bytes, ...]:
    """The classifier's 40x40 crops as PNGs, for a page to show."""
    return tuple(cv2.imencode(".png", cell)[1].tobytes() for cell in cells)


GUIDANCE_REPEAT_SECONDS = 10.0
"""oxbot: a board still unreadable for the same reason is told again after this long (the
robot may have been talking, or the person not listening, the first time)."""

Read = tuple[BoardReading | None, tuple[bytes, ...], Guidance | None, tuple[float, ...]]
"""One frame's reading, crops, guidance (None: the board was read) and grid (BoardSeen.grid)."""


def still_readings(reading: BoardReading) -> tuple[CellReading, ...]:
    """The cells' readings with each cell's ink measured in the cell's fixed square of the
    rectified sheet, for the tracker's check that the pen has stopped.

    The classifier's crops are cut around the ink (`cut_cells_around_ink`), so their ink share
    hardly grows once an arc spans its circle's width: a camera watching a circle drawn slowly
    saw three agreeing readings at 75% of the stroke. In the cell's fixed square the ink grows
    with every bit of stroke."""
    if not reading.readings:
        return ()
    border, side = SHEET_CELL // 2, SHEET_CELL
    squares = np.stack(
        [
            cv2.resize(
                reading.cleaned[border + r * side : border + (r + 1) * side][
                    :, border + c * side : border + (c + 1) * side
                ],
                (CELL_SIZE, CELL_SIZE),
                interpolation=cv2.INTER_AREA,
            )
            for r in range(SIZE)
            for c in range(SIZE)
        ]
    )
    ink = ink_share(squares)
    return tuple(dataclasses.replace(r, ink=float(ink[i])) for i, r in enumerate(reading.readings))


def grid_shares(reading: BoardReading, frame: np.ndarray) -> tuple[float, ...]:
    """The grid's 4x4 lattice as 32 numbers, x, y pairs row by row, in shares of the frame's
    width and height (BoardSeen.grid)."""
    height, width = frame.shape[:2]
    shares = reading.grid.lattice.reshape(-1, 2) / np.array([width, height])
    return tuple(round(float(v), 4) for v in shares.ravel())


def game_started(act: str, before: bool) -> bool:
    """Whether the game is on after the robot says `act`: from its greeting (a new dialogue)
    until it says "let's play", draws, or asks for the person's move."""
    if act == GREETING:
        return False
    return before or starts_game(act)


def move_message(drawing: AcceptedDrawing) -> GameMove:
    """The bus message for a drawing the tracker accepted (the one place the two meet)."""
    return GameMove(who=drawing.who, what=drawing.what, where=drawing.where, symbol=drawing.symbol)


READING_SLOTS = threading.BoundedSemaphore(
    len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
)
"""Frames read at once in this process, by every robot's eyes together: one per core it may
use."""


class GameMoveComponent(Component):
    """Reads the sheet every `config.period_s` seconds and publishes the person's moves.

    With a `source` the component reads it at every tick (a source that cannot be opened or
    that ends turns the component off with one warning). Without one it reads the last frame
    handed over by `push(frame)` or a Frame message.
    """

    listens_to = (
        Frame,
        ArmCommand,
        NewGame,
        DialogueAct,
        GameState,
        SheetMode,
        ComponentJoined,
    )
    # the tracker must know the robot's drawings, the person's moves made in words, whether
    # the game is on, whether a camera shows the sheet and when a manager rejoins; not frames
    retries = (ArmCommand, NewGame, DialogueAct, GameState, SheetMode, ComponentJoined)
    part = "eyes"

    def __init__(
        self,
        bus: Bus,
        robot_starts: bool = True,
        source: FrameSource | None = None,
        reader: BoardReader | None = None,
        config: TrackerConfig | None = None,
        name: str | None = None,
        perception: PerceptionConfig | None = None,
    ) -> None:
        self.config = config if config is not None else TrackerConfig()
        self.perception = perception
        """The `[perception]` settings of the default reader (its wholeness check)."""
        self.period = self.config.period_s
        super().__init__(bus, name)
        self.reader = reader
        self.source = source
        self.tracker = MoveTracker(robot_starts, self.config)
        self.manager_board: Board = EMPTY_BOARD
        """The board as the manager last announced it (GameState)."""
        self._talking = False  # a dialogue manager speaks on this bus (its acts start games)
        self._lock = threading.Lock()
        self._latest: np.ndarray | None = None
        self._version = 0  # counts pushed frames, so a frame is read only once
        # a camera's frames (SheetMode paper) keep coming: one read twice is no second reading
        # (a half-drawn circle seen thrice in one slow frame was taken as drawn); a drawn
        # sheet's frame is the view until the pen lifts again, and is read at every tick
        self._camera = False
        self._last_version = -1
        self._cached: tuple[int, Read] | None = None
        self._last_seen: tuple | None = None
        self._off = False
        # where the grid was last seen (shares), and in frames of which shape: another source
        # (the page's camera after its canvas) has another picture
        self._corners: tuple[np.ndarray, tuple[int, ...]] | None = None
        self._refused = 0  # readings in a row without a board
        self._told: dict[str, float] = {}  # guidance kind -> when told, in refused seconds

    @property
    def off(self) -> bool:
        """True once the frame source failed or ended: moves must come another way."""
        return self._off

    def push(self, frame: np.ndarray) -> None:
        """Hand over the current view of the sheet: uint8 (H, W, 3) RGB or (H, W) gray (a
        Frame message on the bus does the same)."""
        frame = check_frame(frame).copy()
        with self._lock:
            self._latest = frame
            self._version += 1

    def handle(self, message: Message) -> None:
        if isinstance(message, Frame):
            self.push(frame_pixels(message))
        elif isinstance(message, ArmCommand):
            self.tracker.robot_draws(message.where)
        elif isinstance(message, ComponentJoined):
            if message.part == "mind":
                self._hand_over_moves()
        elif isinstance(message, GameState):
            self.manager_board = message.board
            # the moves the manager took: typed or said in words too (its own drawings it knew)
            for cell, mark in enumerate(message.board):
                if mark == USER:
                    self.tracker.person_drew(cell)
        elif isinstance(message, DialogueAct):
            if message.speaker == "sys":  # a robot that talks: its game starts when it says so
                self._talking = True
                self.tracker.playing = game_started(message.act, self.tracker.playing)
        elif isinstance(message, SheetMode):
            self._camera = message.paper
        elif isinstance(message, NewGame):
            with self._lock:
                self._latest = None
                self._cached = None
            self.tracker = MoveTracker(message.robot_starts, self.config)
            self.manager_board = EMPTY_BOARD
            self.tracker.playing = not self._talking  # without a dialogue, drawings are moves
            self._last_seen = None
            self._refused, self._told = 0, {}

    def _hand_over_moves(self) -> None:
        """A respawned manager process never got the moves accepted while its predecessor was
        dead: each one the tracker holds and the manager's board lacks is published again."""
        tracker = self.tracker
        for cell, label in enumerate(tracker.board):
            if label == tracker.user_symbol and self.manager_board[cell] == EMPTY:
                log.info("handing %s again to the manager that rejoined", CELL_NAMES[cell])
                self.bus.publish(
                    GameMove(who="usr", what="draw", where=CELL_NAMES[cell], symbol=label)
                )

    def tick(self) -> None:
        current = self._next_frame()
        if current is None:
            return
        frame, version = current
        if self._camera and version >= 0 and version == self._last_version:
            return  # the camera's next frame has not come yet
        read = self._read(frame, version)
        if read is None:
            return  # the machine is busy reading other sheets: this frame next tick
        self._last_version = version
        reading, cells, guidance, grid = read
        refusal = guidance.text if guidance is not None else ""
        if reading is None:
            event = self.tracker.update(None)
        else:  # the cells' readings: a new symbol must be whole, confident and still
            event = self.tracker.update(reading.labels, still_readings(reading) or None)
        accepted = isinstance(event, AcceptedDrawing)
        labels = reading.labels if reading is not None else ()
        readings = (
            tuple(self.tracker.taken_as(r) for r in reading.readings) if reading is not None else ()
        )
        agreeing = self.config.stable_readings if accepted else self.tracker.agreeing
        # the grid to a hundredth of the frame: a hand-held camera's jitter is no news
        seen = (labels, agreeing, readings, refusal, tuple(round(v, 2) for v in grid))
        if seen != self._last_seen:
            self._last_seen = seen
            confidences = tuple(round(r.confidence, 3) for r in reading.readings) if reading else ()
            self.bus.publish(
                BoardSeen(
                    labels=labels,
                    agreeing=agreeing,
                    cells=cells,
                    readings=readings,
                    confidences=confidences,
                    refusal=refusal,
                    grid=grid,
                )
            )
        self._guide(guidance, frame, grid)
        if accepted:
            log.info("accepted %s", event)
            self.bus.publish(move_message(event))
        elif isinstance(event, ImpossibleEvent):
            log.info("impossible: %s", event)
            where = tuple(CELL_NAMES[c] for c in event.cells)
            self.bus.publish(BoardProblem(reason=event.message, kind=event.kind, cells=where))

    def _guide(self, guidance: Guidance | None, frame: np.ndarray, grid: tuple) -> None:
        """Count the readings without a board; say why once they last `guidance_seconds`."""
        if guidance is None:
            self._refused, self._told = 0, {}
            corners = np.array(grid).reshape(4, 4, 2)[[0, 0, 3, 3], [0, 3, 3, 0]]
            self._corners = (corners, frame.shape[:2])
            return
        self._refused += 1
        if self._refused * self.period < self.config.guidance_seconds:
            return
        refused = self._refused * self.period
        # told again now and then: the robot may have been talking the first time
        due = refused - self._told.get(guidance.kind, -GUIDANCE_REPEAT_SECONDS)
        if due >= GUIDANCE_REPEAT_SECONDS:
            self._told[guidance.kind] = refused
            log.info("cannot see the board: %s", guidance.text)
            self.bus.publish(BoardProblem(reason=guidance.text, kind=guidance.kind))

    def restart(self) -> None:
        with self._lock:
            self._cached = None

    def take_over(self, old: Component) -> None:
        assert isinstance(old, GameMoveComponent)
        # the game so far: what the tracker knows of the sheet, the last view of it
        self.tracker = copy.deepcopy(old.tracker)
        self.reader, self._off, self._last_seen = old.reader, old._off, old._last_seen
        self._talking = old._talking
        self._corners, self._refused, self._told = old._corners, old._refused, dict(old._told)
        with old._lock:
            self._latest, self._version = old._latest, old._version

    def stop(self, timeout: float = 2.0) -> None:
        super().stop(timeout)
        if self.source is not None:
            self.source.close()

    def _next_frame(self) -> tuple[np.ndarray, int] | None:
        """The frame to read now and its version (-1: from a source, never cached)."""
        if self.source is None:
            with self._lock:
                return None if self._latest is None else (self._latest, self._version)
        if self._off:
            return None
        try:
            self.source.open()
            frame = self.source.read()
        except FrameSourceError as exc:
            self._turn_off(f"{exc}")
            log.warning("game-move recognition is off: %s; type your moves instead", exc)
            return None
        if frame is None:
            self._turn_off(f"{self.source.name} has no more frames")
            log.info("%s has no more frames", self.source.name)
            return None
        return frame, -1

    def _turn_off(self, reason: str) -> None:
        self._off = True
        self.bus.publish(SourceEnded(component=self.name, reason=reason))

    def _read(self, frame: np.ndarray, version: int) -> Read | None:
        """The frame's reading (None: no board), crops, why no board could be read (None
        when one was) and where the grid is; a pushed frame is read only once. None when
        every core is already reading a frame (of this robot or another)."""
        cached = self._cached
        if cached is not None and cached[0] == version:
            return cached[1]
        if self.reader is None:
            self.reader = default_reader(self.perception)
        # twenty robots reading at once on two cores all took seconds per frame, past the
        # watchdog's deadline; a frame that waits for a free core is read a tick later
        if not READING_SLOTS.acquire(blocking=False):
            return None
        read: Read
        try:
            reading = self.reader.read(frame)
            read = (reading, encode_cells(reading.cells), None, grid_shares(reading, frame))
        except NoGridFound as exc:
            last = self._corners
            corners = last[0] if last is not None and last[1] == frame.shape[:2] else None
            read = (None, (), diagnose(frame, str(exc), corners), ())
        finally:
            READING_SLOTS.release()
        if version >= 0:
            self._cached = (version, read)
        return read
