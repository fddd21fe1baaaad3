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
import os
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from oxbot import artifacts
from oxbot.atomic import save_figure, write_text_atomic
from oxbot.config import AgentConfig, OxbotConfig
from oxbot.dialogue.agent import DQNPolicy, QNetwork, masked_argmax
from oxbot.dialogue.checkpoint_evaluation import Checkpoint, CheckpointJudge, Judged
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.replay import Batch, BatchAugmenter, ReplayBuffer
from oxbot.dialogue.vector_env import training_envs
from oxbot.errors import ModelFileError, TrainingInterrupted
from oxbot.interrupt import deferred_interrupt

log = logging.getLogger(__name__)

CHECKPOINT_FORMAT = "oxbot-dqn-checkpoint/1"
CHECKPOINT_KIND = "agent-checkpoint"
CHECKPOINT_VERSION = 2
"""2: behind `oxbot.artifacts`' checksummed header; 1 had none."""


@dataclass
class TrainingState:
    """A run's bookkeeping, saved in every checkpoint beside the networks."""

    step: int = 0
    """Experiences collected so far."""
    episodes: int = 0
    updates: int = 0
    elapsed_s: float = 0.0
    """Wall-clock seconds of training before the current session (resumes add up)."""
    cpu_s: float = 0.0
    """CPU seconds of the same, this process's and the checkpoint judge's."""
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
    waiting_evaluations: list[dict[str, Any]] = field(default_factory=list)
    """Checkpoints made but not yet judged when the run stopped (`Checkpoint.as_dict`); a
    resumed run judges them first."""


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
    # The paper's algorithm as one loop read top to bottom, as CleanRL's dqn.py, over `n_envs`
    # dialogues at once: each pass adds n_envs experiences, and learns once per
    # `train_frequency` of them, as one dialogue at a time would.
    out_dir = Path(out_dir)
    cfg = config.agent
    torch.set_num_threads(1)  # a 128-unit MLP trains fastest on one thread
    # the same seed gives the same weights here; on another CPU, BLAS kernels may still sum in
    # another order (docs/dialogue.md says what differs)
    torch.use_deterministic_algorithms(True)
    clock = _Clock()

    # --- set-up: environments, networks, replay memory, the judge of checkpoints ---------------
    envs = training_envs(config, cfg.n_envs)
    env: InteractiveGameEnv = envs.envs[0].unwrapped
    learner = _new_learner(env, cfg, init_from)
    rng = learner.rng
    augment = BatchAugmenter(env, config)
    checkpoint_path = out_dir / "checkpoint.pt"
    run = TrainingState()
    if resume and checkpoint_path.exists():
        run = _load_checkpoint(checkpoint_path, config, learner)
        log.info("resumed from %s at step %d", checkpoint_path, run.step)
    judge = CheckpointJudge(config, learner.q_network, background=cfg.eval_in_background)
    for waiting in run.waiting_evaluations:
        judge.submit(Checkpoint(**waiting))
    saver = _Saver(checkpoint_path, config, learner, run, clock, judge)
    recent_rewards: deque[float] = deque(maxlen=log_every)
    recent_outcomes: deque[str] = deque(run.outcomes[-500:], maxlen=500)

    obs, info = envs.reset(seed=cfg.seed + run.step)
    masks = info["action_mask"]
    progress, task = _progress(show_progress, cfg.total_steps, run.step)
    try:
        with progress, deferred_interrupt() as stop:
            log.info("training from experience %d of %d", run.step, cfg.total_steps)
            step = run.step
            while step < cfg.total_steps:
                n = min(cfg.n_envs, cfg.total_steps - step)  # the last pass may keep fewer
                # 1. act: epsilon-greedy among the offered acts, one batched forward pass
                epsilon = epsilon_at(step, config)
                actions = _epsilon_greedy(learner.q_network, obs, masks, epsilon, rng)

                # 2. step the dialogues and store the experiences
                transition = envs.step(actions)
                _store(transition, obs, actions, n, learner.replay, run, recent_outcomes)
                obs, rewards, _, _, info = transition
                recent_rewards.extend(rewards[:n].tolist())
                masks = info["action_mask"]

                # 3. learn from minibatches
                for k in _due(step, n, cfg.train_frequency, cfg.learning_starts):
                    batch = augment(learner.replay.sample(cfg.batch_size, rng), rng)
                    learn_from(batch, learner, k, cfg)
                    run.updates += 1

                # 4. sync the target network every C steps
                if _due(step, n, cfg.target_update_interval):
                    learner.target_network.load_state_dict(learner.q_network.state_dict())

                # 5. log, evaluate, checkpoint
                done_steps = step + n
                if _due(step + 1, n, log_every):
                    run.reward_curve.append([done_steps, float(np.mean(recent_rewards))])
                    stats = _stats(run, recent_outcomes, recent_rewards, epsilon)
                    progress.update(task, completed=done_steps, stats=stats)
                if cfg.eval_every and _due(step + 1, n, cfg.eval_every):
                    saver.evaluate_at(done_steps)
                saver.keep_judged(stop, done_steps)
                if checkpoint_every and _due(step + 1, n, checkpoint_every):
                    saver.save(done_steps)
                step = done_steps
                if stop.requested:  # Ctrl-C: these steps are whole, save them and stop
                    raise saver.interrupted(done_steps)
            saver.keep_judged(stop, step, wait=True)
            progress.update(task, completed=cfg.total_steps)
    finally:
        judge.close()
        envs.close()

    # --- the result: the best evaluated network (or the last), its metrics and curves ----------
    run.step = cfg.total_steps
    _add_laps(run, clock)
    return _finish(config, env, learner, run, out_dir, checkpoint_path, init_from)


def _add_laps(run: TrainingState, clock: _Clock) -> None:
    wall, cpu = clock.lap()
    run.elapsed_s += wall
    run.cpu_s += cpu


def _store(
    transition: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]],
    obs: np.ndarray,
    actions: np.ndarray,
    n: int,
    replay: ReplayBuffer,
    run: TrainingState,
    recent_outcomes: deque[str],
) -> None:
    """Store the first `n` dialogues' experiences of one vector step; count those that ended."""
    next_obs, rewards, terminated, truncated, info = transition
    ended = terminated | truncated
    last_obs, last_masks = _last_observations(next_obs, info, ended)
    replay.add_batch(
        obs[:n], actions[:n], rewards[:n], last_obs[:n], last_masks[:n], terminated[:n]
    )
    for i in np.flatnonzero(ended[:n]):
        outcome = info["final_info"]["outcome"][i]
        _count_outcome(run, recent_outcomes, outcome if terminated[i] and outcome else "unfinished")


def _due(start: int, n: int, every: int, first: int = 0) -> list[int]:
    """The steps of `start`, ..., `start + n - 1` that are multiples of `every` and >= `first`."""
    return [k for k in range(max(start, first), start + n) if k % every == 0]


def _last_observations(
    obs: np.ndarray, info: dict[str, Any], ended: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """What each dialogue's step led to: its next observation and offered acts, or, for a
    dialogue that just ended (and was reset at once), its last ones."""
    last_obs, last_masks = obs.copy(), info["action_mask"].copy()
    for i in np.flatnonzero(ended):
        last_obs[i] = info["final_obs"][i]
        last_masks[i] = info["final_info"]["action_mask"][i]
    return last_obs, last_masks


def _epsilon_greedy(
    q_network: QNetwork,
    obs: np.ndarray,
    masks: np.ndarray,
    epsilon: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """For each row, a random offered act with probability `epsilon`, else the greedy one."""
    with torch.inference_mode():
        q = q_network(torch.from_numpy(obs)).numpy()
    actions = masked_argmax(q, masks)
    explore = rng.random(len(obs)) < epsilon
    # uniform among the offered acts: the largest of one uniform draw per offered act
    random_acts = np.argmax(np.where(masks, rng.random(masks.shape), -1.0), axis=1)
    return np.where(explore, random_acts, actions)


class _Clock:
    """Wall-clock and CPU seconds of this session of training, read in laps. CPU counts this
    process and its finished children (the judge's process, once closed)."""

    def __init__(self) -> None:
        self._since = time.perf_counter()
        self._cpu_since = _cpu_seconds()

    def peek(self) -> float:
        """Seconds since the last lap, without starting a new one."""
        return time.perf_counter() - self._since

    def lap(self) -> tuple[float, float]:
        """Wall-clock and CPU seconds since the last lap; a new lap starts."""
        now, cpu = time.perf_counter(), _cpu_seconds()
        laps = (now - self._since, cpu - self._cpu_since)
        self._since, self._cpu_since = now, cpu
        return laps


def _cpu_seconds() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@dataclass
class _Saver:
    """Where a run is saved, and the judged checkpoints that keep its best policy."""

    path: Path
    config: OxbotConfig
    learner: _Learner
    run: TrainingState
    clock: _Clock
    judge: CheckpointJudge

    def save(self, step: int) -> None:
        """Write the checkpoint as training stands after `step` experiences."""
        self.run.step = step
        _add_laps(self.run, self.clock)
        self.run.waiting_evaluations = [c.as_dict() for c, _job in self.judge.waiting]
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

    def evaluate_at(self, step: int) -> None:
        """Hand the weights after `step` experiences to the judge."""
        elapsed = round(self.run.elapsed_s + self.clock.peek(), 1)
        weights = copy.deepcopy(self.learner.q_network.state_dict())
        self.judge.submit(Checkpoint(step, self.run.episodes, elapsed, weights))

    def keep_judged(self, stop: Any, step: int, wait: bool = False) -> None:
        """Record what the judge has finished, keeping the best policy; with `wait`, all of it.
        Ctrl-C while judging here stops at once, what is still waiting saved."""
        try:
            with stop.immediately():
                for judged in self.judge.judged(wait=wait):
                    _keep_if_best(self.run, judged)
        except KeyboardInterrupt:
            raise self.interrupted(step) from None


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


def _keep_if_best(run: TrainingState, judged: Judged) -> None:
    """Record a judged checkpoint; keep its weights if it ranks at least as high as the best."""
    checkpoint = judged.checkpoint
    run.evaluations.append(
        {
            "step": checkpoint.step,
            "episodes": checkpoint.episodes,
            "elapsed_s": checkpoint.elapsed_s,
            **judged.record,
        }
    )
    if run.best_score is None or tuple(judged.score) >= tuple(run.best_score):
        run.best_score = list(judged.score)
        run.best_step = checkpoint.step
        run.best_state_dict = checkpoint.weights
    log.info("evaluation at step %d: %s", checkpoint.step, judged.score)


def _metrics(config: OxbotConfig, run: TrainingState) -> dict[str, Any]:
    outcomes = run.outcomes
    return {
        "config": dataclasses.asdict(config),
        "seed": config.agent.seed,
        "experiences": run.step,
        "updates": run.updates,
        "games": run.episodes,
        "wall_clock_s": round(run.elapsed_s, 1),
        "cpu_s": round(run.cpu_s, 1),
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
        state = dict(payload["state"])
        state.pop("evaluation_pending", None)  # older runs judged in this process only
        run = TrainingState(**state)
        learner.optimizer.load_state_dict(payload["optimizer"])
        learner.replay.load_state_dict(payload["replay"])
        learner.rng.bit_generator.state = payload["rng"]
    return run
