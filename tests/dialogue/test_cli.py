import json
import re
import subprocess
import sys

from oxbot.dialogue.domain import CLOSING, load_domain


def oxbot(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "oxbot.cli", *args], capture_output=True, text=True, timeout=120
    )


def test_evaluate_agent_prints_json_figures_and_figure_1_like_transcripts():
    result = oxbot(
        "evaluate", "agent", "--opponent", "minimax", "--robot-starts", "both",
        "--games", "40", "--json", "--show", "1", "--cooperative",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    figures = json.loads(result.stdout)
    assert [f["robot_starts"] for f in figures] == [True, False]
    for f in figures:
        assert f["games"] == 40 and f["loss_rate"] == 0.0 and f["well_formed"] == 1.0
        assert {"win_rate", "draw_rate", "average_reward", "average_turns"} <= set(f)
    assert re.search(r"Rob: [^\n]+ \[who=rob what=draw where=\w+\]", result.stderr)
    closings = load_domain().templates_for(CLOSING)
    assert any(f"Rob: {text}" in result.stderr for text in closings)


def test_train_agent_writes_its_files(tmp_path):
    result = oxbot(
        "--set", "agent.total_steps=600", "--set", "agent.learning_starts=100",
        "train", "agent", "--out", str(tmp_path), "--quiet",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "trained on 600 experiences" in result.stdout
    assert (tmp_path / "agent.pt").exists() and (tmp_path / "agent_metrics.json").exists()


def test_train_agent_can_fine_tune_a_policy_and_records_where_it_started(tmp_path):
    from oxbot.dialogue.agent import load_policy, shipped_policy_path

    result = oxbot(
        "--config", "oxbot/data/models/agent.toml",
        "--set", "agent.total_steps=400", "--set", "agent.learning_starts=100",
        "--set", "agent.eval_every=0", "--set", "agent.seed=5",
        "train", "agent", "--out", str(tmp_path), "--quiet",
        "--init-from", str(shipped_policy_path()),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    tuned, shipped = load_policy(tmp_path / "agent.pt"), load_policy()
    started = tuned.metadata["init_from"]
    assert started["seed"] == shipped.metadata["seed"]
    assert started["experiences"] == shipped.metadata["experiences"]
    assert tuned.metadata["seed"] == 5 and tuned.metadata["experiences"] == 400


def test_bad_evaluate_options_give_one_clear_line():
    result = oxbot("evaluate", "agent", "--robot-starts", "sometimes")
    assert result.returncode == 2
    assert "--robot-starts is 'sometimes'; use yes, no or both" in result.stderr
    assert "Traceback" not in result.stderr


def test_evaluate_agent_measures_the_rule_based_manager():
    result = oxbot(
        "evaluate", "agent", "--manager", "rules", "--opponent", "minimax",
        "--robot-starts", "no", "--games", "30", "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    (figures,) = json.loads(result.stdout)
    assert figures["games"] == 30 and figures["loss_rate"] == 0.0


def test_a_policy_file_goes_with_the_dqn_only():
    result = oxbot("evaluate", "agent", "--manager", "rules", "--policy", "agent.pt")
    assert result.returncode == 2
    assert "--policy is a DQN's file" in result.stderr
