"""Benchmark of oxbot's learners against off-the-shelf peers, side by side in one run.

    .venv/bin/python bench/bench_peers.py             # the shipped configurations (about 15 min)
    .venv/bin/python bench/bench_peers.py --quick     # small budgets (about 1 min)

Learning to perceive: the CNN+SVM and a scikit-learn linear SVM on raw pixels fit the same
generated images; medians of `--repeats` fits, accuracy on the same test sets. Learning to
interact: oxbot's DQN trains from scratch with `oxbot/data/models/agent.toml`, then SB3's DQN
and sb3-contrib's MaskablePPO train for the same wall-clock time on
`oxbot/NoughtsAndCrosses-v0`; one run each (minutes apiece): time to the first greedy
evaluation without a loss, and the last policies' win/draw/loss in the six conditions.
`oxbot reproduce` runs the same comparison and writes it into reports/REPORT.md. Not a test.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from oxbot.config import OxbotConfig, PerceptionConfig, load_config
from oxbot.peers import CONDITIONS, PixelSVM, condition_key
from oxbot.perception.augment import generate
from oxbot.perception.classifier import SymbolClassifier, label_indices
from oxbot.perception.evaluation import TRAIN_STREAM, evaluate, generated_test_set
from oxbot.perception.seeds import load_seeds
from oxbot.reproduce import (
    FULL,
    LEARNER_NAMES,
    QUICK,
    agent_config_for,
    train_agent_peers,
    train_and_evaluate_agent,
)

SHIPPED = Path(__file__).resolve().parent.parent / "oxbot" / "data" / "models" / "agent.toml"


def perception(images: int, repeats: int) -> None:
    """Fit times (medians) and accuracies of the CNN+SVM and the pixel SVM on the same images."""
    config = PerceptionConfig()
    seeds = load_seeds()
    x, y = generate(seeds, images, np.random.default_rng([config.seed, TRAIN_STREAM]), 40)
    test_x, test_y = generated_test_set(seeds, config.test_images, config.seed)
    learners = {
        "oxbot CNN+SVM": lambda: SymbolClassifier(config).fit(x, y),
        "LinearSVC, raw pixels": lambda: PixelSVM(seed=config.seed).fit(x, label_indices(y)),
    }
    times: dict[str, float] = {}
    for name, fit in learners.items():
        seconds = []
        for _ in range(repeats):
            tick = time.perf_counter()
            model = fit()
            seconds.append(time.perf_counter() - tick)
        times[name] = statistics.median(seconds)
        accuracy = evaluate(model, test_x, test_y).accuracy
        print(
            f"{name:22s} {images:,} images: fit median {times[name]:.1f} s, "
            f"accuracy {accuracy:.2%} on {len(test_y):,} test images"
        )
    cnn, svm = times.values()
    print(f"training-time ratio SVM / CNN: {svm / cnn:.1f}x")


def interaction(quick: bool) -> None:
    """One side-by-side run: oxbot's agent, then each SB3 peer for the same time."""
    budgets = QUICK if quick else FULL
    config = agent_config_for(load_config(SHIPPED), budgets)
    games = 300 if quick else 1_000
    budgets = dataclasses.replace(budgets, evaluation_games=games)
    with tempfile.TemporaryDirectory() as work:
        agent = train_and_evaluate_agent(
            Path(work), config, OxbotConfig(), budgets, show_progress=False
        )
    peers = train_agent_peers(config, OxbotConfig(), agent, budgets, print, show_progress=False)
    ours = agent["time_to_zero_losses_s"]
    print(f"\nbudget {agent['train_s']:.0f} s (oxbot's whole run); {games:,} games per condition")
    for name, run in [("oxbot DQN", agent)] + [(LEARNER_NAMES[k], p) for k, p in peers.items()]:
        t = run["time_to_zero_losses_s"]
        shown = "none" if t is None else f"{t:.0f} s"
        ratio = "" if t is None or ours is None else f" ({t / ours:.1f}x oxbot's)"
        print(f"{name}: first evaluation without a loss {shown}{ratio}")
        for opponent, starts in CONDITIONS:
            r = run["final"][condition_key(opponent, starts)]
            print(
                f"    {condition_key(opponent, starts):15s} win {r['win_rate']:.2%}  "
                f"draw {r['draw_rate']:.2%}  loss {r['loss_rate']:.2%}"
            )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small budgets")
    parser.add_argument("--repeats", type=int, default=3, help="fits per perception learner")
    args = parser.parse_args()
    torch.set_num_threads(1)
    perception(1_000 if args.quick else 10_000, args.repeats)
    interaction(args.quick)
    return 0


if __name__ == "__main__":
    sys.exit(main())
