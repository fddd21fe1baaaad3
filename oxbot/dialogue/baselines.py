"""What the learned interaction manager is measured against: a script and tabular Q-learning.

- `scripted_policy`: no learning at all. It says the action model's most probable offered act
  (the Naive Bayes classifier of the seed dialogues), and when that is a move it draws where
  the exact solver says: among the moves that never lose, the one most likely to win against a
  random person. If the DQN is worth learning, it has to beat this.
- `train_tabular_q`: Q-learning with a table, keyed on the state's features read as 0/1 (words
  and acts heard above 0.5, the board, the flags), epsilon-greedy among the offered acts, on the
  same environment and people as the DQN and for the same number of experiences.

Both are batch policies for `oxbot.dialogue.evaluation.evaluate`.
"""

from __future__ import annotations

import time
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np

from oxbot.config import OxbotConfig, opponent_mix, who_starts
from oxbot.dialogue.agent import masked_argmax
from oxbot.dialogue.domain import N_ACTIONS, is_game_move
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.evaluation import Policy
from oxbot.dialogue.features import FeatureLayout
from oxbot.dialogue.model import DialogueModel
from oxbot.game.board import EMPTY, N_CELLS, ROBOT, USER, Board, play
from oxbot.game.opponents import make_opponent
from oxbot.game.solver import best_moves, win_probability_vs_random


def board_of(state: np.ndarray, layout: FeatureLayout) -> Board:
    """The board a state vector shows."""
    robot = state[layout.robot_cells] > 0.5
    person = state[layout.person_cells] > 0.5
    return tuple(ROBOT if r else USER if p else EMPTY for r, p in zip(robot, person, strict=True))


def solver_move(board: Board, offered: np.ndarray) -> int:
    """The offered cell that never loses and most often wins against a random person."""
    cells = [c for c in best_moves(board, ROBOT) if offered[c]] or list(np.flatnonzero(offered))
    return max(cells, key=lambda c: win_probability_vs_random(play(board, c, ROBOT), ROBOT, False))


def scripted_policy(model: DialogueModel) -> Policy:
    """The action model's most probable offered act; the exact solver's cell for a move."""
    layout, action_model = model.layout, model.action_model

    def act(states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        probabilities = action_model.predict_proba(states)
        chosen = masked_argmax(probabilities, masks)
        for i, action in enumerate(chosen):
            if is_game_move(int(action)):
                chosen[i] = solver_move(board_of(states[i], layout), masks[i, :N_CELLS])
        return chosen

    return act


@dataclass
class TabularQ:
    """A Q-table over states read as 0/1; unseen states act on zeros (the first offered act)."""

    table: dict[bytes, np.ndarray] = field(default_factory=dict)
    experiences: int = 0
    cpu_seconds: float = 0.0

    @staticmethod
    def key(state: np.ndarray) -> bytes:
        return np.packbits(state > 0.5).tobytes()

    def values(self, state: np.ndarray) -> np.ndarray:
        return self.table.get(self.key(state), _ZEROS)

    def act_batch(self, states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        q = np.stack([self.values(s) for s in states])
        return masked_argmax(q, np.asarray(masks, dtype=bool))


_ZEROS = np.zeros(N_ACTIONS)


def train_tabular_q(
    config: OxbotConfig,
    experiences: int,
    learning_rate: float = 0.2,
    epsilon: tuple[float, float] = (1.0, 0.01),
) -> TabularQ:
    """Q-learning for `experiences` steps in the DQN's training conditions (`config.agent`:
    seed, discount, opponents, who starts, `eval_every`; epsilon falling linearly over half
    the run), keeping the best evaluated table as the DQN keeps its best network
    (`oxbot.dialogue.training.evaluate_checkpoint`)."""
    from oxbot.dialogue.training import evaluate_checkpoint

    cfg = config.agent
    started = time.process_time()
    env = InteractiveGameEnv(config=config)
    rng = np.random.default_rng(cfg.seed)
    mix = opponent_mix(cfg.opponents)
    names, weights = list(mix), np.array(list(mix.values()))
    opponents = {name: make_opponent(name, rng) for name in names}
    starts = who_starts(cfg.robot_starts)
    table: dict[bytes, np.ndarray] = defaultdict(lambda: np.zeros(N_ACTIONS))
    best, best_score = TabularQ(), None

    def next_episode() -> dict:
        name = names[rng.choice(len(names), p=weights)]
        return {"opponent": opponents[name], "robot_starts": bool(rng.choice(starts))}

    obs, info = env.reset(seed=cfg.seed, options=next_episode())
    for step in range(experiences):
        eps = max(epsilon[1], epsilon[0] - (epsilon[0] - epsilon[1]) * step / (experiences / 2))
        mask = info["action_mask"]
        q = table[TabularQ.key(obs)]
        if rng.random() < eps:
            action = int(rng.choice(np.flatnonzero(mask)))
        else:
            action = int(masked_argmax(q, mask))
        next_obs, reward, terminated, truncated, info = env.step(action)
        target = reward
        if not terminated:
            following = table[TabularQ.key(next_obs)]
            target += cfg.discount * float(
                np.max(np.where(info["action_mask"], following, -np.inf))
            )
        q[action] += learning_rate * (target - q[action])
        obs = next_obs
        if terminated or truncated:
            obs, info = env.reset(options=next_episode())
        if cfg.eval_every and (step + 1) % cfg.eval_every == 0:
            candidate = TabularQ({k: v.copy() for k, v in table.items()}, step + 1)
            _, score = evaluate_checkpoint(config, candidate.act_batch, step + 1)
            if best_score is None or score >= best_score:
                best, best_score = candidate, score
    if not cfg.eval_every:
        best = TabularQ(dict(table), experiences)
    best.cpu_seconds = time.process_time() - started
    return best
