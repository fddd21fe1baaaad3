"""The web page's server: one page, and one WebSocket per game session (`oxbot play`).

Each browser tab opens `/ws` and gets its own `Robot` (oxbot.robot.session): its own bus,
components, tracker and dialogue. Everything the robot publishes goes to the tab as the bus's
JSON (`oxbot.robot.messages.to_json`), in publish order; what the tab sends is checked here
and handed to the robot:

client → server (JSON text messages)::

    {"type": "frame", "image": "data:image/png;base64,..."}   the sheet (canvas), ~10 Hz
    {"type": "look", "image": "data:image/jpeg;base64,..."}   a webcam frame, head tracking
    {"type": "say", "text": "yes let's play"}                  typed answer
    {"type": "talk", "rate": 16000, "pcm": "<base64 int16>"}   push-to-talk, 16 kHz mono
    {"type": "listen", "rate": 16000, "pcm": "<base64 int16>"} hands-free: the stream's next
                                                               piece (at most 1 s; the page
                                                               sends 0.1 s)
    {"type": "listen_off"}                                     hands-free ends or pauses
    {"type": "new_game", "image": "data:..."}                  a fresh sheet and game

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
"""

from __future__ import annotations

import asyncio
import base64
import binascii
import contextlib
import io
import itertools
import json
import logging
import threading
import time
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
from oxbot.robot.messages import to_json
from oxbot.speech.audio import Audio, to_wav_bytes

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
    def new_game(self) -> Any: ...


def default_robot_factory(config: OxbotConfig) -> Callable[[], RobotLike]:
    """A factory of real robots with this config, one per session."""

    def make() -> RobotLike:
        from oxbot.robot.session import Robot

        return Robot(config)

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
            f"{rate!r} (the page resamples with AudioContext({{sampleRate: "
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

    def _forward(self) -> None:
        """Bus → socket, in publish order (runs in its own thread)."""
        while not self._closing.is_set():
            message = self._subscription.get(timeout=0.1)
            if message is None:
                continue
            try:
                text = to_json(message)
            except (TypeError, ValueError) as exc:  # a message the page cannot take
                log.warning("session %d: cannot send a %s: %s", self.id, type(message), exc)
                continue
            self._loop.call_soon_threadsafe(self.outbox.put_nowait, text)

    def error(self, message: str, about: str = "", code: str = "") -> None:
        self.errors += 1
        self.outbox.put_nowait(_error_text(message, about, code))

    def handle(self, text: str) -> None:
        """Act on one message from the tab; an InvalidInputError says what was wrong."""
        if len(text) > self.limits.max_message_bytes:
            raise InvalidInputError(
                f"message is {len(text)} bytes; the limit is {self.limits.max_message_bytes}"
            )
        try:
            message = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InvalidInputError(f"message is not JSON ({exc})") from None
        if not isinstance(message, dict) or not isinstance(message.get("type"), str):
            raise InvalidInputError('a message is a JSON object with a "type" string')
        kind = message["type"]
        handler = getattr(self, f"_on_{kind}", None) if kind in CLIENT_TYPES else None
        if handler is None:
            raise InvalidInputError(
                f"unknown message type {kind!r}; known: {', '.join(CLIENT_TYPES)}"
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

    def _on_listen_off(self, message: dict) -> None:
        if self.listener is not None:
            self.listener.stop_listening()

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


CLIENT_TYPES = ("frame", "look", "say", "talk", "listen", "listen_off", "new_game")
"""The message types a tab may send."""
GAME_TYPES = ("frame",)
"""The ones refused once the robot has said goodbye (until a new game). Words still reach the
robot, which listens for "new game", "again!" after its goodbye."""
OFF_LOOP_TYPES = ("listen", "listen_off")
"""The ones handled off the event loop: the VAD (loaded at the first piece) runs on each."""


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
) -> FastAPI:
    """The FastAPI app: `/` the page, `/static/*` its files, `/ws` a game session per socket,
    `/health` how many sessions run.

    Every session's robot is built with `config` (`[game]` who starts, `[robot]` its speed and
    waits, `[web]` what a tab may send), or by `robot_factory` when given.
    """
    config = config if config is not None else OxbotConfig()
    limits = config.web
    speed_factor, robot_starts = config.robot.speed_factor, config.game.robot_starts
    make_robot = robot_factory if robot_factory is not None else default_robot_factory(config)
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
    app.state.limits = limits
    app.state.listening = config.speech.listening

    @app.get("/", response_class=HTMLResponse)
    def page() -> HTMLResponse:
        return HTMLResponse(_static("index.html"))

    @app.get("/static/{name}")
    def static(name: str) -> Response:
        if name not in STATIC_TYPES:
            return JSONResponse({"error": f"no such file: {name}"}, status_code=404)
        return Response(_static(name), media_type=STATIC_TYPES[name])

    @app.get("/health")
    def health() -> dict:
        return {"ok": True, "sessions": len(sessions), "speed_factor": speed_factor}

    @app.websocket("/ws")
    async def game(websocket: WebSocket) -> None:
        await _game_session(websocket, app, make_robot, ready)

    app.state.speed_factor = speed_factor
    app.state.robot_starts = robot_starts
    app.state.stable_readings = config.tracker.stable_readings
    return app


async def _game_session(
    websocket: WebSocket, app: FastAPI, make_robot: Callable[[], RobotLike], ready: threading.Event
) -> None:
    """One tab's game, from the socket's opening to its closing."""
    sessions: dict[int, Session] = app.state.sessions
    limits: WebConfig = app.state.limits
    await websocket.accept()
    if len(sessions) >= limits.max_sessions:
        await websocket.send_text(_error_text(f"the server is full ({len(sessions)} games)"))
        await websocket.close(code=1013)
        return
    if not ready.is_set():
        await websocket.send_text(
            json.dumps({"type": "Status", "data": {"message": "The robot is waking up…"}})
        )
        await asyncio.to_thread(ready.wait)
    try:
        robot = await asyncio.to_thread(make_robot)
    except Exception as exc:  # the robot cannot be built: say why, to this tab only
        log.exception("cannot create a robot")
        await websocket.send_text(_error_text(f"the robot cannot start: {exc}"))
        await websocket.close(code=1011)
        return
    session = Session(robot, limits, app.state.listening)
    sessions[session.id] = session
    log.info("session %d opened (%d running)", session.id, len(sessions))
    sender = None
    try:
        # the robot starts first (its greeting waits in the outbox), so that a frame sent
        # on Hello is never forgotten by the robot's first NewGame
        await asyncio.to_thread(session.start)
        await websocket.send_text(json.dumps({"type": "Hello", "data": _hello(session, app)}))
        sender = asyncio.create_task(_send_all(websocket, session))
        await _receive_all(websocket, session)
    except WebSocketDisconnect:
        pass
    finally:
        if sender is not None:
            sender.cancel()
        sessions.pop(session.id, None)
        await asyncio.to_thread(session.close)
        log.info("session %d closed (%d running)", session.id, len(sessions))


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
            await websocket.send_text(text)
    except Exception as exc:  # the tab went away; the receiver sees it and ends the session
        log.debug("session %d: sending stopped: %r", session.id, exc)


async def _receive_all(websocket: WebSocket, session: Session) -> None:
    """Socket → robot, until the tab closes. Bad messages get an Error on this socket."""
    while True:
        event = await websocket.receive()
        if event["type"] == "websocket.disconnect":
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
        try:
            if _heavy(text):  # decoding a sheet image: keep it off the event loop
                await asyncio.to_thread(session.handle, text)
            else:
                session.handle(text)
        except OxbotError as exc:
            session.error(str(exc), about=_kind(text), code=getattr(exc, "code", ""))
        except Exception as exc:  # a robot bug must not end the tab's game or another's
            log.exception("session %d: message failed", session.id)
            session.error(f"the server failed on this message: {type(exc).__name__}: {exc}")
        log.debug(
            "session %d handled in %.1f ms", session.id, 1e3 * (time.perf_counter() - started)
        )


def _heavy(text: str) -> bool:
    """Messages whose decoding (a sheet image) or handling (the VAD) takes long enough to
    keep off the event loop."""
    return len(text) > 20_000 or _kind(text) in OFF_LOOP_TYPES


def _kind(text: str) -> str:
    try:
        kind = json.loads(text).get("type", "")
    except (ValueError, AttributeError):
        return ""
    return kind if isinstance(kind, str) else ""


@contextlib.contextmanager
def serving_in_background(app: FastAPI, host: str = "127.0.0.1", port: int = 0):
    """Serve `app` from a background thread (tests, benchmarks); yields its http:// URL and
    stops the server on exit. Port 0 picks a free port."""
    import socket

    import uvicorn

    if port == 0:
        with socket.socket() as probe:
            probe.bind((host, 0))
            port = probe.getsockname()[1]
    config = uvicorn.Config(app, host=host, port=port, log_level="warning", ws_max_size=2**24)
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
        yield f"http://{host}:{port}"
    finally:
        server.should_exit = True
        thread.join(15)


def serve(config: OxbotConfig | None = None) -> None:
    """Run the page's server until interrupted (`oxbot play`), on `[web]` host and port
    (localhost by default)."""
    import uvicorn

    from oxbot.speech.recognition import recognizer_factory

    config = config if config is not None else OxbotConfig()
    host, port = config.web.host, config.web.port
    recognizer_factory(config.speech.recognizer)  # a misnamed one fails now, not in each tab
    check_port_free(host, port)
    app = create_app(config)
    log.info("oxbot: open http://%s:%d in a browser to play", host, port)
    uvicorn.run(app, host=host, port=port, log_level="info", ws_max_size=16 * 1024 * 1024)


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
]
