"""A real oxbot web server on a free localhost port, with real robots behind it."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from oxbot.config import load_config
from oxbot.web.server import create_app, serving_in_background

FAST = load_config(
    None,
    [
        "robot.speed_factor=8",
        "robot.answer_timeout=16",
        "robot.move_timeout=240",
        "web.resume_seconds=10",
    ],
)
"""Speech, arm and waits 8x faster than real time; the robot waits 2 s for an answer and 30 s
for a drawing, so a slow test machine never loses its turn. A tab closed mid-game keeps its
robot running for 10 s, not a minute, so that the tests after it share the cores with fewer."""


@contextmanager
def running_server(**app_options) -> Iterator[str]:
    """Serve `create_app(**app_options)` in a background thread; yields its http:// URL."""
    with serving_in_background(create_app(**app_options)) as url:
        yield url


@pytest.fixture(scope="module")
def server_url() -> Iterator[str]:
    with running_server(config=FAST) as url:
        yield url


@pytest.fixture(scope="module")
def ws_url(server_url: str) -> str:
    return server_url.replace("http://", "ws://") + "/ws"
