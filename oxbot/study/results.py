"""The study's results: one row per participant and condition, and per-condition means with 95%
confidence intervals, as the experimenter's page and the export show them.

A *block* is one participant's games in one condition and the questionnaires after them. Its
row holds the condition, the means of its games' metrics (success rate, turns, duration, time
per move, confidence, asked again, corrected, well-formed share) and its questionnaire scores
(oxbot.study.instruments). Per condition, `summary` gives each measure's mean over the blocks,
and its 95% interval by Student's t with n - 1 degrees of freedom (none below two blocks).
"""

from __future__ import annotations

import math
from collections import defaultdict
from statistics import fmean, stdev
from typing import Any

from oxbot.study.conditions import label
from oxbot.study.instruments import SCORES, score
from oxbot.study.store import StudyStore

GAME_MEASURES = (
    "success",
    "turns",
    "duration",
    "time_per_move",
    "confidence",
    "asked_again",
    "corrected",
    "well_formed",
)
"""Game metrics averaged over a block's games."""
MEASURES = (*GAME_MEASURES, *SCORES)
"""Every measure a block row and the summary hold, games' first."""


def block_rows(store: StudyStore) -> list[dict[str, Any]]:
    """One row per participant and block they started (games played or questions answered)."""
    answers: dict[tuple[str, int, str], dict[str, str]] = defaultdict(dict)
    for a in store.answers():
        answers[(a["participant_id"], a["block"], a["instrument"])][a["item"]] = a["value"]
    games: dict[tuple[str, int], list[dict]] = defaultdict(list)
    for g in store.games():
        games[(g["participant_id"], g["block"])].append(g)
    rows = []
    for p in store.participants():
        for block, condition in enumerate(p["conditions"], start=1):
            played = games.get((p["id"], block), [])
            scores = {s: score(s, answers.get((p["id"], block, s), {})) for s in SCORES}
            if not played and all(v is None for v in scores.values()):
                continue
            row: dict[str, Any] = {
                "participant": p["id"],
                "block": block,
                "condition": label(condition),
                **condition,
                "games": len(played),
            }
            for measure in GAME_MEASURES:
                values = [g[measure] for g in played if g[measure] is not None]
                row[measure] = fmean(values) if values else None
            row.update(scores)
            rows.append(row)
    return rows


def t_quantile_975(df: int) -> float:
    """The 97.5th percentile of Student's t with `df` degrees of freedom."""
    from scipy.stats import t

    return float(t.ppf(0.975, df))


def mean_interval(values: list[float]) -> dict[str, Any]:
    """n, the mean and its 95% interval (low, high; None below two values)."""
    n = len(values)
    if n == 0:
        return {"n": 0, "mean": None, "low": None, "high": None}
    mean = fmean(values)
    if n < 2:
        return {"n": 1, "mean": mean, "low": None, "high": None}
    half = t_quantile_975(n - 1) * stdev(values) / math.sqrt(n)
    return {"n": n, "mean": mean, "low": mean - half, "high": mean + half}


def summary(rows: list[dict[str, Any]]) -> dict[str, dict[str, dict[str, Any]]]:
    """Per condition (its label), per measure: n, mean and 95% interval over the blocks."""
    by_condition: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        by_condition[row["condition"]].append(row)
    return {
        condition: {m: mean_interval([r[m] for r in blocks if r[m] is not None]) for m in MEASURES}
        for condition, blocks in sorted(by_condition.items())
    }
