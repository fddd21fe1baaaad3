"""Reproducing the paper side by side: `oxbot reproduce`.

One run, from a clean work folder: draw the 108 seed images, train the perceiver on 10K images
generated from them, train the interaction manager, evaluate both as the paper did (and as
oxbot's goals ask), train the peers (a linear SVM on raw pixels; Stable-Baselines3's DQN and
sb3-contrib's MaskablePPO for the same wall-clock time as oxbot's agent, and for as many
experiences), compare the interaction managers (this run's DQN, the shipped one, the rules, the
script and tabular Q) on the same people misheard more and more, and write `REPORT.md` with its
plots and `report.json` with every figure, seed, version and the machine.

    result = reproduce("reports", "runs/reproduce", train_config, eval_config, quick=True)
    result.report_path

Everything but the times is fixed by the seeds: the same seeds give the same numbers on the
same machine, except those of the SB3 peers trained for a time, which learn for as many
steps as fit in it.

Where each part of the report is made: `pipeline` runs the steps in order; `seed_data`,
`perceiver`, `agent` (the game outcomes and dialogues), `agent_peers`, `shipped`, `managers`,
`machine` and `plots` each measure their figures and write their rows or section; `report`
assembles REPORT.md; `paper` holds the paper's figures and oxbot's goals; `budgets` the run's
sizes; `cells` how a figure is written in a table cell.
"""

from __future__ import annotations

from oxbot.reproduce.agent import OPPONENT_NAMES, agent_config_for, train_and_evaluate_agent
from oxbot.reproduce.agent_peers import LEARNER_NAMES, train_agent_peers
from oxbot.reproduce.budgets import FULL, QUICK, Budgets
from oxbot.reproduce.machine import environment
from oxbot.reproduce.paper import GOALS, PAPER, PAPER_FIGURES
from oxbot.reproduce.perceiver import SVM_NAME, train_pixel_svm_peer
from oxbot.reproduce.pipeline import MARKER, WORK_PARTS, ReproduceResult, reproduce
from oxbot.reproduce.report import render_report
from oxbot.reproduce.shipped import measure_shipped

# `reproduce` reads QUICK and FULL in oxbot.reproduce.budgets when it runs: patch them there
__all__ = [
    "FULL",
    "GOALS",
    "LEARNER_NAMES",
    "MARKER",
    "OPPONENT_NAMES",
    "PAPER",
    "PAPER_FIGURES",
    "QUICK",
    "SVM_NAME",
    "WORK_PARTS",
    "Budgets",
    "ReproduceResult",
    "agent_config_for",
    "environment",
    "measure_shipped",
    "render_report",
    "reproduce",
    "train_agent_peers",
    "train_and_evaluate_agent",
    "train_pixel_svm_peer",
]
