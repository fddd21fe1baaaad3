import math

import numpy as np
import pytest

from oxbot.config import OxbotConfig
from oxbot.dialogue.baselines import load_manager
from oxbot.dialogue.comparison import compare_at, compare_manager, misheard_config, pooled, wilson
from oxbot.dialogue.evaluation import EvaluationResult


def result(rewards: list[float], successes: int, policy_faults: int = 0) -> EvaluationResult:
    """An evaluation of len(rewards) dialogues with these rewards."""
    n = len(rewards)
    return EvaluationResult(
        opponent="random",
        robot_starts=True,
        games=n,
        win_rate=0.0,
        draw_rate=0.0,
        loss_rate=0.0,
        declined_rate=0.0,
        stopped_rate=0.0,
        abandoned_rate=0.0,
        task_success=successes / n,
        average_reward=float(np.mean(rewards)),
        average_turns=10.0,
        well_formed=successes / n,
        truncated=0,
        policy_faults=policy_faults,
        reward_std=float(np.std(rewards)),
        asked_again=0.5,
    )


def test_wilson_interval_holds_the_share_and_tightens_with_more_dialogues():
    low, high = wilson(50, 100)
    assert low == pytest.approx(0.4038, abs=1e-4) and high == pytest.approx(0.5962, abs=1e-4)
    widths = [wilson(9 * n // 10, n)[1] - wilson(9 * n // 10, n)[0] for n in (100, 1_000, 10_000)]
    assert widths[0] > widths[1] > widths[2]
    for successes, n in ((0, 10), (10, 10), (7, 9)):
        low, high = wilson(successes, n)
        assert 0.0 <= low <= successes / n <= high <= 1.0
    assert wilson(10, 10)[0] < 1.0  # all successes still leave room below


def test_pooled_figures_are_those_of_the_dialogues_taken_together():
    first, second = [1.0, 2.0, 3.0], [10.0, 12.0]
    figures = pooled([result(first, 2, policy_faults=1), result(second, 1, policy_faults=0)])
    together = np.array(first + second)
    assert figures["n"] == 5 and figures["successes"] == 3
    assert figures["success"] == pytest.approx(0.6)
    assert figures["reward"] == pytest.approx(together.mean())
    assert figures["reward_half"] == pytest.approx(1.96 * together.std() / math.sqrt(5))
    assert figures["policy_faults"] == 1


def test_mishearing_share_is_half_the_recognisers_noise():
    assert misheard_config(OxbotConfig(), 0.3).dialogue.asr_noise == pytest.approx(0.6)


def test_rules_beat_the_script_on_the_same_people_heard_cleanly():
    config = OxbotConfig()
    rules = compare_at(load_manager("rules", config).act_batch, config, 0.0, 200)
    script = compare_at(load_manager("script", config).act_batch, config, 0.0, 200)
    assert rules["n"] == script["n"] == 200
    # the script walks away from people who wanted to play; the mask keeps both from asking
    # again after a clear no or leaving before a no or a stop is acknowledged
    assert rules["success"] > script["success"]
    assert rules["policy_faults"] == script["policy_faults"] == 0
    for row in (rules, script):
        assert row["success_low"] <= row["success"] <= row["success_high"]
        assert row["reward_half"] > 0 and row["cpu_s"] > 0


def test_a_manager_is_measured_at_every_level_in_order():
    seen = []
    rows = compare_manager(
        load_manager("rules").act_batch, OxbotConfig(), 20, (0.0, 0.3), on_level=seen.append
    )
    assert [r["misheard"] for r in rows] == seen == [0.0, 0.3]
    assert all(r["n"] == 20 for r in rows)
