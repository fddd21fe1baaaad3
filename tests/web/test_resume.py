"""A page that reloads mid-game gets its game back: the server keeps a session whose socket went
away for `web.resume_seconds`, and a socket with its resume token takes it back, with what the
page needs to show the game as it was. Over the protocol, with the websockets client."""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import time

import httpx
import numpy as np
import pytest
import websockets
from websockets.exceptions import ConnectionClosed

from oxbot.config import load_config
from oxbot.dialogue.domain import INVITATION, MOVE_REQUEST, game_move_cell
from oxbot.game.board import CELL_NAMES, EMPTY_BOARD, ROBOT, USER, outcome, play
from oxbot.testing.player import data_url
from oxbot.testing.sheet import Sheet, person_strokes
from oxbot.web.recording import RecordingSetup
from tests.web.conftest import FAST, running_server

GOING_AWAY = 1001
"""The close code a browser sends when its page reloads or closes."""


def connect(url: str):
    """A client that, like a browser's reload, does not wait for the server to answer its close
    (a client that has left messages unread would wait up to 10 s)."""
    return websockets.connect(url, max_size=2**24, close_timeout=0.5)


async def drain(ws, seconds: float) -> None:
    """Read what comes for `seconds`, as a page does."""
    deadline = time.monotonic() + seconds
    with contextlib.suppress(TimeoutError):
        while (left := deadline - time.monotonic()) > 0:
            await asyncio.wait_for(ws.recv(), left)


@pytest.fixture(scope="module")
def url(tmp_path_factory):
    recording = RecordingSetup(tmp_path_factory.mktemp("recordings"))
    with running_server(config=FAST, recording=recording) as served:
        yield served


def ws_of(url: str, query: str = "") -> str:
    return url.replace("http://", "ws://") + "/ws" + query


async def receive(ws, timeout: float = 20) -> dict:
    """The next message, but for "The robot is waking up" while a new server loads its models."""
    while (message := json.loads(await asyncio.wait_for(ws.recv(), timeout)))["type"] == "Status":
        pass
    return message


class Person:
    """A scripted person who answers yes and draws in a free cell when asked, on one sheet kept
    across sockets, as the page keeps its canvas; what it saw, as the page would show it."""

    def __init__(self, seed: int) -> None:
        self.sheet, self.rng = Sheet(seed), np.random.default_rng(seed)
        self.hello: dict = {}
        self.transcript: list[tuple[str, str]] = []
        self.drawn: list[str] = []
        self.accepted: list[str] = []
        self.board = EMPTY_BOARD
        self.last_frame = ""
        self.outcome: str | None = None
        self.ended = False

    def robot_cells(self) -> list[str]:
        return [
            CELL_NAMES[game_move_cell(act)]
            for speaker, act in self.transcript
            if speaker == "sys" and game_move_cell(act) is not None
        ]

    def waits_for_my_move(self) -> bool:
        said = [act for speaker, act in self.transcript if speaker == "sys"]
        return bool(said) and said[-1] == MOVE_REQUEST and len(self.accepted) == len(self.drawn)

    async def send_sheet(self, ws) -> None:
        self.last_frame = data_url(self.sheet.png())
        await ws.send(json.dumps({"type": "frame", "image": self.last_frame}))

    async def draw_move(self, ws) -> None:
        taken = set(self.drawn) | set(self.robot_cells())
        where = next(c for c in CELL_NAMES if c not in taken)
        self.drawn.append(where)
        self.sheet.draw_strokes(where, person_strokes(self.hello["user_symbol"], self.rng))
        await self.send_sheet(ws)

    def see(self, message: dict) -> None:
        """What the page shows of a message, live or replayed."""
        kind, data = message["type"], message.get("data", {})
        if kind == "DialogueAct":
            self.transcript.append((data["speaker"], data["act"]))
        elif kind == "GameMove" and data["who"] == "usr":
            self.accepted.append(data["where"])
        elif kind == "GameState":
            self.board = tuple(data["board"])
        elif kind == "DialogueEnded":
            self.outcome, self.ended = data["outcome"], True

    async def act(self, ws, message: dict) -> None:
        """See a live message, and answer it as a person would."""
        self.see(message)
        kind, data = message["type"], message.get("data", {})
        if kind == "Hello" and not data["resumed"]:
            self.hello = data
            await self.send_sheet(ws)
        elif kind == "DialogueAct" and data["speaker"] == "sys" and data["act"] == INVITATION:
            await ws.send(json.dumps({"type": "say", "text": "yes let's play"}))
        elif kind == "DialogueAct" and data["speaker"] == "sys" and self.waits_for_my_move():
            await self.draw_move(ws)

    async def play_until(self, ws, done, timeout: float = 60) -> None:
        deadline = time.monotonic() + timeout
        while not done():
            assert time.monotonic() < deadline, f"stuck; transcript: {self.transcript}"
            await self.act(ws, await receive(ws))


def test_a_game_whose_page_reloads_comes_back_as_it_was_and_goes_on_to_its_end(url):
    person = Person(seed=3)

    before: dict = {}

    async def game() -> tuple[dict, dict, list[tuple[str, str]]]:
        async with connect(ws_of(url)) as ws:
            await person.play_until(ws, lambda: len(person.robot_cells()) >= 2)
            before.update(
                transcript=list(person.transcript),
                sheet=person.last_frame,
                robot=person.robot_cells(),
                usr=list(person.accepted),
            )
            await ws.close(code=GOING_AWAY)  # as a browser's reload closes it
        token = person.hello["resume_token"]
        async with connect(ws_of(url, f"?resume={token}")) as ws:
            hello, resumed = await receive(ws), await receive(ws)
            assert (hello["type"], resumed["type"]) == ("Hello", "Resumed")
            person.transcript, person.accepted = [], []  # the page starts afresh: the replay
            for message in resumed["data"]["messages"]:
                person.see(message)
            replayed = list(person.transcript)
            if person.waits_for_my_move():  # asked while the page was away
                await person.draw_move(ws)
            await person.play_until(ws, lambda: person.ended)
        return hello, resumed, replayed

    hello, resumed, replayed = asyncio.run(game())
    assert hello["data"]["resumed"] and hello["data"]["session"] == person.hello["session"]
    assert hello["data"]["resume_token"] == person.hello["resume_token"]
    # the same game: its turns so far, the sheet as the page last sent it, the board
    assert replayed[: len(before["transcript"])] == before["transcript"]
    assert replayed[0] == ("sys", "Salutation(greeting)")
    data = resumed["data"]
    assert data["sheet"] == before["sheet"]
    assert not data["paper"] and not data["recording"] and data["said"]
    board = EMPTY_BOARD
    for cells, who in ((before["usr"], USER), (before["robot"], ROBOT)):
        for cell in cells:
            board = play(board, CELL_NAMES.index(cell), who)
    (state,) = [m for m in data["messages"] if m["type"] == "GameState"]
    assert state["data"]["board"] == list(board)
    # and it went on to its end, every move in its place
    assert person.ended and person.outcome is not None
    assert person.transcript[-1] == ("sys", "Salutation(closing)")
    assert person.accepted == person.drawn
    assert outcome(person.board) == person.outcome


def test_an_unknown_token_is_told_plainly_and_gets_a_new_game(url):
    async def tab() -> list[dict]:
        async with connect(ws_of(url, "?resume=not-a-token-of-ours")) as ws:
            return [await receive(ws) for _ in range(2)]

    error, hello = asyncio.run(tab())
    assert error["type"] == "Error" and error["data"]["code"] == "resume_failed"
    assert "could not be brought back" in error["data"]["message"]
    assert hello["type"] == "Hello" and not hello["data"]["resumed"]
    assert len(hello["data"]["resume_token"]) >= 32


def test_a_newer_socket_with_the_token_takes_the_game_and_the_first_is_closed(url):
    """The first socket of a reloaded page may still be open when the second comes (or a
    duplicated tab copied the token): the newest wins, and the robot goes on."""

    async def tabs() -> tuple[dict, dict, int, str]:
        async with connect(ws_of(url)) as first:
            hello = await receive(first)
            token = hello["data"]["resume_token"]
            while (await receive(first))["type"] != "DialogueAct":
                pass
            # the page turns the record toggle on: a resumed game keeps it so
            await first.send(json.dumps({"type": "record", "on": True}))
            await asyncio.sleep(0.3)
            query = f"?resume={token}"
            async with connect(ws_of(url, query)) as second:
                again, resumed = await receive(second), await receive(second)
                try:
                    while True:
                        await receive(first)
                except ConnectionClosed as closed:
                    code, reason = closed.rcvd.code, closed.rcvd.reason
                health = httpx.get(url + "/health").json()
                assert health["sessions"] == 1, health
        return hello, again, resumed, code, reason

    hello, again, resumed, code, reason = asyncio.run(tabs())
    assert again["data"]["session"] == hello["data"]["session"] and again["data"]["resumed"]
    assert resumed["data"]["recording"]
    acts = [m["data"]["act"] for m in resumed["data"]["messages"] if m["type"] == "DialogueAct"]
    assert acts[0] == "Salutation(greeting)"
    assert code == 4000 and "newer page" in reason, (code, reason)


def robot_threads() -> int:
    shared = ("oxbot-web-server", "oxbot-web-warm-up")
    return sum(
        t.name.startswith("oxbot-") and not t.name.startswith(shared) for t in threading.enumerate()
    )


def sessions(url: str) -> int:
    return httpx.get(url + "/health").json()["sessions"]


def test_a_game_no_page_comes_back_to_is_stopped_and_its_slot_given_back():
    config = load_config(
        None, ["robot.speed_factor=8", "web.resume_seconds=1.5", "web.max_sessions=1"]
    )
    with running_server(config=config) as served:
        baseline = robot_threads()

        async def scenario() -> dict:
            async with connect(ws_of(served)) as ws:
                hello = await receive(ws)
                await ws.close(code=GOING_AWAY)
            kept_at = time.monotonic()
            await asyncio.sleep(0.3)
            assert sessions(served) == 1  # kept, holding the only slot
            async with connect(ws_of(served)) as other:
                refused = await receive(other)
            assert refused["type"] == "Error" and "busy" in refused["data"]["message"]
            while sessions(served):
                assert time.monotonic() - kept_at < 10, "the kept game was never stopped"
                await asyncio.sleep(0.1)
            assert time.monotonic() - kept_at > 1.2  # kept for resume_seconds, then stopped
            while robot_threads() > baseline:  # its slot is given back once they have stopped
                assert time.monotonic() - kept_at < 15, "the kept game's robot did not stop"
                await asyncio.sleep(0.1)
            await asyncio.sleep(0.2)
            token = hello["data"]["resume_token"]
            async with connect(ws_of(served, f"?resume={token}")) as late:
                error, fresh = await receive(late), await receive(late)
                assert error["data"]["code"] == "resume_failed"
                assert (
                    fresh["type"] == "Hello"
                    and fresh["data"]["session"] != hello["data"]["session"]
                )
            return hello

        asyncio.run(scenario())
        deadline = time.monotonic() + 10
        while sessions(served) or robot_threads() > baseline:
            assert time.monotonic() < deadline, "the robots' threads did not stop"
            time.sleep(0.1)


def test_a_tab_that_closes_meaning_to_end_ends_its_game_and_zero_seconds_keeps_none():
    for settings, close_code in (([], 1000), (["web.resume_seconds=0"], GOING_AWAY)):
        config = load_config(None, ["robot.speed_factor=8", *settings])
        with running_server(config=config) as served:

            async def tab(close_code=close_code) -> dict:
                async with connect(ws_of(served)) as ws:
                    hello = await receive(ws)
                    await ws.close(code=close_code)
                return hello

            hello = asyncio.run(tab())
            assert bool(hello["data"]["resume_token"]) == (not settings)
            deadline = time.monotonic() + 5
            while sessions(served):
                assert time.monotonic() < deadline, f"kept after a {close_code} close"
                time.sleep(0.05)


def test_a_resumed_game_gets_no_more_time_than_max_session_seconds():
    config = load_config(None, ["robot.speed_factor=8", "web.max_session_seconds=4"])
    with running_server(config=config) as served:

        async def scenario() -> tuple[float, int, str]:
            async with connect(ws_of(served)) as ws:
                hello = await receive(ws)
                started = time.monotonic()  # the session began a little before its Hello
                await drain(ws, 2)
                await ws.close(code=GOING_AWAY)
            token = hello["data"]["resume_token"]
            async with connect(ws_of(served, f"?resume={token}")) as ws:
                try:
                    while True:
                        await receive(ws)
                except ConnectionClosed as closed:
                    return time.monotonic() - started, closed.rcvd.code, closed.rcvd.reason

        seconds, code, reason = asyncio.run(scenario())
    assert code == 1001 and "max_session_seconds" in reason, (code, reason)
    assert 2.5 < seconds < 4.5, seconds  # from the first socket's start, not the second's
