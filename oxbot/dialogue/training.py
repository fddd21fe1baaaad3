"""Training the DQN interaction manager: one readable loop, CleanRL style, importable.

Paper §2.2 "Deep Q-Learning with Experience Replay" (Mnih et al.): act epsilon-greedily among
the offered acts, store the experience, sample a minibatch uniformly from the replay memory,
regress Q(s, a) on r + gamma * max_a' Q_target(s', a') over the acts offered in s', and copy the
network into the target every C steps. oxbot's options (`AgentConfig`): Double DQN targets,
a random board symmetry applied to each sampled experience, a weighted mix of opponents, both
who-starts conditions, and periodic greedy evaluations that keep the best policy.

`train_agent` writes into its output folder:
- `agent.pt`: the policy (the best evaluated one when `eval_every` > 0, else the last);
- `agent_metrics.json`: the config, seed, curves, evaluations and wall-clock time;
- `agent_reward.png` and `agent_win_draw.png`: the learning curves of the paper's Figure
  "plots" (middle: average reward against experiences; right: win/draw rate against games);
- `checkpoint.pt`: everything needed to resume (written atomically every `checkpoint_every`,
  and at once on Ctrl-C, which then raises `TrainingInterrupted`).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import logging
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import torch
import torch.nn.functional as F
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from oxbot import artifacts
from oxbot.atomic import save_figure, write_text_atomic
from oxbot.config import AgentConfig, OxbotConfig, opponent_mix, who_starts
from oxbot.dialogue.agent import DQNPolicy, QNetwork, greedy_batch_policy, masked_argmax
from oxbot.dialogue.domain import N_ACTIONS
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.evaluation import (
    CONDITIONS,
    Policy,
    condition_key,
    evaluate,
    losing_positions,
    misread_wills,
    wins_against_random,
)
from oxbot.errors import ModelFileError, TrainingInterrupted
from oxbot.game.opponents import make_opponent
from oxbot.interrupt import deferred_interrupt

log = logging.getLogger(__name__)

CHECKPOINT_FORMAT = "oxbot-dqn-checkpoint/1"
CHECKPOINT_KIND = "agent-checkpoint"
CHECKPOINT_VERSION = 2
"""2: behind `oxbot.artifacts`' checksummed header; 1 had none."""
TREE_NOISE_VARIANTS = (10, 40)
"""Noisy hearings of each utterance per board in the game-tree check: always, for candidates."""


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

    def add(self, s: np.ndarray, a: int, r: float, s2: np.ndarray, m2: np.ndarray, done: bool):
        i = self.position
        self.states[i], self.actions[i], self.rewards[i] = s, a, r
        self.next_states[i], self.next_masks[i], self.dones[i] = s2, m2, done
        self.position = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

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


@dataclass
class TrainingState:
    """A run's bookkeeping, saved in every checkpoint beside the networks."""

    step: int = 0
    """Experiences collected so far."""
    episodes: int = 0
    updates: int = 0
    elapsed_s: float = 0.0
    """Wall-clock seconds of training before the current session (resumes add up)."""
    outcomes: list[str] = field(default_factory=list)
    """Every finished training dialogue's outcome ("unfinished" when truncated)."""
    reward_curve: list[list[float]] = field(default_factory=list)
    """[experiences, mean reward of the last `log_every` steps] pairs."""
    win_draw_curve: list[list[float]] = field(default_factory=list)
    """[games, win/draw rate of the last 500 games] every 100 games."""
    evaluations: list[dict[str, Any]] = field(default_factory=list)
    best_score: list[float] | None = None
    best_step: int | None = None
    best_state_dict: dict[str, Any] | None = None
    """The weights of the best evaluated policy so far."""
    evaluation_pending: bool = False
    """Ctrl-C stopped the evaluation due at `step`; a resumed run does it first."""


@dataclass
class TrainingResult:
    """What a training run produced."""

    policy: DQNPolicy
    metrics: dict[str, Any]
    out_dir: Path


@dataclass
class _Learner:
    """The networks, optimiser, replay memory and random generator of a run."""

    q_network: QNetwork
    target_network: QNetwork
    optimizer: torch.optim.Optimizer
    replay: ReplayBuffer
    rng: np.random.Generator


def epsilon_at(step: int, config: OxbotConfig) -> float:
    """Linear decay from `epsilon_start` to `epsilon_min` over `exploration_fraction` of the run."""
    a = config.agent
    span = max(1, int(a.exploration_fraction * a.total_steps))
    return max(a.epsilon_min, a.epsilon_start + (a.epsilon_min - a.epsilon_start) * step / span)


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


def td_target(batch: Batch, learner: _Learner, config: AgentConfig) -> torch.Tensor:
    """r + gamma * Q_target(s', a') over the acts offered in s' (a' by the online net with
    Double DQN, by the target net otherwise); r alone at the end of a dialogue."""
    s2_t, m2_t = torch.from_numpy(batch.next_states), torch.from_numpy(batch.next_masks)
    with torch.no_grad():
        next_target = learner.target_network(s2_t).masked_fill(~m2_t, -1e9)
        if config.double_dqn:  # the online net picks a', the target net values it
            online = learner.q_network(s2_t).masked_fill(~m2_t, -1e9)
            next_value = next_target.gather(1, online.argmax(dim=1, keepdim=True)).squeeze(1)
        else:
            next_value = next_target.max(dim=1).values
        not_done = 1.0 - torch.from_numpy(batch.dones)
        return torch.from_numpy(batch.rewards) + config.discount * next_value * not_done


def learn_from(batch: Batch, learner: _Learner, step: int, config: AgentConfig) -> None:
    """One gradient step on the squared TD error of `batch`."""
    target = td_target(batch, learner, config)
    actions = torch.from_numpy(batch.actions)[:, None]
    predicted = learner.q_network(torch.from_numpy(batch.states)).gather(1, actions).squeeze(1)
    loss = F.mse_loss(predicted, target)
    if config.anneal_learning_rate:
        for group in learner.optimizer.param_groups:
            group["lr"] = config.learning_rate * (1.0 - step / config.total_steps)
    learner.optimizer.zero_grad()
    loss.backward()
    learner.optimizer.step()


def evaluation_score(results: dict[str, Any]) -> tuple[float, ...]:
    """Order policies: fewest losing boards (a person who finds one beats the robot every
    time), then fewest people, heard cleanly, whose no, "later" or stop it got wrong
    (`misread_wills`), then most wins against random people counted exactly on the game tree
    (`wins_against_random`; checkpoints often tie there, at the optimum), then fewest lost or
    badly formed dialogues under noise, then most wins in the sampled games. Those measured
    without noise come first because they are sure: 300 sampled games a condition tell
    neither a policy that gives away a point of wins (one board of the tree, docs/dialogue.md)
    nor faults a few dialogues apart."""
    faults = sum(
        round(r["games"] * (r["loss_rate"] + 1 - r["well_formed"]))
        for r in results.values()
        if isinstance(r, dict)
    )
    # absent when evaluate_checkpoint asks about the losing boards alone, before measuring them
    exact = round(sum(results.get("wins_against_random", [])), 9)
    wins = sum(r["win_rate"] for k, r in results.items() if k.startswith("random"))
    return (-results["losing_positions"], -results.get("misread_wills", 0), exact, -faults, wins)


def train_agent(
    config: OxbotConfig,
    out_dir: str | Path,
    resume: bool = True,
    show_progress: bool = True,
    checkpoint_every: int = 20_000,
    log_every: int = 1_000,
    init_from: DQNPolicy | None = None,
) -> TrainingResult:
    """Train the interaction manager with `config` and write its files into `out_dir`.

    With `resume`, continue from `out_dir/checkpoint.pt` if there is one. Ctrl-C saves that
    checkpoint after the step in hand and raises `TrainingInterrupted`. `init_from`, a policy
    of the same architecture, starts the networks from its weights (a fine-tune, as
    `oxbot learn agent` does).
    """
    # The paper's algorithm as one loop read top to bottom, as CleanRL's dqn.py.
    out_dir = Path(out_dir)
    cfg = config.agent
    torch.set_num_threads(1)  # a 60-unit MLP trains fastest on one thread
    # the same seed gives the same weights here; on another CPU, BLAS kernels may still sum in
    # another order (docs/dialogue.md says what differs)
    torch.use_deterministic_algorithms(True)
    clock = _Clock()

    # --- set-up: environment, networks, replay memory, opponents -------------------------------
    env = InteractiveGameEnv(config=config)
    learner = _new_learner(env, cfg, init_from)
    rng = learner.rng
    augment = BatchAugmenter(env, config)
    next_episode = _episode_options(cfg, rng)
    checkpoint_path = out_dir / "checkpoint.pt"
    run = TrainingState()
    if resume and checkpoint_path.exists():
        run = _load_checkpoint(checkpoint_path, config, learner)
        log.info("resumed from %s at step %d", checkpoint_path, run.step)
    saver = _Saver(checkpoint_path, config, learner, run, clock)
    recent_rewards: deque[float] = deque(maxlen=log_every)
    recent_outcomes: deque[str] = deque(run.outcomes[-500:], maxlen=500)

    obs, info = env.reset(seed=cfg.seed + run.step, options=next_episode())
    progress, task = _progress(show_progress, cfg.total_steps, run.step)
    with progress, deferred_interrupt() as stop:
        log.info("training from experience %d of %d", run.step, cfg.total_steps)
        if run.evaluation_pending:
            saver.evaluate_at(run.step, stop)
        for step in range(run.step, cfg.total_steps):
            # 1. act: epsilon-greedy among the offered acts
            epsilon = epsilon_at(step, config)
            action = _epsilon_greedy(learner.q_network, obs, info["action_mask"], epsilon, rng)

            # 2. step the dialogue and store the experience
            next_obs, reward, terminated, truncated, info = env.step(action)
            learner.replay.add(obs, action, reward, next_obs, info["action_mask"], terminated)
            recent_rewards.append(reward)
            obs = next_obs
            if terminated or truncated:
                result = info["outcome"] if terminated and info["outcome"] else "unfinished"
                _count_outcome(run, recent_outcomes, result)
                obs, info = env.reset(options=next_episode())

            # 3. learn from a minibatch
            if step >= cfg.learning_starts and step % cfg.train_frequency == 0:
                batch = augment(learner.replay.sample(cfg.batch_size, rng), rng)
                learn_from(batch, learner, step, cfg)
                run.updates += 1

            # 4. sync the target network every C steps
            if step % cfg.target_update_interval == 0:
                learner.target_network.load_state_dict(learner.q_network.state_dict())

            # 5. log, evaluate, checkpoint
            done_steps = step + 1
            if done_steps % log_every == 0:
                run.reward_curve.append([done_steps, float(np.mean(recent_rewards))])
                stats = _stats(run, recent_outcomes, recent_rewards, epsilon)
                progress.update(task, completed=done_steps, stats=stats)
            if cfg.eval_every and done_steps % cfg.eval_every == 0:
                saver.evaluate_at(done_steps, stop)
            if checkpoint_every and done_steps % checkpoint_every == 0:
                saver.save(done_steps)
            if stop.requested:  # Ctrl-C: this step is whole, save it and stop
                raise saver.interrupted(done_steps)
        progress.update(task, completed=cfg.total_steps)

    # --- the result: the best evaluated network (or the last), its metrics and curves ----------
    run.step = cfg.total_steps
    run.elapsed_s += clock.lap()
    return _finish(config, env, learner, run, out_dir, checkpoint_path, init_from)


def _epsilon_greedy(
    q_network: QNetwork,
    obs: np.ndarray,
    mask: np.ndarray,
    epsilon: float,
    rng: np.random.Generator,
) -> int:
    """A random offered act with probability `epsilon`, else the greedy one."""
    if rng.random() < epsilon:
        return int(rng.choice(np.flatnonzero(mask)))
    with torch.inference_mode():
        q = q_network(torch.from_numpy(obs[None])).numpy()[0]
    return int(masked_argmax(q, mask))


class _Clock:
    """Wall-clock seconds of this session of training, read in laps."""

    def __init__(self) -> None:
        self._since = time.perf_counter()

    def peek(self) -> float:
        """Seconds since the last lap, without starting a new one."""
        return time.perf_counter() - self._since

    def lap(self) -> float:
        """Seconds since the last lap; a new lap starts."""
        now = time.perf_counter()
        seconds, self._since = now - self._since, now
        return seconds


@dataclass
class _Saver:
    """Where a run is saved, and the evaluations that keep its best policy."""

    path: Path
    config: OxbotConfig
    learner: _Learner
    run: TrainingState
    clock: _Clock

    def save(self, step: int) -> None:
        """Write the checkpoint as training stands after `step` experiences."""
        self.run.step = step
        self.run.elapsed_s += self.clock.lap()
        _save_checkpoint(self.path, self.config, self.learner, self.run)

    def interrupted(self, step: int) -> TrainingInterrupted:
        """Save where training stands after `step` experiences; the error to stop with."""
        self.save(step)
        return TrainingInterrupted(
            f"training interrupted after {step:,} of {self.config.agent.total_steps:,} "
            f"experiences; saved the checkpoint {self.path}",
            self.path,
            step,
        )

    def evaluate_at(self, step: int, stop: Any) -> None:
        """The greedy evaluation due after `step` experiences; Ctrl-C stops it at once."""
        elapsed = self.run.elapsed_s + self.clock.peek()
        try:
            with stop.immediately():
                _evaluate_and_keep_best(
                    self.config, self.learner.q_network, self.run, step, elapsed
                )
        except KeyboardInterrupt:
            self.run.evaluation_pending = True
            raise self.interrupted(step) from None
        self.run.evaluation_pending = False


def _new_learner(
    env: InteractiveGameEnv, cfg: AgentConfig, init_from: DQNPolicy | None = None
) -> _Learner:
    """A fresh learner for `env` (its networks from `init_from`'s weights, when given)."""
    rng = np.random.default_rng(cfg.seed)
    torch.manual_seed(cfg.seed)
    board = env.layout.board
    q_network = QNetwork(
        env.layout.n_features,
        cfg.hidden_sizes,
        board_features=(board.start, board.stop) if cfg.board_head else None,
    )
    learner = _Learner(
        q_network=q_network,
        target_network=copy.deepcopy(q_network),
        optimizer=torch.optim.Adam(q_network.parameters(), lr=cfg.learning_rate),
        replay=ReplayBuffer(cfg.replay_size, env.layout.n_features),
        rng=rng,
    )
    if init_from is not None:
        learner.q_network.load_state_dict(init_from.q_network.state_dict())
        learner.target_network.load_state_dict(init_from.q_network.state_dict())
    return learner


def _episode_options(cfg: AgentConfig, rng: np.random.Generator):
    """Who the next training dialogue is with: an opponent from the mix, who starts."""
    mix = opponent_mix(cfg.opponents)
    names = list(mix)
    weights = np.array([mix[n] for n in names])
    opponents = {name: make_opponent(name, rng) for name in names}
    starts = who_starts(cfg.robot_starts, "agent.robot_starts")

    def next_episode() -> dict[str, Any]:
        name = names[rng.choice(len(names), p=weights)]
        return {"opponent": opponents[name], "robot_starts": bool(rng.choice(starts))}

    return next_episode


def _count_outcome(run: TrainingState, recent: deque[str], result: str) -> None:
    run.episodes += 1
    run.outcomes.append(result)
    recent.append(result)
    if run.episodes % 100 == 0:
        rate = sum(o in ("win", "draw") for o in recent) / len(recent)
        run.win_draw_curve.append([run.episodes, rate])


def _stats(run: TrainingState, recent: deque[str], rewards: deque[float], eps: float) -> str:
    n = max(1, len(recent))
    return (
        f"games {run.episodes}  W/D/L {recent.count('win') / n:.0%}/"
        f"{recent.count('draw') / n:.0%}/{recent.count('loss') / n:.0%}  "
        f"eps {eps:.2f}  reward {np.mean(rewards):+.2f}"
    )


def _progress(show: bool, total: int, done: int) -> tuple[Progress, Any]:
    progress = Progress(
        TextColumn("[bold]training[/]"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[stats]}"),
        TimeElapsedColumn(),
        disable=not show,
        transient=False,
    )
    return progress, progress.add_task("train", total=total, completed=done, stats="")


def _finish(
    config: OxbotConfig,
    env: InteractiveGameEnv,
    learner: _Learner,
    run: TrainingState,
    out_dir: Path,
    checkpoint_path: Path,
    init_from: DQNPolicy | None = None,
) -> TrainingResult:
    """Keep the best evaluated network (or the last); write it, its metrics and curves."""
    if config.agent.eval_every and run.best_state_dict is not None:
        learner.q_network.load_state_dict(run.best_state_dict)
    metrics = _metrics(config, run)
    if init_from is not None:  # a fine-tune records what it started from, and so on back
        started = init_from.metadata
        keys = ("config", "seed", "experiences", "games", "wall_clock_s", "best_step", "init_from")
        metrics["init_from"] = {k: started[k] for k in keys if k in started}
    policy = DQNPolicy(learner.q_network, env.layout.names, metadata=_json_safe(metrics))
    out_dir.mkdir(parents=True, exist_ok=True)
    policy.save(out_dir / "agent.pt")
    write_text_atomic(out_dir / "agent_metrics.json", json.dumps(metrics, indent=2) + "\n")
    plot_learning_curves(metrics, out_dir)
    _save_checkpoint(checkpoint_path, config, learner, run)
    return TrainingResult(policy, metrics, out_dir)


def evaluate_checkpoint(
    config: OxbotConfig, policy: Policy, step: int
) -> tuple[dict[str, Any], tuple[float, float]]:
    """How a checkpoint of any learner is judged while it trains (the same for every learner):
    `eval_games` dialogues per opponent and who-starts condition, and the game-tree check,
    looked at harder when nothing else was wrong. The record for the metrics, and the score
    checkpoints are ranked by (`evaluation_score`)."""
    cfg = config.agent
    results: dict[str, Any] = {
        condition_key(name, robot_starts): evaluate(
            policy, name, robot_starts, cfg.eval_games, config, seed=10_000 + step, n_envs=100
        ).summary()
        for name, robot_starts in CONDITIONS
    }
    results["losing_positions"] = sum(
        losing_positions(policy, robot_starts, config, noisy_variants=TREE_NOISE_VARIANTS[0])
        for robot_starts in (True, False)
    )
    if evaluation_score(results)[0] == 0:  # a candidate: look harder for a noisy mistake
        results["losing_positions"] += sum(
            losing_positions(policy, s, config, noisy_variants=TREE_NOISE_VARIANTS[1], seed=step)
            for s in (True, False)
        )
    results["wins_against_random"] = [
        wins_against_random(policy, robot_starts, config) for robot_starts in (True, False)
    ]
    results["misread_wills"] = misread_wills(policy, config, cfg.eval_games, seed=step)
    games = {k: r for k, r in results.items() if isinstance(r, dict)}
    record = {
        "step": step,
        "losing_positions": results["losing_positions"],
        "wins_against_random": [round(w, 6) for w in results["wins_against_random"]],
        "misread_wills": results["misread_wills"],
        **{k: [r["win_rate"], r["draw_rate"], r["loss_rate"]] for k, r in games.items()},
        "well_formed": min(r["well_formed"] for r in games.values()),
        "task_success": min(r["task_success"] for r in games.values()),
    }
    return record, evaluation_score(results)


def _evaluate_and_keep_best(
    config: OxbotConfig, q_network: QNetwork, run: TrainingState, step: int, elapsed: float
) -> None:
    record, score = evaluate_checkpoint(config, greedy_batch_policy(q_network), step)
    run.evaluations.append(
        {"step": step, "episodes": run.episodes, "elapsed_s": round(elapsed, 1), **record}
    )
    if run.best_score is None or tuple(score) >= tuple(run.best_score):
        run.best_score = list(score)
        run.best_step = step
        run.best_state_dict = copy.deepcopy(q_network.state_dict())
    log.info("evaluation at step %d: %s", step, score)


def _metrics(config: OxbotConfig, run: TrainingState) -> dict[str, Any]:
    outcomes = run.outcomes
    return {
        "config": dataclasses.asdict(config),
        "seed": config.agent.seed,
        "experiences": run.step,
        "updates": run.updates,
        "games": run.episodes,
        "wall_clock_s": round(run.elapsed_s, 1),
        "training_outcomes": {o: outcomes.count(o) for o in sorted(set(outcomes))},
        "reward_curve": run.reward_curve,
        "win_draw_curve": run.win_draw_curve,
        "evaluations": run.evaluations,
        "best_step": run.best_step,
    }


def _json_safe(value: Any) -> Any:
    return json.loads(json.dumps(value))


def plot_learning_curves(metrics: dict[str, Any], out_dir: Path) -> None:
    """The paper's Figure "plots" (middle, right) as two PNG files."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for name, key, xlabel, ylabel in (
        ("agent_reward.png", "reward_curve", "experiences", "average reward"),
        ("agent_win_draw.png", "win_draw_curve", "games", "win/draw rate"),
    ):
        points = np.array(metrics[key] or [[0, 0]], dtype=float)
        fig, ax = plt.subplots(figsize=(5, 3.5), dpi=100)
        ax.plot(points[:, 0], points[:, 1], color="tab:blue", linewidth=1.2)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if key == "win_draw_curve":
            ax.set_ylim(0, 1.02)
        ax.set_title(f"{ylabel} while training (exploring)")
        fig.tight_layout()
        save_figure(fig, out_dir / name)


def _save_checkpoint(
    path: Path, config: OxbotConfig, learner: _Learner, run: TrainingState
) -> None:
    payload = {
        "format": CHECKPOINT_FORMAT,
        "config": _json_safe(dataclasses.asdict(config.agent)),
        "q_network": learner.q_network.state_dict(),
        "target_network": learner.target_network.state_dict(),
        "optimizer": learner.optimizer.state_dict(),
        "replay": learner.replay.state_dict(),
        "rng": _json_safe(learner.rng.bit_generator.state),
        "state": {f.name: getattr(run, f.name) for f in dataclasses.fields(run)},
    }
    artifacts.save(path, CHECKPOINT_KIND, CHECKPOINT_VERSION, payload)


def _load_checkpoint(path: Path, config: OxbotConfig, learner: _Learner) -> TrainingState:
    what = "checkpoint"
    remedy = "delete it, or start afresh with --no-resume"
    payload = artifacts.load(
        path,
        CHECKPOINT_KIND,
        CHECKPOINT_VERSION,
        what,
        remedy,
        legacy=lambda p: isinstance(p, dict) and p.get("format") == CHECKPOINT_FORMAT,
    )
    if payload.get("format") != CHECKPOINT_FORMAT:
        raise ModelFileError(
            f"{path} is not an oxbot DQN checkpoint; delete it or use another --out"
        )
    with artifacts.checked(path, what, remedy):
        saved = dict(payload["config"])
    current = _json_safe(dataclasses.asdict(config.agent))
    changed = sorted(k for k in current if k != "total_steps" and saved.get(k) != current[k])
    if changed:
        raise ModelFileError(
            f"checkpoint {path} was made with other agent settings ({', '.join(changed)}); "
            "use the same settings to resume, or --no-resume"
        )
    with artifacts.checked(path, "checkpoint (does not match this run)", remedy):
        learner.q_network.load_state_dict(payload["q_network"])
        learner.target_network.load_state_dict(payload["target_network"])
        run = TrainingState(**payload["state"])
        learner.optimizer.load_state_dict(payload["optimizer"])
        learner.replay.load_state_dict(payload["replay"])
        learner.rng.bit_generator.state = payload["rng"]
    return run
