"""A scripted person playing one whole game with a headless robot that records.

The person answers the robot's invitation by typing, and when asked for a move draws their
symbol with a `hand` on the page's sheet (`oxbot.testing.sheet.Sheet`), which a "camera"
shows the robot 10 times a second, as the page sends its canvas; the real board reader and
tracker read it. A drawing the robot has not accepted after `type_after` seconds is typed
instead (as a person would, seeing that the robot does not see it), so that the game goes on
and the finished game can label what the robot misread.

    with RecordingStore(folder) as store:
        log = play_recorded_game(store, seed=1, hand=plus_strokes, robot_starts=True)
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from oxbot.config import OxbotConfig, load_config, with_overrides
from oxbot.dialogue.domain import ASK_AGAIN, INVITATION, MOVE_REQUEST
from oxbot.game.board import CELL_NAMES, EMPTY, USER, symbol_of
from oxbot.recording.recorder import Recorder, joining
from oxbot.recording.store import RecordingStore
from oxbot.robot.messages import DialogueAct, DialogueEnded, GameMove
from oxbot.robot.session import Robot
from oxbot.testing.sheet import Sheet, person_strokes

Hand = Callable[[str, np.random.Generator], list[np.ndarray]]

FAST = ("robot.speed_factor=8", "robot.answer_timeout=4", "robot.move_timeout=120")
"""Speech, arm and waits 8x faster than real time; a long wait for drawings."""


@dataclass
class RecordedGame:
    """What the scripted person saw of one game."""

    session: int | None = None
    outcome: str | None = None
    ended: bool = False
    drawn: list[int] = field(default_factory=list)
    """The cells the person drew in."""
    typed: list[int] = field(default_factory=list)
    """The drawings the robot did not accept in time, typed instead."""
    turns: int = 0


def play_recorded_game(
    store: RecordingStore,
    seed: int = 0,
    hand: Hand = person_strokes,
    robot_starts: bool = True,
    config: OxbotConfig | None = None,
    type_after: float = 3.0,
    timeout: float = 150.0,
    on_turn: Callable[[int], None] | None = None,
) -> RecordedGame:
    """Play one game with a robot recording into `store`; what happened.

    `on_turn` is called with the number of turns so far after each one (the kill test uses it).
    """
    config = config if config is not None else load_config(None, list(FAST))
    config = with_overrides(config, {"game": {"robot_starts": robot_starts}})
    rng = np.random.default_rng(seed)
    sheet = Sheet(seed)
    person = symbol_of(USER, robot_starts)
    record = RecordedGame()
    with Robot(config, seed=seed, joining=[joining(store, "scripted")]) as robot:
        events = robot.bus.subscribe(DialogueAct, GameMove, DialogueEnded)
        pending: tuple[int, float] | None = None  # a drawing not yet accepted, since when
        deadline = time.monotonic() + timeout
        next_frame = 0.0
        while time.monotonic() < deadline:
            now = time.monotonic()
            if now >= next_frame:
                robot.show(sheet.image)
                next_frame = now + 0.1
            if pending is not None and now - pending[1] > type_after:
                robot.draw(pending[0])  # not seen in time: typed instead
                record.typed.append(pending[0])
                pending = None
            message = events.get(0.02)
            if message is None:
                continue
            if isinstance(message, DialogueEnded):
                record.ended, record.outcome = True, message.outcome
                break
            if isinstance(message, GameMove) and message.who == "usr":
                if pending is not None and CELL_NAMES[pending[0]] == message.where:
                    pending = None
                continue
            if not isinstance(message, DialogueAct):
                continue
            record.turns += 1
            if on_turn is not None:
                on_turn(record.turns)
            if message.speaker != "sys":
                continue
            if message.act in (INVITATION, ASK_AGAIN):
                robot.say("yes let's play")
            elif message.act == MOVE_REQUEST and pending is None:
                board = robot.board
                empty = [c for c in range(9) if board[c] == EMPTY]
                if empty:
                    cell = int(rng.choice(empty))
                    sheet.draw_strokes(cell, hand(person, rng))
                    record.drawn.append(cell)
                    pending = (cell, time.monotonic())
        recorder = next(c for c in robot.components if isinstance(c, Recorder))
        if record.ended:  # the recorder hears the goodbye a moment after the person does
            wait_until = time.monotonic() + 10
            while recorder.current is not None and time.monotonic() < wait_until:
                time.sleep(0.02)
    record.session = recorder.sessions[-1] if recorder.sessions else None
    return record
