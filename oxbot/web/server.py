"""The web page's server (`oxbot play`): the FastAPI app, its routes, and serving it.

`/` is the page, `/static/*` its files, `/ws` one game session per socket, `/health` and `/tls`,
beside the recording routes (oxbot.web.recording). The WebSocket's protocol, its limits and its
close codes are documented in oxbot.web.session, which runs a tab's game; what a tab sends is
checked by oxbot.web.inbound, and who may open a session is decided by oxbot.web.admission.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import ipaddress
import json
import logging
import threading
import time
from collections.abc import Callable
from importlib import resources
from typing import Any

from fastapi import FastAPI, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import HTMLResponse, JSONResponse, Response

from oxbot.config import OxbotConfig, WebConfig
from oxbot.errors import ConfigError, OxbotError
from oxbot.robot.messages import RecordingSwitch
from oxbot.web.admission import Origins, Slots
from oxbot.web.inbound import decode_image, decode_pcm, pcm_to_wav, stream_piece
from oxbot.web.memory import give_memory_back, share_malloc_arenas
from oxbot.web.recording import RecordingSetup
from oxbot.web.recording import add_routes as add_recording_routes
from oxbot.web.session import Attachment, RobotLike, Session, error_text, hello, run_session
from oxbot.web.tls import Certificate

log = logging.getLogger(__name__)


def default_robot_factory(
    config: OxbotConfig, recording: RecordingSetup | None = None
) -> Callable[[], RobotLike]:
    """A factory of real robots with this config, one per session (each with a Recorder, off
    until its tab switches it on, when `recording` is given)."""

    def make() -> RobotLike:
        from oxbot.recording.recorder import joining
        from oxbot.robot.session import Robot

        if recording is None:
            return Robot(config)
        # the database is opened at the first game kept, and nothing is kept until the tab asks
        recorder = joining(recording.store, "web", keep_audio=recording.keep_audio, enabled=False)
        return Robot(config, joining=[recorder])

    return make


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
        # games kept for a page to come back to stop with the server
        kept = [s for s in app.state.sessions.values() if s.attachment is None]
        for session in kept:
            if session.expiry is not None:
                session.expiry.cancel()
        await asyncio.gather(*(_stop(app, session) for session in kept))

    app = FastAPI(title="oxbot", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    sessions: dict[int, Session] = {}
    app.state.sessions = sessions
    app.state.slots = Slots(limits.max_sessions)
    app.state.starting = asyncio.Semaphore(ROBOTS_STARTING)
    app.state.origins = Origins(limits)
    app.state.limits = limits
    app.state.listening = config.speech.listening
    app.state.fingerprint = certificate.fingerprint if certificate is not None else ""
    app.state.ready = ready

    @app.middleware("http")
    async def same_checks_as_the_socket(request: Request, call_next: Any) -> Response:
        # a DNS-rebinding page would read the person's answers and crops from any route
        refusal = app.state.origins.refusal(request)
        if refusal is not None:
            log.warning("refused %s %s: %s", request.method, request.url.path, refusal)
            return JSONResponse({"error": refusal}, status_code=403)
        return await call_next(request)

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

    # the record toggle's settings, the "what I learned" page (oxbot.web.recording)
    app.state.recording = recording
    add_recording_routes(app, recording)

    app.state.speed_factor = speed_factor
    app.state.robot_starts = robot_starts
    app.state.stable_readings = config.tracker.stable_readings
    return app


async def game_socket(
    websocket: WebSocket, app: FastAPI, make_robot: Callable[[], RobotLike]
) -> None:
    """A tab's game on `websocket` with its robot from `make_robot`, admitted, limited and
    closed as `/ws`'s are: for routes that choose each tab's robot (oxbot.study)."""
    await _game_session(websocket, app, make_robot, app.state.ready)


async def _game_session(
    websocket: WebSocket, app: FastAPI, make_robot: Callable[[], RobotLike], ready: threading.Event
) -> None:
    """One tab's game, from the socket's opening to its closing; or, for a socket with a resume
    token (`/ws?resume=TOKEN`), the game it was given before the page reloaded, taken back."""
    slots: Slots = app.state.slots
    # both decided before the first await, so that a burst of connections cannot all pass
    refusal = app.state.origins.refusal(websocket)
    token = websocket.query_params.get("resume", "") if refusal is None else ""
    kept = _kept_session(app, token, websocket.url.path) if token else None
    admitted = refusal is None and kept is None and slots.take()  # a kept game has its slot
    try:
        await websocket.accept()
        if refusal is not None:
            log.warning("refused a game socket: %s", refusal)
            await _close(websocket, 1008, refusal)
            return
        if kept is not None:
            if await _resume(websocket, app, kept):
                return
            admitted = slots.take()  # it ended while its last socket let go: a new game
        if token:
            log.info("a game socket's resume token matched no game kept; a new game")
            seconds = app.state.limits.resume_seconds
            await websocket.send_text(
                error_text(RESUME_FAILED.format(seconds=seconds), "resume", "resume_failed")
            )
        if not admitted:
            busy = f"the server is busy ({slots.limit} games, web.max_sessions); try again later"
            await websocket.send_text(error_text(busy))
            await _close(websocket, 1013, busy)
            return
        admitted = False  # the slot is the session's now: given back when its robot stops
        await _serve_session(websocket, app, make_robot, ready)
    except CLIENT_GONE as exc:
        log.debug("a tab went away while its session opened or closed: %r", exc)
    finally:
        if admitted:
            await _give_back(app)


async def _serve_session(
    websocket: WebSocket, app: FastAPI, make_robot: Callable[[], RobotLike], ready: threading.Event
) -> None:
    """An admitted tab's game: its robot made and run, holding the slot taken for it."""
    sessions: dict[int, Session] = app.state.sessions
    limits: WebConfig = app.state.limits
    session = None
    try:
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
                await websocket.send_text(error_text(f"the robot cannot start: {exc}"))
                await _close(websocket, 1011, "the robot cannot start")
                return
            session = Session(robot, limits, app.state.listening)
            session.recording_refusal = app.state.recording.unavailable
            session.route = websocket.url.path
            sessions[session.id] = session
            log.info("session %d opened (%d running)", session.id, len(sessions))
    finally:
        if session is None:
            await _give_back(app)
    assert session.attachment is not None  # a new session is its first socket's
    await _play(websocket, app, session, session.attachment)


async def _play(
    websocket: WebSocket,
    app: FastAPI,
    session: Session,
    attachment: Attachment,
    resumed: str | None = None,
) -> None:
    """`session`'s game on `websocket` (`resumed`: the Resumed message of a game taken back, or
    None for a new one, whose robot starts here) until the tab goes, the session ends or a
    newer socket takes it over. Then the game is kept for the page to come back (the tab went
    away mid-game without meaning to end it: a reload), left to the newer socket, or stopped."""
    greeted = resumed is not None  # a page never greeted has no token to come back with
    try:
        if resumed is None:
            if websocket.query_params.get("record") == "1":  # the page's record toggle was on
                if session.recording_refusal:
                    await websocket.send_text(error_text(session.recording_refusal))
                else:
                    session.robot.bus.publish(RecordingSwitch(on=True))
            async with app.state.starting:
                # the robot starts first (its greeting waits in the outbox), so that a frame
                # sent on Hello is never forgotten by the robot's first NewGame
                await asyncio.to_thread(session.start)
        data = hello(session, app, resumed=resumed is not None)
        await websocket.send_text(json.dumps({"type": "Hello", "data": data}))
        greeted = True
        if resumed is not None:  # the page rebuilds the game from it; live messages follow
            await websocket.send_text(resumed)
        code, reason = await run_session(websocket, session, attachment)
        if code:
            log.info("session %d: %s", session.id, reason)
            await _close(websocket, code, reason)
        elif attachment.taken_over.is_set():
            log.info("session %d: taken over by a newer socket", session.id)
            await _close(websocket, TAKEN_OVER_CODE, TAKEN_OVER)
    finally:
        try:
            session.detach(attachment)
            if attachment.taken_over.is_set() and _resumable(session):
                pass  # the newer socket has the game
            elif greeted and _keeps(session, attachment):
                _keep(app, session, attachment.close_code)
            else:
                await _stop(app, session)
        finally:
            attachment.gone.set()


async def _resume(websocket: WebSocket, app: FastAPI, session: Session) -> bool:
    """Take back `session`, kept since its page went away, for this socket; False if it ended
    meanwhile. The newest socket wins: one still attached (a reloaded page's, not closed yet,
    or a duplicated tab's) is closed with TAKEN_OVER, and the robot goes on."""
    while session.attachment is not None and _resumable(session):
        old = session.attachment
        old.taken_over.set()
        await old.gone.wait()
    if not _resumable(session):
        return False
    if session.expiry is not None:
        session.expiry.cancel()
        session.expiry = None
    attachment, resumed = session.attach()
    log.info("session %d: its page came back", session.id)
    await _play(websocket, app, session, attachment, resumed)
    return True


def _kept_session(app: FastAPI, token: str, route: str) -> Session | None:
    """The session opened on `route` whose resume token is `token`, if it can be taken back."""
    if app.state.limits.resume_seconds <= 0 or len(token) > MAX_TOKEN_CHARS:
        return None
    wanted, found = token.encode(errors="replace"), None
    for session in list(app.state.sessions.values()):
        # every token compared in constant time: no answer tells how close a guess came
        same = hmac.compare_digest(session.token.encode(), wanted)
        if same and session.route == route and _resumable(session):
            found = session
    return found


def _resumable(session: Session) -> bool:
    return not session.stopping and session.end_reason is None


def _keeps(session: Session, attachment: Attachment) -> bool:
    """Whether `session`, whose socket has gone, waits for its page to come back: its game is
    under way, and the tab did not close the socket meaning to end it (1000, a client that is
    done: a reload or a closed tab says 1001, a lost connection gives no close frame)."""
    return (
        session.limits.resume_seconds > 0
        and _resumable(session)
        and attachment.close_code != 1000
        and not session.robot.finished
    )


def _keep(app: FastAPI, session: Session, close_code: int | None) -> None:
    """Keep `session`'s robot running, and its slot, for `resume_seconds`; then stop it."""
    seconds = session.limits.resume_seconds

    async def expire() -> None:
        await asyncio.sleep(seconds)
        if session.attachment is None:
            log.info(
                "session %d: no page came back in %g s (web.resume_seconds)", session.id, seconds
            )
            await _stop(app, session)

    log.info(
        "session %d: its tab went away mid-game (close code %s); kept %g s for a reload",
        session.id,
        close_code,
        seconds,
    )
    session.expiry = asyncio.create_task(expire())


async def _stop(app: FastAPI, session: Session) -> None:
    """Stop `session`'s robot (once) and give its slot back."""
    if session.stopping:
        return
    session.stopping = True  # before any await: no socket takes it back from now on
    sessions: dict[int, Session] = app.state.sessions
    sessions.pop(session.id, None)
    try:
        # stops the robot's threads (run in a worker: it joins them)
        await asyncio.to_thread(session.close)
    finally:
        log.info("session %d closed (%d running)", session.id, len(sessions))
        await _give_back(app)


async def _give_back(app: FastAPI) -> None:
    slots: Slots = app.state.slots
    slots.give_back()
    if slots.taken == 0:  # every robot stopped, not only unregistered
        await asyncio.to_thread(give_memory_back)


RESUME_FAILED = (
    "the game before the reload could not be brought back: it had ended, or its page was away "
    "longer than {seconds:g} s (web.resume_seconds); a new game starts"
)
TAKEN_OVER_CODE = 4000
TAKEN_OVER = "this game went on in a newer page with its token (this tab reloaded, or a copy of it)"
MAX_TOKEN_CHARS = 100
"""Longer resume tokens are no token of ours (they are 32 characters)."""


REMOTE_RECORDING = (
    "recording is not available for a robot whose parts run as processes (oxbot robot --web): "
    "nothing of this game is kept; play with `oxbot play --record` to keep games"
)
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


def _warm_up(ready: threading.Event, config: OxbotConfig) -> None:
    try:
        from oxbot.robot.session import warm_up

        warm_up(config)
    except Exception:  # the sessions will meet the same problem and report it
        log.exception("loading the robot's models failed")
    finally:
        ready.set()


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
    add_routes: Callable[[FastAPI], None] | None = None,
    page: str = "",
) -> None:
    """Run the page's server until interrupted (`oxbot play`), on `[web]` host and port
    (localhost by default), over HTTPS when `[web] https` says so (see `uses_https`).

    `announce` is given what a person needs to open the page (the URL; with HTTPS a QR code
    of it for a phone and the certificate's fingerprint). Each tab's robot comes from
    `robot_factory` when given (a robot whose components run elsewhere: `oxbot robot --web`).
    With `record`, the page's record toggle starts on and games are kept in the recordings in
    `data_dir`, to learn from. `add_routes` adds more routes to the app (`oxbot study`'s), and
    the URLs announced open `page` (a path such as "study")."""
    import uvicorn

    from oxbot.speech.recognition import recognizer_factory

    if record and robot_factory is not None:
        raise ConfigError(REMOTE_RECORDING)
    share_malloc_arenas()
    config = config if config is not None else OxbotConfig()
    host, port = config.web.host, config.web.port
    recognizer_factory(config.speech.recognizer)  # a misnamed one fails now, not in each tab
    check_port_free(host, port)
    certificate, urls = None, [page_url("http", "127.0.0.1" if _any(host) else host, port)]
    if uses_https(config.web):
        from oxbot.web.tls import ensure_certificate, local_addresses, qr_text

        reachable = local_addresses() if _any(host) else [host]
        certificate = ensure_certificate(reachable)
        urls = [page_url("https", h, port) for h in (reachable or ["127.0.0.1"])]
    recording = RecordingSetup(data_dir, on_by_default=record, keep_audio=record_audio)
    if robot_factory is not None:  # its parts run elsewhere: no Recorder joins their bus
        recording.unavailable = REMOTE_RECORDING
    if record:
        log.warning("recording is on: %s", recording.notice())
    app = create_app(config, robot_factory, certificate=certificate, recording=recording)
    if add_routes is not None:
        add_routes(app)
    urls = [url + page for url in urls]
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


def page_url(scheme: str, host: str, port: int) -> str:
    """The page's URL on `host` (an IPv6 address in brackets: http://[::1]:8000/)."""
    return f"{scheme}://{f'[{host}]' if ':' in host else host}:{port}/"


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
                    "running?); stop it, or pick another port: "
                    f"`.venv/bin/oxbot play --port {port + 1}`"
                ) from None
            raise ConfigError(f"cannot listen on {host}:{port}: {exc.strerror}") from None


__all__ = [
    "RobotLike",
    "Session",
    "check_port_free",
    "create_app",
    "decode_image",
    "decode_pcm",
    "default_robot_factory",
    "game_socket",
    "pcm_to_wav",
    "serve",
    "serving_in_background",
    "stream_piece",
    "uses_https",
]
