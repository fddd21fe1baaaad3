"""Configuration: frozen dataclasses whose defaults are the paper's values.

Each field carries a one-line docstring saying where its default comes from; `oxbot config`
prints them. A TOML file with one table per section overrides the defaults, and
`--set section.field=value` on the command line overrides the file:

    [agent]
    discount = 0.7

    [game]
    opponent = "blocker"
"""

from __future__ import annotations

import ast
import dataclasses
import functools
import inspect
import itertools
import textwrap
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from oxbot.errors import ConfigError


@dataclass(frozen=True)
class GameConfig:
    """The game itself and the terminal game's opponent."""

    robot_starts: bool = True
    """Paper §3.3: the robot always started, drawing circles (the starter draws circles)."""
    opponent: str = "minimax"
    """oxbot: who plays the robot's side in `oxbot game` until the trained manager exists."""

    def __post_init__(self) -> None:
        from oxbot.game.opponents import OPPONENTS

        if self.opponent not in OPPONENTS:
            raise ConfigError(
                f"game.opponent is {self.opponent!r}; choose one of {', '.join(OPPONENTS)}"
            )


@dataclass(frozen=True)
class PerceptionConfig:
    """The CNN+SVM symbol classifier and its generated training data."""

    image_size: int = 40
    """Paper §2.1: cells are 40x40 grayscale images."""
    conv1_filters: int = 8
    """Paper §2.1: first convolution has 8 filters."""
    conv2_filters: int = 16
    """Paper §2.1: second convolution has 16 filters."""
    kernel_size: int = 5
    """ConvNetJS default used by SimpleDS: 5x5 kernels, padding 2."""
    pool1: int = 2
    """Paper §2.1: first max-pool 2x2, stride 2."""
    pool2: int = 3
    """Paper §2.1: second max-pool 3x3, stride 3."""
    seeds_per_class: int = 36
    """Paper §3.3: 108 seed images, i.e. 36 per class."""
    train_images: int = 10_000
    """Paper §3.3: 10K generated training images."""
    test_images: int = 1_000
    """Paper §3.3: accuracy measured on 1,000 randomly generated test images."""
    seed: int = 0
    """oxbot: seed of every random generator used in data generation and training."""
    epochs: int = 10
    """oxbot: passes over the generated images; enough for 99.9% within 30 s on 2 cores."""
    batch_size: int = 64
    """oxbot: images per optimiser step (the paper does not say)."""
    learning_rate: float = 0.01
    """oxbot: peak Adam step size of a one-cycle schedule (the paper does not say)."""
    weight_decay: float = 0.0001
    """oxbot: L2 penalty on the weights, as ConvNetJS's l2_decay (the paper does not say)."""
    threads: int = 1
    """oxbot: torch threads while training; more barely help a net this small, on shared cores."""

    def __post_init__(self) -> None:
        _require_positive(self, "image_size", "conv1_filters", "conv2_filters", "kernel_size")
        _require_positive(self, "pool1", "pool2", "seeds_per_class", "train_images", "test_images")
        _require_positive(self, "epochs", "batch_size", "learning_rate", "threads")
        if self.weight_decay < 0:
            raise ConfigError(f"perception.weight_decay is {self.weight_decay}; use 0 or more")


@dataclass(frozen=True)
class TrackerConfig:
    """The game-move tracker that turns board readings into moves."""

    period_s: float = 0.1
    """Paper §2.1: the classifier runs every 100 milliseconds."""
    stable_readings: int = 3
    """Paper §2.1: a new drawing is accepted once recognised 3 times in a row."""
    min_confidence: float = 0.9
    """oxbot (issue 15): a new symbol counts only when the classifier's calibrated confidence
    in it is at least this, in every one of those readings."""
    ink_tolerance: float = 0.1
    """oxbot (issue 15): the readings agree only while the new symbol's ink (share of its
    cell) changes by at most this fraction of itself: the pen has stopped."""

    def __post_init__(self) -> None:
        _require_positive(self, "period_s", "stable_readings")
        for name in ("min_confidence", "ink_tolerance"):
            value = getattr(self, name)
            if not 0.0 <= value < 1.0:
                raise ConfigError(f"tracker.{name} is {value}; use a value in [0, 1)")


@dataclass(frozen=True)
class RewardConfig:
    """The reward R(s,a,s') = BR*w + DR*(1-w) - DL and the action mask."""

    win_bonus: float = 5.0
    """Paper §2.2: BR = 5 if the agent is about to win."""
    draw_bonus: float = 1.0
    """Paper §2.2: BR = 1 if the agent is about to draw."""
    bonus_weight: float = 0.5
    """Paper §2.2: w = 0.5, the weight of BR against DR."""
    length_penalty: float = 0.1
    """Paper §2.2: DL = 0.1, to encourage efficient interactions."""
    end_reward_loss: float = 0.0
    """Paper §2.2: 0 at the end of a dialogue whose game the robot lost."""
    end_reward_otherwise: float = 5.0
    """Paper §2.2: 5 at the end of any other dialogue (oxbot: whose game was finished)."""
    end_reward_declined: float = 3.0
    """oxbot: at the end of a dialogue with a person who declined to play, and no game."""
    end_reward_stopped: float = 3.0
    """oxbot: at the end of a dialogue whose game the person asked to stop."""
    mask_threshold: float = 0.001
    """Paper §2.2: only actions with Pr(a|s) > 0.001 are offered."""

    def __post_init__(self) -> None:
        if not 0.0 <= self.bonus_weight <= 1.0:
            raise ConfigError(f"reward.bonus_weight is {self.bonus_weight}; use a value in [0, 1]")
        if not 0.0 <= self.mask_threshold < 1.0:
            raise ConfigError(
                f"reward.mask_threshold is {self.mask_threshold}; use a value in [0, 1)"
            )


@dataclass(frozen=True)
class AgentConfig:
    """The DQN interaction manager (Mnih et al. 2015, as configured in the paper)."""

    hidden_sizes: tuple[int, ...] = (60, 60)
    """Paper §2.2: two hidden layers of 60 ReLU units."""
    replay_size: int = 100_000
    """Paper §2.2: experience replay size 100K."""
    discount: float = 0.7
    """Paper §2.2: discount factor 0.7."""
    epsilon_min: float = 0.01
    """Paper §2.2: minimum epsilon 0.01."""
    learning_rate: float = 0.001
    """Paper §2.2: learning rate 0.001."""
    batch_size: int = 32
    """Paper §2.2: batch size 32."""
    seed: int = 0
    """oxbot: seed of the environment, exploration and network initialisation."""
    target_update_interval: int = 1_000
    """oxbot: the paper syncs the target network every C steps without giving C."""
    total_steps: int = 200_000
    """oxbot: the training budget in experiences (the paper trained for 3 hours)."""
    learning_starts: int = 1_000
    """oxbot: experiences collected before the first update."""
    train_frequency: int = 1
    """oxbot: experiences between two updates."""
    epsilon_start: float = 1.0
    """oxbot: the paper gives only the minimum epsilon; exploration starts fully random."""
    exploration_fraction: float = 0.5
    """oxbot: share of the budget over which epsilon falls linearly to its minimum."""
    anneal_learning_rate: bool = False
    """oxbot: let the learning rate fall linearly to 0 over the run; off, as in the paper."""
    double_dqn: bool = False
    """oxbot: Double DQN targets (van Hasselt et al. 2016); off, like the paper's DQN."""
    symmetries: bool = False
    """oxbot: augment each sampled experience with a random symmetry of the board; off."""
    misheard_words: float = 0.0
    """oxbot: share of sampled states given one extra low-confidence misheard word; off."""
    board_head: bool = False
    """oxbot: the GameMoves' values from a move value of the whole state plus per-cell
    advantages of the board alone (a dueling split, `oxbot.dialogue.agent`); off."""
    opponents: str = "random"
    """Paper §3.3: a semi-random simulated person; oxbot: a weighted mix, random:2,minimax:1."""
    robot_starts: str = "yes"
    """Paper §3.3: the robot always started; oxbot: yes, no or both (half the games each)."""
    eval_every: int = 0
    """oxbot: experiences between greedy evaluations that keep the best policy; 0 never."""
    eval_games: int = 300
    """oxbot: games per opponent and who-starts condition in each of those evaluations."""

    def __post_init__(self) -> None:
        _require_positive(self, "replay_size", "learning_rate", "batch_size")
        _require_positive(self, "target_update_interval", "total_steps", "train_frequency")
        _require_positive(self, "eval_games")
        if self.learning_starts < 0 or self.eval_every < 0:
            raise ConfigError("agent.learning_starts and agent.eval_every must be 0 or more")
        if not 0.0 <= self.misheard_words <= 1.0:
            raise ConfigError(f"agent.misheard_words is {self.misheard_words}; use [0, 1]")
        if not 0.0 < self.exploration_fraction <= 1.0:
            raise ConfigError(
                f"agent.exploration_fraction is {self.exploration_fraction}; use a value in (0, 1]"
            )
        who_starts(self.robot_starts, "agent.robot_starts")
        opponent_mix(self.opponents)
        if not 0.0 <= self.discount <= 1.0:
            raise ConfigError(f"agent.discount is {self.discount}; use a value in [0, 1]")
        if not 0.0 <= self.epsilon_min <= 1.0:
            raise ConfigError(f"agent.epsilon_min is {self.epsilon_min}; use a value in [0, 1]")
        if not self.hidden_sizes or any(int(h) <= 0 for h in self.hidden_sizes):
            raise ConfigError(
                f"agent.hidden_sizes is {self.hidden_sizes}; give one or more positive sizes"
            )


def who_starts(text: str, where: str = "robot_starts") -> tuple[bool, ...]:
    """The who-starts conditions `yes`, `no` or `both` names: True where the robot starts."""
    conditions = {"yes": (True,), "no": (False,), "both": (True, False)}.get(text)
    if conditions is None:
        raise ConfigError(f"{where} is {text!r}; use yes, no or both")
    return conditions


def opponent_mix(text: str) -> dict[str, float]:
    """Parse `random:2,minimax:1` (a weight after each name, default 1) into normalised weights."""
    from oxbot.game.opponents import OPPONENTS

    weights: dict[str, float] = {}
    for item in text.split(","):
        name, _, weight = item.strip().partition(":")
        if name not in OPPONENTS:
            raise ConfigError(
                f"agent.opponents names {name!r}; choose from {', '.join(OPPONENTS)}, "
                "e.g. random:2,blocker:1,minimax:1"
            )
        try:
            weights[name] = float(weight) if weight else 1.0
        except ValueError:
            raise ConfigError(f"agent.opponents weight {weight!r} is not a number") from None
        if weights[name] <= 0:
            raise ConfigError(f"agent.opponents weight of {name} must be greater than 0")
    total = sum(weights.values())
    return {name: w / total for name, w in weights.items()}


@dataclass(frozen=True)
class DialogueConfig:
    """The dialogue domain's simulated person and the interactive game environment."""

    asr_noise: float = 0.2
    """oxbot: speech-recognition noise level in [0, 1]; the paper does not give its simulator's."""
    decline_probability: float = 0.1
    """oxbot: chance that the simulated person declines the first invitation to play."""
    out_of_turn_probability: float = 0.05
    """oxbot: chance that the simulated person answers a request for a move with small talk."""
    refuse_probability: float = 0.05
    """oxbot: chance that the simulated person declines every invitation (declines for good)."""
    stop_probability: float = 0.05
    """oxbot: chance that the simulated person asks to stop after their first to third move."""
    nonsense_probability: float = 0.05
    """oxbot: chance that an answer to a question is none of the game's acts (chatter)."""
    silence_probability: float = 0.05
    """oxbot: chance that the simulated person does not answer an invitation at all."""
    rematch_probability: float = 0.1
    """oxbot: chance that the simulated person asks for another game when told who won."""
    max_turns: int = 60
    """oxbot: the dialogue length cap in system acts; the episode is truncated there."""
    nb_alpha: float = 0.01
    """oxbot: Laplace smoothing of the Naive Bayes action model (paper §2.2 gives none)."""
    nb_binarize: float = 0.5
    """oxbot: a feature above this counts as on for the Naive Bayes action model."""

    def __post_init__(self) -> None:
        for name in (
            "asr_noise",
            "decline_probability",
            "out_of_turn_probability",
            "refuse_probability",
            "stop_probability",
            "nonsense_probability",
            "silence_probability",
            "rematch_probability",
        ):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ConfigError(f"dialogue.{name} is {value}; use a value in [0, 1]")
        _require_positive(self, "max_turns", "nb_alpha")


@dataclass(frozen=True)
class ArmConfig:
    """The simulated arm: how big the cells are and how fast its pen moves."""

    cell_size: float = 0.05
    """oxbot: metres across one cell of the drawn grid (a 15 cm grid on an A4 sheet)."""
    fill: float = 0.7
    """oxbot: fraction of the cell the symbol spans, leaving a margin clear of the grid lines."""
    pen_speed: float = 0.15
    """oxbot: metres per second along a stroke, a steady hand: a symbol takes one to two seconds."""
    pen_lift: float = 0.2
    """oxbot: seconds to lift the pen and put it down at the next stroke's start."""
    travel: float = 0.3
    """oxbot: seconds to move from rest to the cell, and again from the cell back to rest."""

    def __post_init__(self) -> None:
        _require_positive(self, "cell_size", "pen_speed")
        if not 0 < self.fill <= 1:
            raise ConfigError(f"robot.arm.fill is {self.fill}; use a value in (0, 1]")
        if min(self.pen_lift, self.travel) < 0:
            raise ConfigError("robot.arm.pen_lift and travel are durations; use 0 or more")


@dataclass(frozen=True)
class HeadConfig:
    """Head-move recognition: how faces are found and how far a head must turn to count."""

    calibration_detections: int = 5
    """oxbot: detections averaged into the centre when nobody calibrates (person looks ahead)."""
    horizontal_threshold: float = 0.35
    """Paper §3.1 thresholds the head's pose; oxbot: face widths left or right of the centre."""
    vertical_threshold: float = 0.25
    """Paper §3.1 thresholds the head's pose; oxbot: face heights above or below the centre."""
    detection_width: int = 480
    """oxbot: wider frames are shrunk before detection (Haar cascades are slow on big frames)."""
    min_face: int = 24
    """oxbot: the smallest face, in pixels of the shrunk frame, the cascades look for."""
    mirrored: bool = False
    """oxbot: true when the camera mirrors its image, so the image's left is the person's left."""

    def __post_init__(self) -> None:
        _require_positive(self, "calibration_detections")
        _require_positive(self, "horizontal_threshold", "vertical_threshold")
        if self.detection_width < 64 or self.min_face < 8:
            raise ConfigError(
                "robot.head.detection_width must be 64 or more and min_face 8 or more pixels"
            )


@dataclass(frozen=True)
class RobotConfig:
    """The integrated robot: how long it waits for the person, how fast it runs, its body."""

    answer_timeout: float = 4.0
    """oxbot: seconds to wait for an optional answer (to a greeting, say) before taking silence."""
    question_timeout: float = 30.0
    """oxbot: seconds to wait for the answer to a question before taking silence."""
    move_timeout: float = 30.0
    """oxbot: seconds to wait for the person's drawing after "Your turn"; then it asks again."""
    speed_factor: float = 1.0
    """oxbot: how many times faster than real time speech, the arm and the waits run (tests)."""
    arm: ArmConfig = field(default_factory=ArmConfig)
    """Paper §3.1: Baxter's arm drew the robot's symbol; oxbot's is simulated, as fast as a pen."""
    head: HeadConfig = field(default_factory=HeadConfig)
    """Paper §3.1: head-move recognition from a Kinect; oxbot's from a webcam."""

    def __post_init__(self) -> None:
        _require_positive(self, "speed_factor")
        for name in ("answer_timeout", "question_timeout", "move_timeout"):
            value = getattr(self, name)
            if not value >= 0:
                raise ConfigError(f"robot.{name} is {value}; a wait cannot be negative")


@dataclass(frozen=True)
class ListeningConfig:
    """Hands-free listening: a microphone's stream cut into utterances by a voice activity
    detector (Silero VAD), and the audio push-to-talk keeps from before the press."""

    threshold: float = 0.5
    """oxbot: the VAD's aggressiveness: speech probability a frame needs (Silero's default)."""
    start_seconds: float = 0.15
    """oxbot: speech heard within twice this time that starts an utterance (a click does not)."""
    end_silence_seconds: float = 0.6
    """oxbot: quiet that ends an utterance (the pauses between a phrase's words are shorter)."""
    max_utterance_seconds: float = 8.0
    """oxbot: an utterance is cut here and handed on even if the speech goes on."""
    pre_roll_seconds: float = 0.3
    """oxbot: audio kept from before an utterance's start or a push-to-talk press (first words)."""
    echo_seconds: float = 0.3
    """oxbot: not listened to after the robot stops speaking (its voice reaches a mic late)."""

    def __post_init__(self) -> None:
        if not 0 < self.threshold < 1:
            raise ConfigError(
                f"speech.listening.threshold is {self.threshold}; use a probability in (0, 1)"
            )
        _require_positive(self, "start_seconds", "end_silence_seconds", "max_utterance_seconds")
        for name in ("pre_roll_seconds", "echo_seconds"):
            value = getattr(self, name)
            if not 0 <= value <= 2:
                raise ConfigError(f"speech.listening.{name} is {value}; use 0 to 2 seconds")
        if self.max_utterance_seconds <= self.start_seconds + self.pre_roll_seconds:
            raise ConfigError(
                "speech.listening.max_utterance_seconds must be longer than start_seconds "
                "plus pre_roll_seconds"
            )


@dataclass(frozen=True)
class SpeechConfig:
    """Hearing and speaking: the recogniser, the voice and hands-free listening."""

    recognizer: str = "pocketsphinx"
    """Paper §3.1 used Google ASR; oxbot: pocketsphinx, or `module:factory` for another."""
    nbest: int = 5
    """Paper §3.1: the recogniser's N-best list is passed on; oxbot keeps this many entries."""
    voice: str = "en-us"
    """Paper §3.1 used MARY TTS; oxbot: the espeak-ng voice of the robot."""
    listening: ListeningConfig = field(default_factory=ListeningConfig)
    """Paper §3.1 listened by push-to-talk; oxbot adds hands-free listening with a VAD."""

    def __post_init__(self) -> None:
        _require_positive(self, "nbest")
        if not self.recognizer.strip():
            raise ConfigError("speech.recognizer is empty; use pocketsphinx or module:factory")


@dataclass(frozen=True)
class WebConfig:
    """The web page's server (`oxbot play`) and what one tab may send it."""

    host: str = "127.0.0.1"
    """oxbot: the address to listen on; 0.0.0.0 lets anyone who can reach this machine play."""
    port: int = 8000
    """oxbot: the port to listen on."""
    max_message_bytes: int = 4_000_000
    """oxbot: largest message from a tab (a 1280x720 PNG as a data URL is about 1-2 MB)."""
    max_image_side: int = 2048
    """oxbot: largest width or height of a sheet or webcam image, in pixels."""
    min_image_side: int = 64
    """oxbot: smallest width or height: a smaller image cannot show a readable grid."""
    audio_rate: int = 16_000
    """oxbot: the recogniser's sample rate (pocketsphinx en-us); the page resamples to it."""
    max_audio_seconds: float = 30.0
    """oxbot: longest push-to-talk recording."""
    max_stream_piece_seconds: float = 1.0
    """oxbot: longest piece of a hands-free stream in one message (the page sends 0.1 s)."""
    max_text_chars: int = 500
    """oxbot: longest typed answer."""
    max_sessions: int = 32
    """oxbot: sessions (tabs) served at once; more are refused with a message."""

    def __post_init__(self) -> None:
        _require_positive(self, "max_message_bytes", "max_image_side", "min_image_side")
        _require_positive(self, "audio_rate", "max_audio_seconds", "max_text_chars")
        _require_positive(self, "max_stream_piece_seconds")
        _require_positive(self, "max_sessions")
        if not 0 < self.port < 65536:
            raise ConfigError(f"web.port is {self.port}; use a port in 1-65535")
        if self.min_image_side > self.max_image_side:
            raise ConfigError("web.min_image_side is larger than web.max_image_side")


@dataclass(frozen=True)
class OxbotConfig:
    """The whole configuration, one section per part of the system."""

    game: GameConfig = field(default_factory=GameConfig)
    perception: PerceptionConfig = field(default_factory=PerceptionConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)
    agent: AgentConfig = field(default_factory=AgentConfig)
    dialogue: DialogueConfig = field(default_factory=DialogueConfig)
    robot: RobotConfig = field(default_factory=RobotConfig)
    speech: SpeechConfig = field(default_factory=SpeechConfig)
    web: WebConfig = field(default_factory=WebConfig)


def _require_positive(config: Any, *names: str) -> None:
    section = _section_name(type(config))
    for name in names:
        value = getattr(config, name)
        if not value > 0:  # NaN is not greater than 0 either
            raise ConfigError(f"{section}.{name} is {value}; it must be greater than 0")


def _section_name(cls: type, root: type | None = None, prefix: str = "") -> str:
    """Where a config class sits in OxbotConfig, e.g. `robot.arm`."""
    for f in dataclasses.fields(root or OxbotConfig):
        if not callable(f.default_factory):
            continue
        if f.default_factory is cls:
            return prefix + f.name
        if dataclasses.is_dataclass(f.default_factory):
            found = _section_name(cls, f.default_factory, f"{prefix}{f.name}.")
            if found != cls.__name__:
                return found
    return cls.__name__


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """The docstring written under each field of a config dataclass, by field name."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body  # type: ignore[attr-defined]
    docs: dict[str, str] = {}
    for node, following in itertools.pairwise(body):
        if (
            isinstance(node, ast.AnnAssign)
            and isinstance(node.target, ast.Name)
            and isinstance(following, ast.Expr)
            and isinstance(following.value, ast.Constant)
            and isinstance(following.value.value, str)
        ):
            docs[node.target.id] = following.value.value.strip()
    return docs


def _coerce(where: str, default: Any, value: Any) -> Any:
    """Check a value from TOML or the command line against the type of the field's default."""
    if isinstance(default, bool):
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in {"true", "yes", "1", "false", "no", "0"}:
            return value.lower() in {"true", "yes", "1"}
    elif isinstance(default, int):
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif isinstance(default, float):
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
    elif isinstance(default, str):
        if isinstance(value, str):
            return value
    elif (
        isinstance(default, tuple)
        and isinstance(value, list | tuple)
        and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
    ):
        return tuple(value)
    raise ConfigError(
        f"{where} = {value!r} has the wrong type; expected {type(default).__name__} "
        f"like the default {default!r}"
    )


Overrides = dict[str, Any]
"""`{section: {field: value}}`, a nested section being a table in its section."""


def with_overrides(config: OxbotConfig, overrides: Overrides) -> OxbotConfig:
    """A copy of `config` with `{section: {field: value}}` applied, each value type-checked."""
    return _apply(config, overrides, "")


def _apply(node: Any, values: Any, path: str) -> Any:
    if not isinstance(values, dict):
        raise ConfigError(f"[{path}] must be a table of field = value lines")
    known = {f.name for f in dataclasses.fields(node)}
    changes = {}
    for name, value in values.items():
        where = f"{path}.{name}" if path else name
        if name not in known:
            if not path:
                raise ConfigError(
                    f"unknown config section [{name}]; sections are {', '.join(sorted(known))}"
                )
            raise ConfigError(f"unknown field {where}; fields are {', '.join(sorted(known))}")
        current = getattr(node, name)
        if dataclasses.is_dataclass(current):
            changes[name] = _apply(current, value, where)
        else:
            changes[name] = _coerce(where, current, value)
    return dataclasses.replace(node, **changes)


def parse_assignment(text: str) -> tuple[list[str], Any]:
    """Split a command-line override `section.field=value` (or `section.table.field=value`)
    into its keys and value; the value is read as TOML."""
    key, sep, raw = text.partition("=")
    keys = [k.strip() for k in key.split(".")]
    if not sep or len(keys) < 2 or not all(keys):
        raise ConfigError(f"--set {text!r} is malformed; write it as section.field=value")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()  # a bare word such as blocker reads as a string
    return keys, value


def load_config(path: str | Path | None = None, assignments: Sequence[str] = ()) -> OxbotConfig:
    """The defaults, overridden by the TOML file at `path`, then by `section.field=value` items."""
    config = OxbotConfig()
    if path is not None:
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ConfigError(f"config file {path} does not exist; check the path") from None
        except IsADirectoryError:
            raise ConfigError(f"config file {path} is a folder; give a TOML file") from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ConfigError(f"config file {path} is not valid TOML: {exc}") from None
        config = with_overrides(config, data)
    overrides: Overrides = {}
    for item in assignments:
        keys, value = parse_assignment(item)
        table = overrides
        for key in keys[:-1]:
            table = table.setdefault(key, {})
            if not isinstance(table, dict):
                raise ConfigError(f"--set {item!r} sets {key} both as a value and as a table")
        table[keys[-1]] = value
    return with_overrides(config, overrides)


def to_toml(config: OxbotConfig) -> str:
    """The configuration as a commented TOML file that `load_config` reads back."""
    lines: list[str] = []
    for section_field in dataclasses.fields(config):
        _table_lines(getattr(config, section_field.name), section_field.name, lines)
    return "\n".join(lines)


def _table_lines(section: Any, name: str, lines: list[str]) -> None:
    docs = field_docs(type(section))
    lines.append(f"[{name}]")
    tables = []
    for f in dataclasses.fields(section):
        value = getattr(section, f.name)
        if dataclasses.is_dataclass(value):
            tables.append(f)
            continue
        if f.name in docs:
            lines.extend(_comment(docs[f.name]))
        lines.append(f"{f.name} = {_toml_value(value)}")
    lines.append("")
    for f in tables:  # a TOML table's own fields come before its sub-tables
        if f.name in docs:
            lines.extend(_comment(docs[f.name]))
        _table_lines(getattr(section, f.name), f"{name}.{f.name}", lines)


def _comment(doc: str) -> list[str]:
    """A field's documentation as TOML comment lines, however many lines it has."""
    return [f"# {line.strip()}" for line in doc.splitlines()]


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return repr(value)
