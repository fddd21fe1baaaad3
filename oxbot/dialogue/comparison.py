"""Interaction managers compared on the same people, misheard more and more.

Each manager (any batch policy: the DQN, `RuleBasedManager`, `ScriptedManager`, a `TabularQ`)
talks with the same simulated people, seeded alike, against a random opponent, half the
dialogues with the robot starting, heard through the simulator's recogniser at each word
mishearing level (`dialogue.asr_noise` n drops a word with probability n/4 and swaps it for a
random one with probability n/4: n = 2 x the share misheard). Per manager and level: task
success (well formed and as the person wanted) with its 95% Wilson interval, turns and times
the robot asked again per dialogue, reward with its 95% interval (mean ± 1.96 standard
errors), the well-formed share, the ill-formed dialogues that are the policy's own faults
(`wellformed.blame`) and the CPU seconds the dialogues took.

`oxbot reproduce` reports it (`oxbot.reproduce.managers`) and `bench/bench_mishearing.py`
prints it.

>>> from oxbot.config import OxbotConfig
>>> from oxbot.dialogue.baselines import load_manager
>>> rows = compare_manager(load_manager("rules").act_batch, OxbotConfig(), 4, levels=(0.0,))
>>> rows[0]["n"], rows[0]["misheard"]
(4, 0.0)
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any

from oxbot.config import OxbotConfig, with_overrides
from oxbot.dialogue.evaluation import EvaluationResult, Policy, evaluate

MISHEARING = (0.0, 0.1, 0.2, 0.3)
"""The shares of words misheard the managers are compared at."""

Z95 = 1.96
"""The standard normal's 97.5th percentile: a two-sided 95% interval."""


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The 95% Wilson score interval of `successes` out of `n`."""
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def pooled(results: Sequence[EvaluationResult]) -> dict[str, float]:
    """The figures of several runs' dialogues taken together: dialogues `n`, task `successes`,
    the shares and means per dialogue, the reward's 95% half-interval `reward_half`, and the
    ill-formed dialogues that are the policy's own faults (`policy_faults`, a count)."""
    n = sum(r.games for r in results)

    def mean(name: str) -> float:
        return sum(getattr(r, name) * r.games for r in results) / n

    reward = float(mean("average_reward"))
    second = sum((r.reward_std**2 + r.average_reward**2) * r.games for r in results) / n
    spread = math.sqrt(max(0.0, second - reward**2))
    return {
        "n": n,
        "successes": sum(round(r.task_success * r.games) for r in results),
        "success": mean("task_success"),
        "turns": mean("average_turns"),
        "asked_again": mean("asked_again"),
        "reward": reward,
        "reward_half": Z95 * spread / math.sqrt(n),
        "well_formed": mean("well_formed"),
        "policy_faults": sum(r.policy_faults for r in results),
    }


def misheard_config(config: OxbotConfig, share: float) -> OxbotConfig:
    """`config`'s people heard with `share` of their words misheard (`asr_noise` = 2 x share)."""
    return with_overrides(config, {"dialogue": {"asr_noise": 2 * share}})


def compare_at(
    policy: Policy, config: OxbotConfig, share: float, dialogues: int, seed: int = 0
) -> dict[str, float]:
    """One manager's figures at one mishearing level: `dialogues` with `config`'s people
    against a random opponent, half with the robot starting (the same people for every
    manager at the same `seed`); `pooled`'s figures, the task success's Wilson interval
    (`success_low`, `success_high`), the level and the CPU seconds the dialogues took."""
    misheard = misheard_config(config, share)
    half = dialogues // 2
    started = time.process_time()
    results = [
        evaluate(policy, "random", starts, half, misheard, seed=seed) for starts in (True, False)
    ]
    cpu = time.process_time() - started
    figures = pooled(results)
    low, high = wilson(int(figures["successes"]), int(figures["n"]))
    return {"misheard": share, **figures, "success_low": low, "success_high": high, "cpu_s": cpu}


def compare_manager(
    policy: Policy,
    config: OxbotConfig,
    dialogues: int,
    levels: Sequence[float] = MISHEARING,
    seed: int = 0,
    on_level: Callable[[float], None] | None = None,
) -> list[dict[str, Any]]:
    """`compare_at` at every mishearing level in `levels`, in order; `on_level` is called with
    each level once it is measured."""
    rows = []
    for share in levels:
        rows.append(compare_at(policy, config, share, dialogues, seed))
        if on_level is not None:
            on_level(share)
    return rows
