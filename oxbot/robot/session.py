"""The whole robot: every component on one bus, and the ways a person reaches it.

    from oxbot.robot.session import Robot, RobotOptions
    with Robot(RobotOptions(robot_starts=True)) as robot:   # starts; the robot greets
        events = robot.bus.subscribe()                      # every message, in order
        robot.say("yes let's play")                         # typed words
        robot.hear(wav_bytes)                               # a push-to-talk recording
        robot.show(frame)                                   # the sheet, as a camera sees it
        robot.draw("middle")                                # a typed move (no camera)

The terminal (`oxbot play --terminal`), the web page (`oxbot play`) and the tests build the
same Robot; each browser tab has its own. Components that load models (the classifier, the
recogniser, the policy) share one copy per process.
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass

import numpy as np

from oxbot.dialogue.domain import words_of
from oxbot.errors import ConfigError, InvalidInputError
from oxbot.game.board import CELL_NAMES, USER, Board, cell_index, symbol_of
from oxbot.perception.sources import FrameSource
from oxbot.robot.arm import ArmComponent, ArmConfig
from oxbot.robot.bus import Bus, Component, start_all, stop_all
from oxbot.robot.game_moves import GameMoveComponent
from oxbot.robot.head_movement import HeadMovementComponent
from oxbot.robot.head_tracking import HeadTrackingComponent
from oxbot.robot.manager import InteractionManagerComponent, ManagerTiming
from oxbot.robot.messages import (
    DialogueEnded,
    GameMove,
    NewGame,
    SpeechAudio,
    SpeechHypotheses,
)
from oxbot.robot.voice import SpeechRecognitionComponent, SpeechSynthesisComponent
from oxbot.speech.audio import read_wav
from oxbot.speech.synthesis import Voice

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RobotOptions:
    """How one robot is put together."""

    robot_starts: bool = True
    """Who draws first (with circles); the paper's robot always started."""
    speed_factor: float = 1.0
    """How many times faster than real time speech, the arm and the waits run (tests)."""
    answer_timeout: float = 4.0
    """Seconds the robot waits for an optional answer (to a greeting) before taking silence."""
    question_timeout: float = 30.0
    """Seconds the robot waits for the answer to a question before taking silence."""
    move_timeout: float = 30.0
    """Seconds the robot waits for the person's drawing after "Your turn"."""
    voice: str = "en-us"
    """The espeak-ng voice of the robot."""
    seed: int | None = None
    """Seeds the robot's choice among templates and the arm's hand; None: fresh each time."""

    def __post_init__(self) -> None:
        if self.speed_factor <= 0:
            raise ConfigError(f"speed_factor must be positive; got {self.speed_factor}")


@functools.cache
def _shared_policy():
    from oxbot.dialogue.agent import load_policy

    return load_policy()


@functools.cache
def warm_up() -> None:
    """Load the shared models once (policy, classifier, recogniser: a few seconds), so that
    the first game does not wait for them mid-sentence."""
    from oxbot.errors import SpeechUnavailable
    from oxbot.perception.board import default_reader
    from oxbot.speech.recognition import default_recognizer

    _shared_policy()
    default_reader()
    try:
        default_recognizer()
    except SpeechUnavailable as exc:
        log.warning("speech recognition is off, type your answers instead: %s", exc)


class Robot:
    """One robot: its components running on their own bus (see the module docstring).

    `sheet_camera` / `head_camera` are frame sources the robot reads itself; without them it
    sees only what `show` / `look` hand over.
    """

    def __init__(
        self,
        options: RobotOptions = RobotOptions(),
        sheet_camera: FrameSource | None = None,
        head_camera: FrameSource | None = None,
    ) -> None:
        self.options = options
        self.bus = Bus()
        rng = np.random.default_rng(options.seed)
        seeds = rng.integers(2**32, size=2)
        self.manager = InteractionManagerComponent(
            self.bus,
            policy=_shared_policy(),
            timing=ManagerTiming(
                answer_timeout=options.answer_timeout,
                question_timeout=options.question_timeout,
                move_timeout=options.move_timeout,
                speed_factor=options.speed_factor,
            ),
            rng=np.random.default_rng(seeds[0]),
        )
        self.vision = GameMoveComponent(self.bus, options.robot_starts, source=sheet_camera)
        self.head_tracking = HeadTrackingComponent(self.bus, source=head_camera)
        self.voice = SpeechSynthesisComponent(
            self.bus, Voice(options.voice), speed_factor=options.speed_factor
        )
        self.components: list[Component] = [
            self.manager,
            self.vision,
            SpeechRecognitionComponent(self.bus),
            self.voice,
            ArmComponent(
                self.bus,
                ArmConfig(speed_factor=options.speed_factor),
                rng=np.random.default_rng(seeds[1]),
            ),
            self.head_tracking,
            HeadMovementComponent(self.bus),
        ]
        self._ended = False
        self._watch = self.bus.subscribe(DialogueEnded, NewGame)
        self._started = False

    # --- lifecycle ---

    def start(self) -> Robot:
        """Start every component and the first game: the robot begins to talk."""
        if not self._started:
            warm_up()
            start_all(self.components)
            self._started = True
            self.new_game()
        return self

    def stop(self) -> None:
        """Stop every component (a sentence or a drawing under way is cut off)."""
        stop_all(self.components)
        self._watch.close()
        self._started = False

    def __enter__(self) -> Robot:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def new_game(self, robot_starts: bool | None = None) -> None:
        """A clean sheet and a new dialogue."""
        starts = self.options.robot_starts if robot_starts is None else robot_starts
        self._ended = False
        self.bus.publish(NewGame(robot_starts=starts))

    # --- the person ---

    def say(self, text: str) -> None:
        """Typed words: heard with confidence 1."""
        if not isinstance(text, str) or not text.strip():
            raise InvalidInputError("say() needs some words; an empty answer is silence")
        words = tuple((w, 1.0) for w in words_of(text))
        self.bus.publish(SpeechHypotheses(nbest=((text, 1.0),), source="text", words=words))

    def hear(self, wav: bytes) -> None:
        """A push-to-talk recording (any WAV; resampled to 16 kHz mono) for the recogniser."""
        if not isinstance(wav, bytes):
            raise InvalidInputError(f"hear() takes the bytes of a WAV file, not {type(wav)}")
        read_wav(wav)  # a bad recording fails here, in the caller's thread, not the recogniser's
        self.bus.publish(SpeechAudio(audio=wav))

    def show(self, frame: np.ndarray) -> None:
        """The sheet as a camera sees it now (uint8 RGB or gray); read at 10 Hz."""
        self.vision.push(frame)

    def look(self, frame: np.ndarray) -> None:
        """A webcam frame of the person, for head tracking."""
        self.head_tracking.push(frame)

    def draw(self, where: str | int) -> None:
        """A move typed instead of drawn (no camera): the person's symbol in `where`."""
        cell = cell_index(where) if isinstance(where, str) else where
        if not isinstance(cell, int) or not 0 <= cell < 9:
            raise InvalidInputError(f"{where!r} is not a cell; cells are {', '.join(CELL_NAMES)}")
        symbol = symbol_of(USER, self.manager.robot_starts)
        self.bus.publish(GameMove(who="usr", what="draw", where=CELL_NAMES[cell], symbol=symbol))

    # --- state ---

    @property
    def board(self) -> Board:
        return self.manager.board

    @property
    def transcript(self) -> list[dict[str, str]]:
        return self.manager.transcript

    @property
    def finished(self) -> bool:
        """True once the robot has said goodbye in the current game."""
        for message in self._watch.drain():  # in order: a NewGame after a goodbye clears it
            self._ended = isinstance(message, DialogueEnded)
        return self._ended
