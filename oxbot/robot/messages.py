"""The messages the robot's components exchange, one typed dataclass per topic.

In the spirit of ROS topics: each message type names its topic, carries plain data, and turns
into JSON and back (`to_json` / `from_json`), with audio and images as base64 bytes beside
their format. A networked transport can therefore replace the in-process bus without touching
any component.
"""

from __future__ import annotations

import base64
import binascii
import dataclasses
import json
import time
import typing
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

from oxbot.errors import InvalidInputError
from oxbot.game.board import Ending

Direction = Literal["left", "right", "up", "down", "centre"]
Speaker = Literal["sys", "usr"]


@dataclass(frozen=True)
class Message:
    """Base of every message: its topic and the time it was made."""

    topic: ClassVar[str] = ""
    stamp: float = field(default_factory=time.monotonic, kw_only=True)


@dataclass(frozen=True)
class NewGame(Message):
    """Start again: a clean sheet and a new dialogue."""

    topic: ClassVar[str] = "game/new"
    robot_starts: bool = True
    carried: tuple[tuple[str, str, str], ...] = ()
    """(speaker, act, text) turns of the visit's conversation that the new dialogue takes up
    without saying them again: the robot's greeting and introduction, and, when the person
    agreed to this game in words, the question and their yes."""


@dataclass(frozen=True)
class PersonAnswering(Message):
    """The person has begun to answer: speech starting in the hands-free stream, push-to-talk
    pressed, a key in the answer box. The robot then waits for their answer (`answer_timeout`)
    rather than going on after a pause (`pause_timeout`)."""

    topic: ClassVar[str] = "person/answering"
    how: Literal["speaking", "typing"] = "speaking"


@dataclass(frozen=True)
class SpeechAudio(Message):
    """A push-to-talk recording to recognise."""

    topic: ClassVar[str] = "speech/audio"
    audio: bytes
    format: Literal["wav"] = "wav"


@dataclass(frozen=True)
class SpeechHypotheses(Message):
    """What the person said: an N-best list of (text, confidence), best first."""

    topic: ClassVar[str] = "speech/hypotheses"
    nbest: tuple[tuple[str, float], ...]
    source: Literal["microphone", "text"] = "microphone"
    words: tuple[tuple[str, float], ...] = ()
    """The best hypothesis word by word with each word's confidence (typed text: 1 each)."""
    keywords: tuple[float, ...] = ()
    """The keyword model's P(yes), P(no), P(other) of a short answer (`oxbot.speech.keywords`),
    empty when it was not asked; the manager uses it only for the answer to a yes/no question."""


@dataclass(frozen=True)
class Frame(Message):
    """An image of the game sheet (camera frame or the web page's canvas).

    `raw` is uint8 pixels row by row, `shape` (H, W, 3) RGB or (H, W) gray; `png` and `jpeg`
    carry their own size."""

    topic: ClassVar[str] = "vision/frame"
    image: bytes
    format: Literal["png", "jpeg", "raw"] = "png"
    shape: tuple[int, ...] = ()


@dataclass(frozen=True)
class PersonFrame(Message):
    """A webcam image of the person, for head tracking (the fields are Frame's)."""

    topic: ClassVar[str] = "vision/person_frame"
    image: bytes
    format: Literal["png", "jpeg", "raw"] = "png"
    shape: tuple[int, ...] = ()


@dataclass(frozen=True)
class SheetMode(Message):
    """Where the game's sheet is: on the page's canvas, or real paper under a camera (issue
    17). On paper the robot has no arm to draw with, so it says where it plays."""

    topic: ClassVar[str] = "game/sheet"
    paper: bool


@dataclass(frozen=True)
class SourceEnded(Message):
    """A component's camera failed or ran out of frames: what it saw must come another way."""

    topic: ClassVar[str] = "vision/source_ended"
    component: str
    reason: str


@dataclass(frozen=True)
class GameMove(Message):
    """A drawing the tracker accepted: [who=usr what=draw where=middle]."""

    topic: ClassVar[str] = "vision/game_move"
    who: Literal["usr", "rob"]
    what: Literal["draw"]
    where: str
    symbol: Literal["circle", "cross"]


@dataclass(frozen=True)
class BoardSeen(Message):
    """One reading of the sheet, for a "what the robot sees" panel.

    `labels` is empty when no grid was found. `cells` are the 9 crops the classifier saw, as
    40x40 PNGs; `agreeing` says how many readings in a row showed the same new drawing(s)
    (the tracker accepts at 3).
    """

    topic: ClassVar[str] = "vision/board"
    labels: tuple[str, ...]
    agreeing: int = 0
    cells: tuple[bytes, ...] = ()
    format: Literal["png"] = "png"
    readings: tuple[str, ...] = ()
    """Each cell's reading among circle, cross, nothing and partial (ink that is not a whole
    symbol, or a symbol read with less than `[tracker] min_confidence`, which cannot become a
    move); empty when no grid was found."""
    confidences: tuple[float, ...] = ()
    """The classifier's calibrated confidence in each of `readings`."""
    refusal: str = ""
    """Why no grid was found, in words saying what to do; empty when one was."""
    grid: tuple[float, ...] = ()
    """Where the grid was found: its 4x4 lattice of cell corners, row by row, as x, y pairs
    (32 numbers) in shares of the frame's width and height; empty when no grid was found. A
    page draws the grid and the robot's own symbols over its camera's video with it."""


@dataclass(frozen=True)
class BoardProblem(Message):
    """Something impossible seen on the sheet (two new symbols, an occupied cell, ...)."""

    topic: ClassVar[str] = "vision/problem"
    reason: str
    kind: str = ""
    """What went wrong, for code: the tracker's `ImpossibleKind` or the manager's own."""
    cells: tuple[str, ...] = ()
    """The cells involved, by name (`CELL_NAMES`), when the tracker knows them."""


@dataclass(frozen=True)
class HeadDirection(Message):
    """Where the person's head points, from their own point of view."""

    topic: ClassVar[str] = "vision/head"
    direction: Direction


@dataclass(frozen=True)
class HeadMove(Message):
    """Where the robot turns its head (mirroring the person)."""

    topic: ClassVar[str] = "robot/head"
    direction: Direction


@dataclass(frozen=True)
class Utterance(Message):
    """Words for the robot to speak, with the dialogue act they verbalise."""

    topic: ClassVar[str] = "speech/say"
    text: str
    act: str


@dataclass(frozen=True)
class SpeakingStarted(Message):
    """The robot's speech audio starts now; `audio` is the WAV of its first sentence (of all of
    `text` with espeak-ng), for a page to play; more sentences follow as SpeakingContinued.
    `visemes` are the mouth's shapes, (start seconds into `audio`, viseme) each
    (`oxbot.speech.visemes`); none with espeak-ng, whose mouth follows the loudness."""

    topic: ClassVar[str] = "speech/started"
    text: str
    audio: bytes = b""
    format: Literal["wav"] = "wav"
    seconds: float = 0.0
    visemes: tuple[tuple[float, str], ...] = ()


@dataclass(frozen=True)
class SpeakingContinued(Message):
    """The next sentence of the utterance `text`, to play as soon as the one before ends (it is
    sent when it is ready, usually while the one before plays)."""

    topic: ClassVar[str] = "speech/continued"
    text: str
    audio: bytes = b""
    format: Literal["wav"] = "wav"
    seconds: float = 0.0
    visemes: tuple[tuple[float, str], ...] = ()


@dataclass(frozen=True)
class SpeakingFinished(Message):
    """The robot has finished saying `text`."""

    topic: ClassVar[str] = "speech/finished"
    text: str


@dataclass(frozen=True)
class StopSpeaking(Message):
    """The person talks over the robot (barge-in, `oxbot.robot.listening`): stop saying `text`
    now, its audio in every player too; SpeakingFinished follows at once."""

    topic: ClassVar[str] = "speech/stop"
    text: str


@dataclass(frozen=True)
class ArmCommand(Message):
    """Draw the robot's symbol in a cell."""

    topic: ClassVar[str] = "arm/command"
    where: str
    symbol: Literal["circle", "cross"]


@dataclass(frozen=True)
class ArmStroke(Message):
    """One stroke the arm has drawn: points in the cell's unit square, (0,0) upper left."""

    topic: ClassVar[str] = "arm/stroke"
    where: str
    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class ArmDone(Message):
    """The arm finished drawing and is back at rest."""

    topic: ClassVar[str] = "arm/done"
    where: str


@dataclass(frozen=True)
class DialogueAct(Message):
    """A turn of the conversation, for the log: who, which act, which words."""

    topic: ClassVar[str] = "dialogue/act"
    speaker: Speaker
    act: str
    text: str


@dataclass(frozen=True)
class Decision(Message):
    """The interaction manager's choice: the acts it was offered, their Q-values, the act."""

    topic: ClassVar[str] = "dialogue/decision"
    offered: tuple[str, ...]
    q_values: tuple[float, ...]
    """Q(s, a) for every act (a baseline manager's scores), in `oxbot.dialogue.domain.SYSTEM_ACTS`
    order."""
    chosen: str


@dataclass(frozen=True)
class GameState(Message):
    """The game as the interaction manager knows it: when a game starts (the empty board, so
    every turn published after it belongs to that game) and after every move."""

    topic: ClassVar[str] = "game/state"
    board: tuple[int, ...]
    """One int per cell, row-major from the upper left: 0 empty, 1 the robot's, 2 the person's."""
    robot_starts: bool


@dataclass(frozen=True)
class DialogueEnded(Message):
    """The robot said goodbye; `outcome` is the game's result from its side, if it finished,
    else "declined" (the person said no and never yes) or "stopped" (they asked to stop), as
    the robot understood them; None for a dialogue that ended otherwise."""

    topic: ClassVar[str] = "dialogue/ended"
    outcome: Ending | None


@dataclass(frozen=True)
class ComponentFailed(Message):
    """A component raised or hung; the runtime restarts it (after a wait) and carries on."""

    topic: ClassVar[str] = "robot/failure"
    component: str
    error: str


@dataclass(frozen=True)
class ComponentLost(Message):
    """A component failed or hung more often than its restart budget allows and stays off; if
    the game needs it (`essential`), the robot says so and ends the game."""

    topic: ClassVar[str] = "robot/lost"
    component: str
    part: str
    """What the component is to the robot, in words: "voice", "arm", "hearing"."""
    error: str
    essential: bool


@dataclass(frozen=True)
class ComponentJoined(Message):
    """A component's process joined the robot again after its predecessor's ended (across
    processes, oxbot.robot.zenoh_bus): what it was asked and never answered must be asked again."""

    topic: ClassVar[str] = "robot/joined"
    component: str
    part: str


@dataclass(frozen=True)
class RecordingSwitch(Message):
    """Whether the person lets the robot keep what it sees and hears: a Recorder on
    the bus starts or stops keeping the game."""

    topic: ClassVar[str] = "recording/switch"
    on: bool


MESSAGE_TYPES: dict[str, type[Message]] = {cls.__name__: cls for cls in Message.__subclasses__()}
"""Every message type by class name, for decoding JSON."""


def to_json(message: Message) -> str:
    """The message as JSON: its type, topic and fields, bytes as base64."""
    data = {f.name: _encode(getattr(message, f.name)) for f in dataclasses.fields(message)}
    return json.dumps({"type": type(message).__name__, "topic": message.topic, "data": data})


def _encode(value: Any) -> Any:
    if isinstance(value, bytes):
        return base64.b64encode(value).decode("ascii")
    if isinstance(value, tuple):
        return [_encode(v) for v in value]
    return value


def from_json(text: str | bytes) -> Message:
    """The message `to_json` made, checked (`oxbot.robot.message_checks`: size and nesting
    before parsing, then every field); InvalidInputError if it is not one."""
    from oxbot.robot.message_checks import check_json, check_message

    check_json(text)
    try:
        envelope = json.loads(text)
        cls = MESSAGE_TYPES[envelope["type"]]
        data = dict(envelope["data"])
    except (json.JSONDecodeError, KeyError, TypeError, UnicodeDecodeError, RecursionError) as exc:
        raise InvalidInputError(
            f"not a message of oxbot's bus ({type(exc).__name__}: {exc}); "
            f"known types: {', '.join(sorted(MESSAGE_TYPES))}"
        ) from None
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if f.name not in data:
            continue
        try:
            if hints[f.name] is bytes:
                data[f.name] = base64.b64decode(data[f.name], validate=True)
            elif hints[f.name] == tuple[bytes, ...] and isinstance(data[f.name], list):
                data[f.name] = tuple(base64.b64decode(v, validate=True) for v in data[f.name])
            elif isinstance(data[f.name], list):
                data[f.name] = _tuples(data[f.name])
        except RecursionError:
            raise InvalidInputError(
                f"field {f.name!r} of a {cls.__name__} message is nested too deeply"
            ) from None
        except (binascii.Error, TypeError, ValueError):
            raise InvalidInputError(
                f"field {f.name!r} of a {cls.__name__} message is not base64 bytes"
            ) from None
    try:
        return check_message(cls(**data))
    except TypeError as exc:
        raise InvalidInputError(f"malformed {cls.__name__} message: {exc}") from None


def _tuples(value: Any) -> Any:
    return tuple(_tuples(v) for v in value) if isinstance(value, list) else value
