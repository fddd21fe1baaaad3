"""The launcher owns its component processes: kill -9 of the launcher leaves no orphan, a new
launcher ends what an old one left, and the components' shared memory goes with them."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from oxbot.robot.children import end_leftovers, pid_file, remove_unmapped
from tests.robot.test_zenoh import REPO, free_port, robot_name

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

LAUNCH = """
import sys, time
from oxbot.config import load_config
from oxbot.robot.launch import Launcher, LaunchFile
launch = LaunchFile(robot=sys.argv[1], components=("head-movement", "arm"),
                    listen=(f"tcp/127.0.0.1:{sys.argv[2]}",))
launcher = Launcher(launch, load_config(None, [])).start()
print(" ".join(str(p.pid) for p in launcher.processes.values()), flush=True)
time.sleep(600)
"""


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split()[2]
    except OSError:
        return False
    return state != "Z"


def test_kill_9_of_the_launcher_leaves_no_orphan_within_10_s():
    robot = robot_name()
    launcher = subprocess.Popen(
        [sys.executable, "-c", LAUNCH, robot, str(free_port())],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": REPO},
    )
    try:
        children = [int(p) for p in launcher.stdout.readline().split()]
        assert len(children) == 2 and all(_running(p) for p in children)
        deadline, names = time.monotonic() + 20, set()
        while names != {"oxbot-head-move", "oxbot-arm"} and time.monotonic() < deadline:
            time.sleep(0.1)  # each names itself as it starts
            names = {Path(f"/proc/{p}/comm").read_text().strip() for p in children}
        children.append(int(Path(f"/proc/{children[0]}/stat").read_text().split()[3]))
        assert children[-1] != launcher.pid  # the fork server: it must go too
        launcher.send_signal(signal.SIGKILL)
        launcher.wait(10)
        killed = time.monotonic()
        while any(_running(p) for p in children) and time.monotonic() - killed < 10:
            time.sleep(0.1)
        assert not any(_running(p) for p in children), "orphans outlived the launcher"
        assert names == {"oxbot-head-move", "oxbot-arm"}  # ps shows what they are
    finally:
        launcher.kill()
        pid_file(robot).unlink(missing_ok=True)


def test_a_new_launcher_ends_the_children_an_old_one_left():
    robot = robot_name()
    named = (
        "import ctypes, time; ctypes.CDLL(None).prctl(15, b'oxbot-arm', 0, 0, 0); time.sleep(60)"
    )
    orphan = subprocess.Popen([sys.executable, "-c", named])
    stranger = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        time.sleep(0.3)  # it has named itself
        gone_launcher = 2**22 + 17  # no such process
        pid_file(robot).write_text(
            json.dumps({"launcher": gone_launcher, "children": [orphan.pid, stranger.pid]})
        )
        assert end_leftovers(robot) == [orphan.pid]
        assert orphan.wait(5) is not None
        assert stranger.poll() is None  # not oxbot's: a recycled pid is never killed
    finally:
        for process in (orphan, stranger):
            process.kill()
            process.wait(5)
        pid_file(robot).unlink(missing_ok=True)


def test_shared_memory_no_process_maps_is_removed_and_mapped_memory_kept(tmp_path):
    import mmap

    left = Path("/dev/shm") / f"oxbot-test-{os.getpid()}-left.zenoh"
    used = Path("/dev/shm") / f"oxbot-test-{os.getpid()}-used.zenoh"
    for path in (left, used):
        path.write_bytes(b"\0" * 4096)
    with used.open("r+b") as handle, mmap.mmap(handle.fileno(), 4096):
        try:
            assert remove_unmapped([left, used]) == 4096
            assert not left.exists() and used.exists()
            # a process's own mappings outlive the names: when it is done, they may go
            assert remove_unmapped([used], ignore=os.getpid()) == 4096 and not used.exists()
        finally:
            used.unlink(missing_ok=True)
            left.unlink(missing_ok=True)
