"""Every HTTP route checks Host and Origin as the game socket does, and the learned page's data
stays small whatever the recordings hold."""

from __future__ import annotations

import gc
import os
import urllib.parse

import pytest
from fastapi.testclient import TestClient

from oxbot.config import load_config
from oxbot.game.board import EMPTY_BOARD
from oxbot.recording import Recorder, RecordingStore
from oxbot.robot.bus import LocalBus
from oxbot.robot.messages import GameState
from oxbot.testing.hostile import HTTP_ROUTES, decompression_bomb
from oxbot.web.recording import RecordingSetup
from oxbot.web.server import create_app, page_url

CONFIG = load_config(None, ['web.allowed_origins="http://oxbot.lan:8000"'])


@pytest.fixture(scope="module")
def client(tmp_path_factory) -> TestClient:
    """The app without its lifespan (no models loaded), its recordings in an empty folder."""
    recording = RecordingSetup(tmp_path_factory.mktemp("data"))
    return TestClient(create_app(CONFIG, recording=recording), base_url="http://127.0.0.1:8000")


@pytest.mark.parametrize("route", HTTP_ROUTES)
def test_every_route_answers_its_own_host_and_origin(client, route):
    assert client.get(route).status_code == 200
    assert client.get(route, headers={"origin": "http://127.0.0.1:8000"}).status_code == 200
    assert client.get(route, headers={"origin": "http://oxbot.lan:8000"}).status_code == 200


@pytest.mark.parametrize("route", HTTP_ROUTES)
@pytest.mark.parametrize(
    "headers",
    [
        {"host": "evil.example:8000"},  # DNS rebinding: the page of another name, this address
        {"host": "evil.example"},
        {"origin": "http://evil.example"},
        {"origin": "null"},
    ],
)
def test_a_foreign_host_or_origin_is_refused_on_every_route(client, route, headers):
    response = client.get(route, headers=headers)
    assert response.status_code == 403, response.text
    assert "web.allowed_origins" in response.json()["error"]


def _rss_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def test_an_oversized_crop_is_left_unread_and_memory_stays_put(tmp_path):
    with RecordingStore(tmp_path) as store:
        recorder = Recorder(LocalBus(), store)
        recorder.handle(GameState(board=EMPTY_BOARD, robot_starts=True))
        with store.transaction() as db:
            db.executemany(
                "INSERT INTO crops VALUES (?, ?, 0, 0.0, ?, 'circle', 0.9, 2, 'cross')",
                [(recorder.sessions[0], 1, decompression_bomb(20_000)),  # 400 MB decoded
                 (recorder.sessions[0], 2, decompression_bomb(2_000))],  # small, still not 40x40
            )  # fmt: skip
    client = TestClient(
        create_app(CONFIG, recording=RecordingSetup(tmp_path)), base_url="http://127.0.0.1:8000"
    )
    client.get("/recording/learned")
    gc.collect()
    before = _rss_mb()
    for _ in range(10):
        response = client.get("/recording/learned")
        assert response.status_code == 200 and response.json()["crops"] == []
        assert len(response.content) < 100_000
    gc.collect()
    assert _rss_mb() - before < 50


def test_an_ipv6_host_gives_a_valid_url():
    url = page_url("http", "::1", 8000)
    assert url == "http://[::1]:8000/"
    assert urllib.parse.urlsplit(url).hostname == "::1" and urllib.parse.urlsplit(url).port == 8000


def test_a_robot_that_cannot_record_says_so_and_refuses_the_toggle(tmp_path):
    import asyncio
    from types import SimpleNamespace

    from oxbot.config import WebConfig
    from oxbot.errors import ConfigError, InvalidInputError
    from oxbot.web.server import REMOTE_RECORDING, serve
    from oxbot.web.session import Session

    remote = RecordingSetup(tmp_path, unavailable=REMOTE_RECORDING)
    client = TestClient(create_app(CONFIG, recording=remote), base_url="http://127.0.0.1:8000")
    status = client.get("/recording/status").json()
    assert status["available"] is False and "not available" in status["notice"]
    with pytest.raises(ConfigError, match="not available"):
        serve(CONFIG, record=True, robot_factory=lambda: None)

    async def toggle() -> list:
        bus = LocalBus()
        seen = bus.subscribe()
        session = Session(SimpleNamespace(bus=bus), WebConfig())
        session.recording_refusal = REMOTE_RECORDING
        with pytest.raises(InvalidInputError, match="not available"):
            session._on_record({"on": True})
        session._on_record({"on": False})  # nothing is kept: switching off is harmless
        return seen.drain()

    assert [type(m).__name__ for m in asyncio.run(toggle())] == ["RecordingSwitch"]


def test_eyes_that_rejoin_are_shown_the_last_sheet_again():
    import asyncio
    import threading
    import time
    from types import SimpleNamespace

    import cv2
    import numpy as np

    from oxbot.config import WebConfig
    from oxbot.robot.messages import ComponentJoined
    from oxbot.testing.player import data_url
    from oxbot.web.session import Session

    shown: list[np.ndarray] = []
    again = threading.Event()

    def show(frame):
        shown.append(frame)
        if len(shown) == 2:
            again.set()

    bus = LocalBus()
    robot = SimpleNamespace(bus=bus, show=show, start=lambda: None, stop=lambda: None)

    async def rejoin() -> bool:
        session = Session(robot, WebConfig())
        session.start()
        try:
            sheet = np.full((120, 160, 3), 255, np.uint8)
            session._on_frame({"image": data_url(cv2.imencode(".png", sheet)[1].tobytes())})
            bus.publish(ComponentJoined(component="GameMoveComponent", part="eyes"))
            return await asyncio.to_thread(again.wait, 5.0)
        finally:
            await asyncio.to_thread(session.close)

    started = time.monotonic()
    assert asyncio.run(rejoin()), "the sheet was not shown again"
    assert np.array_equal(shown[0], shown[1]) and time.monotonic() - started < 5
