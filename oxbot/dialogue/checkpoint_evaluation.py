"""How a training run's checkpoints are judged, and the judging done beside training.

Every learner's checkpoints are judged the same way (`evaluate_checkpoint`): greedy dialogues
with every opponent from both starts, the game-tree checks, and people whose no or stop must be
let go; `evaluation_score` ranks them. A `CheckpointJudge` judges a run's checkpoints in the
order they were made, in a second process while training goes on (the machine's other core),
or in this one. Judging never changes what training does next, so both give the same policy.
"""

from __future__ import annotations

import multiprocessing
import signal
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import torch

from oxbot.config import OxbotConfig
from oxbot.dialogue.agent import QNetwork, greedy_batch_policy
from oxbot.dialogue.evaluation import (
    CONDITIONS,
    Policy,
    condition_key,
    evaluate,
    losing_positions,
    misread_wills,
    wins_against_random,
)

TREE_NOISE_VARIANTS = (10, 40)
"""Noisy hearings of each utterance per board in the game-tree check: always, for candidates."""


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


@dataclass
class Checkpoint:
    """A checkpoint waiting to be judged: the weights after `step` experiences."""

    step: int
    episodes: int
    """Training dialogues finished when it was made."""
    elapsed_s: float
    """Wall-clock seconds of training when it was made."""
    weights: dict[str, Any]

    def as_dict(self) -> dict[str, Any]:
        """Its fields, the weights as they are (`dataclasses.asdict` would copy every tensor)."""
        return dict(vars(self))


@dataclass
class Judged:
    """A judged checkpoint: the record kept in the metrics, and its rank."""

    checkpoint: Checkpoint
    record: dict[str, Any]
    score: tuple[float, ...]


class CheckpointJudge:
    """Judges checkpoints of one network shape in the order they come (see the module)."""

    def __init__(self, config: OxbotConfig, network: QNetwork, background: bool) -> None:
        self.config = config
        self.shape = {
            "n_features": network.n_features,
            "hidden_sizes": network.hidden_sizes,
            "board_features": network.board_features,
        }
        self.waiting: list[tuple[Checkpoint, Any]] = []
        self._pool = None
        if background:
            context = multiprocessing.get_context("spawn")
            self._pool = context.Pool(1, initializer=_worker_starts)

    def submit(self, checkpoint: Checkpoint) -> None:
        """Queue `checkpoint` (judged at once in the background, else by `judged`)."""
        job = None
        if self._pool is not None:
            job = self._pool.apply_async(
                judge, (self.config, self.shape, checkpoint.weights, checkpoint.step)
            )
        self.waiting.append((checkpoint, job))

    def judged(self, wait: bool = False) -> Iterator[Judged]:
        """The checkpoints judged so far, oldest first; with `wait`, every one submitted.

        In this process, judging happens here (Ctrl-C leaves the rest waiting)."""
        while self.waiting:
            checkpoint, job = self.waiting[0]
            if job is None:
                record, score = judge(self.config, self.shape, checkpoint.weights, checkpoint.step)
            elif wait or job.ready():
                record, score = job.get()
            else:
                return
            self.waiting.pop(0)
            yield Judged(checkpoint, record, score)

    def close(self) -> None:
        """Stop the second process at once (what it was judging stays waiting)."""
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None


def judge(
    config: OxbotConfig, shape: dict[str, Any], weights: dict[str, Any], step: int
) -> tuple[dict[str, Any], tuple[float, ...]]:
    """`evaluate_checkpoint` of the greedy policy of a network of `shape` with `weights`."""
    network = QNetwork(**shape)
    network.load_state_dict(weights)
    return evaluate_checkpoint(config, greedy_batch_policy(network.eval()), step)


def _worker_starts() -> None:
    # Ctrl-C is the trainer's to handle: it saves what is still waiting in its checkpoint
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    torch.set_num_threads(1)
