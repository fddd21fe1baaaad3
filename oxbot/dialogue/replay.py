"""The replay memory D of deep Q-learning, and what is done to each minibatch drawn from it.

Paper §2.2 (Mnih et al.): experiences (s, a, r, s') are stored in a ring and minibatches are
drawn from it uniformly. oxbot's options (`AgentConfig`): each sampled experience is seen through
a random symmetry of the board, and some states hear one more word with a low confidence.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import torch

from oxbot.config import OxbotConfig
from oxbot.dialogue.domain import N_ACTIONS
from oxbot.dialogue.env import InteractiveGameEnv


class Batch(NamedTuple):
    """A minibatch of experiences (s, a, r, s', offered in s', terminal), one row each."""

    states: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    next_states: np.ndarray
    next_masks: np.ndarray
    dones: np.ndarray


class ReplayBuffer:
    """The experience replay memory D: a ring of (s, a, r, s', offered in s', terminal)."""

    def __init__(self, capacity: int, n_features: int, n_actions: int = N_ACTIONS) -> None:
        self.capacity = capacity
        self.states = np.zeros((capacity, n_features), dtype=np.float32)
        self.actions = np.zeros(capacity, dtype=np.int64)
        self.rewards = np.zeros(capacity, dtype=np.float32)
        self.next_states = np.zeros((capacity, n_features), dtype=np.float32)
        self.next_masks = np.zeros((capacity, n_actions), dtype=bool)
        self.dones = np.zeros(capacity, dtype=np.float32)
        self.size = 0
        self.position = 0

    def add_batch(
        self,
        s: np.ndarray,
        a: np.ndarray,
        r: np.ndarray,
        s2: np.ndarray,
        m2: np.ndarray,
        done: np.ndarray,
    ) -> None:
        """Store one experience per row, in row order (the oldest are overwritten first)."""
        rows = (self.position + np.arange(len(a))) % self.capacity
        self.states[rows], self.actions[rows], self.rewards[rows] = s, a, r
        self.next_states[rows], self.next_masks[rows], self.dones[rows] = s2, m2, done
        self.position = int(rows[-1] + 1) % self.capacity
        self.size = min(self.size + len(a), self.capacity)

    def sample(self, batch_size: int, rng: np.random.Generator) -> Batch:
        """A minibatch drawn uniformly at random, MB ~ U(D)."""
        i = rng.integers(self.size, size=batch_size)
        return Batch(*(getattr(self, name)[i] for name in Batch._fields))

    def state_dict(self) -> dict[str, Any]:
        n = self.size
        arrays = {name: torch.from_numpy(getattr(self, name)[:n].copy()) for name in Batch._fields}
        return {**arrays, "position": self.position}

    def load_state_dict(self, data: dict[str, Any]) -> None:
        n = len(data["actions"])
        for name in Batch._fields:
            getattr(self, name)[:n] = data[name].numpy()
        self.size = n
        self.position = int(data["position"])


def add_misheard_words(
    states: np.ndarray, share: float, n_words: int, below: float, rng: np.random.Generator
) -> np.ndarray:
    """A copy of `states` where a `share` of rows hear one more absent word, with confidence
    in [0.1, `below`).

    Below the action model's threshold such a word changes neither the offered acts nor the
    DR reward, and what the person says next does not depend on how the robot heard them: the
    experience is exactly as valid for the altered state. It teaches the network to ignore the
    recogniser's low-confidence guesses, which otherwise tip a close choice between moves.
    """
    states = states.copy()
    chosen = np.flatnonzero(rng.random(len(states)) < share)
    if len(chosen):
        words = rng.integers(n_words, size=len(chosen))
        absent = states[chosen, words] == 0
        states[chosen[absent], words[absent]] = rng.uniform(0.1, below, size=int(absent.sum()))
    return states


class BatchAugmenter:
    """What `agent.symmetries` and `agent.misheard_words` do to each sampled minibatch."""

    def __init__(self, env: InteractiveGameEnv, config: OxbotConfig) -> None:
        self.config = config.agent
        self.feature_perm, self.action_perm = env.layout.symmetry_permutations()
        self.mask_perm = np.argsort(self.action_perm, axis=1)  # new_mask = old_mask[mask_perm[k]]
        self.rows = np.arange(self.config.batch_size)[:, None]
        self.n_words = env.layout.n_words
        self.binarize = config.dialogue.nb_binarize

    def __call__(self, batch: Batch, rng: np.random.Generator) -> Batch:
        s, a, r, s2, m2, done = batch
        if self.config.symmetries:  # the same experience seen rotated or mirrored
            k = rng.integers(len(self.feature_perm), size=self.config.batch_size)
            s = s[self.rows, self.feature_perm[k]]
            s2 = s2[self.rows, self.feature_perm[k]]
            a = self.action_perm[k, a]
            m2 = m2[self.rows, self.mask_perm[k]]
        if self.config.misheard_words:  # a word heard with low confidence changes nothing
            s = add_misheard_words(s, self.config.misheard_words, self.n_words, self.binarize, rng)
        return Batch(s, a, r, s2, m2, done)
