"""Many training dialogues at once: Gymnasium's vector API over the interactive game.

Training steps `n_envs` dialogues together (`gymnasium.vector.SyncVectorEnv`), so that the
Q-network chooses all their acts in one batched forward pass. Each dialogue resets itself the
moment it ends (`AutoresetMode.SAME_STEP`: the step that ends it returns the next dialogue's
first observation, and the last one in `info["final_obs"]`), and meets the next person of the
training mix: an opponent drawn by its weight, and who starts (`TrainingPeople`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv

from oxbot.config import OxbotConfig, opponent_mix, who_starts
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.game.opponents import make_opponent


class TrainingPeople(gym.Wrapper):
    """Each reset starts a dialogue with the next person of `opponents` (a weighted mix such as
    "random:2,minimax:1") under the `robot_starts` conditions ("yes", "no" or "both")."""

    def __init__(self, env: InteractiveGameEnv, opponents: str, robot_starts: str) -> None:
        super().__init__(env)
        mix = opponent_mix(opponents)
        self._names = list(mix)
        self._weights = np.array([mix[name] for name in self._names], dtype=float)
        self._weights /= self._weights.sum()
        self._starts = who_starts(robot_starts, "agent.robot_starts")
        self._choose(np.random.default_rng())

    def _choose(self, rng: np.random.Generator) -> None:
        """Draw people (and the opponents' own moves) with `rng` from now on."""
        self._rng = rng
        self._opponents = {name: make_opponent(name, rng) for name in self._names}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        if seed is not None:
            self._choose(np.random.default_rng(seed))
        name = self._names[self._rng.choice(len(self._names), p=self._weights)]
        person = {
            "opponent": self._opponents[name],
            "robot_starts": bool(self._rng.choice(self._starts)),
        }
        return self.env.reset(seed=seed, options={**person, **(options or {})})


def training_envs(config: OxbotConfig, n_envs: int) -> SyncVectorEnv:
    """`n_envs` training dialogues with the people of `config.agent`'s mix, reset on the step
    that ends them."""
    agent = config.agent

    def make() -> TrainingPeople:
        return TrainingPeople(
            InteractiveGameEnv(config=config), agent.opponents, agent.robot_starts
        )

    return SyncVectorEnv([make] * n_envs, autoreset_mode=AutoresetMode.SAME_STEP)
