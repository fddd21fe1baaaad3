"""The DQN, the rule-based manager and the script, on the same people misheard more and more.

    .venv/bin/python bench/bench_mishearing.py                       # 10,000 dialogues a cell
    .venv/bin/python bench/bench_mishearing.py --dialogues 2000 --managers dqn,rules

Each manager (`oxbot.dialogue.baselines.load_manager`: the shipped DQN, `RuleBasedManager`,
`ScriptedManager`) talks with the default simulated people (who decline once or for good,
stop, chatter, say nothing, ask for another game) against a random opponent, half the
dialogues with the robot starting, heard through the simulator's recogniser at word mishearing
0, 10, 20 and 30% (`dialogue.asr_noise` n drops a word with probability n/4 and swaps it for a
random one with probability n/4: n = 2 x the share misheard). The same people and the same seeds
for every manager. Printed per manager and mishearing: task success (well formed and as the
person wanted) with its 95% Wilson interval, turns and times the robot asked again per
dialogue, reward with its 95% interval (mean ± 1.96 standard errors), well-formed share, and
the CPU seconds the dialogues took. Not a test: the simulated mishearing is not calibrated to
a real recogniser's confidences.
"""

from __future__ import annotations

import argparse
import math
import time

from oxbot.config import load_config
from oxbot.dialogue.baselines import load_manager
from oxbot.dialogue.evaluation import EvaluationResult, evaluate

MISHEARING = (0.0, 0.1, 0.2, 0.3)


def wilson(successes: float, n: int, z: float = 1.96) -> tuple[float, float]:
    """The 95% Wilson score interval of a share."""
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def pooled(results: list[EvaluationResult]) -> dict[str, float]:
    """The figures of several runs' dialogues taken together."""
    n = sum(r.games for r in results)

    def mean(name: str) -> float:
        return sum(getattr(r, name) * r.games for r in results) / n

    reward = mean("average_reward")
    second = sum((r.reward_std**2 + r.average_reward**2) * r.games for r in results) / n
    spread = math.sqrt(max(0.0, second - reward**2))
    return {
        "n": n,
        "success": mean("task_success"),
        "turns": mean("average_turns"),
        "asked_again": mean("asked_again"),
        "reward": reward,
        "reward_half": 1.96 * spread / math.sqrt(n),
        "well_formed": mean("well_formed"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dialogues", type=int, default=10_000, help="per manager and level")
    parser.add_argument("--managers", default="dqn,rules,script")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    half = args.dialogues // 2
    print(
        f"{'manager':8s} {'misheard':>8s} {'task success [95% CI]':>27s} {'turns':>6s} "
        f"{'asked again':>11s} {'reward ± 95%':>15s} {'well formed':>11s} {'CPU s':>6s}"
    )
    for name in args.managers.split(","):
        for misheard in MISHEARING:
            config = load_config(None, [f"dialogue.asr_noise={2 * misheard}"])
            manager = load_manager(name, config)
            started = time.process_time()
            results = [
                evaluate(manager.act_batch, "random", starts, half, config, seed=args.seed)
                for starts in (True, False)
            ]
            cpu = time.process_time() - started
            f = pooled(results)
            low, high = wilson(f["success"] * f["n"], int(f["n"]))
            print(
                f"{name:8s} {misheard:8.0%} {f['success']:9.2%} [{low:6.2%}, {high:6.2%}] "
                f"{f['turns']:6.1f} {f['asked_again']:11.3f} "
                f"{f['reward']:8.2f} ± {f['reward_half']:4.2f} {f['well_formed']:11.2%} "
                f"{cpu:6.0f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
