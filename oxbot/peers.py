"""Peers: off-the-shelf learners measured side by side with oxbot's own.

- Learning to perceive: a scikit-learn linear SVM on the raw pixels, trained on the very images
  the CNN+SVM is trained on (`train_pixel_svm`).
- Learning to interact: Stable-Baselines3's DQN and sb3-contrib's MaskablePPO (with the
  environment's action mask) on `oxbot/NoughtsAndCrosses-v0`, trained for a wall-clock budget
  or a number of experiences against the same opponents and who-starts conditions as oxbot's
  agent (`train_peer_agent`).
  Both are evaluated with `oxbot.dialogue.evaluation.evaluate`, oxbot's own protocol.
- Playing on the robot: `SB3Policy` makes a saved SB3 DQN or MaskablePPO model the robot's
  `oxbot.dialogue.policy.Policy`, and `load_robot_policy` loads whichever policy the config
  names (`oxbot play --policy model.zip`).

>>> from oxbot.config import OxbotConfig
>>> peer = train_peer_agent("dqn", OxbotConfig(), budget_s=1, eval_every_s=1, eval_games=2)
>>> peer.evaluations[-1]["results"]["minimax/person"]["games"]
2
>>> SB3Policy(peer.model).algorithm
'dqn'
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from oxbot.config import OxbotConfig, opponent_mix, who_starts
from oxbot.dialogue import ENV_ID
from oxbot.dialogue.agent import greedy_batch_policy
from oxbot.dialogue.baselines import load_manager
from oxbot.dialogue.domain import N_ACTIONS
from oxbot.dialogue.evaluation import CONDITIONS, Policy, condition_key, evaluate
from oxbot.dialogue.model import build_dialogue_model
from oxbot.dialogue.policy import Policy as RobotPolicy
from oxbot.dialogue.policy import retrain_advice
from oxbot.errors import ConfigError, ModelFileError
from oxbot.game.opponents import make_opponent
from oxbot.perception.synth import LABELS

log = logging.getLogger(__name__)

PEER_AGENTS = ("dqn", "maskable_ppo")
"""The interaction-manager peers: SB3's DQN and sb3-contrib's MaskablePPO."""


# --- learning to perceive: a linear SVM on raw pixels ---------------------------------------


class PixelSVM:
    """A linear SVM (scikit-learn `LinearSVC`) on the raw pixels of 40x40 cells, scaled to [0, 1].

    The perception peer: no learnt features, no normalisation, no augmentation at fit time;
    `decision_function` makes it usable with `oxbot.perception.evaluation.evaluate`.
    """

    def __init__(
        self, image_size: int = 40, c: float = 1.0, seed: int = 0, max_iter: int = 5_000
    ) -> None:
        from sklearn.svm import LinearSVC

        self.image_size = image_size
        # 5 times scikit-learn's default iterations: raw pixels converge slowly
        # the primal problem: as many samples as pixels or more (10K images of 1,600 pixels)
        self.svm = LinearSVC(C=c, dual=False, random_state=seed, max_iter=max_iter)

    @staticmethod
    def _pixels(images: np.ndarray) -> np.ndarray:
        return np.asarray(images, dtype=np.float32).reshape(len(images), -1) / 255.0

    def fit(self, images: np.ndarray, labels: np.ndarray) -> PixelSVM:
        """Learn from uint8 (N, 40, 40) images and label indices (0 circle, 1 cross, 2 nothing)."""
        import warnings

        from sklearn.exceptions import ConvergenceWarning

        with warnings.catch_warnings():  # reported as is: the peer gets no tuning from us
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.svm.fit(self._pixels(images), np.asarray(labels))
        return self

    def decision_function(self, images: np.ndarray) -> np.ndarray:
        """One score per label (circle, cross, nothing) for each cell, (N, 3)."""
        scores = self.svm.decision_function(self._pixels(images))
        if scores.ndim == 1:  # trained on two labels: one score, positive for the second
            scores = np.stack([-scores, scores], axis=1)
        # LinearSVC orders its columns by the labels it saw; put them in LABELS order.
        out = np.full((len(images), len(LABELS)), -np.inf, dtype=np.float64)
        out[:, self.svm.classes_] = scores
        return out


# --- learning to interact: SB3's DQN and MaskablePPO ---------------------------------------


class TrainingConditions(gym.Wrapper):
    """Each episode against an opponent drawn from the agent config's mix, either side starting.

    The conditions oxbot's own agent trains in (`agent.opponents`, `agent.robot_starts`). Keeps
    the offered acts of the current state as `action_mask` for sb3-contrib's `ActionMasker`.
    """

    def __init__(self, env: gym.Env, config: OxbotConfig, seed: int) -> None:
        super().__init__(env)
        self.rng = np.random.default_rng([seed, 1])
        mix = opponent_mix(config.agent.opponents)
        self.names = list(mix)
        self.weights = np.array([mix[n] for n in self.names], dtype=float)
        self.opponents = {name: make_opponent(name, self.rng) for name in self.names}
        self.starts = who_starts(config.agent.robot_starts)
        self.action_mask = np.ones(env.action_space.n, dtype=bool)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        name = self.names[self.rng.choice(len(self.names), p=self.weights)]
        options = {
            "opponent": self.opponents[name],
            "robot_starts": bool(self.rng.choice(self.starts)),
            **(options or {}),
        }
        obs, info = self.env.reset(seed=seed, options=options)
        self.action_mask = info["action_mask"]
        return obs, info

    def step(self, action: Any):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.action_mask = info["action_mask"]
        return obs, reward, terminated, truncated, info


def make_peer_env(algorithm: str, config: OxbotConfig, seed: int) -> gym.Env:
    """The registered environment in oxbot's training conditions; masked for MaskablePPO."""
    env = TrainingConditions(gym.make(ENV_ID, config=config), config, seed)
    if algorithm == "maskable_ppo":
        from sb3_contrib.common.wrappers import ActionMasker

        return ActionMasker(env, lambda e: e.action_mask)
    return env


def build_peer(algorithm: str, env: gym.Env, config: OxbotConfig, seed: int) -> Any:
    """An SB3 model with oxbot's network size and discount; the rest SB3's defaults or, for
    DQN, the values oxbot's agent uses (replay, batch, exploration, target sync)."""
    a = config.agent
    policy_kwargs = {"net_arch": list(a.hidden_sizes)}
    if algorithm == "dqn":
        from stable_baselines3 import DQN

        return DQN(
            "MlpPolicy",
            env,
            learning_rate=a.learning_rate,
            buffer_size=a.replay_size,
            learning_starts=a.learning_starts,
            batch_size=a.batch_size,
            gamma=a.discount,
            train_freq=a.train_frequency,
            target_update_interval=a.target_update_interval,
            exploration_fraction=a.exploration_fraction,
            exploration_initial_eps=a.epsilon_start,
            exploration_final_eps=a.epsilon_min,
            policy_kwargs=policy_kwargs,
            seed=seed,
            device="cpu",
            verbose=0,
        )
    if algorithm == "maskable_ppo":
        from sb3_contrib import MaskablePPO

        return MaskablePPO(
            "MlpPolicy",
            env,
            gamma=a.discount,
            policy_kwargs=policy_kwargs,
            seed=seed,
            device="cpu",
            verbose=0,
        )
    raise ConfigError(f"unknown peer {algorithm!r}; choose one of {', '.join(PEER_AGENTS)}")


def peer_batch_policy(algorithm: str, model: Any) -> Policy:
    """The trained peer as a greedy batch policy over the offered acts, like oxbot's.

    DQN cannot mask while it learns, but it is judged as oxbot is: the best Q-value among the
    offered acts. MaskablePPO takes the mask itself and acts by its most likely act.
    """
    if algorithm == "dqn":
        return greedy_batch_policy(model.q_net)

    def act_masked(states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        actions, _ = model.predict(
            np.asarray(states, np.float32), action_masks=masks, deterministic=True
        )
        return np.asarray(actions)

    return act_masked


def evaluate_conditions(
    policy: Policy, games: int, config: OxbotConfig, seed: int, cooperative: bool = False
) -> dict[str, dict[str, Any]]:
    """oxbot's evaluation in all six conditions: `{"random/robot": summary, ...}`; with
    `cooperative` people, who always play a whole game (game play, as the paper measured it)."""
    return {
        condition_key(name, starts): evaluate(
            policy, name, starts, games, config, seed=seed, cooperative=cooperative
        ).summary()
        for name, starts in CONDITIONS
    }


def zero_losses(results: dict[str, dict[str, Any]]) -> bool:
    """True when the policy lost no game in any condition."""
    return all(r["loss_rate"] == 0 for r in results.values())


@dataclass
class PeerRun:
    """A peer's training run: its model, steps, greedy evaluations and final figures; its
    budget in training seconds (`budget_s`) or in experiences (`budget_steps`)."""

    algorithm: str
    model: Any
    budget_s: float | None
    budget_steps: int | None = None
    train_s: float = 0.0
    steps: int = 0
    evaluations: list[dict[str, Any]] = field(default_factory=list)

    @property
    def time_to_zero_losses(self) -> float | None:
        """Training seconds at the first evaluation without a loss, None if never."""
        return next((e["train_s"] for e in self.evaluations if zero_losses(e["results"])), None)

    def to_dict(self) -> dict[str, Any]:
        return {
            "algorithm": self.algorithm,
            "budget_s": None if self.budget_s is None else round(self.budget_s, 1),
            "budget_steps": self.budget_steps,
            "train_s": round(self.train_s, 1),
            "steps": self.steps,
            "time_to_zero_losses_s": self.time_to_zero_losses,
            "evaluations": self.evaluations,
        }


def train_peer_agent(
    algorithm: str,
    config: OxbotConfig,
    budget_s: float | None = None,
    eval_every_s: float | None = None,
    eval_games: int = 300,
    seed: int = 0,
    on_progress: Callable[[float], None] | None = None,
    *,
    budget_steps: int | None = None,
    eval_every_steps: int | None = None,
) -> PeerRun:
    """Train an SB3 peer for `budget_s` seconds of training (its evaluations not counted), or
    for `budget_steps` experiences: one budget or the other, each with its evaluation period.

    Every `eval_every_s` training seconds (`eval_every_steps` experiences), and at the end, the
    greedy peer plays `eval_games` games in each of the six conditions; `on_progress` is told
    the seconds (experiences) spent after each. The schedules SB3 ties to the total steps
    (DQN's exploration) span the run: on a step budget, its experiences; on a time budget, the
    steps the peer makes in it, measured over its first tenth. Either way it explores as much
    of its run as oxbot's agent does of its own.
    """
    if algorithm not in PEER_AGENTS:
        raise ConfigError(f"unknown peer {algorithm!r}; choose one of {', '.join(PEER_AGENTS)}")
    if (budget_steps is None) == (budget_s is None):
        raise ConfigError("a peer needs one budget: training seconds or experiences, not both")
    by_steps = budget_steps is not None
    budget = float(budget_steps) if budget_steps is not None else float(budget_s or 0)
    every = eval_every_steps if by_steps else eval_every_s
    if budget <= 0 or every is None or every <= 0 or eval_games <= 0:
        raise ConfigError("a peer needs a positive budget, evaluation period and game count")
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    torch.set_num_threads(1)  # as oxbot's agent: small MLPs are fastest on one thread
    env = make_peer_env(algorithm, config, seed)
    model = build_peer(algorithm, env, config, seed)
    run = PeerRun(algorithm, model, budget_s, budget_steps)
    policy = peer_batch_policy(algorithm, model)
    eval_seed = 20_000 + seed  # the same people at every evaluation, for every learner

    class Budget(BaseCallback):
        """Stops at the budget; evaluates with the clock stopped."""

        def _on_training_start(self) -> None:
            self.clock = 0.0
            self.tick = time.perf_counter()
            self.next_eval = float(every)
            self.rescaled = by_steps  # a step budget's schedules are right from the start

        def _on_step(self) -> bool:
            now = time.perf_counter()
            self.clock += now - self.tick
            self.tick = now
            if not self.rescaled and self.clock >= budget / 10:
                steps = int(self.num_timesteps * budget / self.clock)
                self.model._total_timesteps = max(steps, self.num_timesteps + 1)
                self.rescaled = True
            spent = float(self.num_timesteps) if by_steps else self.clock
            if spent >= self.next_eval or spent >= budget:
                self.next_eval += every
                was_training = self.model.policy.training
                self.model.policy.set_training_mode(False)
                results = evaluate_conditions(policy, eval_games, config, eval_seed)
                self.model.policy.set_training_mode(was_training)
                run.evaluations.append(
                    {
                        "train_s": round(self.clock if by_steps else min(self.clock, budget), 1),
                        "steps": self.num_timesteps,
                        "results": results,
                    }
                )
                if on_progress is not None:
                    on_progress(min(spent, budget))
                self.tick = time.perf_counter()  # evaluating is not training
            run.train_s, run.steps = self.clock, self.num_timesteps
            # PPO collects whole rollouts: stopping here keeps its experiences to the budget
            return spent < budget

    # On a time budget, far more steps than fit in it: the callback ends the run.
    model.learn(
        total_timesteps=budget_steps if by_steps else 10**9, callback=Budget(), progress_bar=False
    )
    env.close()
    return run


def peer_settings(algorithm: str, model: Any) -> dict[str, Any]:
    """The hyper-parameters a peer trained with, for the report."""
    dqn_names = ("learning_rate", "buffer_size", "learning_starts", "batch_size", "gamma")
    dqn_names += ("train_freq", "target_update_interval", "exploration_fraction")
    dqn_names += ("exploration_final_eps",)
    ppo_names = ("learning_rate", "n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda")
    names = dqn_names if algorithm == "dqn" else (*ppo_names, "clip_range", "ent_coef")
    settings: dict[str, Any] = {}
    for name in names:
        value = getattr(model, name, None)
        if callable(value):
            value = value(1.0)
        elif hasattr(value, "frequency"):  # DQN's TrainFreq(frequency, unit)
            value = f"{value.frequency} {value.unit.value}s"
        settings[name] = value if isinstance(value, int | float | str | None) else str(value)
    settings["net_arch"] = list(model.policy_kwargs.get("net_arch", []))
    return settings


# --- playing on the robot: a saved SB3 model as the robot's policy ------------------------


class SB3Policy:
    """A Stable-Baselines3 DQN or sb3-contrib MaskablePPO model as the robot's policy
    (`oxbot.dialogue.policy.Policy`), greedy over the offered acts as in `peer_batch_policy`;
    a DQN's Q-values are its scores on the page."""

    def __init__(self, model: Any) -> None:
        self.model = model
        self.algorithm = "dqn" if hasattr(model, "q_net") else "maskable_ppo"
        self.act_batch = peer_batch_policy(self.algorithm, model)

    def act(self, observation: np.ndarray, mask: np.ndarray) -> int:
        """The model's act in `observation` among those `mask` offers."""
        batch = self.act_batch(np.asarray(observation, np.float32)[None], np.asarray(mask)[None])
        return int(batch[0])

    def q_values(self, states: np.ndarray) -> np.ndarray:
        """A DQN's Q-values (N, N_ACTIONS); MaskablePPO's log-probabilities of each act."""
        import torch

        x = torch.as_tensor(np.asarray(states, np.float32))
        with torch.inference_mode():
            if self.algorithm == "dqn":
                return self.model.q_net(x).numpy()
            return self.model.policy.get_distribution(x).distribution.logits.numpy()


def load_sb3_policy(path: str | Path, n_features: int, advice: str = "") -> SB3Policy:
    """The SB3 DQN or MaskablePPO model saved at `path` (`model.save`), checked to fit the
    domain's `n_features` state features and oxbot's acts; else `ModelFileError` with `advice`.

    Loading an SB3 file unpickles it: load only models you trust (your own)."""
    path = Path(path)
    algorithm = sb3_algorithm(path)
    if algorithm == "dqn":
        from stable_baselines3 import DQN as Algorithm
    else:
        from sb3_contrib import MaskablePPO as Algorithm
    model = Algorithm.load(path, device="cpu")
    shape, actions = model.observation_space.shape, getattr(model.action_space, "n", None)
    if shape != (n_features,) or actions != N_ACTIONS:
        raise ModelFileError(
            f"{path} was trained on {shape} observations and {actions} acts; the robot's domain "
            f"has ({n_features},) and {N_ACTIONS}: train it on this domain's environment "
            f"(docs/extending.md){'; or ' + advice if advice else ''}"
        )
    return SB3Policy(model)


def sb3_algorithm(path: Path) -> str:
    """Which peer a saved SB3 file holds ("dqn" or "maskable_ppo"), from its policy class;
    `ModelFileError` if it is neither or no SB3 file."""
    import json
    import zipfile

    try:
        with zipfile.ZipFile(path) as archive:
            data = json.loads(archive.read("data"))
        module = str(data["policy_class"]["__module__"])
    except (OSError, KeyError, TypeError, ValueError, zipfile.BadZipFile) as exc:
        raise ModelFileError(
            f"{path} is not a Stable-Baselines3 model file ({type(exc).__name__}); save one with "
            "model.save(path)"
        ) from None
    if module.startswith("stable_baselines3.dqn"):
        return "dqn"
    if module.startswith("sb3_contrib.common.maskable"):
        return "maskable_ppo"
    raise ModelFileError(
        f"{path} holds a {module} policy; the robot plays SB3's DQN or sb3-contrib's MaskablePPO"
    )


def load_robot_policy(config: OxbotConfig, manager: str | None = None) -> RobotPolicy:
    """The policy the robot plays with: `[robot] manager` (or `manager`) and, for the DQN,
    `[robot] policy` (an oxbot policy file or its folder, or an SB3 model's .zip; the shipped
    policy when empty), for the feature layout of `[dialogue] domain`."""
    name = manager or config.robot.manager
    path = config.robot.policy
    if name == "dqn" and path and Path(path).suffix == ".zip":
        n_features = len(build_dialogue_model(config).layout.names)
        return load_sb3_policy(path, n_features, retrain_advice(config.dialogue.domain))
    return load_manager(name, config, Path(path) if path else None)
