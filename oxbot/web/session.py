"""One browser tab's game session over the WebSocket `/ws`, and the protocol it speaks.

Each browser tab opens `/ws` (the route is oxbot.web.server's) and gets its own `Robot`
(oxbot.robot.session): its own bus, components, tracker and dialogue. Everything the robot
publishes goes to the tab as the bus's JSON (`oxbot.robot.messages.to_json`), in publish
order, but for the tab's own frames and recordings (`ECHOES`); what the tab sends is checked
(oxbot.web.inbound) and handed to the robot:

client → server (JSON text messages)::

    {"type": "frame", "image": "data:image/png;base64,..."}   the sheet (canvas), ~10 Hz, or
                                                               real paper (camera, JPEG)
    {"type": "paper", "on": true}                              the sheet is real paper under
                                                               the camera (false: the canvas)
    {"type": "look", "image": "data:image/jpeg;base64,..."}   a webcam frame, head tracking
    {"type": "say", "text": "yes let's play"}                  typed answer
    {"type": "talk", "rate": 16000, "pcm": "<base64 int16>"}   push-to-talk, 16 kHz mono
    {"type": "listen", "rate": 16000, "pcm": "<base64 int16>", hands-free: the stream's next
     "played": [{"text": "...", "sentence": 0, "at": 480}]}    piece (at most 1 s; the page
                                                               sends 0.1 s), and where in it
                                                               the robot's sentences began
                                                               to play (optional)
    {"type": "listen_off"}                                     hands-free ends or pauses
    {"type": "answering", "how": "typing"}                     the person began to answer
                                                               (a key in the answer box,
                                                               push-to-talk: "speaking")
    {"type": "new_game", "image": "data:..."}                  a fresh sheet and game
    {"type": "record", "on": true}                             keep the game, to learn from;
                                                               /ws?record=1 from the start

Paper mode: the page streams its camera's frames of real paper as `frame`s, and the robot
reads them as the canvas's. `paper` tells the robot, which then says where it plays (it has no
arm to draw there) and says what to do when the camera cannot show it the board.

Hands-free: the server cuts the stream of `listen` pieces into utterances with the VAD
(oxbot.speech.vad, `[speech.listening]`) and hands each to the robot exactly as a push-to-talk
recording. While the robot speaks (SpeakingStarted until `echo_seconds` after its audio's
echo), its own voice is taken out of the stream and the person is heard over it
(oxbot.robot.listening): each sentence placed where the page's `played` says it began, or,
from a page that does not say, where the stream was when the robot said it. `listen_off`
drops an utterance under way. `listen` pieces after the robot's goodbye are checked, then
dropped without an Error (a stream cannot stop at the goodbye's instant).

server → client: {"type": "Hello", "data": {...}} first (the session's symbols, the cell names
and the system acts, its `resume_token`), then every bus message, and {"type": "Error", "data":
{"message", "about", "code"}} for anything the server refused (`code` is "game_over" for a
drawing after the robot's goodbye, "resume_failed" for a resume token that brings no game
back, else empty). A bad message never closes the socket and never reaches another session.
The limits are `[web]` in the config (`oxbot config`).

A reload mid-game: the page keeps the Hello's `resume_token` (per tab) and, once reloaded,
opens `/ws?resume=TOKEN` (on the same route, with the same Origin and Host checks). When a
socket closes while its dialogue is under way, unless the tab closed it meaning to end (code
1000), the server keeps its robot running, and its slot, for `resume_seconds`; then stops it
as before. A socket with the token in that time takes the game back and gets a Hello with
`"resumed": true`, then::

    {"type": "Resumed", "data": {"sheet": "data:image/png;base64,..." or "", "paper": false,
     "recording": false, "said": "...", "speaking": false, "messages": [...]}}

`sheet` is the last canvas the tab sent (the robot's ink is not in it), `paper` and
`recording` the sheet mode and record switch as they are (a resumed game keeps them; `record=1`
is ignored), `said` the robot's last sentence and `speaking` whether it is still saying it, and
`messages` the game so far as the tab first received them: every DialogueAct, GameMove,
ArmStroke and DialogueEnded since the game began, then the last GameState, BoardSeen, Decision
and HeadMove. Nothing is queued while no socket is there: the replay holds it, and live
messages follow the Resumed. Speech audio is not replayed. A token is good for one socket at a
time: a newer socket with it takes the game over, and the older is closed with 4000 and a
reason (a reload's first socket may still be open; a duplicated tab takes the game from the
first). An unknown token, or one whose game ended or waited too long, gets the
"resume_failed" Error and a new game, as a socket without one.

What closes a socket, with a close code and a reason the tab can show:

- 1013 the server already runs `max_sessions` games: try again later (the slot is taken
  before the first await, so a burst of connections never gets past the limit);
- 1008 a page from another origin, or a Host that is not this server's (DNS rebinding):
  see `Origins` (oxbot.web.admission) and `allowed_origins`; a tab sending more than
  `max_messages_per_second`; a tab that has not read `max_outbox_bytes` of messages;
- 1001 a tab quiet for `idle_timeout` seconds, or a session older than `max_session_seconds`
  (counted from its first socket: a resumed game gets no more time);
- 4000 a newer socket took the game over with its resume token.

A message's size and JSON depth are checked before it is parsed, and errors quote at most an
excerpt of it. Closing a session stops its robot's threads (after `resume_seconds`, when its
tab went away mid-game).
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
import secrets
import threading
import time
from collections import deque
from typing import Any, Protocol

import numpy as np
from fastapi import FastAPI, WebSocket

from oxbot.config import ListeningConfig, WebConfig
from oxbot.errors import InvalidInputError, OxbotError
from oxbot.robot.listening import HandsFreeListener
from oxbot.robot.messages import (
    ArmStroke,
    BoardSeen,
    ComponentJoined,
    Decision,
    DialogueAct,
    DialogueEnded,
    Frame,
    GameMove,
    GameState,
    HeadMove,
    Message,
    NewGame,
    PersonAnswering,
    PersonFrame,
    RecordingSwitch,
    SheetMode,
    SpeakingContinued,
    SpeakingFinished,
    SpeakingStarted,
    SpeechAudio,
    to_json,
)
from oxbot.web.inbound import (
    STREAM_PIECE_SECONDS,
    STREAM_PIECE_SECONDS_OVER_SPEECH,
    MessageRate,
    check_raw,
    decode_image,
    excerpt,
    pcm_to_wav,
    played_marks,
    stream_piece,
)

log = logging.getLogger(__name__)


class RobotLike(Protocol):
    """What the server needs of a robot: oxbot.robot.session.Robot's public surface."""

    bus: Any
    finished: bool

    def start(self) -> Any: ...
    def stop(self) -> Any: ...
    def say(self, text: str) -> Any: ...
    def hear(self, wav: bytes) -> Any: ...
    def show(self, frame: np.ndarray) -> Any: ...
    def look(self, frame: np.ndarray) -> Any: ...
    def paper(self, on: bool) -> Any: ...
    def new_game(self) -> Any: ...


class Attachment:
    """One socket's hold on a session: the session's messages go to it until its tab goes away
    or a newer socket with the session's resume token takes the game over."""

    def __init__(self) -> None:
        self.taken_over = asyncio.Event()
        """Set when a newer socket takes the game: this one is closed, the robot goes on."""
        self.gone = asyncio.Event()
        """Set once this socket's handler is done with the session (kept, stopped or handed on)."""
        self.close_code: int | None = None
        """The tab's close code, once it closed (1000: it meant to end; 1001: a reload...)."""


class Replay:
    """What a page needs to show the current game again after a reload: every turn, move, arm
    stroke and goodbye since the game began, in order, then the latest reading of the sheet,
    board, decision and gaze, and the robot's last sentence (its text, not its audio)."""

    KEPT = (DialogueAct, GameMove, ArmStroke, DialogueEnded)
    LATEST = (GameState, BoardSeen, Decision, HeadMove)

    def __init__(self) -> None:
        self.kept: deque[str] = deque(maxlen=MAX_REPLAYED)
        self.latest: dict[str, str] = {}
        self.said = ""
        self.speaking = False

    def note(self, message: Message, text: str) -> None:
        """Keep `message` (sent as `text`) if a page needs it; a new game starts afresh."""
        if isinstance(message, NewGame):
            self.kept.clear()
            self.latest.clear()
        elif isinstance(message, self.KEPT):
            self.kept.append(text)
        elif isinstance(message, self.LATEST):
            self.latest[type(message).__name__] = text
        elif isinstance(message, SpeakingStarted):
            self.said, self.speaking = message.text, True
        elif isinstance(message, SpeakingFinished):
            self.speaking = False

    def messages(self) -> list[str]:
        return [*self.kept, *self.latest.values()]


STALL_SECONDS = 4.0
"""Seconds of messages at the full rate a page may send in one burst (`MessageRate`'s bucket)."""
MAX_REPLAYED = 2000
"""The most turns, moves and strokes kept to replay (a game has a few dozen)."""


class Session:
    """One tab's game: its robot, the bridge from the robot's bus to the socket, and the
    handling of what the tab sends.

    A session outlives its socket when the page reloads mid-game: the server keeps it for
    `resume_seconds` (detached: nothing is queued, the `Replay` keeps what the page needs),
    and a socket that brings its `token` takes it back (`attach`)."""

    ids = itertools.count(1)

    def __init__(
        self, robot: RobotLike, limits: WebConfig, listening: ListeningConfig | None = None
    ) -> None:
        self.id = next(self.ids)
        self.token = secrets.token_urlsafe(24)
        """The page's key to this game after a reload: unguessable, shown only to its tab."""
        self.started_at = time.monotonic()  # max_session_seconds counts from here, not a socket
        self.robot = robot
        self.limits = limits
        self.listening = listening if listening is not None else ListeningConfig()
        self.listener: HandsFreeListener | None = None  # made at the first hands-free piece
        # the robot's latest speech, for a listener made while it speaks
        self.said_recently: deque[Message] = deque(maxlen=16)
        self.outbox: asyncio.Queue[str | None] = asyncio.Queue()
        self.outbox_bytes = 0  # what waits in the outbox: bounded by limits.max_outbox_bytes
        self.ended = asyncio.Event()
        self.end_reason: tuple[int, str] | None = None
        self._loop = asyncio.get_running_loop()
        self._subscription = robot.bus.subscribe()
        self._closing = threading.Event()
        self._bridge = threading.Thread(
            target=self._forward, name=f"oxbot-web-session-{self.id}", daemon=True
        )
        self.errors = 0
        self.sheet: np.ndarray | None = None
        """The last sheet the tab sent, shown again to eyes that rejoin (a respawned process)."""
        self.recording_refusal = ""
        """Why the record toggle is refused (games cannot be kept here), or "" if it is not."""
        self.attachment: Attachment | None = Attachment()
        """The socket's hold on the session; None while the tab is away (a reload)."""
        self.replay = Replay()
        self.sheet_url: str | None = None
        """The last canvas the tab sent, as it sent it: a reloaded page draws it again."""
        self.paper = False  # the sheet is real paper under the camera
        self.recording = False  # the robot keeps this game (its last RecordingSwitch)
        self.stopping = False  # its robot is being stopped: no socket may take it any more
        self.route = ""  # the socket path it was opened on: a token takes it back there only
        self.expiry: asyncio.Task | None = None  # stops it if no tab comes back in time
        self.stream_cut = False  # a hands-free stream ended with its socket, unannounced

    def start(self) -> None:
        self._bridge.start()
        self.robot.start()

    def close(self) -> None:
        """Stop the robot and the bridge (blocking: run it in a worker thread)."""
        self._closing.set()
        try:
            self.robot.stop()
        finally:
            self._subscription.close()
            if self.listener is not None:
                self.listener.close()
            self._bridge.join(2.0)

    def end(self, code: int, reason: str) -> None:
        """Ask for the session to end, closing the socket with `code` and `reason` (the first
        reason given wins). Call it on the event loop."""
        if self.end_reason is None:
            self.end_reason = (code, reason)
            self.ended.set()

    def _forward(self) -> None:
        """Bus → socket, in publish order (runs in its own thread)."""
        while not self._closing.is_set():
            message = self._subscription.get(timeout=0.1)
            if message is None or isinstance(message, ECHOES):
                continue
            if isinstance(message, SpeakingStarted | SpeakingContinued | SpeakingFinished):
                self.said_recently.append(message)
            if isinstance(message, ComponentJoined) and message.part == "eyes":
                sheet = self.sheet
                if sheet is not None:  # what the tab sent while they were gone reached nobody
                    self.robot.show(sheet)
            try:
                text = to_json(message)
            except (TypeError, ValueError) as exc:  # a message the page cannot take
                log.warning("session %d: cannot send a %s: %s", self.id, type(message), exc)
                continue
            with contextlib.suppress(RuntimeError):  # the loop closed: the server is stopping
                self._loop.call_soon_threadsafe(self._publish, message, text)

    def _publish(self, message: Message, text: str) -> None:
        """One bus message for the tab, kept to replay if a page needs it. On the event loop,
        as `attach` is, so that a replay and the messages after it never overlap."""
        self.replay.note(message, text)
        if isinstance(message, RecordingSwitch):
            self.recording = message.on
        elif isinstance(message, SheetMode):
            self.paper = message.paper
        elif isinstance(message, NewGame):
            self.sheet_url = None  # the page sends its fresh sheet when the NewGame reaches it
        self.deliver(text)

    def attach(self) -> tuple[Attachment, str]:
        """A new socket takes the session (the last one has gone): its hold, and the Resumed
        message that shows the page the game as it is. Call it on the event loop."""
        self.attachment = Attachment()
        # what waited for the last socket is in the replay
        self.outbox, self.outbox_bytes = asyncio.Queue(), 0
        data = {
            "sheet": self.sheet_url or "",
            "paper": self.paper,
            "recording": self.recording,
            "said": self.replay.said,
            "speaking": self.replay.speaking,
        }
        head = json.dumps({"type": "Resumed", "data": data})
        # the replayed messages are JSON already, each as the page first received it
        return self.attachment, f'{head[:-2]}, "messages": [{",".join(self.replay.messages())}]}}}}'

    def detach(self, attachment: Attachment) -> None:
        """`attachment`'s socket has gone: the tab's messages wait in the replay, not the outbox."""
        if self.attachment is attachment:
            self.attachment = None
            self.outbox, self.outbox_bytes = asyncio.Queue(), 0
            # the old page's stream stopped mid-utterance, maybe: the next page's starts afresh
            self.stream_cut = True

    def deliver(self, text: str) -> None:
        """Queue `text` for the tab; a tab that has not read `max_outbox_bytes` of them ends
        its session, so that they never pile up in memory. Call it on the event loop."""
        if self.end_reason is not None or self.attachment is None:
            return
        # one message alone always fits: the limit is on what piles up behind it
        if self.outbox_bytes and self.outbox_bytes + len(text) > self.limits.max_outbox_bytes:
            self.end(
                1008,
                f"closed: the tab read none of the last {self.outbox.qsize()} messages "
                "(web.max_outbox_bytes)",
            )
            return
        self.outbox_bytes += len(text)
        self.outbox.put_nowait(text)

    def error(self, message: str, about: str = "", code: str = "") -> None:
        self.errors += 1
        if len(message) > MAX_ERROR_CHARS:  # a backstop: messages quote excerpts only
            message = message[:MAX_ERROR_CHARS] + "…"
        self.deliver(error_text(message, about, code))

    def handle(self, text: str) -> None:
        """Act on one message from the tab; an InvalidInputError says what was wrong."""
        self.dispatch(self.parse(text))

    def parse(self, text: str) -> dict:
        """The message in `text`, checked for size and depth before it is parsed."""
        check_raw(text, self.limits)
        try:
            message = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InvalidInputError(f"message is not JSON ({exc})") from None
        if not isinstance(message, dict) or not isinstance(message.get("type"), str):
            raise InvalidInputError('a message is a JSON object with a "type" string')
        return message

    def dispatch(self, message: dict) -> None:
        """Hand a parsed message to its handler."""
        kind = message["type"]
        handler = getattr(self, f"_on_{kind}", None) if kind in CLIENT_TYPES else None
        if handler is None:
            raise InvalidInputError(
                f"unknown message type {excerpt(kind)}; known: {', '.join(CLIENT_TYPES)}"
            )
        if kind in GAME_TYPES and self.robot.finished:
            raise GameOver(
                f"the game is over (the robot said goodbye), so {kind!r} is refused; "
                'send {"type": "new_game"} to play again'
            )
        handler(message)

    def _on_frame(self, message: dict) -> None:
        self.sheet = decode_image(message.get("image"), self.limits)
        if not self.paper:  # a camera's picture of paper is no canvas to draw again
            self.sheet_url = message["image"]
        self.robot.show(self.sheet)

    def _on_look(self, message: dict) -> None:
        self.robot.look(decode_image(message.get("image"), self.limits))

    def _on_say(self, message: dict) -> None:
        text = message.get("text")
        if not isinstance(text, str) or not text.strip():
            raise InvalidInputError("'text' must be a non-empty string")
        if len(text) > self.limits.max_text_chars:
            raise InvalidInputError(
                f"'text' has {len(text)} characters; at most {self.limits.max_text_chars}"
            )
        self.robot.say(text.strip())

    def _on_talk(self, message: dict) -> None:
        self.robot.hear(pcm_to_wav(message.get("pcm"), message.get("rate"), self.limits))

    def _on_listen(self, message: dict) -> None:
        samples = stream_piece(message.get("pcm"), message.get("rate"), self.limits)
        played = played_marks(message.get("played"), message.get("rate"), self.limits)
        if self.listener is None:
            self.listener = HandsFreeListener(self.robot, self.listening)  # loads the VAD
            # the page says where it plays the robot's voice, from its first piece on
            self.listener.placed_by_player = "played" in message
            self.listener.remember(list(self.said_recently))
        if self.robot.finished:  # the goodbye: nothing more to hear until a new game
            self.listener.stop_listening()
            return
        if self.stream_cut:  # in the feeder's thread, as every listen and listen_off
            self.stream_cut = False
            self.listener.stop_listening()
        self.listener.feed(samples, played)

    def _on_paper(self, message: dict) -> None:
        on = message.get("on")
        if not isinstance(on, bool):
            raise InvalidInputError("'on' must be true (real paper) or false (the canvas)")
        self.paper = on
        self.robot.paper(on)

    def _on_answering(self, message: dict) -> None:
        """The person began to answer: the robot waits for it rather than going on."""
        how = message.get("how")
        if how not in ("typing", "speaking"):
            raise InvalidInputError('\'how\' must be "typing" or "speaking"')
        self.robot.bus.publish(PersonAnswering(how=how))

    def _on_listen_off(self, message: dict) -> None:
        if self.listener is not None:
            self.listener.stop_listening()

    def _on_record(self, message: dict) -> None:
        """The page's record toggle: keep this game from now on, to learn from, or stop."""
        on = message.get("on")
        if not isinstance(on, bool):
            raise InvalidInputError("'on' must be true or false")
        if on and self.recording_refusal:
            raise InvalidInputError(self.recording_refusal)
        self.robot.bus.publish(RecordingSwitch(on=on))

    def _on_new_game(self, message: dict) -> None:
        image = message.get("image")
        frame = decode_image(image, self.limits) if image is not None else None
        self.robot.new_game()  # forgets the old sheet
        self.sheet = frame
        self.sheet_url = image if frame is not None and not self.paper else None
        if frame is not None:
            # the fresh sheet; should the robot forget it too (it handles NewGame in its own
            # thread), the page sends it again when the NewGame message comes back
            self.robot.show(frame)


class GameOver(InvalidInputError):
    """A game message after the robot's goodbye."""

    code = "game_over"


CLIENT_TYPES = (
    "frame",
    "look",
    "say",
    "talk",
    "listen",
    "listen_off",
    "answering",
    "new_game",
    "paper",
    "record",
)
"""The message types a tab may send."""
GAME_TYPES = ("frame",)
"""The ones refused once the robot has said goodbye (until a new game). Words still reach the
robot, which listens for "new game", "again!" after its goodbye."""
OFF_LOOP_TYPES = ("listen", "listen_off")
"""The ones handled off the event loop: the VAD (loaded at the first piece) runs on each."""
ECHOES = (Frame, PersonFrame, SpeechAudio)
"""What the tab itself sent, as the robot's bus carries it: not sent back (a sheet frame is
megabytes of raw pixels as JSON)."""
MAX_ERROR_CHARS = 400
"""The longest Error message sent to a tab."""


def hello(session: Session, app: FastAPI, resumed: bool = False) -> dict:
    """The Hello message's data for `session`: its symbols, the cell names, the system acts, and
    the settings the page needs (from `app.state`, set by oxbot.web.server.create_app); its
    resume token ("" when games are not kept for a reload), and whether it is `resumed`."""
    from oxbot.dialogue.domain import GAME_MOVES, MOVE_REQUEST, PROBLEM, SYSTEM_ACTS
    from oxbot.game.board import CELL_NAMES, ROBOT, SIZE, USER, symbol_of

    # a robot may be made to start otherwise than the server's default (a study's condition)
    starts = getattr(session.robot, "robot_starts", app.state.robot_starts)
    return {
        "session": session.id,
        "robot_starts": starts,
        "user_symbol": symbol_of(USER, starts),
        "robot_symbol": symbol_of(ROBOT, starts),
        "size": SIZE,
        "cells": list(CELL_NAMES),
        "acts": list(SYSTEM_ACTS),
        "game_moves": list(GAME_MOVES),
        "act_names": {"move_request": MOVE_REQUEST, "problem": PROBLEM},
        "stable_readings": app.state.stable_readings,
        "speed_factor": app.state.speed_factor,
        "audio_rate": session.limits.audio_rate,
        "pre_roll_seconds": session.listening.pre_roll_seconds,
        "stream_piece_seconds": STREAM_PIECE_SECONDS,
        "stream_piece_seconds_over_speech": STREAM_PIECE_SECONDS_OVER_SPEECH,
        "tls_fingerprint": app.state.fingerprint,
        "resume_token": session.token if session.limits.resume_seconds > 0 else "",
        "resume_seconds": session.limits.resume_seconds,
        "resumed": resumed,
    }


def error_text(message: str, about: str = "", code: str = "") -> str:
    """An Error message as the tab receives it (JSON text)."""
    return json.dumps({"type": "Error", "data": {"message": message, "about": about, "code": code}})


async def _send_all(websocket: WebSocket, session: Session) -> None:
    """Outbox → socket, until the session ends."""
    outbox = session.outbox  # this socket's: another socket that takes the game gets its own
    try:
        while True:
            text = await outbox.get()
            if text is None:
                return
            session.outbox_bytes -= len(text)
            await websocket.send_text(text)
    except Exception as exc:  # the tab went away; the receiver sees it and ends the session
        log.debug("session %d: sending stopped: %r", session.id, exc)


async def _receive_all(
    websocket: WebSocket, session: Session, attachment: Attachment | None = None
) -> None:
    """Socket → robot, until the tab closes (its close code noted in `attachment`), goes quiet
    or floods. Bad messages get an Error on this socket."""
    limits = session.limits
    # A server that stalls (loading a robot's models on a busy machine) then reads seconds of
    # a page's messages at once: a page is closed for a flood, not for the server's own stall.
    rate = MessageRate(
        limits.max_messages_per_second, burst=STALL_SECONDS * limits.max_messages_per_second
    )
    while True:
        try:
            event = await asyncio.wait_for(websocket.receive(), limits.idle_timeout)
        except TimeoutError:
            session.end(
                1001,
                f"closed after {limits.idle_timeout:g} s without a message (web.idle_timeout)",
            )
            return
        if event["type"] == "websocket.disconnect":
            if attachment is not None:
                attachment.close_code = event.get("code", 1005)
            return
        if not rate.allow():
            session.end(
                1008,
                f"closed: more than {limits.max_messages_per_second:g} messages a second "
                "(web.max_messages_per_second)",
            )
            return
        text = event.get("text")
        if text is None:
            session.error(
                "binary messages are not part of the protocol; send JSON text "
                '(images as base64 data URLs, audio as {"type": "talk", ...})',
                about="binary",
            )
            continue
        started = time.perf_counter()
        kind = ""
        try:
            if len(text) > HEAVY_CHARS:  # parsing and decoding an image: off the event loop
                message = await asyncio.to_thread(session.parse, text)
            else:
                message = session.parse(text)
            kind = message["type"] if message["type"] in CLIENT_TYPES else ""
            if len(text) > HEAVY_CHARS or kind in OFF_LOOP_TYPES:
                await asyncio.to_thread(session.dispatch, message)
            else:
                session.dispatch(message)
        except OxbotError as exc:
            session.error(str(exc), about=kind, code=getattr(exc, "code", ""))
        except Exception as exc:  # a robot bug must not end the tab's game or another's
            log.exception("session %d: message failed", session.id)
            session.error(f"the server failed on this message: {type(exc).__name__}: {exc}")
        log.debug(
            "session %d handled in %.1f ms", session.id, 1e3 * (time.perf_counter() - started)
        )


HEAVY_CHARS = 20_000
"""Messages longer than this (a sheet image) are parsed and handled off the event loop."""
CLOSE_CODE_WAIT = 0.5
"""Seconds to wait for a closing tab's close code once sending to it failed."""


async def run_session(
    websocket: WebSocket, session: Session, attachment: Attachment | None = None
) -> tuple[int, str]:
    """Receive from and send to the tab until either side ends the session, or (with an
    `attachment`) another socket takes it over; the close code and reason the server ends it
    with, or (0, "") if the tab went away or was taken over."""
    limits = session.limits
    sending = asyncio.create_task(_send_all(websocket, session))
    receiving = asyncio.create_task(_receive_all(websocket, session, attachment))
    tasks = {sending, receiving, asyncio.create_task(session.ended.wait())}
    if attachment is not None:
        tasks.add(asyncio.create_task(attachment.taken_over.wait()))
    # a resumed session's age counts from its first socket
    left = limits.max_session_seconds - (time.monotonic() - session.started_at)
    try:
        done, _ = await asyncio.wait(
            tasks, timeout=max(left, 0), return_when=asyncio.FIRST_COMPLETED
        )
        if sending in done and receiving not in done and session.end_reason is None:
            # sending failed as the tab closed: its close code says whether it meant to end
            await asyncio.wait({receiving}, timeout=CLOSE_CODE_WAIT)
    finally:
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
    if not done:
        session.end(
            1001,
            f"closed after {limits.max_session_seconds:g} s (web.max_session_seconds); "
            "reload the page to play again",
        )
    return session.end_reason or (0, "")
