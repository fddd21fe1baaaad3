"""Faults injected into the robot's components mid-game, for the supervision tests and bench.

A `Fault` breaks one method of one component class (`TARGETS`) once the game is under way: the
method raises once, raises at every call, or hangs once until released. The class's own code
runs otherwise (the real classifier, recogniser, voice and policy), and a fresh copy the
supervisor builds is broken the same way, as a bug in the code would be. `play` has a scripted
person play a typed game against the robot meanwhile and times what follows the fault.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Literal

from oxbot.dialogue.domain import ASK_AGAIN, INVITATION, MOVE_REQUEST, is_game_move
from oxbot.game.board import EMPTY
from oxbot.robot.arm import ArmComponent
from oxbot.robot.bus import Component
from oxbot.robot.game_moves import GameMoveComponent
from oxbot.robot.head_movement import HeadMovementComponent
from oxbot.robot.head_tracking import HeadTrackingComponent
from oxbot.robot.manager import InteractionManagerComponent
from oxbot.robot.messages import (
    ArmCommand,
    ComponentFailed,
    ComponentLost,
    DialogueAct,
    DialogueEnded,
    HeadDirection,
    Message,
    SpeechAudio,
    Utterance,
)
from oxbot.robot.session import Robot
from oxbot.robot.voice import SpeechRecognitionComponent, SpeechSynthesisComponent

Mode = Literal["raises once", "raises always", "hangs", "hangs always"]
MODES: tuple[Mode, ...] = ("raises once", "raises always", "hangs")
"""The faults every component is tested with ("hangs always" is for the bench)."""
HANG_SECONDS = 30.0
"""How long a hung call sleeps unless released first."""


@dataclass(frozen=True)
class Target:
    """Where a fault goes: `cls.method`, when it handles a `message` (None: any, or a tick)."""

    cls: type[Component]
    method: Literal["handle", "tick"]
    message: type[Message] | None = None
    from_start: bool = False
    """Broken from the first call (the person speaks only before the game starts)."""


TARGETS: dict[str, Target] = {
    "manager": Target(InteractionManagerComponent, "handle"),
    "game moves": Target(GameMoveComponent, "handle", ArmCommand),
    "recognition": Target(SpeechRecognitionComponent, "handle", SpeechAudio, from_start=True),
    "synthesis": Target(SpeechSynthesisComponent, "handle", Utterance),
    "arm": Target(ArmComponent, "handle", ArmCommand),
    "head tracking": Target(HeadTrackingComponent, "tick"),
    "head movement": Target(HeadMovementComponent, "handle", HeadDirection),
}


class Fault:
    """One fault: armed when the game is under way, fired at the target's next call."""

    def __init__(self, mode: Mode) -> None:
        self.mode = mode
        self.armed = threading.Event()
        self.release = threading.Event()
        """Set to end a hung call (it then returns without doing anything)."""
        self.fired: list[float] = []
        """When each failing call began (time.monotonic)."""
        self._lock = threading.Lock()

    def fires(self) -> bool:
        """Whether this call fails (and then it is counted)."""
        with self._lock:
            if not self.armed.is_set() or (self.fired and not self.mode.endswith("always")):
                return False
            self.fired.append(time.monotonic())
            return True

    def wrap(self, original: Callable, message: type[Message] | None) -> Callable:
        fault = self

        @functools.wraps(original)
        def broken(component: Component, *args: object) -> None:
            if (message is None or isinstance(args[0], message)) and fault.fires():
                if fault.mode.startswith("hangs"):
                    fault.release.wait(HANG_SECONDS)
                    return
                # stands for a bug in the component, so deliberately not an OxbotError
                raise RuntimeError(f"injected fault in {type(component).__name__}")
            original(component, *args)

        return broken


@contextlib.contextmanager
def injected(target: Target, fault: Fault) -> Iterator[Fault]:
    """`target.cls.method` broken by `fault` inside the block; the hung calls released after."""
    cls, name = target.cls, target.method
    own = name in vars(cls)
    original = getattr(cls, name)
    setattr(cls, name, fault.wrap(original, target.message))
    if target.from_start:
        fault.armed.set()
    try:
        yield fault
    finally:
        if own:
            setattr(cls, name, original)
        else:
            delattr(cls, name)
        fault.release.set()


@dataclass
class FaultRun:
    """What followed a fault: times in seconds from the first failing call."""

    next_turn: float | None
    """To the robot's next turn (a sentence in the transcript)."""
    ended: float | None
    """To the goodbye (DialogueEnded)."""
    outcome: str | None
    last_words: str
    log: list[Message] = field(default_factory=list)

    def of(self, kind: type[Message]) -> list[Message]:
        return [m for m in self.log if isinstance(m, kind)]


def play(
    robot: Robot,
    fault: Fault,
    voice: bytes | None = None,
    bursts: int = 1,
    seconds: float = 20.0,
) -> FaultRun:
    """A person plays a started robot to the goodbye while `fault` strikes; what followed.

    The person agrees to play (by `voice`, a recording sent `bursts` times, until the robot's
    hearing fails; then by typing), draws typed moves in the first free cell of a preference,
    and turns their head at every sentence of the robot's. The fault is armed at the robot's
    first "your turn". AssertionError if the goodbye does not come within `seconds`.
    """
    events = robot.bus.subscribe()
    prefer = (4, 0, 2, 6, 8, 1, 3, 5, 7)
    heads = itertools.cycle(("left", "right"))
    hearing_failed, playing = False, False
    log: list[Message] = []
    deadline = time.monotonic() + seconds
    try:
        while time.monotonic() < deadline:
            message = events.get(0.05)
            if message is None:
                continue
            log.append(message)
            if isinstance(message, DialogueEnded):
                break
            if isinstance(message, ComponentFailed | ComponentLost):
                hearing_failed |= message.component == SpeechRecognitionComponent.__name__
            if not isinstance(message, DialogueAct) or message.speaker != "sys":
                continue
            robot.bus.publish(HeadDirection(direction=next(heads)))
            playing |= message.act == MOVE_REQUEST or is_game_move(message.act)
            if message.act in (INVITATION, ASK_AGAIN) and not playing:
                if voice is not None and not hearing_failed:
                    for _ in range(bursts):
                        robot.hear(voice)
                else:
                    robot.say("Yes, let's play.")
            elif message.act == MOVE_REQUEST:
                fault.armed.set()
                board = robot.board
                free = [c for c in prefer if board[c] == EMPTY]
                if free:
                    robot.draw(free[0])
        else:
            raise AssertionError(f"no goodbye within {seconds} s: {robot.transcript}")
    finally:
        events.close()
    start = fault.fired[0] if fault.fired else None
    turns = [m for m in log if isinstance(m, DialogueAct) and m.speaker == "sys"]
    after = [m.stamp for m in turns if start is not None and m.stamp > start]
    ended = log[-1]
    assert isinstance(ended, DialogueEnded)
    return FaultRun(
        next_turn=after[0] - start if after and start is not None else None,
        ended=ended.stamp - start if start is not None else None,
        outcome=ended.outcome,
        last_words=turns[-1].text if turns else "",
        log=log,
    )
