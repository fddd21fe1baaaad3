"""A simulated person talking with the running robot over the page's WebSocket, by voice.

It does what the page does for a person who speaks: push-to-talk (an `answering` message when
the button goes down, then the recording as one `talk` message) or hands-free (the microphone
streamed as `listen` pieces every 100 ms, the words inside the room's sound). Its moves are
drawn on the page's own sheet (`oxbot.testing.sheet`) and sent a frame per stroke, as in
`oxbot.testing.player`. What it says comes from a `Persona`, spoken by a synthetic voice
(`oxbot.speech.evaluation.speak`) into a `Room`. What the robot did is kept in a
`Conversation` for `judge`.

    conversation = asyncio.run(converse(url, persona, "flite:rms", room, seed=3))
    judge(conversation)
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import time
from collections import deque
from collections.abc import Sequence
from functools import lru_cache

import numpy as np

from oxbot.dialogue.domain import (
    CLOSING,
    FEEDBACK_ACTS,
    MOVE_REQUEST,
    game_move_cell,
    is_game_move,
)
from oxbot.game.board import CELL_NAMES
from oxbot.speech.audio import RATE, pcm16
from oxbot.speech.evaluation import speak
from oxbot.testing.personas import Conversation, Game, Persona, Reply, understood_as_answer
from oxbot.testing.player import data_url, draw_symbol, received
from oxbot.testing.rooms import Room
from oxbot.testing.sheet import Sheet

PIECE_SECONDS = 0.1
"""A hands-free piece's length, as the page sends them."""
THINKING_SECONDS = 0.3
"""How long after the robot stops speaking the person answers."""
OUTCOMES = {act: outcome for outcome, act in FEEDBACK_ACTS.items()}


@lru_cache(maxsize=4096)
def spoken(text: str, voice: str) -> np.ndarray:
    """`text` in `voice` as int16 samples at RATE (kept: a persona's phrasings recur)."""
    return pcm16(speak(text, voice))


def _pcm(samples: np.ndarray) -> str:
    return base64.b64encode(np.asarray(samples, dtype="<i2").tobytes()).decode("ascii")


async def converse(
    url: str,
    persona: Persona,
    voice: str,
    room: Room,
    seed: int = 0,
    hands_free: bool = False,
    noises: Sequence[np.ndarray] = (),
    timeout: float = 300.0,
    frame_period: float = 0.1,
) -> Conversation:
    """One conversation of `persona` with the robot at `url` (ws://host:port/ws), spoken in
    `voice` in `room`; `noises` are the non-speech sounds (int16) a silent person's room makes
    (the room's own sound when empty)."""
    # Long on purpose: one message loop, each branch the page's handler of that message.
    import websockets

    rng = np.random.default_rng(seed)
    record = Conversation(persona.kind)
    sheet = Sheet(seed)
    symbol, sheets = "cross", 0
    speaking = asyncio.Event()
    mouth: deque[np.ndarray] = deque()  # hands-free: what the person says next, piece by piece
    sent_at: float | None = None
    meant: Reply | None = None  # the answer the robot has not yet shown it understood
    tasks: set[asyncio.Task] = set()
    start = time.monotonic()

    async with websockets.connect(url, max_size=2**24) as ws:

        async def send(message: dict) -> None:
            await ws.send(json.dumps(message))

        def later(coroutine) -> None:
            task = asyncio.create_task(coroutine)
            tasks.add(task)
            task.add_done_callback(tasks.discard)

        def heard(reply: Reply) -> np.ndarray | None:
            if reply.family == "silence":
                return None
            if reply.family == "noise":
                if noises:
                    return room.around(noises[int(rng.integers(len(noises)))], 0.2, 0.2)
                return room.noise(float(rng.uniform(1.0, 2.0)))
            return room.around(spoken(reply.text, voice))

        async def answer(reply: Reply) -> None:
            nonlocal sent_at, meant
            for _ in range(100):  # the person waits for the robot to finish its sentence
                if not speaking.is_set():
                    break
                await asyncio.sleep(0.05)
            await asyncio.sleep(THINKING_SECONDS)
            record.said.append(reply)
            audio = heard(reply)
            if audio is None:
                return
            meant = reply
            if hands_free:
                mouth.extend(np.array_split(audio, max(1, len(audio) // int(PIECE_SECONDS * RATE))))
                return
            await send({"type": "answering", "how": "speaking"})
            await send({"type": "talk", "pcm": _pcm(audio), "rate": RATE})
            sent_at = time.monotonic()

        async def stream() -> None:
            nonlocal sent_at
            n = int(PIECE_SECONDS * RATE)
            while True:
                piece = room.stream(n)
                if mouth:
                    words = mouth.popleft().astype(np.float64)
                    piece = (
                        words if len(words) >= n else np.concatenate([words, piece[len(words) :]])
                    )
                    if not mouth:
                        sent_at = time.monotonic()  # the answer's last sound has left
                piece = np.clip(np.round(piece), -32768, 32767).astype(np.int16)
                await send({"type": "listen", "pcm": _pcm(piece), "rate": RATE})
                await asyncio.sleep(PIECE_SECONDS)

        async def draw() -> None:
            taken = set(record.game.drawn) | {
                c for c in CELL_NAMES if record.game.board[CELL_NAMES.index(c)]
            }
            free = [c for c in CELL_NAMES if c not in taken]
            if not free:
                return
            where = free[int(rng.integers(len(free)))]
            record.game.drawn.append(where)
            await draw_symbol(send, sheet, where, symbol, frame_period)

        def robot_said(act: str) -> None:
            cell = game_move_cell(act)  # the robot's own moves come as its acts alone
            if cell is not None:
                record.game.robot_moved(CELL_NAMES[cell])
                record.moves_without_consent += not persona.consented
                record.moves_after_stop += persona.stopping
            elif act in OUTCOMES:
                record.game.feedback = OUTCOMES[act]
            elif act == CLOSING:
                record.goodbye = True
            if act == MOVE_REQUEST and not (persona.consented or persona.stopping):
                record.moves_without_consent += 1
            reply = persona.reply(act)
            if reply is not None:
                later(answer(reply))
            elif act == MOVE_REQUEST and len(record.game.accepted) == len(record.game.drawn):
                later(draw())

        def person_understood(act: str) -> None:
            nonlocal meant
            if meant is None or is_game_move(act):
                return
            if meant.family in ("noise", "silence"):
                record.noise_answered += understood_as_answer(act)
            else:
                record.understood.append((meant.family, act))
            meant = None

        if hands_free:
            later(stream())
        try:
            ended = False
            while not ended:
                got = await received(ws, start + timeout)
                if got is None:
                    record.problems.append(f"no goodbye within {timeout:.0f} s")
                    break
                kind, data = got
                if kind == "Hello":
                    symbol = data["user_symbol"]
                    await send({"type": "frame", "image": data_url(sheet.png())})
                elif kind == "NewGame":
                    sheets += 1
                    sheet = Sheet(seed * 1000 + sheets)  # the page clears its canvas
                    if record.game.board != Game().board or record.game.drawn:
                        record.games.append(Game())
                    await send({"type": "frame", "image": data_url(sheet.png())})
                elif kind == "DialogueAct":
                    record.turns.append((data["speaker"], data["act"], data["text"]))
                    if data["speaker"] == "sys":
                        robot_said(data["act"])
                    else:
                        person_understood(data["act"])
                elif kind == "GameMove" and data["who"] == "usr":
                    record.game.person_moved(data["where"])
                elif kind == "SpeechHypotheses" and data.get("source") == "microphone":
                    best = (data.get("nbest") or [["", 0.0]])[0]
                    record.heard.append((str(best[0]), float(best[1])))
                    if sent_at is not None:
                        record.latencies.append(time.monotonic() - sent_at)
                        sent_at = None
                elif kind == "SpeakingStarted":
                    speaking.set()
                elif kind == "SpeakingFinished":
                    speaking.clear()
                elif kind == "Error":
                    record.problems.append(f"error: {data['message']}")
                elif kind == "ComponentFailed":
                    record.problems.append(f"{data['component']} failed: {data['error']}")
                elif kind == "DialogueEnded":  # after a goodbye, or before a rematch
                    record.outcome = data["outcome"] or "none"
                    said = [act for speaker, act, _ in record.turns if speaker == "sys"]
                    ended = bool(said) and said[-1] == CLOSING
        finally:
            for task in list(tasks):
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task
    return record


__all__ = ["converse", "spoken"]
