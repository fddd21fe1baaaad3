"""The web page's server: one page, and one WebSocket per game session (`oxbot play`).

Each browser tab opens `/ws` and gets its own `Robot` (oxbot.robot.session): its own bus,
components, tracker and dialogue. Everything the robot publishes goes to the tab as the bus's
JSON (`oxbot.robot.messages.to_json`), in publish order, but for the tab's own frames and
recordings (`ECHOES`); what the tab sends is checked here and handed to the robot:

client → server (JSON text messages)::

    {"type": "frame", "image": "data:image/png;base64,..."}   the sheet (canvas), ~10 Hz, or
                                                               real paper (camera, JPEG)
    {"type": "paper", "on": true}                              the sheet is real paper under
                                                               the camera (false: the canvas)
    {"type": "look", "image": "data:image/jpeg;base64,..."}   a webcam frame, head tracking
    {"type": "say", "text": "yes let's play"}                  typed answer
    {"type": "talk", "rate": 16000, "pcm": "<base64 int16>"}   push-to-talk, 16 kHz mono
    {"type": "listen", "rate": 16000, "pcm": "<base64 int16>"} hands-free: the stream's next
                                                               piece (at most 1 s; the page
                                                               sends 0.1 s)
    {"type": "listen_off"}                                     hands-free ends or pauses
    {"type": "new_game", "image": "data:..."}                  a fresh sheet and game
    {"type": "record", "on": true}                             keep the game (issue 18);
                                                               /ws?record=1 from the start

Paper mode (issue 17): the page streams its camera's frames of real paper as `frame`s, and the
robot reads them as the canvas's. `paper` tells the robot, which then says where it plays (it
has no arm to draw there) and says what to do when the camera cannot show it the board.

Hands-free: the server cuts the stream of `listen` pieces into utterances with the VAD
(oxbot.speech.vad, `[speech.listening]`) and hands each to the robot exactly as a push-to-talk
recording. While the robot speaks (SpeakingStarted until `echo_seconds` after
SpeakingFinished) the stream is not listened to, and `listen_off` drops an utterance under
way. `listen` pieces after the robot's goodbye are checked, then dropped without an Error (a
stream cannot stop at the goodbye's instant).

server → client: {"type": "Hello", "data": {...}} first (the session's symbols, the cell
names and the system acts), then every bus message, and {"type": "Error", "data": {"message",
"about", "code"}} for anything the server refused (`code` is "game_over" for a drawing
after the robot's goodbye, else empty). A bad message never closes the socket and never
reaches another session. The limits are `[web]` in the config (`oxbot config`).

What closes a socket, with a close code and a reason the tab can show:

- 1013 the server already runs `max_sessions` games: try again later (the slot is taken
  before the first await, so a burst of connections never gets past the limit);
- 1008 a page from another origin, or a Host that is not this server's (DNS rebinding):
  see `Origins` and `allowed_origins`; a tab sending more than `max_messages_per_second`;
  a tab that has not read `max_outbox_bytes` of messages;
- 1001 a tab quiet for `idle_timeout` seconds, or a session older than `max_session_seconds`.

A message's size and JSON depth are checked before it is parsed, and errors quote at most an
excerpt of it. Closing a session stops its robot's threads.
"""

from __future__ import annotations

import asyncio
import base64
import binascii
import contextlib
import ctypes
import gc
import io
import ipaddress
import itertools
import json
import logging
import re
import threading
import time
import urllib.parse
from collections.abc import Callable
from importlib import resources
from typing import Any, Protocol

import numpy as np
from fastapi import FastAPI, WebSocket, WebSocketDisconnect
from fastapi.responses import HTMLResponse, JSONResponse, Response
from PIL import Image, UnidentifiedImageError

from oxbot.config import ListeningConfig, OxbotConfig, WebConfig
from oxbot.errors import ConfigError, InvalidInputError, OxbotError
from oxbot.image_size import check_pixels
from oxbot.robot.listening import HandsFreeListener
from oxbot.robot.messages import Frame, PersonFrame, RecordingSwitch, SpeechAudio, to_json
from oxbot.speech.audio import Audio, to_wav_bytes
from oxbot.web.recording import RecordingSetup
from oxbot.web.recording import add_routes as add_recording_routes
from oxbot.web.tls import Certificate

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


def default_robot_factory(
    config: OxbotConfig, recording: RecordingSetup | None = None
) -> Callable[[], RobotLike]:
    """A factory of real robots with this config, one per session (each with a Recorder, off
    until its tab switches it on, when `recording` is given: issue 18)."""

    def make() -> RobotLike:
        from oxbot.recording.recorder import joining
        from oxbot.robot.session import Robot

        if recording is None:
            return Robot(config)
        # the database is opened at the first game kept, and nothing is kept until the tab asks
        recorder = joining(recording.store, "web", keep_audio=recording.keep_audio, enabled=False)
        return Robot(config, joining=[recorder])

    return make


# --- checking what a tab sends ---


def decode_image(payload: object, limits: WebConfig) -> np.ndarray:
    """A data URL or base64 string of a PNG/JPEG/WebP as uint8 RGB (H, W, 3).

    Raises InvalidInputError naming what is wrong (not a string, not base64, not an image,
    too big or too small).
    """
    if not isinstance(payload, str) or not payload:
        raise InvalidInputError("'image' must be a data URL or base64 string of a PNG or JPEG")
    if payload.startswith("data:"):
        header, _, payload = payload.partition(",")
        if ";base64" not in header:
            raise InvalidInputError("an image data URL must be base64-encoded")
    try:
        raw = base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError):
        raise InvalidInputError("'image' is not valid base64") from None
    # the header's size first: a small PNG can declare gigabytes of pixels
    size = check_pixels(raw, "'image'", limits.max_image_side**2)
    if size is None:
        raise InvalidInputError("'image' is not a readable PNG or JPEG image")
    try:
        with Image.open(io.BytesIO(raw)) as image:
            if image.format not in ("PNG", "JPEG", "WEBP"):
                raise InvalidInputError(f"images must be PNG, JPEG or WebP, not {image.format}")
            width, height = size
            if max(width, height) > limits.max_image_side:
                raise InvalidInputError(
                    f"image is {width}x{height}; the largest side accepted is "
                    f"{limits.max_image_side} pixels"
                )
            if min(width, height) < limits.min_image_side:
                raise InvalidInputError(
                    f"image is {width}x{height}; a readable sheet needs at least "
                    f"{limits.min_image_side} pixels a side"
                )
            return np.asarray(image.convert("RGB"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        if isinstance(exc, InvalidInputError):
            raise
        raise InvalidInputError(f"'image' is not a readable PNG or JPEG image ({exc})") from None


def decode_pcm(payload: object, rate: object, limits: WebConfig, what: str) -> np.ndarray:
    """Base64 little-endian int16 mono PCM at `limits.audio_rate` as samples (`what` names
    the audio in errors)."""
    if rate != limits.audio_rate:
        raise InvalidInputError(
            f"{what} must be {limits.audio_rate} Hz mono 16-bit PCM; got rate "
            f"{excerpt(rate)} (the page resamples with AudioContext({{sampleRate: "
            f"{limits.audio_rate}}}))"
        )
    if not isinstance(payload, str):
        raise InvalidInputError("'pcm' must be a base64 string of 16-bit samples")
    try:
        raw = base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError):
        raise InvalidInputError("'pcm' is not valid base64") from None
    if len(raw) % 2:
        raise InvalidInputError("'pcm' holds an odd number of bytes; samples are 16-bit")
    return np.frombuffer(raw, dtype="<i2").astype(np.int16)


def pcm_to_wav(payload: object, rate: object, limits: WebConfig) -> bytes:
    """Base64 little-endian int16 mono PCM at `limits.audio_rate` as WAV bytes."""
    samples = decode_pcm(payload, rate, limits, "push-to-talk audio")
    seconds = len(samples) / limits.audio_rate
    if seconds > limits.max_audio_seconds:
        raise InvalidInputError(
            f"recording is {seconds:.1f} s; push-to-talk takes at most "
            f"{limits.max_audio_seconds:.0f} s"
        )
    if seconds < 0.1:
        raise InvalidInputError("recording is shorter than 0.1 s; hold the button while talking")
    return to_wav_bytes(Audio(samples, limits.audio_rate))


def stream_piece(payload: object, rate: object, limits: WebConfig) -> np.ndarray:
    """A hands-free stream's next piece: base64 int16 PCM at `limits.audio_rate`, at most
    `limits.max_stream_piece_seconds` long, as samples."""
    samples = decode_pcm(payload, rate, limits, "hands-free audio")
    if not len(samples):
        raise InvalidInputError("'pcm' is empty; send the stream's next samples")
    seconds = len(samples) / limits.audio_rate
    if seconds > limits.max_stream_piece_seconds:
        raise InvalidInputError(
            f"a hands-free piece is {seconds:.2f} s; send at most "
            f"{limits.max_stream_piece_seconds:g} s at a time"
        )
    return samples


STREAM_PIECE_SECONDS = 0.1
"""How much of the hands-free stream the page sends at a time (told in Hello)."""


def check_raw(text: str, limits: WebConfig) -> None:
    """InvalidInputError if a message is too long or nested too deep to parse; neither is
    parsed to find out."""
    if len(text) > limits.max_message_bytes:
        raise InvalidInputError(
            f"message is {len(text)} bytes; the limit is {limits.max_message_bytes}"
        )
    if json_depth(text, limits.max_json_depth) > limits.max_json_depth:
        raise InvalidInputError(
            f"message nests JSON more than {limits.max_json_depth} deep; the protocol's "
            "messages are flat objects"
        )


_JSON_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"')
_OPENS, _CLOSES = b"[{", b"]}"


def json_depth(text: str, limit: int) -> int:
    """How deep the JSON in `text` nests arrays and objects (exact when it is over `limit`;
    any value not over it when it is not), without parsing it: Python's parser recurses and
    fails on 100,000 levels."""
    if text.count("[") + text.count("{") <= limit:  # every message the page sends
        return 0
    skeleton = _JSON_STRING.sub("", text).encode("utf-8", "replace")  # brackets in strings
    codes = np.frombuffer(skeleton, np.uint8)
    steps = np.isin(codes, list(_OPENS)).astype(np.int32) - np.isin(codes, list(_CLOSES))
    return int(np.cumsum(steps).max(initial=0))


def excerpt(value: object, length: int = 40) -> str:
    """`repr(value)`, cut to about `length` characters: errors never echo a whole input."""
    text = repr(value)
    return text if len(text) <= length else f"{text[:length]}… ({len(text)} characters)"


class MessageRate:
    """A token bucket: `rate` messages a second on average, in bursts of up to `rate`."""

    def __init__(self, rate: float, clock: Callable[[], float] = time.monotonic) -> None:
        self.rate, self.clock = rate, clock
        self.tokens, self.last = rate, clock()

    def allow(self) -> bool:
        """Whether one more message may come now (and count it if so)."""
        now = self.clock()
        self.tokens = min(self.rate, self.tokens + (now - self.last) * self.rate)
        self.last = now
        if self.tokens < 1:
            return False
        self.tokens -= 1
        return True


# --- one session per tab ---


class Session:
    """One tab's game: its robot, the bridge from the robot's bus to the socket, and the
    handling of what the tab sends."""

    ids = itertools.count(1)

    def __init__(
        self, robot: RobotLike, limits: WebConfig, listening: ListeningConfig | None = None
    ) -> None:
        self.id = next(self.ids)
        self.robot = robot
        self.limits = limits
        self.listening = listening if listening is not None else ListeningConfig()
        self.listener: HandsFreeListener | None = None  # made at the first hands-free piece
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
            try:
                text = to_json(message)
            except (TypeError, ValueError) as exc:  # a message the page cannot take
                log.warning("session %d: cannot send a %s: %s", self.id, type(message), exc)
                continue
            with contextlib.suppress(RuntimeError):  # the loop closed: the server is stopping
                self._loop.call_soon_threadsafe(self.deliver, text)

    def deliver(self, text: str) -> None:
        """Queue `text` for the tab; a tab that has not read `max_outbox_bytes` of them ends
        its session, so that they never pile up in memory. Call it on the event loop."""
        if self.end_reason is not None:
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
        self.deliver(_error_text(message, about, code))

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
        self.robot.show(decode_image(message.get("image"), self.limits))

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
        if self.listener is None:
            self.listener = HandsFreeListener(self.robot, self.listening)  # loads the VAD
        if self.robot.finished:  # the goodbye: nothing more to hear until a new game
            self.listener.stop_listening()
            return
        self.listener.feed(samples)

    def _on_paper(self, message: dict) -> None:
        on = message.get("on")
        if not isinstance(on, bool):
            raise InvalidInputError("'on' must be true (real paper) or false (the canvas)")
        self.robot.paper(on)

    def _on_listen_off(self, message: dict) -> None:
        if self.listener is not None:
            self.listener.stop_listening()

    def _on_record(self, message: dict) -> None:
        """The page's record toggle (issue 18): keep this game from now on, or stop."""
        on = message.get("on")
        if not isinstance(on, bool):
            raise InvalidInputError("'on' must be true or false")
        self.robot.bus.publish(RecordingSwitch(on=on))

    def _on_new_game(self, message: dict) -> None:
        image = message.get("image")
        frame = decode_image(image, self.limits) if image is not None else None
        self.robot.new_game()  # forgets the old sheet
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


# --- the app ---


def _static(name: str) -> bytes:
    return resources.files("oxbot.web").joinpath("static", name).read_bytes()


STATIC_TYPES = {
    "app.js": "text/javascript",
    "style.css": "text/css",
    "tap.js": "text/javascript",
}


def create_app(
    config: OxbotConfig | None = None,
    robot_factory: Callable[[], RobotLike] | None = None,
    certificate: Certificate | None = None,
    recording: RecordingSetup | None = None,
) -> FastAPI:
    """The FastAPI app: `/` the page, `/static/*` its files, `/ws` a game session per socket,
    `/health` how many sessions run, `/tls` the HTTPS certificate's fingerprint (empty when
    `certificate`, the one it is served with, is None).

    Every session's robot is built with `config` (`[game]` who starts, `[robot]` its speed and
    waits, `[web]` what a tab may send), or by `robot_factory` when given.
    """
    config = config if config is not None else OxbotConfig()
    limits = config.web
    speed_factor, robot_starts = config.robot.speed_factor, config.game.robot_starts
    recording = recording if recording is not None else RecordingSetup()
    make_robot = (
        robot_factory if robot_factory is not None else default_robot_factory(config, recording)
    )
    ready = threading.Event()

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI):
        # the shared models (policy, classifier, recogniser) take seconds to load: load them
        # once, while the person opens the page, not in the first tab's greeting
        threading.Thread(
            target=_warm_up, args=(ready, config), name="oxbot-web-warm-up", daemon=True
        ).start()
        yield

    app = FastAPI(title="oxbot", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    sessions: dict[int, Session] = {}
    app.state.sessions = sessions
    app.state.slots = Slots(limits.max_sessions)
    app.state.starting = asyncio.Semaphore(ROBOTS_STARTING)
    app.state.origins = Origins(limits)
    app.state.limits = limits
    app.state.listening = config.speech.listening
    app.state.fingerprint = certificate.fingerprint if certificate is not None else ""

    @app.get("/", response_class=HTMLResponse)
    def page() -> HTMLResponse:
        return HTMLResponse(_static("index.html"))

    @app.get("/static/{name}")
    def static(name: str) -> Response:
        if name not in STATIC_TYPES:
            return JSONResponse({"error": f"no such file: {name}"}, status_code=404)
        return Response(_static(name), media_type=STATIC_TYPES[name])

    @app.get("/health")
    async def health() -> dict:  # on the event loop: no worker thread to wait for
        return {"ok": True, "sessions": len(sessions), "speed_factor": speed_factor}

    @app.get("/tls")
    async def tls() -> dict:  # the page shows it, to compare with the browser's and terminal's
        return {"sha256": app.state.fingerprint}

    @app.websocket("/ws")
    async def game(websocket: WebSocket) -> None:
        await _game_session(websocket, app, make_robot, ready)

    # --- issue 18: the record toggle's settings, the "what I learned" page ---
    app.state.recording = recording
    add_recording_routes(app, recording)

    app.state.speed_factor = speed_factor
    app.state.robot_starts = robot_starts
    app.state.stable_readings = config.tracker.stable_readings
    return app


async def _game_session(
    websocket: WebSocket, app: FastAPI, make_robot: Callable[[], RobotLike], ready: threading.Event
) -> None:
    """One tab's game, from the socket's opening to its closing."""
    slots: Slots = app.state.slots
    # both decided before the first await, so that a burst of connections cannot all pass
    refusal = app.state.origins.refusal(websocket)
    admitted = refusal is None and slots.take()
    try:
        await websocket.accept()
        if refusal is not None:
            log.warning("refused a game socket: %s", refusal)
            await _close(websocket, 1008, refusal)
            return
        if not admitted:
            busy = f"the server is busy ({slots.limit} games, web.max_sessions); try again later"
            await websocket.send_text(_error_text(busy))
            await _close(websocket, 1013, busy)
            return
        await _serve_session(websocket, app, make_robot, ready)
    except CLIENT_GONE as exc:
        log.debug("a tab went away while its session opened or closed: %r", exc)
    finally:
        if admitted:
            slots.give_back()
            if slots.taken == 0:  # every robot stopped, not only unregistered
                await asyncio.to_thread(give_memory_back)


async def _serve_session(
    websocket: WebSocket, app: FastAPI, make_robot: Callable[[], RobotLike], ready: threading.Event
) -> None:
    """An admitted tab's game: its robot made, run and stopped."""
    sessions: dict[int, Session] = app.state.sessions
    limits: WebConfig = app.state.limits
    if not ready.is_set():
        await websocket.send_text(
            json.dumps({"type": "Status", "data": {"message": "The robot is waking up…"}})
        )
        await asyncio.to_thread(ready.wait)
    async with app.state.starting:
        try:
            robot = await asyncio.to_thread(make_robot)
        except Exception as exc:  # the robot cannot be built: say why, to this tab only
            log.exception("cannot create a robot")
            await websocket.send_text(_error_text(f"the robot cannot start: {exc}"))
            await _close(websocket, 1011, "the robot cannot start")
            return
        session = Session(robot, limits, app.state.listening)
        sessions[session.id] = session
        if websocket.query_params.get("record") == "1":  # issue 18: the toggle was on
            robot.bus.publish(RecordingSwitch(on=True))
        log.info("session %d opened (%d running)", session.id, len(sessions))
    try:
        async with app.state.starting:
            # the robot starts first (its greeting waits in the outbox), so that a frame
            # sent on Hello is never forgotten by the robot's first NewGame
            await asyncio.to_thread(session.start)
        await websocket.send_text(json.dumps({"type": "Hello", "data": _hello(session, app)}))
        code, reason = await _run(websocket, session)
        if code:
            log.info("session %d: %s", session.id, reason)
            await _close(websocket, code, reason)
    finally:
        sessions.pop(session.id, None)
        # stops the robot's threads (run in a worker: it joins them)
        await asyncio.to_thread(session.close)
        log.info("session %d closed (%d running)", session.id, len(sessions))


async def _run(websocket: WebSocket, session: Session) -> tuple[int, str]:
    """Receive from and send to the tab until either side ends the session; the close code
    and reason the server ends it with, or (0, "") if the tab went away."""
    limits = session.limits
    tasks = {
        asyncio.create_task(_send_all(websocket, session)),
        asyncio.create_task(_receive_all(websocket, session)),
        asyncio.create_task(session.ended.wait()),
    }
    try:
        done, _ = await asyncio.wait(
            tasks, timeout=limits.max_session_seconds, return_when=asyncio.FIRST_COMPLETED
        )
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


ROBOTS_STARTING = 2
"""Robots built or started at once: a burst of tabs starts its robots a few at a time, so
that their threads never starve the event loop (and /health, and the games under way)."""

CLIENT_GONE = (WebSocketDisconnect, OSError, RuntimeError)
"""What sending to or receiving from a tab that has gone raises (uvicorn's ClientDisconnected
is an OSError; Starlette raises RuntimeError once the socket is closed)."""


async def _close(websocket: WebSocket, code: int, reason: str) -> None:
    """Close the socket with `code` and `reason`, if the tab is still there to be told."""
    # a close frame's reason holds at most 123 bytes
    reason = reason.encode()[:123].decode(errors="ignore")
    with contextlib.suppress(*CLIENT_GONE):
        await websocket.close(code, reason)


class Slots:
    """The sessions' slots, at most `limit` taken: taken and given back on the event loop,
    with no await between looking and taking, so that the limit holds under any burst."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.taken = 0

    def take(self) -> bool:
        if self.taken >= self.limit:
            return False
        self.taken += 1
        return True

    def give_back(self) -> None:
        self.taken -= 1


class Origins:
    """Which pages may open the game socket: those served under a Host that cannot be a DNS
    rebinding (an IP address, localhost, this server's configured name, an allowed origin's
    host), from the same origin as that Host or an origin in `web.allowed_origins`. A client
    that sends no Origin is not a browser page, and may."""

    def __init__(self, limits: WebConfig) -> None:
        self.allowed = {
            _origin_key(o)
            for o in (o.strip() for o in limits.allowed_origins.split(","))
            if o and _origin_key(o) is not None
        }
        self.hosts = {"localhost"} | {host for host, _ in self.allowed}
        if limits.host not in ("0.0.0.0", "::", ""):
            self.hosts.add(limits.host.lower())

    def refusal(self, websocket: WebSocket) -> str | None:
        """Why this socket is refused (for its close reason and the log), or None."""
        host = websocket.headers.get("host", "")
        default_port = 443 if websocket.url.scheme == "wss" else 80
        served = _host_key(host, default_port)
        if served is None or not (served[0] in self.hosts or _is_ip(served[0])):
            return (
                f"Host {excerpt(host)} is not this server's; add its page's origin to "
                "web.allowed_origins"
            )
        origin = websocket.headers.get("origin")
        if not origin or served == _origin_key(origin):
            return None
        if _origin_key(origin) in self.allowed:
            return None
        return (
            f"pages from {excerpt(origin)} may not play here; add the origin to web.allowed_origins"
        )


def _origin_key(origin: str) -> tuple[str, int] | None:
    """(host, port) of an origin such as http://127.0.0.1:8000, or None if malformed."""
    scheme, _, rest = origin.strip().lower().partition("://")
    if scheme not in ("http", "https"):
        return None  # also "null", the origin of files and sandboxed frames
    return _host_key(rest, 443 if scheme == "https" else 80)


def _host_key(host: str, default_port: int) -> tuple[str, int] | None:
    """(host, port) of a Host header such as 127.0.0.1:8000 or [::1], or None if malformed."""
    try:
        parts = urllib.parse.urlsplit("//" + host.strip().lower())
        port = parts.port
    except ValueError:
        return None
    if not parts.hostname or parts.path or parts.username is not None:
        return None
    return parts.hostname, port if port is not None else default_port


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


MALLOC_ARENAS = 2
"""glibc malloc arenas the server's threads share (`M_ARENA_MAX`; glibc's default is 8 per core)."""


def share_malloc_arenas(arenas: int = MALLOC_ARENAS) -> None:
    """Let all threads share a few malloc arenas, before the sessions' threads exist.

    Each robot runs about ten threads; with an arena per thread, what a burst of sessions
    frees is scattered over many arenas and not handed back whole: after bursts of 200
    connections the server kept 11, 16, 18 then 20 MB more than its baseline, and 3-4 MB with
    two arenas (`bench/bench_soak.py`, with `give_memory_back`). Elsewhere than glibc this
    does nothing."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").mallopt(-8, arenas)  # M_ARENA_MAX


def give_memory_back() -> None:
    """Hand the memory freed by closed sessions back to the system.

    A session's robot runs several threads, and glibc's malloc keeps what each thread's arena
    freed for reuse: after a burst of sessions the server would stay tens of MB bigger for good.
    The robots, their threads and queues hold reference cycles: collect them first, or their
    memory is freed only at some later collection, after the trim. Elsewhere than glibc the
    trim does nothing."""
    gc.collect()
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").malloc_trim(0)


def _warm_up(ready: threading.Event, config: OxbotConfig) -> None:
    try:
        from oxbot.robot.session import warm_up

        warm_up(config)
    except Exception:  # the sessions will meet the same problem and report it
        log.exception("loading the robot's models failed")
    finally:
        ready.set()


def _hello(session: Session, app: FastAPI) -> dict:
    from oxbot.dialogue.domain import GAME_MOVES, MOVE_REQUEST, PROBLEM, SYSTEM_ACTS
    from oxbot.game.board import CELL_NAMES, ROBOT, SIZE, USER, symbol_of

    starts = app.state.robot_starts
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
        "tls_fingerprint": app.state.fingerprint,
    }


def _error_text(message: str, about: str = "", code: str = "") -> str:
    return json.dumps({"type": "Error", "data": {"message": message, "about": about, "code": code}})


async def _send_all(websocket: WebSocket, session: Session) -> None:
    """Outbox → socket, until the session ends."""
    try:
        while True:
            text = await session.outbox.get()
            if text is None:
                return
            session.outbox_bytes -= len(text)
            await websocket.send_text(text)
    except Exception as exc:  # the tab went away; the receiver sees it and ends the session
        log.debug("session %d: sending stopped: %r", session.id, exc)


async def _receive_all(websocket: WebSocket, session: Session) -> None:
    """Socket → robot, until the tab closes, goes quiet or floods. Bad messages get an Error
    on this socket."""
    limits = session.limits
    rate = MessageRate(limits.max_messages_per_second)
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


@contextlib.contextmanager
def serving_in_background(
    app: FastAPI, host: str = "127.0.0.1", port: int = 0, certificate: Certificate | None = None
):
    """Serve `app` from a background thread (tests, benchmarks); yields its http:// URL (https://
    with a `certificate`) and stops the server on exit. Port 0 picks a free port."""
    import socket

    import uvicorn

    if port == 0:
        with socket.socket() as probe:
            probe.bind((host, 0))
            port = probe.getsockname()[1]
    config = uvicorn.Config(
        app,
        host=host,
        port=port,
        log_level="warning",
        **socket_options(app.state.limits),
        **tls_options(certificate),
    )
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, name="oxbot-web-server", daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            server.should_exit = True
            raise OxbotError(f"the web server could not start on {host}:{port}")
        time.sleep(0.02)
    try:
        yield f"{'https' if certificate else 'http'}://{host}:{port}"
    finally:
        server.should_exit = True
        thread.join(15)


def serve(
    config: OxbotConfig | None = None,
    announce: Callable[[str], None] | None = None,
    robot_factory: Callable[[], RobotLike] | None = None,
    record: bool = False,
    data_dir: Any = None,
    record_audio: bool = False,
) -> None:
    """Run the page's server until interrupted (`oxbot play`), on `[web]` host and port
    (localhost by default), over HTTPS when `[web] https` says so (see `uses_https`).

    `announce` is given what a person needs to open the page (the URL; with HTTPS a QR code
    of it for a phone and the certificate's fingerprint). Each tab's robot comes from
    `robot_factory` when given (a robot whose components run elsewhere: `oxbot robot --web`).
    With `record`, the page's record toggle starts on and games are kept in the recordings in
    `data_dir` (issue 18)."""
    import uvicorn

    from oxbot.speech.recognition import recognizer_factory

    share_malloc_arenas()
    config = config if config is not None else OxbotConfig()
    host, port = config.web.host, config.web.port
    recognizer_factory(config.speech.recognizer)  # a misnamed one fails now, not in each tab
    check_port_free(host, port)
    certificate, urls = None, [f"http://{'127.0.0.1' if _any(host) else host}:{port}/"]
    if uses_https(config.web):
        from oxbot.web.tls import ensure_certificate, local_addresses, qr_text

        reachable = local_addresses() if _any(host) else [host]
        certificate = ensure_certificate(reachable)
        urls = [f"https://{_url_host(h)}:{port}/" for h in (reachable or ["127.0.0.1"])]
    recording = RecordingSetup(data_dir, on_by_default=record, keep_audio=record_audio)
    if record:
        log.warning("recording is on: %s", recording.notice())
    app = create_app(config, robot_factory, certificate=certificate, recording=recording)
    lines = [f"oxbot: open {urls[0]} in a browser to play"]
    lines += [f"        or {url}" for url in urls[1:]]
    if certificate is not None:
        lines += [
            "A phone on the same network can scan this:",
            qr_text(urls[0]),
            "The browser warns once about the self-signed certificate: accept it if its SHA-256",
            f"fingerprint is {certificate.fingerprint}",
            f"(kept in {certificate.cert.parent}; the page shows it too).",
        ]
    if announce is not None:
        announce("\n".join(lines))
    log.info("%s", lines[0])
    uvicorn.run(
        app,
        host=host,
        port=port,
        log_level="info",
        **socket_options(config.web),
        **tls_options(certificate),
    )


def uses_https(limits: WebConfig) -> bool:
    """Whether the page is served over HTTPS: `[web] https` "on", or "auto" with a host that is
    not a loopback address (a phone's browser gives the camera only to a secure page)."""
    if limits.https != "auto":
        return limits.https == "on"
    if limits.host.lower() == "localhost":
        return False
    try:
        return not ipaddress.ip_address(limits.host).is_loopback
    except ValueError:
        return True  # a host name: reached from other machines


def tls_options(certificate: Certificate | None) -> dict[str, str]:
    """uvicorn's options for serving with `certificate` (none for plain HTTP)."""
    if certificate is None:
        return {}
    return {"ssl_certfile": str(certificate.cert), "ssl_keyfile": str(certificate.key)}


def _any(host: str) -> bool:
    return host in ("0.0.0.0", "::", "")


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host


def socket_options(limits: WebConfig) -> dict[str, int]:
    """uvicorn's WebSocket limits: what one socket may buffer before the app reads it."""
    # a message up to twice the limit still gets an Error naming the limit; a larger one
    # is refused by the protocol (close code 1009); at most 4 wait unread per socket
    return {"ws_max_size": 2 * limits.max_message_bytes, "ws_max_queue": 4}


def check_port_free(host: str, port: int) -> None:
    """ConfigError, saying what to do, if `host:port` cannot be listened on."""
    import errno
    import socket

    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise ConfigError(f"--host {host!r} is not an address of this machine ({exc})") from None
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise ConfigError(
                    f"port {port} on {host} is already in use (is another `oxbot play` "
                    f"running?); stop it, or pick another port: oxbot play --port {port + 1}"
                ) from None
            raise ConfigError(f"cannot listen on {host}:{port}: {exc.strerror}") from None


__all__ = [
    "Session",
    "check_port_free",
    "create_app",
    "decode_image",
    "decode_pcm",
    "pcm_to_wav",
    "serve",
    "serving_in_background",
    "stream_piece",
    "uses_https",
]
