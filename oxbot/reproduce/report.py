"""REPORT.md from the figures a run measured: its header, the paper's figures table assembled
from each learner's rows, and every section in order."""

from __future__ import annotations

from typing import Any

from oxbot.reproduce.agent import _game_outcome_rows, _interaction_manager_rows
from oxbot.reproduce.agent_peers import _agent_peers_notes, _agent_peers_section
from oxbot.reproduce.machine import _environment_section
from oxbot.reproduce.managers import _managers_section
from oxbot.reproduce.paper import PAPER
from oxbot.reproduce.perceiver import _perceiver_rows, _perception_peers_section
from oxbot.reproduce.plots import _learning_curves_section
from oxbot.reproduce.seed_data import _seed_data_rows
from oxbot.reproduce.shipped import _shipped_models_note


def render_report(f: dict[str, Any]) -> str:
    """REPORT.md from the figures `reproduce` measured, one function per section, in order."""
    sections = (
        _header_section,
        _paper_figures_section,
        _shipped_models_note,
        _learning_curves_section,
        _perception_peers_section,
        _agent_peers_section,
        _agent_peers_notes,
        _managers_section,
        _environment_section,
    )
    # each section's lines end with a blank one, so the report ends with a newline
    return "\n".join(line for section in sections for line in section(f))


def _header_section(f: dict[str, Any]) -> list[str]:
    """The title, a quick run's warning, the paper and how and when the report was made."""
    quick = f["mode"] == "quick"
    lines = ["# Reproducing the paper, side by side", ""]
    if quick:
        lines += [
            "> **Quick run (`oxbot reproduce --quick`)**: smaller budgets "
            f"({f['perceiver']['train_images']:,} training images, "
            f"{f['agent']['experiences']:,} experiences, "
            f"{f['budgets']['evaluation_games']:,} evaluation games per condition), so the "
            "figures below check the pipeline, not the paper. The full report is "
            "`oxbot reproduce` (reports/REPORT.md in the repository).",
            "",
        ]
    lines += [
        f"Paper: {PAPER}. Paper figures are quoted with the section of the paper that gives them;",
        "goals are oxbot's. Made by `oxbot reproduce"
        + (" --quick" if quick else "")
        + f"` in {f['wall_clock_s']:.0f} s, started {f['started']}.",
        "",
    ]
    return lines


def _paper_figures_section(f: dict[str, Any]) -> list[str]:
    """The table of the paper's figures, this run's, the shipped models' and the goals."""
    return [
        "## The paper's figures and oxbot's",
        "",
        "| measured | paper | oxbot, this run | oxbot, shipped model | goal | goal met: "
        "run / shipped |",
        "|---|---|---|---|---|---|",
        *_perceiver_rows(f),
        *_game_outcome_rows(f),
        *_interaction_manager_rows(f),
        *_seed_data_rows(f),
        "",
    ]
