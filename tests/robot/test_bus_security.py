"""Zenoh's TLS with mutual authentication and access control on a robot's bus: a part with the
robot's credentials is heard; a peer whose certificate another CA signed cannot connect, and
one the CA signed under a name not allowed connects but is not heard. A router here and each
peer in a process of its own, over loopback."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from oxbot.errors import ConfigError
from oxbot.robot.bus_security import BusSecurity, make_credentials
from oxbot.robot.launch import load_launch_file
from oxbot.robot.messages import NewGame
from oxbot.robot.zenoh_bus import Endpoints, ZenohBus
from tests.robot.test_zenoh import REPO, free_port, robot_name

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

PEER = """
import sys
from pathlib import Path
from oxbot.errors import OxbotError
from oxbot.robot.bus_security import BusSecurity
from oxbot.robot.messages import NewGame
from oxbot.robot.zenoh_bus import Endpoints, ZenohBus
robot, endpoint, folder, name = sys.argv[1:5]
folder = Path(folder)
security = BusSecurity(folder / "ca.pem", folder / f"{name}.pem", folder / f"{name}-key.pem",
                       ("router", "part"))
try:
    with ZenohBus(robot, Endpoints(connect=(endpoint,), scouting=False, security=security)) as bus:
        for _ in range(20):
            bus.publish(NewGame(robot_starts=False))
            import time; time.sleep(0.1)
except OxbotError as exc:
    print(exc)
    sys.exit(2)
"""


def peer(robot: str, endpoint: str, folder, name: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", PEER, robot, endpoint, str(folder), name],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": REPO},
    )


def test_only_the_robots_credentialed_parts_are_heard(tmp_path):
    make_credentials(tmp_path / "robot", ["router", "part", "stranger"])
    make_credentials(tmp_path / "evil", ["part"])  # the right name, another CA
    robot, endpoint = robot_name(), f"tls/127.0.0.1:{free_port()}"
    folder = tmp_path / "robot"
    security = BusSecurity(
        folder / "ca.pem", folder / "router.pem", folder / "router-key.pem", ("router", "part")
    )
    router = Endpoints(listen=(endpoint,), scouting=False, router=True, security=security)
    with ZenohBus(robot, router) as bus:
        inbox = bus.subscribe(NewGame)
        evil = peer(robot, endpoint, tmp_path / "evil", "part")
        assert evil.returncode == 2 and "nothing answers" in evil.stdout, evil
        stranger = peer(robot, endpoint, folder, "stranger")
        assert stranger.returncode == 0, stranger.stderr[-500:]
        time.sleep(0.3)
        assert inbox.drain() == []  # connected, and not heard
        part = peer(robot, endpoint, folder, "part")
        assert part.returncode == 0, part.stderr[-500:]
        time.sleep(0.3)
        assert inbox.drain(), "the robot's own part was not heard"


def test_a_launch_files_security_table_is_read_and_checked(tmp_path):
    make_credentials(tmp_path, ["launcher"])
    good = tmp_path / "robot.toml"
    good.write_text(
        'listen = ["tls/127.0.0.1:7447"]\n[security]\nca = "ca.pem"\n'
        'certificate = "launcher.pem"\nkey = "launcher-key.pem"\nallowed = ["launcher"]\n'
    )
    launch = load_launch_file(good)
    assert launch.security is not None and launch.security.allowed == ("launcher",)
    assert launch.child_endpoints().security == launch.security
    bad = tmp_path / "bad.toml"
    bad.write_text('[security]\nca = "nowhere.pem"\ncertificate = "x"\nkey = "y"\nallowed = []\n')
    with pytest.raises(ConfigError, match="is not a file"):
        load_launch_file(bad)


def test_a_components_security_file_is_read_for_its_endpoints(tmp_path):
    from oxbot.robot.launch import endpoints_of

    make_credentials(tmp_path, ["arm-machine"])
    file = tmp_path / "security.toml"
    file.write_text(
        '[security]\nca = "ca.pem"\ncertificate = "arm-machine.pem"\n'
        'key = "arm-machine-key.pem"\nallowed = ["launcher", "arm-machine"]\n'
    )
    endpoints = endpoints_of(["tls/192.0.2.1:7447"], None, False, file)
    assert endpoints.security is not None
    assert endpoints.security.certificate == tmp_path / "arm-machine.pem"
    file.write_text('robot = "x"\n')
    with pytest.raises(ConfigError, match="one \\[security\\] table"):
        endpoints_of([], None, False, file)
