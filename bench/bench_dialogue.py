"""Benchmark of learning to interact: env steps/s, training updates/s, time to each milestone.

    .venv/bin/python bench/bench_dialogue.py            # everything (about 5 minutes)
    .venv/bin/python bench/bench_dialogue.py --quick    # no milestone run

Prints medians over repeats. The milestones come from one training run of the shipped
configuration (`oxbot/data/models/agent.toml`) with greedy evaluations every 10,000 experiences
against the random person in both who-starts conditions: the wall-clock time at which the
greedy policy first reaches 98% win/draw, and first has 0 losses. Not a test.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from oxbot.config import load_config, with_overrides
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.training import train_agent

SHIPPED = Path(__file__).resolve().parent.parent / "oxbot" / "data" / "models" / "agent.toml"


def env_steps_per_second(steps: int = 20_000) -> float:
    """Steps of the environment with uniformly random offered acts."""
    env = InteractiveGameEnv()
    rng = np.random.default_rng(0)
    _, info = env.reset(seed=0)
    started = time.perf_counter()
    for _ in range(steps):
        action = rng.choice(np.flatnonzero(info["action_mask"]))
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            _, info = env.reset()
    return steps / (time.perf_counter() - started)


def updates_per_second(steps: int = 12_000) -> float:
    """Minibatch updates per second of a whole training run (acting and stepping included)."""
    config = load_config(SHIPPED, [f"agent.total_steps={steps}", "agent.eval_every=0"])
    with tempfile.TemporaryDirectory() as out:
        result = train_agent(config, out, resume=False, show_progress=False, checkpoint_every=0)
    return result.metrics["updates"] / result.metrics["wall_clock_s"]


def milestones() -> dict[str, float | None]:
    """Wall-clock seconds until the greedy policy reaches 98% win/draw and 0 losses vs random."""
    config = load_config(SHIPPED)
    config = with_overrides(config, {"agent": {"eval_every": 10_000, "eval_games": 500}})
    with tempfile.TemporaryDirectory() as out:
        result = train_agent(config, out, resume=False, show_progress=False, checkpoint_every=0)
    found: dict[str, float | None] = {"98% win/draw": None, "0 losses": None}
    for evaluation in result.metrics["evaluations"]:
        outcomes = [evaluation["random/robot"], evaluation["random/person"]]
        if found["98% win/draw"] is None and all(w + d >= 0.98 for w, d, _ in outcomes):
            found["98% win/draw"] = evaluation["elapsed_s"]
        if found["0 losses"] is None and all(loss == 0 for _, _, loss in outcomes):
            found["0 losses"] = evaluation["elapsed_s"]
    found["whole run"] = result.metrics["wall_clock_s"]
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the milestone training run")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    torch.set_num_threads(1)
    steps = [env_steps_per_second() for _ in range(args.repeats)]
    print(f"env steps/s (random offered acts): median {statistics.median(steps):,.0f}")
    updates = [updates_per_second() for _ in range(max(1, args.repeats // 2))]
    print(f"training updates/s (whole loop):   median {statistics.median(updates):,.0f}")
    if not args.quick:
        found = milestones()
        whole = found.pop("whole run")
        for name, seconds in found.items():
            shown = "not reached" if seconds is None else f"{seconds:.0f} s"
            print(f"time to {name} vs the random person: {shown} (one run)")
        print(f"whole training run of the shipped configuration: {whole:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
