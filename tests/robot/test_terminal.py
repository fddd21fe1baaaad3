"""`oxbot play --terminal`: the whole robot with a keyboard for ears and a screen for a face."""

import logging
import time

from rich.console import Console

from oxbot.config import load_config
from oxbot.game.board import EMPTY
from oxbot.perception.sources import CameraSource
from oxbot.robot.session import Robot
from oxbot.robot.terminal import Microphone, Speakers, TerminalRobot

FAST = load_config(
    None, ["robot.speed_factor=25", "robot.answer_timeout=2", "robot.move_timeout=10"]
)


def typist(robot: Robot, answers: dict[str, str], timeout: float = 30.0):
    """A read_line that waits for the robot's next question and types the answer to it."""
    handled = [0]

    def read_line(prompt: str) -> str:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if robot.finished:
                return "quit"
            transcript = robot.transcript
            for i in range(handled[0], len(transcript)):
                turn = transcript[i]
                handled[0] = i + 1
                if turn["speaker"] != "sys":
                    continue
                if turn["act"] == "Request(userGameMove)":
                    free = [c for c in (4, 0, 2, 6, 8, 1, 3, 5, 7) if robot.board[c] == EMPTY]
                    return str(free[0] + 1)  # cells typed as 1-9
                if turn["act"] in answers:
                    return answers[turn["act"]]
            time.sleep(0.01)
        raise EOFError

    return read_line


def run(robot: Robot, answers: dict[str, str]) -> str:
    console = Console(record=True, width=120, force_terminal=False)
    TerminalRobot(
        robot,
        read_line=typist(robot, answers),
        console=console,
        speakers=Speakers(enabled=False),
        microphone=Microphone(),
    ).run()
    return console.export_text()


def test_a_typed_game_in_the_terminal_prints_the_dialogue_like_figure_1():
    robot = Robot(FAST, seed=4)
    out = run(robot, {"Request(playGame)": "yes let's play"})
    assert "Rob: Hello!" in out or "Rob: Hi!" in out
    assert "[Salutation(greeting)]" in out
    assert "Usr: yes let's play" in out
    assert "[who=usr what=draw where=middle]" in out  # the first typed cell, 5
    assert "Game over:" in out
    assert "[Salutation(closing)]" in out
    assert not any(c.running for c in robot.components)  # stopped when the person quit


def test_a_camera_that_cannot_be_opened_falls_back_to_typed_moves(caplog):
    caplog.set_level(logging.WARNING)
    robot = Robot(FAST, sheet_camera=CameraSource(97), seed=4)
    out = run(robot, {"Request(playGame)": "okay"})
    warnings = [r for r in caplog.records if "game-move recognition is off" in r.message]
    assert len(warnings) == 1
    assert "Game over:" in out and "[who=usr what=draw" in out
