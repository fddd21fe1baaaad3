"""The machine, Python packages and commit a run was made with, and the report's last section:
seeds, versions and machine."""

from __future__ import annotations

import importlib.metadata
import os
import platform
import subprocess
from pathlib import Path
from typing import Any


def environment() -> dict[str, Any]:
    """The machine, Python packages and commit a run was made with."""
    packages = {}
    for name in (
        "oxbot",
        "torch",
        "numpy",
        "scikit-learn",
        "gymnasium",
        "stable-baselines3",
        "sb3-contrib",
        "opencv-python-headless",
        "matplotlib",
    ):
        try:
            packages[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            packages[name] = None
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "python": platform.python_version(),
        "packages": packages,
        "platform": platform.platform(),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "commit": _git_commit(),
    }


_NOT_CODE = ("--", ".", ":(exclude)reports")


def _git_commit() -> str | None:
    root = Path(__file__).resolve().parents[2]  # the repository, above oxbot/reproduce/
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
        dirty = subprocess.run(
            # reports/ is this command's own output: rewriting it is not a change to the code
            [
                *("git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"),
                *_NOT_CODE,
            ],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{head}{' (with uncommitted changes)' if dirty else ''}"


def _environment_section(f: dict[str, Any]) -> list[str]:
    """Seeds, versions and machine: how times were judged, the seeds, commit, packages and
    machine."""
    env, seeds = f["environment"], f["seeds"]
    refit = f["perceiver"]["timed_refit"]
    return [
        "## Seeds, versions and machine",
        "",
        "- Times: the cores were shared with other jobs, so the time goals are judged on CPU "
        "time (the learners run on one torch thread: their CPU time is what they take on a "
        "core of their own), with wall-clock beside it. The perceiver's time is of a second, "
        "timed generation and fit after the curve's runs; it gave "
        + ("the very same" if refit["identical_weights"] else "**different**")
        + " weights. The SB3 peers' budget is oxbot's wall-clock time, then its number of "
        "experiences, all run one after the other on the same machine.",
        f"- Seeds: perception {seeds['perception']} (seed images, training and test "
        f"images, font set), agent {seeds['agent']} (training, its evaluations "
        f"10,000 + step), final evaluations {seeds['evaluation']}, peers "
        f"{seeds['peers']} (their evaluations 20,000 + seed). The same seeds give the "
        "same figures on the same machine, except times and the figures of the SB3 peers "
        "trained for oxbot's time, which depend on how many steps fit into it.",
        f"- Commit: {env['commit'] or 'unknown'}",
        f"- Python {env['python']}; "
        + ", ".join(f"{k} {v}" for k, v in env["packages"].items() if v),
        f"- Machine: {env['cpu']}, {env['cores']} cores, {env['platform']}; load average "
        f"at the start {', '.join(str(x) for x in env['load_average'])} (other jobs shared "
        "the cores). Torch uses one thread for both learners.",
        "- Every figure, curve and the two configs (training, evaluation) are in "
        "`report.json` beside this file.",
        "",
    ]
