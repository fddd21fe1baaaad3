"""How much each learner gets in a run of `oxbot reproduce`: the full budgets and the quick ones."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Budgets:
    """How much each learner gets; the full run is the one the shipped models came from."""

    perceiver_images: int | None
    """Training images generated from the seeds (None: the config's, 10K)."""
    agent_steps: int | None
    """Experiences of the interaction manager (None: the config's)."""
    agent_eval_every: int | None
    """Greedy evaluations during training every this many experiences (None: the config's)."""
    agent_eval_games: int | None
    """Games per condition of those evaluations (None: the config's)."""
    evaluation_games: int
    """Games per opponent and who-starts condition of the final evaluations (goal: 10,000)."""
    comparison_dialogues: int
    """Dialogues per manager and mishearing level in the managers compared (goal: 10,000)."""


FULL = Budgets(None, None, None, None, 10_000, 10_000)
QUICK = Budgets(1_000, 4_000, 2_000, 100, 300, 200)


def budgets_for(quick: bool) -> Budgets:
    """`QUICK` for a quick run, else `FULL`; looked up when called, so a test may shrink `QUICK`."""
    return QUICK if quick else FULL
