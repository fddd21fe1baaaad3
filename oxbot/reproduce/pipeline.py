"""The steps of `oxbot reproduce` in order: a clean work folder, the seed data, both learners and
their peers, the shipped models, the interaction managers compared, then the plots,
`report.json` and `REPORT.md`."""

from __future__ import annotations

import dataclasses
import datetime
import json
import logging
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from oxbot.atomic import write_text_atomic
from oxbot.config import OxbotConfig
from oxbot.errors import ConfigError
from oxbot.reproduce.agent import agent_config_for, train_and_evaluate_agent
from oxbot.reproduce.agent_peers import train_agent_peers
from oxbot.reproduce.budgets import budgets_for
from oxbot.reproduce.machine import environment
from oxbot.reproduce.managers import compare_run_managers
from oxbot.reproduce.perceiver import _train_perceiver, train_pixel_svm_peer
from oxbot.reproduce.plots import _write_plots
from oxbot.reproduce.report import render_report
from oxbot.reproduce.seed_data import _make_seed_data
from oxbot.reproduce.shipped import measure_shipped

# the package's logger: the command's log lines name `oxbot.reproduce`, whichever module logs
log = logging.getLogger(__package__)

MARKER = ".oxbot-reproduce"
"""A file in the work folder saying oxbot made it, so a rerun may clear it."""
WORK_PARTS = ("seeds", "perceiver", "agent", MARKER)


@dataclass
class ReproduceResult:
    """What `reproduce` measured and where it wrote it."""

    figures: dict[str, Any]
    report_path: Path
    json_path: Path
    plots: list[Path]


def reproduce(
    out_dir: str | Path,
    work_dir: str | Path,
    train_config: OxbotConfig,
    eval_config: OxbotConfig,
    quick: bool = False,
    show_progress: bool = True,
    announce: Callable[[str], None] = log.info,
) -> ReproduceResult:
    """Make the seeds, train and evaluate both learners and their peers, write the report.

    `train_config` trains the learners (the shipped agent's: `oxbot/data/models/agent.toml`);
    `eval_config` is the simulated person they are measured against (the paper's defaults).
    `quick` uses the small `QUICK` budgets and says so in the report.
    """
    started = time.perf_counter()
    budgets = budgets_for(quick)
    out_dir, work_dir = Path(out_dir), Path(work_dir)
    _prepare_work_dir(work_dir)
    _check_out_dir(out_dir)
    figures: dict[str, Any] = {
        "mode": "quick" if quick else "full",
        "budgets": dataclasses.asdict(budgets),
        "started": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "environment": environment(),
    }

    announce("1/7 drawing the seed images")
    figures["data"] = _make_seed_data(work_dir, train_config)

    announce("2/7 training and evaluating the perceiver")
    figures["perceiver"] = _train_perceiver(work_dir, train_config, budgets, show_progress)

    announce("3/7 training the perception peer: a linear SVM on raw pixels")
    figures["perceiver_peer"] = train_pixel_svm_peer(
        work_dir / "seeds", train_config, budgets.perceiver_images
    )

    announce("4/7 training the interaction manager")
    agent_config = agent_config_for(train_config, budgets)
    figures["agent"] = train_and_evaluate_agent(
        work_dir, agent_config, eval_config, budgets, show_progress
    )

    announce("5/7 training the SB3 peers for the same time and experiences as oxbot's agent")
    for by, key in (("time", "agent_peers"), ("experiences", "agent_peers_by_experiences")):
        figures[key] = train_agent_peers(
            agent_config, eval_config, figures["agent"], budgets, announce, show_progress, by
        )

    announce("6/7 measuring the shipped models")
    figures["shipped"] = measure_shipped(work_dir, train_config, eval_config, budgets)
    figures["shipped"]["agent"].update(
        _shipped_agent_against_run(figures["shipped"]["agent"], figures["agent"], agent_config)
    )

    announce(
        "7/7 comparing the interaction managers on the same people "
        f"({budgets.comparison_dialogues:,} dialogues per manager and mishearing level), then "
        "writing the report"
    )
    figures["managers"] = compare_run_managers(
        work_dir,
        agent_config,
        eval_config,
        figures["agent"],
        figures["shipped"]["agent"],
        budgets,
        show_progress,
    )
    figures["seeds"] = {
        "perception": train_config.perception.seed,
        "agent": agent_config.agent.seed,
        "evaluation": 0,
        "peers": agent_config.agent.seed,
    }
    figures["configs"] = {
        "train": dataclasses.asdict(agent_config),
        "evaluate": dataclasses.asdict(eval_config),
    }
    figures["wall_clock_s"] = round(time.perf_counter() - started, 1)
    plots = _write_plots(out_dir, work_dir, figures)
    json_path = out_dir / "report.json"
    write_text_atomic(json_path, json.dumps(_json_safe(figures), indent=2) + "\n")
    report_path = out_dir / "REPORT.md"
    write_text_atomic(report_path, render_report(figures))
    return ReproduceResult(figures, report_path, json_path, plots)


def _prepare_work_dir(work_dir: Path) -> None:
    """A clean work folder: a previous run's parts are removed, anyone else's folder refused."""
    if work_dir.exists() and not work_dir.is_dir():
        raise ConfigError(f"work folder {work_dir} is a file; give a folder with --work")
    if work_dir.is_dir() and any(work_dir.iterdir()):
        if not (work_dir / MARKER).exists():
            raise ConfigError(
                f"work folder {work_dir} is not empty and was not made by `oxbot reproduce`; "
                "give an empty or new folder with --work"
            )
        for part in WORK_PARTS:
            path = work_dir / part
            if path.is_dir():
                shutil.rmtree(path)
            elif path.exists():
                path.unlink()
    work_dir.mkdir(parents=True, exist_ok=True)
    write_text_atomic(work_dir / MARKER, "made by oxbot reproduce; cleared by its next run\n")


def _check_out_dir(out_dir: Path) -> None:
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"report folder {out_dir} is a file; give a folder with --out")
    out_dir.mkdir(parents=True, exist_ok=True)


def _shipped_agent_against_run(
    shipped: dict[str, Any], agent: dict[str, Any], agent_config: OxbotConfig
) -> dict[str, Any]:
    """Whether the shipped agent was trained with this run's config, and the first experience
    at which its average reward parts from this run's agent's (None if it never does)."""
    return {
        "same_config": shipped["config"] == _json_safe(dataclasses.asdict(agent_config)),
        "diverges_at": next(
            (
                ours[0]
                for ours, theirs in zip(
                    agent["reward_curve"], shipped["reward_curve"], strict=False
                )
                if ours != theirs
            ),
            None,
        ),
    }


def _json_safe(value: Any) -> Any:
    return json.loads(json.dumps(value, default=str))
