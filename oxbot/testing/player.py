"""A scripted person over the page's WebSocket: plays one whole game without a browser.

It does what the page does, with the page's own sheet (`oxbot.testing.sheet.Sheet`): it sends the
sheet as a PNG, answers the robot's invitation by typing, and when asked for a move draws its
symbol in an empty cell — first stroke, then the whole symbol — sending a frame every 100 ms
while it draws, as the page does. Load tests (`tests/web/test_sessions.py`) and the latency
benchmark (`bench/bench_web.py`) run many of these at once.

    record = asyncio.run(play_game("ws://127.0.0.1:8000/ws", seed=1))
    record.outcome, record.latencies, record.errors
"""

from __future__ import annotations

import asyncio
import base64
import json
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field

import numpy as np

from oxbot.dialogue.domain import INVITATION, MOVE_REQUEST, game_move_cell
from oxbot.game.board import CELL_NAMES, EMPTY_BOARD, ROBOT, USER, Board, play
from oxbot.testing.sheet import Sheet, person_strokes

ANSWER = "yes let's play"
"""What the scripted person answers to the robot's invitation."""


@dataclass
class GameRecord:
    """What one scripted game saw."""

    session: int = 0
    user_symbol: str = ""
    transcript: list[tuple[str, str, str]] = field(default_factory=list)
    """(speaker, act, text) of every DialogueAct, in order."""
    drawn: list[str] = field(default_factory=list)
    """The cells the scripted person drew in, in order."""
    accepted: list[str] = field(default_factory=list)
    """The cells of the person's moves the robot accepted (GameMove who=usr)."""
    robot_cells: list[str] = field(default_factory=list)
    """The cells of the robot's own moves (its GameMove acts)."""
    latencies: list[float] = field(default_factory=list)
    """Seconds from the last frame of a finished drawing to its accepted GameMove."""
    problems: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    outcome: str | None = None
    ended: bool = False
    seconds: float = 0.0

    def board(self) -> Board:
        """The board the conversation describes: the robot's and the person's GameMove acts."""
        board = EMPTY_BOARD
        for speaker, act, _ in self.transcript:
            cell = game_move_cell(act)
            if cell is not None:
                board = play(board, cell, ROBOT if speaker == "sys" else USER)
        return board


def data_url(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


async def received(ws, deadline: float) -> tuple[str, dict] | None:
    """The robot's next message on `ws` as (type, data); None once `deadline` (monotonic) has
    passed without one."""
    while (left := deadline - time.monotonic()) > 0:
        try:
            raw = await asyncio.wait_for(ws.recv(), left)
        except TimeoutError:
            continue
        message = json.loads(raw)
        return message["type"], message.get("data", {})
    return None


async def draw_symbol(
    send: Callable[[dict], Awaitable[None]], sheet: Sheet, where: str, symbol: str, period: float
) -> None:
    """Draw `symbol` in the cell `where` of `sheet` as the page sends it: the sheet after each
    stroke but the last, `period` seconds apart, then the whole symbol."""
    strokes = person_strokes(symbol, sheet.rng)
    for k in range(1, len(strokes)):
        partial = sheet.copy().draw_strokes(where, strokes[:k])
        await send({"type": "frame", "image": data_url(partial.png())})
        await asyncio.sleep(period)
    sheet.draw_strokes(where, strokes)
    await send({"type": "frame", "image": data_url(sheet.png())})


async def play_game(
    url: str,
    seed: int = 0,
    timeout: float = 120.0,
    frame_period: float = 0.1,
    answer: str = ANSWER,
) -> GameRecord:
    """Play one game against the robot at `url` (ws://host:port/ws) and return its record."""
    # Long on purpose: one message loop, each branch the page's handler of that message.
    import websockets

    rng = np.random.default_rng(seed)
    sheet = Sheet(seed)
    record = GameRecord()
    start = time.monotonic()
    drawn_at: float | None = None
    async with websockets.connect(url, max_size=2**24) as ws:

        async def send(message: dict) -> None:
            await ws.send(json.dumps(message))

        async def draw_move() -> None:
            nonlocal drawn_at
            taken = set(record.drawn) | set(record.robot_cells)
            free = [c for c in cells if c not in taken]
            if not free:
                return
            where = free[int(rng.integers(len(free)))]
            record.drawn.append(where)
            # the page sends the sheet every 100 ms while it changes: stroke by stroke here
            await draw_symbol(send, sheet, where, record.user_symbol, frame_period)
            drawn_at = time.monotonic()

        cells: list[str] = []
        while not record.ended:
            got = await received(ws, start + timeout)
            if got is None:
                record.failures.append(f"no goodbye within {timeout:.0f} s")
                break
            kind, data = got
            if kind == "Hello":
                record.session, record.user_symbol = data["session"], data["user_symbol"]
                cells = list(data["cells"])
                await send({"type": "frame", "image": data_url(sheet.png())})
            elif kind == "DialogueAct":
                record.transcript.append((data["speaker"], data["act"], data["text"]))
                act = data["act"]
                if data["speaker"] != "sys":
                    continue
                if act == INVITATION:
                    await send({"type": "say", "text": answer})
                elif game_move_cell(act) is not None:
                    record.robot_cells.append(CELL_NAMES[game_move_cell(act)])
                elif act == MOVE_REQUEST and len(record.accepted) == len(record.drawn):
                    await draw_move()
            elif kind == "NewGame":
                await send({"type": "frame", "image": data_url(sheet.png())})
            elif kind == "GameMove" and data["who"] == "usr":
                record.accepted.append(data["where"])
                if drawn_at is not None:
                    record.latencies.append(time.monotonic() - drawn_at)
                    drawn_at = None
            elif kind == "BoardProblem":
                record.problems.append(data["reason"])
            elif kind == "Error":
                record.errors.append(data["message"])
            elif kind == "ComponentFailed":
                record.failures.append(f"{data['component']}: {data['error']}")
            elif kind == "DialogueEnded":
                record.outcome, record.ended = data["outcome"], True
    record.seconds = time.monotonic() - start
    return record


__all__ = ["GameRecord", "data_url", "draw_symbol", "play_game", "received"]
