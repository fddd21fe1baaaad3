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
- `checkpoint.pt`: everything needed to resume (written atomically every `checkpoint_every`).
"""

from __future__ import annotations

import copy
import dataclasses
import json
import logging
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from oxbot.atomic import atomic_write, write_text_atomic
from oxbot.config import OxbotConfig, opponent_mix
from oxbot.dialogue.agent import DQNPolicy, QNetwork
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.evaluation import evaluate, losing_positions
from oxbot.errors import ModelFileError
from oxbot.game.opponents import make_opponent

log = logging.getLogger(__name__)

CHECKPOINT_FORMAT = "oxbot-dqn-checkpoint/1"
STARTS = {"yes": (True,), "no": (False,), "both": (True, False)}
TREE_NOISE_VARIANTS = (10, 40)
"""Noisy hearings of each utterance per board in the game-tree check: always, for candidates."""


class ReplayBuffer:
    """The experience replay memory D: a ring of (s, a, r, s', offered in s', terminal)."""

    def __init__(self, capacity: int, n_features: int, n_actions: int = 18) -> None:
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

    def sample(self, batch_size: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        """A minibatch drawn uniformly at random, MB ~ U(D)."""
        i = rng.integers(self.size, size=batch_size)
        return (
            self.states[i],
            self.actions[i],
            self.rewards[i],
            self.next_states[i],
            self.next_masks[i],
            self.dones[i],
        )

    def state_dict(self) -> dict[str, Any]:
        n = self.size
        return {
            "states": torch.from_numpy(self.states[:n].copy()),
            "actions": torch.from_numpy(self.actions[:n].copy()),
            "rewards": torch.from_numpy(self.rewards[:n].copy()),
            "next_states": torch.from_numpy(self.next_states[:n].copy()),
            "next_masks": torch.from_numpy(self.next_masks[:n].copy()),
            "dones": torch.from_numpy(self.dones[:n].copy()),
            "position": self.position,
        }

    def load_state_dict(self, data: dict[str, Any]) -> None:
        n = len(data["actions"])
        for name in ("states", "actions", "rewards", "next_states", "next_masks", "dones"):
            getattr(self, name)[:n] = data[name].numpy()
        self.size = n
        self.position = int(data["position"])


@dataclass
class TrainingResult:
    """What a training run produced."""

    policy: DQNPolicy
    metrics: dict[str, Any]
    out_dir: Path


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


def greedy_batch_policy(q_network: QNetwork):
    """The network as a batch policy for `evaluate` (greedy over the offered acts)."""

    def act(states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            q = q_network(torch.from_numpy(np.asarray(states, dtype=np.float32))).numpy()
        return np.argmax(np.where(masks, q, -np.inf), axis=1)

    return act


def evaluation_score(results: dict[str, Any]) -> tuple[float, float]:
    """Order policies: fewest losing boards and lost or badly formed games, then most wins."""
    faults = results["losing_positions"] + sum(
        round(r["games"] * (r["loss_rate"] + 1 - r["well_formed"]))
        for r in results.values()
        if isinstance(r, dict)
    )
    wins = sum(r["win_rate"] for k, r in results.items() if k.startswith("random"))
    return (-faults, wins)


def train_agent(
    config: OxbotConfig,
    out_dir: str | Path,
    resume: bool = True,
    show_progress: bool = True,
    checkpoint_every: int = 20_000,
    log_every: int = 1_000,
) -> TrainingResult:
    """Train the interaction manager with `config` and write its files into `out_dir`."""
    out_dir = Path(out_dir)
    cfg = config.agent
    torch.set_num_threads(1)  # a 60-unit MLP trains fastest on one thread
    started_at = time.perf_counter()

    # --- set-up: environment, networks, replay memory, opponents -------------------------------
    env = InteractiveGameEnv(config=config)
    layout = env.layout
    rng = np.random.default_rng(cfg.seed)
    torch.manual_seed(cfg.seed)
    q_network = QNetwork(layout.n_features, cfg.hidden_sizes)
    target_network = copy.deepcopy(q_network)
    optimizer = torch.optim.Adam(q_network.parameters(), lr=cfg.learning_rate)
    replay = ReplayBuffer(cfg.replay_size, layout.n_features)
    mix = opponent_mix(cfg.opponents)
    opponent_names = list(mix)
    opponent_weights = np.array([mix[n] for n in opponent_names])
    opponents = {name: make_opponent(name, rng) for name in opponent_names}
    starts = STARTS[cfg.robot_starts]
    feature_perm, action_perm = layout.symmetry_permutations()
    mask_perm = np.argsort(action_perm, axis=1)  # new_mask = old_mask[mask_perm[k]]
    rows = np.arange(cfg.batch_size)[:, None]
    binarize = config.dialogue.nb_binarize

    def episode_options() -> dict[str, Any]:
        name = opponent_names[rng.choice(len(opponent_names), p=opponent_weights)]
        return {"opponent": opponents[name], "robot_starts": bool(rng.choice(starts))}

    # --- curves and bookkeeping ---------------------------------------------------------------
    state: dict[str, Any] = {
        "step": 0,
        "episodes": 0,
        "outcomes": [],
        "reward_curve": [],
        "win_draw_curve": [],
        "evaluations": [],
        "best_score": None,
        "best_state_dict": None,
        "elapsed_s": 0.0,
        "updates": 0,
    }
    checkpoint_path = out_dir / "checkpoint.pt"
    if resume and checkpoint_path.exists():
        state = _load_checkpoint(
            checkpoint_path, config, q_network, target_network, optimizer, replay, rng
        )
        log.info("resumed from %s at step %d", checkpoint_path, state["step"])
    recent_rewards: deque[float] = deque(maxlen=log_every)
    recent_outcomes: deque[str] = deque(maxlen=500)
    recent_outcomes.extend(state["outcomes"][-500:])
    episode_reward = 0.0

    obs, info = env.reset(seed=cfg.seed + state["step"], options=episode_options())
    progress = Progress(
        TextColumn("[bold]training[/]"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[stats]}"),
        TimeElapsedColumn(),
        disable=not show_progress,
        transient=False,
    )
    task = progress.add_task("train", total=cfg.total_steps, completed=state["step"], stats="")
    with progress:
        for step in range(state["step"], cfg.total_steps):
            # 1. act: epsilon-greedy among the offered acts
            epsilon = epsilon_at(step, config)
            mask = info["action_mask"]
            if rng.random() < epsilon:
                action = int(rng.choice(np.flatnonzero(mask)))
            else:
                with torch.inference_mode():
                    q = q_network(torch.from_numpy(obs[None])).numpy()[0]
                action = int(np.argmax(np.where(mask, q, -np.inf)))

            # 2. step the dialogue and store the experience
            next_obs, reward, terminated, truncated, info = env.step(action)
            replay.add(obs, action, reward, next_obs, info["action_mask"], terminated)
            recent_rewards.append(reward)
            episode_reward += reward
            obs = next_obs
            if terminated or truncated:
                result = info["outcome"] if terminated and info["outcome"] else "unfinished"
                state["episodes"] += 1
                state["outcomes"].append(result)
                recent_outcomes.append(result)
                if state["episodes"] % 100 == 0:
                    rate = sum(o in ("win", "draw") for o in recent_outcomes) / len(recent_outcomes)
                    state["win_draw_curve"].append([state["episodes"], rate])
                episode_reward = 0.0
                obs, info = env.reset(options=episode_options())

            # 3. learn from a minibatch
            if step >= cfg.learning_starts and step % cfg.train_frequency == 0:
                s, a, r, s2, m2, done = replay.sample(cfg.batch_size, rng)
                if cfg.symmetries:  # the same experience seen rotated or mirrored
                    k = rng.integers(len(feature_perm), size=cfg.batch_size)
                    s = s[rows, feature_perm[k]]
                    s2 = s2[rows, feature_perm[k]]
                    a = action_perm[k, a]
                    m2 = m2[rows, mask_perm[k]]
                if cfg.misheard_words:  # a word heard with low confidence changes nothing
                    s = add_misheard_words(s, cfg.misheard_words, layout.n_words, binarize, rng)
                s_t, s2_t = torch.from_numpy(s), torch.from_numpy(s2)
                m2_t = torch.from_numpy(m2)
                with torch.no_grad():
                    next_target = target_network(s2_t).masked_fill(~m2_t, -1e9)
                    if cfg.double_dqn:  # the online net picks a', the target net values it
                        best = q_network(s2_t).masked_fill(~m2_t, -1e9).argmax(dim=1, keepdim=True)
                        next_value = next_target.gather(1, best).squeeze(1)
                    else:
                        next_value = next_target.max(dim=1).values
                    target = torch.from_numpy(r) + cfg.discount * next_value * (
                        1.0 - torch.from_numpy(done)
                    )
                predicted = q_network(s_t).gather(1, torch.from_numpy(a)[:, None]).squeeze(1)
                loss = F.mse_loss(predicted, target)
                if cfg.anneal_learning_rate:
                    for group in optimizer.param_groups:
                        group["lr"] = cfg.learning_rate * (1.0 - step / cfg.total_steps)
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
                state["updates"] += 1

            # 4. sync the target network every C steps
            if step % cfg.target_update_interval == 0:
                target_network.load_state_dict(q_network.state_dict())

            # 5. log, evaluate, checkpoint
            done_steps = step + 1
            if done_steps % log_every == 0:
                state["reward_curve"].append([done_steps, float(np.mean(recent_rewards))])
                recent = list(recent_outcomes)
                n = max(1, len(recent))
                stats = (
                    f"games {state['episodes']}  W/D/L {recent.count('win') / n:.0%}/"
                    f"{recent.count('draw') / n:.0%}/{recent.count('loss') / n:.0%}  "
                    f"eps {epsilon:.2f}  reward {np.mean(recent_rewards):+.2f}"
                )
                progress.update(task, completed=done_steps, stats=stats)
            if cfg.eval_every and done_steps % cfg.eval_every == 0:
                elapsed = state["elapsed_s"] + time.perf_counter() - started_at
                _evaluate_and_keep_best(config, q_network, state, done_steps, elapsed)
            if checkpoint_every and done_steps % checkpoint_every == 0:
                state["step"] = done_steps
                state["elapsed_s"] += time.perf_counter() - started_at
                started_at = time.perf_counter()
                _save_checkpoint(
                    checkpoint_path,
                    config,
                    q_network,
                    target_network,
                    optimizer,
                    replay,
                    rng,
                    state,
                )
        progress.update(task, completed=cfg.total_steps)

    # --- the result: the best evaluated network (or the last), its metrics and curves ----------
    state["step"] = cfg.total_steps
    state["elapsed_s"] += time.perf_counter() - started_at
    if cfg.eval_every and state["best_state_dict"] is not None:
        q_network.load_state_dict(state["best_state_dict"])
    metrics = _metrics(config, state)
    policy = DQNPolicy(q_network, layout.names, metadata=_json_safe(metrics))
    out_dir.mkdir(parents=True, exist_ok=True)
    policy.save(out_dir / "agent.pt")
    write_text_atomic(out_dir / "agent_metrics.json", json.dumps(metrics, indent=2) + "\n")
    plot_learning_curves(metrics, out_dir)
    _save_checkpoint(
        checkpoint_path, config, q_network, target_network, optimizer, replay, rng, state
    )
    return TrainingResult(policy, metrics, out_dir)


def _evaluate_and_keep_best(
    config: OxbotConfig, q_network: QNetwork, state: dict[str, Any], step: int, elapsed: float
) -> None:
    cfg = config.agent
    policy = greedy_batch_policy(q_network)
    results = {}
    for name in ("random", "blocker", "minimax"):
        for robot_starts in (True, False):
            result = evaluate(
                policy, name, robot_starts, cfg.eval_games, config, seed=10_000 + step, n_envs=100
            )
            results[f"{name}/{'robot' if robot_starts else 'person'}"] = result.summary()
    results["losing_positions"] = sum(
        losing_positions(policy, robot_starts, config, noisy_variants=TREE_NOISE_VARIANTS[0])
        for robot_starts in (True, False)
    )
    if evaluation_score(results)[0] == 0:  # a candidate: look harder for a noisy mistake
        results["losing_positions"] += sum(
            losing_positions(policy, s, config, noisy_variants=TREE_NOISE_VARIANTS[1], seed=step)
            for s in (True, False)
        )
    score = evaluation_score(results)
    state["evaluations"].append(
        {
            "step": step,
            "episodes": state["episodes"],
            "elapsed_s": round(elapsed, 1),
            "losing_positions": results["losing_positions"],
            **{
                k: [r["win_rate"], r["draw_rate"], r["loss_rate"]]
                for k, r in results.items()
                if isinstance(r, dict)
            },
            "well_formed": min(r["well_formed"] for r in results.values() if isinstance(r, dict)),
        }
    )
    if state["best_score"] is None or tuple(score) >= tuple(state["best_score"]):
        state["best_score"] = list(score)
        state["best_step"] = step
        state["best_state_dict"] = copy.deepcopy(q_network.state_dict())
    log.info("evaluation at step %d: %s", step, score)


def _metrics(config: OxbotConfig, state: dict[str, Any]) -> dict[str, Any]:
    outcomes = state["outcomes"]
    return {
        "config": dataclasses.asdict(config),
        "seed": config.agent.seed,
        "experiences": state["step"],
        "updates": state["updates"],
        "games": state["episodes"],
        "wall_clock_s": round(state["elapsed_s"], 1),
        "training_outcomes": {o: outcomes.count(o) for o in sorted(set(outcomes))},
        "reward_curve": state["reward_curve"],
        "win_draw_curve": state["win_draw_curve"],
        "evaluations": state["evaluations"],
        "best_step": state.get("best_step"),
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
        with atomic_write(out_dir / name, "wb") as handle:
            fig.savefig(handle, format="png")
        plt.close(fig)


def _save_checkpoint(
    path: Path,
    config: OxbotConfig,
    q_network: QNetwork,
    target_network: QNetwork,
    optimizer: torch.optim.Optimizer,
    replay: ReplayBuffer,
    rng: np.random.Generator,
    state: dict[str, Any],
) -> None:
    payload = {
        "format": CHECKPOINT_FORMAT,
        "config": _json_safe(dataclasses.asdict(config.agent)),
        "q_network": q_network.state_dict(),
        "target_network": target_network.state_dict(),
        "optimizer": optimizer.state_dict(),
        "replay": replay.state_dict(),
        "rng": _json_safe(rng.bit_generator.state),
        "state": state,
    }
    with atomic_write(path, "wb") as handle:
        torch.save(payload, handle)


def _load_checkpoint(
    path: Path,
    config: OxbotConfig,
    q_network: QNetwork,
    target_network: QNetwork,
    optimizer: torch.optim.Optimizer,
    replay: ReplayBuffer,
    rng: np.random.Generator,
) -> dict[str, Any]:
    try:
        payload = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as exc:
        raise ModelFileError(f"checkpoint {path} cannot be read ({exc}); delete it") from None
    if not isinstance(payload, dict) or payload.get("format") != CHECKPOINT_FORMAT:
        raise ModelFileError(
            f"{path} is not an oxbot DQN checkpoint; delete it or use another --out"
        )
    saved = dict(payload["config"])
    current = _json_safe(dataclasses.asdict(config.agent))
    changed = sorted(k for k in current if k != "total_steps" and saved.get(k) != current[k])
    if changed:
        raise ModelFileError(
            f"checkpoint {path} was made with other agent settings ({', '.join(changed)}); "
            "use the same settings to resume, or --no-resume"
        )
    try:
        q_network.load_state_dict(payload["q_network"])
        target_network.load_state_dict(payload["target_network"])
    except RuntimeError as exc:
        raise ModelFileError(f"checkpoint {path} does not match the network: {exc}") from None
    optimizer.load_state_dict(payload["optimizer"])
    replay.load_state_dict(payload["replay"])
    rng.bit_generator.state = payload["rng"]
    return payload["state"]
