import subprocess
import sys

import pytest
from typer.testing import CliRunner

from oxbot.cli import app

runner = CliRunner()


def oxbot(*args: str, stdin: str = "") -> subprocess.CompletedProcess:
    """The installed console command, as a user runs it."""
    return subprocess.run(
        [sys.executable, "-m", "oxbot.cli", *args],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_help_lists_the_commands():
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0
    for command in ("game", "config"):
        assert command in result.output


def test_game_plays_to_the_end_from_typed_input():
    result = oxbot(
        "game", "--opponent", "random", "--seed", "1", stdin="5\n1\n3\n7\n9\n2\n4\n6\n8\nn\n"
    )
    assert result.returncode == 0, result.stderr
    assert "Hello! I am oxbot." in result.stdout
    assert "Good bye!" in result.stdout
    assert any(end in result.stdout for end in ("Yes, I won.", "It is a draw.", "you won."))


def test_game_survives_garbage_and_eof():
    result = oxbot("game", stdin="\nhello\n42\n")
    assert result.returncode == 0, result.stderr
    assert "'hello' is not a cell" in result.stdout
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize(
    "args,message",
    [
        (["--set", "game.opponent=perfect", "game"], "choose one of random, blocker, minimax"),
        (["game", "--opponent", "perfect"], "unknown opponent 'perfect'"),
        (["--config", "/nonexistent.toml", "config"], "does not exist"),
        (["play", "--manager", "oracle"], "manager is 'oracle'; choose one of dqn, rules, script"),
    ],
)
def test_bad_options_give_one_clear_line_and_no_traceback(args, message):
    result = oxbot(*args)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_config_prints_the_overridden_value():
    result = oxbot("--set", "agent.discount=0.9", "config")
    assert result.returncode == 0
    assert "discount = 0.9" in result.stdout


def test_help_shows_flags_without_a_type_to_give():
    result = runner.invoke(app, ["play", "--help"])
    assert result.exit_code == 0
    assert "--terminal" in result.output and "<bool>" not in result.output


def test_play_serves_where_the_config_says_and_a_taken_port_is_one_clear_line():
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = oxbot("--set", f"web.port={port}", "play")
    assert result.returncode == 2
    assert f"port {port} on 127.0.0.1 is already in use" in result.stderr
    assert "Traceback" not in result.stderr and "Errno" not in result.stderr


def test_play_in_the_terminal_takes_the_config_too(tmp_path):
    config = tmp_path / "robot.toml"
    config.write_text('[speech]\nrecognizer = "no_such_module:make"\n')
    result = oxbot("--config", str(config), "play", "--terminal", "--mute", stdin="quit\n")
    assert result.returncode == 2
    assert "speech.recognizer 'no_such_module:make' cannot be imported" in result.stderr
