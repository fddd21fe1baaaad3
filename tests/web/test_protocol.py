"""The page's WebSocket: one robot per tab, and bad input answered on its own socket only."""

from __future__ import annotations

import asyncio
import base64
import io
import json
import re
import socket
import threading
import time

import httpx
import numpy as np
import pytest
import websockets
from PIL import Image

from oxbot.config import OxbotConfig, load_config
from oxbot.errors import ConfigError
from oxbot.game.board import outcome
from oxbot.speech import Voice, pcm16, synthesize
from oxbot.testing.player import GameRecord, data_url, play_game
from oxbot.testing.sheet import Sheet
from oxbot.testing.sounds import in_noise
from oxbot.web.server import serve


def png(image: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return buffer.getvalue()


async def next_of(ws, kinds: set[str], timeout: float = 10.0) -> dict:
    """The next message of one of `kinds`, skipping the robot's other messages."""
    deadline = time.monotonic() + timeout
    while True:
        message = json.loads(await asyncio.wait_for(ws.recv(), deadline - time.monotonic()))
        if message["type"] in kinds:
            return message


def test_page_has_the_spec_hooks_and_its_files(server_url):
    page = httpx.get(server_url + "/").text
    for hook in ("board", "log", "say", "talk", "start"):
        assert f'data-testid="{hook}"' in page
    for name in ("app.js", "style.css", "tap.js"):
        assert httpx.get(f"{server_url}/static/{name}").status_code == 200
    assert httpx.get(f"{server_url}/static/secret.py").status_code == 404
    # its own icon, inline: no request for a /favicon.ico the server does not have
    icon = re.search(r'<link rel="icon" [^>]*href="data:image/svg\+xml,(.+?)"', page)
    assert icon and "%3Csvg" in icon.group(1)


def test_server_binds_to_localhost_unless_told_otherwise():
    assert OxbotConfig().web.host == "127.0.0.1"


def test_a_taken_port_is_a_clear_error_not_uvicorns():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        config = load_config(None, [f"web.port={port}"])
        with pytest.raises(ConfigError, match=f"port {port} on 127.0.0.1 is already in use") as e:
            serve(config)
        # `oxbot` is not on PATH in a clone: the hint runs as pasted
        assert f"`.venv/bin/oxbot play --port {port + 1}`" in str(e.value)


def test_each_tab_is_its_own_session_and_ends_cleanly(server_url, ws_url):
    def robot_threads() -> int:
        """The sessions' bridges and their robots' component threads."""
        names = [t.name for t in threading.enumerate()]
        shared = ("oxbot-web-server", "oxbot-web-warm-up")
        return sum(n.startswith("oxbot-") and not n.startswith(shared) for n in names)

    baseline = robot_threads()

    async def two_tabs() -> list[int]:
        async with websockets.connect(ws_url) as a, websockets.connect(ws_url) as b:
            hellos = [await next_of(ws, {"Hello"}) for ws in (a, b)]
            greetings = [await next_of(ws, {"DialogueAct"}) for ws in (a, b)]
            assert all(g["data"]["act"] == "Salutation(greeting)" for g in greetings)
            assert httpx.get(server_url + "/health").json()["sessions"] == 2
            assert robot_threads() >= baseline + 2 * 8  # a bridge and 7 components each
            return [h["data"]["session"] for h in hellos]

    ids = asyncio.run(two_tabs())
    assert ids[0] != ids[1]
    deadline = time.monotonic() + 10
    while httpx.get(server_url + "/health").json()["sessions"] or robot_threads() > baseline:
        assert time.monotonic() < deadline, "sessions did not end when their tabs closed"
        time.sleep(0.1)


PIECE = base64.b64encode(bytes(3_200)).decode()  # 0.1 s of silence

BAD_INPUT = [
    ("not json{", "not JSON"),
    ("[1, 2]", "JSON object"),
    ('{"type": "dance"}', "unknown message type"),
    ('{"type": "frame"}', "data URL"),
    ('{"type": "frame", "image": "%%%"}', "not valid base64"),
    (
        json.dumps({"type": "frame", "image": base64.b64encode(b"hello, not a PNG").decode()}),
        "not a readable",
    ),
    (
        json.dumps({"type": "frame", "image": data_url(png(np.zeros((9, 2100, 3), np.uint8)))}),
        "largest side",
    ),
    (json.dumps({"type": "frame", "image": "A" * 4_100_000}), "limit"),
    (
        json.dumps({"type": "talk", "rate": 44100, "pcm": base64.b64encode(bytes(8820)).decode()}),
        "16000 Hz",
    ),
    (
        json.dumps({"type": "talk", "rate": 16000, "pcm": base64.b64encode(bytes(6401)).decode()}),
        "odd number",
    ),
    ('{"type": "say", "text": ""}', "non-empty"),
    (b"\x00\x01binary", "binary messages"),
    (
        json.dumps({"type": "listen", "rate": 48000, "pcm": base64.b64encode(bytes(960)).decode()}),
        "hands-free audio must be 16000 Hz",
    ),
    (json.dumps({"type": "listen", "rate": 16000, "pcm": "%%%"}), "not valid base64"),
    (json.dumps({"type": "listen", "rate": 16000, "pcm": 3200}), "base64 string"),
    (json.dumps({"type": "listen", "rate": 16000, "pcm": ""}), "empty"),
    (
        json.dumps({"type": "listen", "rate": 16000, "pcm": base64.b64encode(bytes(3)).decode()}),
        "odd number",
    ),
    (
        json.dumps(
            {"type": "listen", "rate": 16000, "pcm": base64.b64encode(bytes(32_002)).decode()}
        ),
        "at most 1 s",
    ),
    *[
        (json.dumps({"type": "listen", "rate": 16000, "pcm": PIECE, "played": bad}), expected)
        for bad, expected in [
            ({"text": "Hello"}, "must be a list"),
            ([{"text": "Hello", "sentence": 0, "at": 0}] * 17, "at most 16"),
            (["Hello"], "must be an object"),
            ([{"text": 3, "sentence": 0, "at": 0}], "text must be the robot's utterance"),
            ([{"text": "Hello", "sentence": -1, "at": 0}], "its index in the utterance"),
            ([{"text": "Hello", "sentence": 0, "at": 1e12}], "within a minute"),
            ([{"text": "Hello", "sentence": 0, "at": True}], "within a minute"),
        ]
    ],
]


def test_bad_input_gets_an_error_on_its_socket_and_never_breaks_another_game(ws_url):
    async def garbage() -> list[str]:
        seen = []
        async with websockets.connect(ws_url, max_size=2**24) as ws:
            await next_of(ws, {"Hello"})
            for payload, expected in BAD_INPUT:
                await ws.send(payload)
                error = await next_of(ws, {"Error"})
                assert expected in error["data"]["message"], (payload[:60], error)
                seen.append(error["data"]["message"])
            # the socket still works: a typed answer is heard
            await ws.send(json.dumps({"type": "say", "text": "hello"}))
            heard = await next_of(ws, {"DialogueAct"})
            while heard["data"]["speaker"] != "usr":
                heard = await next_of(ws, {"DialogueAct"})
            assert heard["data"]["text"] == "hello"
        return seen

    async def both() -> tuple[list[str], GameRecord]:
        return await asyncio.gather(garbage(), play_game(ws_url, seed=11, timeout=90))

    errors, record = asyncio.run(both())
    assert len(errors) == len(BAD_INPUT)
    assert record.ended and not record.errors and not record.failures and not record.problems
    assert record.accepted == record.drawn
    assert outcome(record.board()) == record.outcome


def test_after_the_goodbye_drawings_are_refused_and_a_new_game_can_be_asked_for(ws_url):
    async def after_the_end() -> tuple[list[str], dict]:
        sheet = Sheet(5)
        async with websockets.connect(ws_url, max_size=2**24) as ws:
            hello = await next_of(ws, {"Hello"})
            user = hello["data"]["user_symbol"]
            taken: set[str] = set()
            mine: list[str] = []
            while True:
                message = await next_of(ws, {"DialogueAct", "DialogueEnded", "Error"}, 60)
                assert message["type"] != "Error", message
                if message["type"] == "DialogueEnded":
                    break
                act = message["data"]["act"]
                if act == "Request(playGame)":
                    await ws.send(json.dumps({"type": "say", "text": "yes let's play"}))
                elif act.startswith("GameMove(gridloc="):
                    taken.add(act[len("GameMove(gridloc=") : -1])
                elif act == "Request(userGameMove)" and message["data"]["speaker"] == "sys":
                    where = next(c for c in hello["data"]["cells"] if c not in taken)
                    taken.add(where)
                    mine.append(where)
                    sheet.draw(where, user)
                    await ws.send(json.dumps({"type": "frame", "image": data_url(sheet.png())}))
            await ws.send(json.dumps({"type": "frame", "image": data_url(sheet.png())}))
            refused = (await next_of(ws, {"Error"}))["data"]
            # words still reach the robot, which listens for a new game after its goodbye
            await ws.send(json.dumps({"type": "say", "text": "one more game please"}))
            greeting = await next_of(ws, {"DialogueAct", "Error"}, 30)
            while greeting["type"] == "DialogueAct" and greeting["data"]["speaker"] == "usr":
                greeting = await next_of(ws, {"DialogueAct", "Error"}, 30)
            await ws.send(json.dumps({"type": "new_game", "image": data_url(Sheet(6).png())}))
            again = await next_of(ws, {"DialogueAct", "Error"}, 30)
        return refused, greeting, again

    refused, greeting, again = asyncio.run(after_the_end())
    assert "game is over" in refused["message"] and refused["code"] == "game_over"
    assert greeting["type"] == "DialogueAct"
    # "one more game" started one, which goes on from the yes: no greeting again
    assert greeting["data"]["act"] == "Reply(playGame=yes)"
    assert again["type"] == "DialogueAct" and again["data"]["speaker"] == "sys"


def test_impossible_drawings_are_refused_in_words_and_never_change_the_board(ws_url):
    async def game() -> tuple[list[dict], GameRecord]:
        record, problems = GameRecord(), []
        clean = Sheet(21)
        async with websockets.connect(ws_url, max_size=2**24) as ws:

            async def show(sheet: Sheet) -> None:
                await ws.send(json.dumps({"type": "frame", "image": data_url(sheet.png())}))

            async def problem() -> dict:
                found = await next_of(ws, {"BoardProblem", "Error"})
                assert found["type"] == "BoardProblem", found
                problems.append(found["data"])
                await show(clean)  # the page wipes the impossible ink
                return found["data"]

            hello = (await next_of(ws, {"Hello"}))["data"]
            cells, user = hello["cells"], hello["user_symbol"]
            await next_of(ws, {"DialogueAct"})  # the greeting: the robot has begun its game
            # before the game: the robot has only greeted (and starts, and has not drawn yet)
            early = clean.copy().draw("middle", user)
            await show(early)
            assert (await problem())["kind"] == "not_started"
            two_at_once_tried = False
            while not record.ended:
                message = await next_of(
                    ws, {"DialogueAct", "GameMove", "DialogueEnded", "Error"}, 60
                )
                kind, data = message["type"], message["data"]
                assert kind != "Error", data
                if kind == "DialogueEnded":
                    record.ended, record.outcome = True, data["outcome"]
                elif kind == "GameMove":
                    record.accepted.append(data["where"])
                elif kind == "DialogueAct":
                    record.transcript.append((data["speaker"], data["act"], data["text"]))
                    act = data["act"]
                    if act.startswith("GameMove(gridloc=") and data["speaker"] == "sys":
                        record.robot_cells.append(act[len("GameMove(gridloc=") : -1])
                    elif act in ("Request(playGame)", "Request(repeat)"):
                        # a person asked again ("Pardon? Shall we play?") answers again
                        await ws.send(json.dumps({"type": "say", "text": "yes let's play"}))
                    elif act == "Request(userGameMove)" and data["speaker"] == "sys":
                        free = [c for c in cells if c not in record.robot_cells + record.drawn]
                        if not two_at_once_tried:
                            two_at_once_tried = True
                            both = clean.copy().draw(free[0], user).draw(free[1], user)
                            await show(both)
                            assert (await problem())["kind"] == "two_new_symbols"
                        record.drawn.append(free[0])
                        clean.draw(free[0], user)
                        await show(clean)
        return problems, record

    problems, record = asyncio.run(game())
    assert [p["kind"] for p in problems] == ["not_started", "two_new_symbols"]
    told = [text for speaker, act, text in record.transcript if act == "Inform(problem)"]
    assert told == [
        "We have not started a game yet.",  # drawn before anyone agreed to play
        "I see two new symbols at once. Please draw one at a time.",
    ]
    # the refused drawings never became moves: the board is the legal moves alone
    assert record.accepted == record.drawn
    assert record.outcome is not None and outcome(record.board()) == record.outcome


def test_hands_free_a_spoken_answer_streamed_in_pieces_is_heard(ws_url):
    speech = pcm16(synthesize("yes let's play", Voice("en-us")))
    stream, _ = in_noise(speech, np.random.default_rng(8), before=0.5, after=1.0)
    pieces = [stream[at : at + 1600] for at in range(0, len(stream), 1600)]

    async def answer_hands_free() -> dict:
        async with websockets.connect(ws_url) as ws:
            hello = (await next_of(ws, {"Hello"}))["data"]
            assert hello["stream_piece_seconds"] == 0.1 and hello["pre_roll_seconds"] > 0
            assert 0 < hello["stream_piece_seconds_over_speech"] < hello["stream_piece_seconds"]
            while (await next_of(ws, {"DialogueAct"}))["data"]["act"] != "Request(playGame)":
                pass
            await next_of(ws, {"SpeakingFinished"})
            # past the robot's echo; the browser test streams in real time
            await asyncio.sleep(0.4)
            for piece in pieces:
                await ws.send(
                    json.dumps(
                        {"type": "listen", "rate": 16000, "pcm": base64.b64encode(piece).decode()}
                    )
                )
            await ws.send(json.dumps({"type": "listen_off"}))
            while True:
                message = await next_of(ws, {"DialogueAct", "Error"}, 20)
                if message["type"] == "Error" or message["data"]["speaker"] == "usr":
                    return message

    heard = asyncio.run(answer_hands_free())
    assert heard["type"] == "DialogueAct", heard
    assert heard["data"]["text"].startswith("yes"), heard
    assert heard["data"]["act"] == "Confirm(playGame=yes)"


def test_a_person_who_begins_to_answer_the_greeting_is_waited_for(ws_url):
    """After its hello the robot pauses (robot.pause_timeout) and goes on to its name; a key
    in the answer box ("answering") makes it wait for the answer instead."""

    async def opening(answering: bool) -> tuple[float, list[tuple[str, str]]]:
        async with websockets.connect(ws_url) as ws:
            act = await next_of(ws, {"DialogueAct"}, 30)
            assert act["data"]["act"] == "Salutation(greeting)"
            greeted = time.monotonic()
            if answering:
                await ws.send(json.dumps({"type": "answering", "how": "typing"}))
                await asyncio.sleep(1.0)  # typing "hello" (the pause is 0.1 s here)
                await ws.send(json.dumps({"type": "say", "text": "hello"}))
            turns = []
            while not turns or turns[-1] != ("sys", "Provide(name)"):
                data = (await next_of(ws, {"DialogueAct"}, 30))["data"]
                turns.append((data["speaker"], data["act"]))
            return time.monotonic() - greeted, turns

    quiet, quiet_turns = asyncio.run(opening(False))
    waited, waited_turns = asyncio.run(opening(True))
    # quiet: the greeting said, then 0.1 s; before, answer_timeout (16 s / 8) after it
    assert quiet_turns == [("sys", "Provide(name)")] and quiet < 1.9
    assert waited_turns == [("usr", "Salutation(greeting)"), ("sys", "Provide(name)")]
    assert waited >= 1.0
