import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from oxbot.cli import app
from oxbot.config import OxbotConfig
from oxbot.dialogue.domain import load_domain
from oxbot.errors import ConfigError
from oxbot.reproduce import MARKER, PAPER_FIGURES, Budgets, reproduce
from oxbot.reproduce.cells import _ratio
from oxbot.reproduce.managers import MANAGER_NAMES, _managers_section

PNG = b"\x89PNG\r\n\x1a\n"


def table_rows(markdown: str) -> list[list[str]]:
    """Every data row of every Markdown table, as stripped cells."""
    rows = []
    for line in markdown.splitlines():
        if line.startswith("|") and not re.fullmatch(r"\|(-+\|)+", line):
            rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return rows


@pytest.mark.slow
def test_reproduce_quick_writes_a_full_report_with_every_cell_and_plot(tmp_path: Path, monkeypatch):
    # the report's every cell and plot, not its figures: budgets smaller still than --quick's
    budgets = Budgets(300, 500, 500, 10, 20, 20)
    monkeypatch.setattr("oxbot.reproduce.budgets.QUICK", budgets)
    out, work = tmp_path / "reports", tmp_path / "work"
    result = CliRunner().invoke(
        app, ["reproduce", "--quick", "--out", str(out), "--work", str(work), "--quiet"]
    )
    assert result.exit_code == 0, result.output
    report = (out / "REPORT.md").read_text(encoding="utf-8")
    figures = json.loads((out / "report.json").read_text(encoding="utf-8"))

    assert "Quick run" in report and figures["mode"] == "quick"
    rows = table_rows(report)
    assert rows, "no tables"
    for row in rows:
        assert all(row), f"empty cell in {row}"
        assert not any(c in ("nan%", "None", "not measuredx") for c in row), row
    # every row the report must have, each against the paper's figure
    for needle in (
        "same distribution",
        "another hand",
        "training time, 300 images",
        "well-formed dialogues",
        "training time of the interaction manager",
        "seed images",
        "seed dialogues",
        "sb3-contrib MaskablePPO",
        "SB3 DQN",
        "LinearSVC",
    ):
        assert any(needle in row[0] for row in rows), needle
    outcome_rows = [r for r in rows if r[0].startswith("win / draw / loss")]
    assert len(outcome_rows) == 6  # three opponents, both who-starts conditions
    assert "98% win/draw" in outcome_rows[0][1]
    assert f"{100 * PAPER_FIGURES['accuracy'][0]:.1f}%" in report

    # every plot linked is there and is a PNG; the paper's three curves among them
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    for name in ("perceiver_accuracy.png", "agent_reward.png", "agent_win_draw.png"):
        assert name in links
    for link in links:
        assert (out / link).read_bytes()[:8] == PNG, link

    # the figures behind the table, and what makes them repeatable
    assert figures["data"]["seed_images"] == 108
    assert figures["data"]["seed_images_same_as_shipped"]  # the seeds are redrawn exactly
    assert figures["data"]["seed_dialogues"] == len(load_domain().dialogues)
    assert figures["perceiver"]["train_images"] == budgets.perceiver_images
    assert f"{100 * figures['perceiver']['accuracy']:.1f}%" in report
    assert figures["agent"]["experiences"] == budgets.agent_steps
    for peer in ("dqn", "maskable_ppo"):
        p = figures["agent_peers"][peer]
        assert p["budget_s"] == pytest.approx(figures["agent"]["train_s"], abs=0.1)
        assert p["steps"] > 0 and len(p["final"]) == 6
    # the peers again for oxbot's experiences, exactly
    for peer in ("dqn", "maskable_ppo"):
        p = figures["agent_peers_by_experiences"][peer]
        assert p["steps"] == p["budget_steps"] == budgets.agent_steps and len(p["final"]) == 6
    assert sum("oxbot's experiences" in row[0] for row in rows) == 2
    # every manager at every level, on the budget's dialogues
    managers = figures["managers"]
    assert managers["dialogues"] == budgets.comparison_dialogues
    assert managers["managers"]["tabular_q"]["experiences"] <= budgets.agent_steps
    assert managers["managers"]["dqn_run"]["experiences"] == budgets.agent_steps
    assert len([r for r in rows if r[0].endswith("%") and r[1] in MANAGER_NAMES.values()]) == 20
    assert set(figures["seeds"]) == {"perception", "agent", "evaluation", "peers"}
    env = figures["environment"]
    assert env["packages"]["torch"] and env["packages"]["stable-baselines3"] and env["cpu"]
    assert figures["configs"]["train"]["agent"]["total_steps"] == budgets.agent_steps
    assert (work / MARKER).exists()


def test_reproduce_refuses_a_work_folder_it_did_not_make(tmp_path: Path):
    work = tmp_path / "work"
    work.mkdir()
    (work / "thesis.tex").write_text("precious")
    with pytest.raises(ConfigError, match="not made by `oxbot reproduce`"):
        reproduce(tmp_path / "out", work, OxbotConfig(), OxbotConfig(), quick=True)
    assert (work / "thesis.tex").read_text() == "precious"


def test_reproduce_refuses_files_where_folders_go(tmp_path: Path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError, match="is a file"):
        reproduce(tmp_path / "out", tmp_path / "file", OxbotConfig(), OxbotConfig())
    with pytest.raises(ConfigError, match="is a file"):
        reproduce(tmp_path / "file", tmp_path / "work", OxbotConfig(), OxbotConfig())


def test_cli_reports_a_bad_work_folder_as_one_clear_error(tmp_path: Path):
    import subprocess
    import sys

    (tmp_path / "file").write_text("x")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "oxbot.cli",
            "reproduce",
            "--quick",
            "--work",
            str(tmp_path / "file"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert result.returncode == 2
    assert "is a file" in result.stderr and "Traceback" not in result.stderr


def test_time_ratio_is_a_lower_bound_when_a_peer_never_stops_losing():
    assert _ratio(60.0, 20.0, 240.0) == "3.0x"
    assert _ratio(None, 20.0, 240.0) == "> 12.0x (none within 240 s)"
    assert _ratio(None, None, 240.0) == "oxbot had losses to the end"


def manager_row(share: float, success: float, faults: int) -> dict:
    return {
        "misheard": share,
        "n": 100,
        "successes": round(100 * success),
        "success": success,
        "success_low": success - 0.05,
        "success_high": min(1.0, success + 0.02),
        "turns": 19.0,
        "asked_again": 0.25,
        "reward": 11.5,
        "reward_half": 0.2,
        "well_formed": success,
        "policy_faults": faults,
        "cpu_s": 0.4,
    }


def test_managers_section_shows_each_managers_budget_and_its_figures_at_every_level():
    levels = [0.0, 0.1, 0.2, 0.3]
    budgets = {"dqn_run": (4_000, 30.0), "dqn_shipped": (400_000, 525.2), "tabular_q": (4_000, 9.0)}
    f = {
        "managers": {
            "dialogues": 100,
            "levels": levels,
            "seed": 0,
            "tabular_q_states": 1_234,
            "tabular_q_kept_at": 2_000,
            "managers": {
                key: {
                    "experiences": budgets.get(key, (0, 0.0))[0],
                    "cpu_s": budgets.get(key, (0, 0.0))[1],
                    "rows": [manager_row(s, 0.99 - s / 10, k) for k, s in enumerate(levels)],
                }
                for key in MANAGER_NAMES
            },
        }
    }
    lines = _managers_section(f)
    assert lines[-1] == ""
    rows = table_rows("\n".join(lines))
    assert all(all(row) for row in rows)
    budget_rows = {r[0]: r for r in rows if r[0] in MANAGER_NAMES.values()}
    assert budget_rows[MANAGER_NAMES["dqn_shipped"]][1:3] == ["400,000", "525 s"]
    assert budget_rows[MANAGER_NAMES["rules"]][1:3] == ["0", "0.0 s"]
    assert "1,234 states" in budget_rows[MANAGER_NAMES["tabular_q"]][3]
    figure_rows = [r for r in rows if r[1] in MANAGER_NAMES.values()]
    assert len(figure_rows) == len(levels) * len(MANAGER_NAMES)
    # grouped by level, every manager once in each, in the report's order
    assert [r[0] for r in figure_rows[:: len(MANAGER_NAMES)]] == ["0%", "10%", "20%", "30%"]
    assert [r[1] for r in figure_rows[: len(MANAGER_NAMES)]] == list(MANAGER_NAMES.values())
    at_30 = figure_rows[-1]
    assert at_30[2] == "96.00% [91.00%, 98.00%]" and at_30[5] == "11.50 ± 0.20"
    assert at_30[7] == "3 of 100"
