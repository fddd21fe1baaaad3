"""A real oxbot web server on a free localhost port, with real robots behind it."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import httpx
import pytest
import uvicorn

from oxbot.robot.session import RobotOptions
from oxbot.web.server import create_app

FAST = RobotOptions(speed_factor=8.0, answer_timeout=16.0, move_timeout=240.0)
"""Speech, arm and waits 8x faster than real time; the robot waits 2 s for an answer and 30 s
for a drawing, so a slow test machine never loses its turn."""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def running_server(**app_options) -> Iterator[str]:
    """Serve `create_app(**app_options)` in a background thread; yields its http:// URL."""
    port = free_port()
    app = create_app(**app_options)
    server = uvicorn.Server(
        uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning", ws_max_size=2**24)
    )
    thread = threading.Thread(target=server.run, name="oxbot-test-server", daemon=True)
    thread.start()
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 20
    while True:
        try:
            if httpx.get(f"{url}/health", timeout=1).status_code == 200:
                break
        except httpx.HTTPError:
            pass
        if time.monotonic() > deadline or not thread.is_alive():
            raise RuntimeError("the oxbot web server did not start")
        time.sleep(0.05)
    try:
        yield url
    finally:
        server.should_exit = True
        thread.join(15)


@pytest.fixture(scope="module")
def server_url() -> Iterator[str]:
    with running_server(robot_options=FAST) as url:
        yield url


@pytest.fixture(scope="module")
def ws_url(server_url: str) -> str:
    return server_url.replace("http://", "ws://") + "/ws"
