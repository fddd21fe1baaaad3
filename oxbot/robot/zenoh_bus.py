"""The bus across processes and machines, on Eclipse Zenoh.

`ZenohBus` is a `Bus` (oxbot.robot.bus): the same two calls, the same typed messages, so any
component runs on it unchanged. A message of topic `game/new` on robot `kitchen` travels on the
key expression `oxbot/kitchen/game/new` as its JSON (`messages.to_json`, encoding
application/json; a message carrying bytes, such as a camera frame, as a line of JSON followed
by the raw bytes, see `encode`), with the message format's version in the attachment. Every
process of a robot opens one session; peers find each other by multicast scouting on a LAN, or
by `connect` / `listen` endpoints (`tcp/192.168.1.10:7447`), through a router for larger
deployments.

Besides messages, each component process of a robot declares:
- a liveliness token `oxbot/<robot>/alive/<name>/<format>/<zenoh id>/<pid>`, which Zenoh
  withdraws as soon as the process is gone (its links close; a silent machine is dropped after
  the 1 s lease), so every process knows who is up (`alive`, `PartsWatcher`);
- a queryable `oxbot/<robot>/state/<name>` answering the current game so far (`NewGame`,
  `GameState`, `DialogueAct`, `DialogueEnded`, `ArmStroke`), so a late joiner (a respawned
  component, a web page opened mid-game) learns the board and the dialogue (`game_so_far`).

What comes from the network is not trusted (any peer that reaches the endpoints may publish):
each message is checked before it is dispatched (`oxbot.robot.message_checks`: the JSON's size
and depth, every field's type and range, cell names) and a bad one is dropped with one log
line; each topic's rate is bounded (`FloodGuard`: beyond it, messages are dropped, a line per
burst); a game record answering a state query is bounded and checked the same way; and every
subscription's queue is bounded (`oxbot.robot.bus.MAX_QUEUED`, the oldest dropped).

Refusals are errors of oxbot.errors, raised at once: an endpoint nobody answers at
(`BusUnreachable`, after `CONNECT_TIMEOUT`), a process of another message format on the same
robot (`BusVersionError`), a component that is up already (`ComponentAlreadyRunning`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import logging
import os
import queue
import re
import threading
import time
import typing
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import zenoh

from oxbot.errors import (
    BusError,
    BusUnreachable,
    BusVersionError,
    ComponentAlreadyRunning,
    ConfigError,
    InvalidInputError,
)
from oxbot.robot.bus import LocalSubscription, Subscriptions
from oxbot.robot.bus_security import BusSecurity
from oxbot.robot.message_checks import FloodGuard, check_json, check_message
from oxbot.robot.messages import (
    MESSAGE_TYPES,
    ArmStroke,
    ComponentFailed,
    ComponentJoined,
    ComponentLost,
    DialogueAct,
    DialogueEnded,
    Frame,
    GameState,
    Message,
    NewGame,
    PersonFrame,
    from_json,
    to_json,
)

log = logging.getLogger(__name__)

FORMAT_VERSION = 1
"""Bumped by hand when the envelope changes; the fingerprint below follows the messages."""


def message_format() -> str:
    """`<FORMAT_VERSION>-<fingerprint>`: the fingerprint hashes every message type's name and
    fields, so two processes built from different oxbot versions refuse each other."""
    hints = {
        name: [(f.name, str(typing.get_type_hints(cls)[f.name])) for f in dataclasses.fields(cls)]
        for name, cls in sorted(MESSAGE_TYPES.items())
    }
    digest = hashlib.sha256(json.dumps(hints, sort_keys=True).encode()).hexdigest()
    return f"{FORMAT_VERSION}-{digest[:10]}"


FORMAT = message_format()
TOPICS: dict[str, type[Message]] = {cls.topic: cls for cls in MESSAGE_TYPES.values()}
"""Every message type by topic: the key expression names the type before any decoding."""
RECORDED = (NewGame, GameState, DialogueAct, DialogueEnded, ArmStroke)
"""The messages that make the current game for a late joiner (the arm's strokes: so that a
page opened mid-game draws the robot's symbols)."""
LOSSY = (Frame, PersonFrame)
"""Camera frames come 10 times a second: under congestion an old one is dropped, not queued."""
CONNECT_TIMEOUT = 3.0
"""Seconds to reach the `connect` endpoints before BusUnreachable."""
QUERY_TIMEOUT = 1.0
"""Seconds to wait for the answers of a liveliness or state query."""
REJOIN_SECONDS = 10.0
"""How long a component whose process ended may take to come back (respawned by
`oxbot robot --launch` within about 1 s, then its models loaded: Piper's voice takes 1.3 s on
a quiet machine and more than 5 s beside other jobs) before the robot takes it as lost."""
MAX_WATCHED_CHANGES = 1_000
"""The most liveliness changes `PartsWatcher` holds unread (a robot's seven parts make a few a
respawn; only a peer flooding tokens makes more). Beyond it a new change is dropped, with a log
line per burst, and once the queue has drained the watcher re-reads who is up (`alive`), so
that no death or comeback is missed for good."""
MAX_RECORD_BYTES = 16 * 1024 * 1024
"""The most a game record (the answer to a state query) may take; a whole game's is ~100 KB."""
NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")
BLOBS = zenoh.Encoding.APPLICATION_OCTET_STREAM.with_schema("oxbot-blobs")
SHARED_MEMORY_FROM = 64 * 1024
"""Payloads from this size (camera frames) are put in shared memory: a process on the same
machine maps them instead of receiving 14 TCP fragments (a 900 KB frame: 2.8 ms median, 7.8
ms p99 by TCP on loopback; 0.5 / 4.4 ms shared). Zenoh copies them for other machines."""
SHARED_MEMORY_POOL = 32 * 1024 * 1024
"""Bytes of shared memory a publishing process sets aside: about 3 s of 640x480 frames."""


def encode(message: Message) -> tuple[bytes, zenoh.Encoding]:
    """The message on the wire: its JSON (`to_json`) when it carries no bytes; else, since
    base64 in JSON costs about 12 ms a camera frame each way, the blob layout: one line of
    JSON whose bytes fields are replaced by `{"blob": i}`, with `"blobs": [sizes]`, then the
    blobs themselves, raw, one after another."""
    pieces, encoding = encode_pieces(message)
    return b"".join(pieces), encoding


def encode_pieces(message: Message) -> tuple[list[bytes], zenoh.Encoding]:
    """`encode`'s payload in the pieces it is made of, for writing them straight into shared
    memory without joining them first."""
    blobs: list[bytes] = []

    def pack(value: typing.Any) -> typing.Any:
        if isinstance(value, bytes):
            blobs.append(value)
            return {"blob": len(blobs) - 1}
        if isinstance(value, tuple):
            return [pack(v) for v in value]
        return value

    data = {f.name: pack(getattr(message, f.name)) for f in dataclasses.fields(message)}
    if not blobs:
        return [to_json(message).encode()], zenoh.Encoding.APPLICATION_JSON
    header = {"type": type(message).__name__, "topic": message.topic, "data": data}
    header["blobs"] = [len(b) for b in blobs]
    return [json.dumps(header).encode() + b"\n", *blobs], BLOBS


@functools.cache
def _hints(cls: type[Message]) -> dict[str, typing.Any]:
    return typing.get_type_hints(cls)


def decode(payload: bytes, blobs: bool) -> Message:
    """The message `encode` made; InvalidInputError if it is not one."""
    if not blobs:
        return from_json(payload)
    try:
        end = payload.index(b"\n")
        check_json(payload[:end], "a message's header")
        header = json.loads(payload[:end])
        cls = MESSAGE_TYPES[header["type"]]
        data, sizes = dict(header["data"]), [int(n) for n in header["blobs"]]
        sent = len(payload) - end - 1
        if sum(sizes) != sent or any(n < 0 for n in sizes):
            raise ValueError(f"blobs of {sum(sizes)} bytes announced, {sent} sent")
        view = memoryview(payload)  # each blob copied once, out of the payload
        starts = [end + 1 + sum(sizes[:i]) for i in range(len(sizes))]
        pieces = [bytes(view[a : a + n]) for a, n in zip(starts, sizes, strict=True)]

        def unpack(value: typing.Any) -> typing.Any:
            if isinstance(value, dict) and set(value) == {"blob"}:
                return pieces[value["blob"]]
            if isinstance(value, list):
                return tuple(unpack(v) for v in value)
            return value

        fields = {k: unpack(v) for k, v in data.items()}
        hints = _hints(cls)
        for name, value in fields.items():
            if hints.get(name) is bytes and not isinstance(value, bytes):
                raise TypeError(f"field {name!r} of a {cls.__name__} message is not bytes")
        return check_message(cls(**fields))
    except (ValueError, KeyError, TypeError, IndexError, RecursionError) as exc:
        raise InvalidInputError(
            f"not a message of oxbot's bus ({type(exc).__name__}: {exc})"
        ) from None


@dataclass(frozen=True)
class Endpoints:
    """How a process finds the others of its robot (Zenoh's `connect`, `listen`, scouting)."""

    connect: tuple[str, ...] = ()
    """Endpoints of peers or routers to connect to, e.g. `tcp/192.168.1.10:7447`."""
    listen: tuple[str, ...] = ()
    """Endpoints to accept connections on, e.g. `tcp/0.0.0.0:7447`."""
    scouting: bool = True
    """Find peers on the LAN by UDP multicast (Zenoh's default); off for tests and routers."""
    router: bool = False
    """Run as a Zenoh router (routes for peers that cannot reach each other directly)."""
    security: BusSecurity | None = None
    """TLS with mutual authentication and access control (oxbot.robot.bus_security); the
    endpoints are then `tls/HOST:PORT`."""

    def zenoh_config(self) -> zenoh.Config:
        config = zenoh.Config()
        settings = {
            "mode": "router" if self.router else "peer",
            "scouting/multicast/enabled": self.scouting,
            # a machine that goes silent is dropped, its components lost, within a second
            "transport/link/tx/lease": 1000,
            "transport/link/tx/keep_alive": 4,
            "transport/shared_memory/enabled": True,
        }
        if self.connect:
            settings |= {
                "connect/endpoints": list(self.connect),
                "connect/timeout_ms": int(CONNECT_TIMEOUT * 1000),
                "connect/exit_on_failure": True,
            }
        if self.listen:
            settings["listen/endpoints"] = list(self.listen)
        if self.security is not None:
            settings |= self.security.zenoh_settings()
        for key, value in settings.items():
            try:
                config.insert_json5(key, json.dumps(value))
            except zenoh.ZError as exc:
                raise ConfigError(f"bad Zenoh setting {key}={value!r}: {exc}") from None
        return config


@dataclass(frozen=True)
class Peer:
    """A component process that is up, from its liveliness token."""

    name: str
    format: str
    zid: str
    pid: int


class ZenohBus(Subscriptions):
    """The `Bus` of one robot (`robot`, a name) over Zenoh: see the module docstring.

    Each subscription is a FIFO queue, as on `LocalBus`; one Zenoh subscriber per process
    feeds them all in the order a publisher published. `close` when done.
    """

    FORMAT = FORMAT

    def __init__(self, robot: str, endpoints: Endpoints | None = None) -> None:
        if not NAME.match(robot):
            raise ConfigError(
                f"robot name {robot!r}: use letters, digits, '_', '-' and '.' (it is a key "
                "expression chunk, oxbot/<robot>/<topic>)"
            )
        self.robot = robot
        self.endpoints = endpoints if endpoints is not None else Endpoints()
        self.prefix = f"oxbot/{robot}/"
        super().__init__()  # subscribe / unsubscribe: the queues of this process
        self._record: list[Message] = []
        self._refused: set[str] = set()  # formats already reported, so the log says it once
        self._flood = FloodGuard()
        self._declared: list[typing.Any] = []
        self._shared_memory: zenoh.shm.ShmProvider | None = None
        self._shared_memory_failed = False
        self.session = open_session(self.endpoints)
        self.zid = str(self.session.zid())
        try:
            subscriber = self.session.declare_subscriber(self.prefix + "**", self._receive)
            self._declared.append(subscriber)
            self.check_formats()
        except BaseException:
            self.close()
            raise

    # --- the Bus protocol ---

    def publish(self, message: Message) -> None:
        if not isinstance(message, Message):
            raise TypeError(f"only oxbot.robot.messages types travel on the bus, not {message!r}")
        if self.session.is_closed():
            raise BusError(f"the bus of robot {self.robot!r} is closed: nothing can be published")
        lossy = isinstance(message, LOSSY)
        pieces, encoding = encode_pieces(message)
        self.session.put(
            self.prefix + message.topic,
            self._payload(pieces),
            encoding=encoding,
            attachment=self.FORMAT,
            congestion_control=zenoh.CongestionControl.DROP
            if lossy
            else zenoh.CongestionControl.BLOCK,
            express=not lossy,  # small messages leave at once instead of waiting for a batch
        )

    def _payload(self, pieces: list[bytes]) -> bytes | zenoh.ZBytes:
        """The pieces joined: in shared memory when they are large and it can be had."""
        size = sum(len(piece) for piece in pieces)
        if size < SHARED_MEMORY_FROM or self._shared_memory_failed:
            return b"".join(pieces)
        try:
            if self._shared_memory is None:
                self._shared_memory = zenoh.shm.ShmProvider.default_backend(SHARED_MEMORY_POOL)
            # chunks every reader has let go are collected; a pool still full: this one by TCP
            buffer = self._shared_memory.alloc(size, zenoh.shm.GarbageCollect())
        except zenoh.ZError as exc:
            if self._shared_memory is None:
                self._shared_memory_failed = True  # no /dev/shm here: said once, then TCP
                log.warning("no shared memory for camera frames (%s): they go by TCP", exc)
            return b"".join(pieces)
        at = 0
        for piece in pieces:
            buffer[at : at + len(piece)] = piece
            at += len(piece)
        return zenoh.ZBytes(buffer)

    def _receive(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        cls = TOPICS.get(key[len(self.prefix) :])
        if cls is None:
            return
        sent_as = sample.attachment.to_string() if sample.attachment is not None else "none"
        if sent_as != self.FORMAT:
            if sent_as not in self._refused:
                self._refused.add(sent_as)
                log.error(
                    "dropped %s from a process of message format %s (this one: %s): run the "
                    "same oxbot version everywhere",
                    key,
                    sent_as,
                    self.FORMAT,
                )
            return
        with self._lock:
            targets = [s for s in self._subscriptions if issubclass(cls, s.types)]
            if not issubclass(cls, LOSSY) and not self._flood.admit(cls.topic, time.monotonic()):
                return  # over its topic's rate: a peer floods (logged by the guard)
        if not targets and not issubclass(cls, RECORDED):
            return  # nobody here wants it: not even decoded
        try:
            message = decode(sample.payload.to_bytes(), sample.encoding == BLOBS)
        except InvalidInputError as exc:
            log.error("dropped a malformed message on %s: %s", key, exc)
            return
        with self._lock:
            if isinstance(message, NewGame):
                self._record = [message]
            elif isinstance(message, RECORDED):
                self._record.append(message)
            # put under the lock: `subscribe_with_history` reorders behind it
            for subscription in targets:
                subscription.put(message)

    # --- who is up ---

    def alive(self) -> list[Peer]:
        """The component processes of this robot that are up now."""
        replies = self.session.liveliness().get(self.prefix + "alive/**", timeout=QUERY_TIMEOUT)
        peers = [self._peer(str(r.ok.key_expr)) for r in replies if r.ok is not None]
        return [p for p in peers if p is not None]

    def _peer(self, key: str) -> Peer | None:
        parts = key[len(self.prefix) :].split("/")
        if len(parts) != 5 or parts[0] != "alive" or not parts[4].isdigit():
            return None
        return Peer(name=parts[1], format=parts[2], zid=parts[3], pid=int(parts[4]))

    def check_formats(self, peers: Iterable[Peer] | None = None) -> None:
        """BusVersionError if a process of this robot speaks another message format."""
        for peer in self.alive() if peers is None else peers:
            if peer.format != self.FORMAT:
                raise BusVersionError(
                    f"component {peer.name!r} of robot {self.robot!r} (pid {peer.pid}) speaks "
                    f"message format {peer.format}, this process {self.FORMAT}: run the same "
                    "oxbot version in every process of the robot"
                )

    def join(self, name: str, replace: bool = False) -> None:
        """Announce component `name` as up (its liveliness token) and answer state queries;
        ComponentAlreadyRunning if it is up in another process of this robot, unless `replace`
        (a launcher's child, which the network's claims do not stop)."""
        if not NAME.match(name):
            raise ConfigError(f"component name {name!r}: letters, digits, '_', '-' and '.'")
        if not replace:
            self.check_running(name)
        self._seed_record()
        token = f"{self.prefix}alive/{name}/{self.FORMAT}/{self.zid}/{os.getpid()}"
        self._declared.append(self.session.liveliness().declare_token(token))
        self._declared.append(
            self.session.declare_queryable(f"{self.prefix}state/{name}", self._answer_state)
        )

    def check_running(self, name: str) -> None:
        """ComponentAlreadyRunning if component `name` is up in another process."""
        twins = [p for p in self.alive() if p.name == name and p.zid != self.zid]
        if twins:
            raise ComponentAlreadyRunning(
                f"component {name!r} already runs for robot {self.robot!r} (pid {twins[0].pid}, "
                f"zenoh id {twins[0].zid}): stop that one first, or use another --robot name"
            )

    def watch(self, callback: Callable[[Peer, bool], None]) -> None:
        """Call `callback(peer, up)` for every component process already up (up=True), then
        for each that comes up or goes down, from a Zenoh thread."""

        def changed(sample: zenoh.Sample) -> None:
            peer = self._peer(str(sample.key_expr))
            if peer is not None:
                callback(peer, sample.kind == zenoh.SampleKind.PUT)

        subscriber = self.session.liveliness().declare_subscriber(
            self.prefix + "alive/**", changed, history=True
        )
        self._declared.append(subscriber)

    # --- the game so far, for late joiners ---

    def _answer_state(self, query: zenoh.Query) -> None:
        with self._lock:
            record = [to_json(m) for m in self._record]
        query.reply(query.key_expr, json.dumps(record), attachment=self.FORMAT)

    def game_so_far(self) -> list[Message]:
        """The current game's NewGame, GameStates, DialogueActs, ArmStrokes and DialogueEnded,
        oldest first, as the most complete answer among the component processes has it."""
        best: list[Message] = []
        for reply in self.session.get(self.prefix + "state/*", timeout=QUERY_TIMEOUT):
            if reply.ok is None:
                continue
            sample = reply.ok
            if sample.attachment is None or sample.attachment.to_string() != self.FORMAT:
                continue  # its process is refused by `check_formats`
            try:  # any peer may answer: bounded before it is parsed, each message checked
                raw = sample.payload.to_bytes()
                if len(raw) > MAX_RECORD_BYTES:
                    raise InvalidInputError(f"{len(raw):,} bytes")
                record = json.loads(raw)
                if not isinstance(record, list) or not all(isinstance(m, str) for m in record):
                    raise InvalidInputError("not a list of messages")
                record = [from_json(m) for m in record]
            except (InvalidInputError, ValueError, TypeError, RecursionError) as exc:
                log.error("dropped a malformed game record from %s: %s", sample.key_expr, exc)
                continue
            if len(record) > len(best):
                best = record
        with self._lock:
            mine = list(self._record)
        return mine if len(mine) >= len(best) else best

    def _seed_record(self) -> None:
        """A process that joins mid-game (a respawned one) learns the game so far."""
        history = self.game_so_far()
        with self._lock:
            self._record = history + [m for m in self._record if m not in history]

    def subscribe_with_history(self, *types: type[Message]) -> LocalSubscription:
        """`subscribe`, with the game so far (of `types`) first: what a late joiner needs."""
        subscription = self.subscribe(*types)
        history = [m for m in self.game_so_far() if isinstance(m, subscription.types)]
        with self._lock:  # no message is dispatched meanwhile: it would land before the history
            live = subscription.drain()
            for message in history + [m for m in live if m not in history]:
                subscription.put(message)
        return subscription

    def close(self) -> None:
        """Undeclare everything (liveliness tokens first: others see this process go) and close
        the session."""
        for declared in reversed(self._declared):
            with contextlib.suppress(zenoh.ZError):
                declared.undeclare()
        self._declared.clear()
        if not self.session.is_closed():
            self.session.close()

    def __enter__(self) -> ZenohBus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_session(endpoints: Endpoints) -> zenoh.Session:
    """A Zenoh session, or a BusError saying which endpoint failed and what to do."""
    try:
        return zenoh.open(endpoints.zenoh_config())
    except zenoh.ZError as exc:
        detail = str(exc).split(" at /", 1)[0]  # Zenoh appends the Rust source location
        if "Unable to connect" in detail:
            raise BusUnreachable(
                f"nothing answers at {', '.join(endpoints.connect)} within {CONNECT_TIMEOUT:.0f} "
                "s: start the robot's router or a component listening there (oxbot robot "
                "--launch FILE, oxbot component NAME --listen ENDPOINT), or fix --connect"
            ) from None
        if "listener" in detail or "Address already in use" in detail:
            raise BusError(
                f"cannot listen on {', '.join(endpoints.listen)}: {detail}; another process "
                "may hold the port: pick another --listen endpoint"
            ) from None
        raise BusError(f"cannot open a Zenoh session: {detail}") from None


class PartsWatcher:
    """Tells the robot, over its bus, when a component process goes and comes back.

    Run by the manager's process (it decides what the person hears). A process whose
    liveliness token is withdrawn is reported at once (ComponentFailed); one that is not back
    within `rejoin_seconds` is lost (ComponentLost: the robot says so and, if the game needs
    it, ends the game); one that comes back announces ComponentJoined, so that the manager asks
    it again what its predecessor never answered. `parts` maps a component's name to its
    (class name, part, essential), as the robot's messages name them. A token that goes counts
    even while another claims the same name (a launcher's child replaces a stale or fake one).
    """

    def __init__(
        self,
        bus: ZenohBus,
        parts: dict[str, tuple[str, str, bool]],
        rejoin_seconds: float = REJOIN_SECONDS,
    ) -> None:
        self.bus = bus
        self.parts = parts
        self.rejoin_seconds = rejoin_seconds
        self._up: dict[str, set[str]] = {}
        self._down: dict[str, float] = {}  # name -> when its last process went
        self._lost: set[str] = set()
        self._events: queue.Queue[tuple[Peer, bool]] = queue.Queue(MAX_WATCHED_CHANGES)
        self._dropped = 0  # changes dropped since the last re-reading of who is up
        self._dropped_lock = threading.Lock()
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name="oxbot-parts-watcher", daemon=True)

    def start(self) -> PartsWatcher:
        self._thread.start()
        # publishing from Zenoh's own callback thread could wait on itself: a queue between
        self.bus.watch(self._queue)
        return self

    def stop(self) -> None:
        self._stopping.set()
        self._thread.join(2.0)

    def _queue(self, peer: Peer, up: bool) -> None:
        """A liveliness change, from Zenoh's thread: queued, or dropped when the queue is full
        (see MAX_WATCHED_CHANGES)."""
        if peer.name not in self.parts:
            return  # none of the robot's parts: never looked at
        try:
            self._events.put_nowait((peer, up))
        except queue.Full:
            with self._dropped_lock:
                self._dropped += 1
                first = self._dropped == 1
            if first:
                log.warning(
                    "over %d liveliness changes unread (a peer flooding tokens?): dropping "
                    "new ones until they are read, then reading who is up",
                    MAX_WATCHED_CHANGES,
                )

    def _run(self) -> None:
        while not self._stopping.is_set():
            try:
                self._changed(*self._events.get(timeout=0.05))
            except queue.Empty:
                if self._dropped:
                    self._reread()
            now = time.monotonic()
            for name, since in list(self._down.items()):
                if now - since >= self.rejoin_seconds and name not in self._lost:
                    self._give_up(name)

    def _changed(self, peer: Peer, up: bool) -> None:
        if peer.name not in self.parts:
            return
        component, part, _ = self.parts[peer.name]
        zids = self._up.setdefault(peer.name, set())
        if up:
            zids.add(peer.zid)
            if self._down.pop(peer.name, None) is not None:
                self._lost.discard(peer.name)
                log.warning("%s is back (pid %d)", peer.name, peer.pid)
                self.bus.publish(ComponentJoined(component=component, part=part))
            return
        if peer.zid not in zids:
            return
        zids.discard(peer.zid)
        # one of its processes went: down until a new one comes, whatever other tokens claim
        # the name (any peer can declare one; a fake must not hide the death and stall the game)
        if peer.name not in self._down:
            self._down[peer.name] = time.monotonic()
            log.warning(
                "%s's process (pid %d) is gone; waiting for it to come back", peer.name, peer.pid
            )
            self.bus.publish(ComponentFailed(component=component, error="its process ended"))

    def _reread(self) -> None:
        """After dropped changes: who is up now, told as the changes that lead there."""
        with self._dropped_lock:
            dropped, self._dropped = self._dropped, 0
        log.warning("dropped %d liveliness changes; reading who is up", dropped)
        alive = [p for p in self.bus.alive() if p.name in self.parts]
        for name, zids in list(self._up.items()):
            for zid in zids - {p.zid for p in alive if p.name == name}:
                self._changed(Peer(name=name, format="", zid=zid, pid=0), False)
        for peer in alive:
            if peer.zid not in self._up.get(peer.name, set()):
                self._changed(peer, True)

    def _give_up(self, name: str) -> None:
        component, part, essential = self.parts[name]
        self._lost.add(name)
        error = f"its process ended and did not come back within {self.rejoin_seconds:.0f} s"
        log.error("%s: %s", name, error)
        self.bus.publish(
            ComponentLost(component=component, part=part, error=error, essential=essential)
        )
