"""Ctrl-C during `oxbot train`: a checkpoint at once, one line saying how to resume, exit 130.

Real runs of the command line in a subprocess, interrupted with SIGINT once training started
(the log line `-v` prints then), and resumed with the very command they printed.
"""

import json
import os
import queue
import shlex
import signal
import subprocess
import sys
import threading
import time

import pytest

from oxbot import artifacts

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="SIGINT to a child is POSIX")


def _default_sigint() -> None:
    # A job started in the background (`make test &`, nohup, some CI runners) inherits SIGINT
    # ignored, and oxbot then leaves it ignored, as a user who ran it so would want: the child
    # starts as from a terminal.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(args: list[str], cwd) -> tuple[subprocess.Popen, "queue.Queue[str]"]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "oxbot.cli", *args],
        cwd=cwd,
        preexec_fn=_default_sigint,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    )
    lines: queue.Queue[str] = queue.Queue()

    def pump() -> None:
        for line in proc.stderr:
            lines.put(line)
        lines.put("")  # end of the stream

    threading.Thread(target=pump, daemon=True).start()
    return proc, lines


def _wait_for(lines: "queue.Queue[str]", text: str, seen: list[str], timeout: float = 60) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = lines.get(timeout=deadline - time.monotonic())
        seen.append(line)
        if text in line:
            return
        assert line, f"the run ended before {text!r}:\n{''.join(seen)}"
    raise AssertionError(f"no {text!r} within {timeout} s:\n{''.join(seen)}")


def _interrupt(args: list[str], cwd, started: str) -> tuple[str, str]:
    """Run `oxbot -v ARGS`, send SIGINT once `started` is logged; its stderr's last line."""
    proc, lines = _start(["-v", *args], cwd)
    seen: list[str] = []
    _wait_for(lines, started, seen)
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=60) == 130
    while (line := lines.get(timeout=10)) != "":
        seen.append(line)
    stderr = "".join(seen)
    assert "Traceback" not in stderr
    last = [line for line in seen if not line.startswith(("DEBUG", "INFO", "WARNING"))][-1]
    return last.strip(), stderr


def _resume(printed: str, cwd) -> str:
    """Run the resume command as printed (oxbot ... --resume), with -v; its stderr."""
    words = shlex.split(printed.split("resume with: ", 1)[1])
    assert words[0] == "oxbot" and words[-1] == "--resume"
    result = subprocess.run(
        [sys.executable, "-m", "oxbot.cli", "-v", *words[1:]],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stderr


def test_ctrl_c_while_training_the_agent_saves_and_the_printed_command_resumes(tmp_path):
    config = tmp_path / "tiny.toml"
    config.write_text("[agent]\ntotal_steps = 1000\nlearning_starts = 100\nreplay_size = 3000\n")
    args = ["--config", str(config), "--set", "agent.seed=3", "train", "agent", "--out", "run"]
    line, _ = _interrupt([*args, "--quiet"], tmp_path, "training from experience 0")

    checkpoint = tmp_path / "run" / "checkpoint.pt"
    assert line.startswith("training interrupted after ")
    assert f"saved the checkpoint {os.path.join('run', 'checkpoint.pt')}" in line
    assert line.endswith(
        f"resume with: oxbot --config {config} --set agent.seed=3 train agent --out run --resume"
    )
    state = artifacts.load(checkpoint, "agent-checkpoint", 2, "checkpoint", "")["state"]
    step = state["step"]
    assert 0 < step < 1000 and f"after {step:,} of 1,000 experiences" in line

    stderr = _resume(line, tmp_path)
    assert f"resumed from {os.path.join('run', 'checkpoint.pt')} at step {step}" in stderr
    assert f"training from experience {step} of 1000" in stderr
    metrics = json.loads((tmp_path / "run" / "agent_metrics.json").read_text())
    assert metrics["experiences"] == 1000 and metrics["games"] > state["episodes"]


def test_ctrl_c_while_training_the_perceiver_saves_and_the_printed_command_resumes(tmp_path):
    args = ["--set", "perception.epochs=1", "--set", "perception.test_images=100"]
    args += ["train", "perceiver", "--images", "1500", "--out", "p/perceiver.pt", "--quiet"]
    line, _ = _interrupt(args, tmp_path, "training on 1000 images")

    checkpoint = tmp_path / "p" / "perceiver.checkpoint.pt"
    payload = artifacts.load(checkpoint, "perceiver-checkpoint", 1, "checkpoint", "")
    done = [p["images"] for p in payload["points"]]
    assert done in ([100, 300], [100, 300, 1000])  # SIGINT came during the third fit, or after
    assert line.startswith(f"training interrupted after {len(done)} of 4 fits")
    assert line.endswith(
        "resume with: oxbot --set perception.epochs=1 --set perception.test_images=100 "
        "train perceiver --out p/perceiver.pt --images 1500 --resume"
    )
    assert not (tmp_path / "p" / "perceiver.pt").exists()

    stderr = _resume(line, tmp_path)
    assert f"{len(done)} of 4 fits done" in stderr
    assert "training on 100 images" not in stderr  # the finished fits are not redone
    metrics = json.loads((tmp_path / "p" / "perceiver.metrics.json").read_text())
    assert metrics["learning_curve"][: len(done)] == payload["points"]
    assert [p["images"] for p in metrics["learning_curve"]] == [100, 300, 1000, 1500]
    assert not checkpoint.exists()  # finished: nothing left to resume
