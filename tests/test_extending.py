"""docs/extending.md's worked examples, run as written with smaller budgets: a policy trained in
a fresh folder, a domain with a new phrase and a MaskablePPO model each play a game through
`oxbot play --policy` (in the terminal, answers typed; the MaskablePPO model on the page too),
and a body joins the robot's bus."""

import contextlib
import io
import os
import re
import shlex
import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

from oxbot.dialogue.domain import default_domain_dir
from tests.robot.test_terminal import typist

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "extending.md").read_text()
SMALLER = {"agent.total_steps=20000": "agent.total_steps=3000", "--games 200": "--games 4"}
"""The doc's budgets, cut to seconds: a policy that plays, not one that plays well."""


def section(number: int) -> str:
    return re.search(rf"^## {number}\. .*?(?=^## |\Z)", DOC, re.M | re.S).group(0)


def code(number: int, language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", section(number), re.S)


def shell_lines(number: int) -> list[str]:
    return [line for block in code(number, "sh") for line in block.splitlines() if line.strip()]


def run_shell(line: str, cwd: Path) -> None:
    """A doc line that is not `oxbot play`, with a smaller budget: oxbot's in this process,
    others in a shell."""
    from oxbot.cli import app

    for big, small in SMALLER.items():
        line = line.replace(big, small)
    if line.startswith(".venv/bin/oxbot "):
        os.chdir(cwd)  # the tests' monkeypatch.chdir gives the folder back
        result = CliRunner().invoke(app, shlex.split(line)[1:])
        assert result.exit_code == 0, f"{line}\n{result.output}{result.exception!r}"
        return
    line = line.replace("oxbot/data/dialogue", str(default_domain_dir()))
    done = subprocess.run(line, shell=True, cwd=cwd, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, f"{line}\n{done.stderr}"


def play(line: str, cwd: Path, monkeypatch, answer: str):
    """`oxbot play ...` from the doc, in the terminal, a typist answering: the Robot played."""
    import oxbot.robot.terminal as terminal
    from oxbot.cli import app

    played = []

    class Typed(terminal.TerminalRobot):
        def __init__(self, robot, **kwargs):
            played.append(robot)
            answers = {"Request(playGame)": answer, "Request(repeat)": answer}
            super().__init__(
                robot, read_line=typist(robot, answers, timeout=20), speakers=kwargs["speakers"]
            )

    monkeypatch.setattr(terminal, "TerminalRobot", Typed)
    monkeypatch.chdir(cwd)
    args = [*shlex.split(line)[1:], "--terminal", "--mute", "--speed", "25"]
    fast = ["--set", "robot.answer_timeout=2", "--set", "robot.move_timeout=10"]
    result = CliRunner().invoke(app, fast + args)
    assert result.exit_code == 0, result.output + repr(result.exception)
    (robot,) = played
    return robot


def manager_of(robot):
    from oxbot.robot.manager import InteractionManagerComponent

    return next(c for c in robot.components if isinstance(c, InteractionManagerComponent))


def played_a_game(robot, answer: str) -> None:
    """The robot asked to play and understood the typed answer as a yes."""
    answered = [t for t in robot.transcript if t["speaker"] == "usr" and t["text"] == answer]
    assert answered and all(t["act"] == "Confirm(playGame=yes)" for t in answered)


def test_a_policy_trained_in_a_fresh_folder_plays_through_play_policy(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    *others, play_line = shell_lines(1)
    for line in others:
        run_shell(line, tmp_path)
    robot = play(play_line, tmp_path, monkeypatch, "yes let's play")
    assert manager_of(robot).policy.metadata["experiences"] == 3000
    played_a_game(robot, "yes let's play")


def test_a_domain_with_a_new_phrase_trains_and_plays(tmp_path, monkeypatch):
    from oxbot.errors import ModelFileError

    monkeypatch.chdir(tmp_path)
    *others, play_line = shell_lines(2)
    for line in others:
        run_shell(line, tmp_path)
    from oxbot.config import load_config
    from oxbot.robot.session import shared_policy

    with pytest.raises(ModelFileError, match="train agent --domain mydomain"):
        shared_policy("dqn", load_config(None, ["dialogue.domain=mydomain"]))
    robot = play(play_line, tmp_path, monkeypatch, "Absolutely, bring it on.")
    assert "word:absolutely" in manager_of(robot).policy.feature_names
    played_a_game(robot, "Absolutely, bring it on.")


def test_a_maskable_ppo_model_plays_through_the_adapter(tmp_path, monkeypatch):
    from oxbot.peers import SB3Policy

    train, own_policy = code(3, "python")
    monkeypatch.chdir(tmp_path)
    from oxbot.torch_threads import one_thread

    with one_thread():  # small networks are faster unshared, above all on a busy machine
        exec(train.replace("20_000", "2_048"), {})
    *others, play_line = shell_lines(3)
    for line in others:
        run_shell(line, tmp_path)
    robot = play(play_line, tmp_path, monkeypatch, "yes let's play")
    policy = manager_of(robot).policy
    assert isinstance(policy, SB3Policy) and policy.algorithm == "maskable_ppo"
    played_a_game(robot, "yes let's play")
    plays_on_the_page(tmp_path / "runs" / "ppo.zip")
    scope = {}
    exec(own_policy, scope)
    assert isinstance(manager_of(scope["robot"]).policy, scope["FirstOffered"])


def plays_on_the_page(policy: Path) -> None:
    """The page's game (a scripted person over its WebSocket) with `[robot] policy`."""
    import asyncio

    from oxbot.config import with_overrides
    from oxbot.testing.player import play_game
    from tests.web.conftest import FAST, running_server

    config = with_overrides(FAST, {"robot": {"policy": str(policy), "speed_factor": 20}})
    with running_server(config=config) as url:
        # a weak policy may never say goodbye: 12 s of its game are enough to see it play
        record = asyncio.run(play_game(url.replace("http://", "ws://") + "/ws", timeout=12))
    assert not record.errors, record.errors
    assert ("usr", "Confirm(playGame=yes)") in [(s, a) for s, a, _ in record.transcript]
    assert record.robot_cells, record.transcript  # it drew


def test_a_body_on_the_bus_follows_the_robots_strokes():
    (example,) = code(4, "python")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(example, {"__name__": "example"})
    assert re.search(r"plot \d+ points in the \w+ cell", printed.getvalue())
