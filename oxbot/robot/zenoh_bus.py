"""The bus across processes and machines, on Eclipse Zenoh.

`ZenohBus` is a `Bus` (oxbot.robot.bus): the same two calls, the same typed messages, so any
component runs on it unchanged. A message of topic `game/new` on robot `kitchen` travels on the
key expression `oxbot/kitchen/game/new` as its JSON (`messages.to_json`, encoding
application/json; a message carrying bytes, such as a camera frame, as a line of JSON followed
by the raw bytes: oxbot.robot.wire_format), with the message format's version in the
attachment. Every
process of a robot opens one session; peers find each other by multicast scouting on a LAN, or
by `connect` / `listen` endpoints (`tcp/192.168.1.10:7447`), through a router for larger
deployments.

Besides messages, each component process of a robot declares:
- a liveliness token `oxbot/<robot>/alive/<name>/<format>/<zenoh id>/<pid>`, which Zenoh
  withdraws as soon as the process is gone (its links close; a silent machine is dropped after
  the 1 s lease), so every process knows who is up (`alive`; the manager's `PartsWatcher`,
  oxbot.robot.liveliness);
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
import json
import logging
import os
import re
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
from oxbot.robot.liveliness import MAX_WATCHED_CHANGES, REJOIN_SECONDS, PartsWatcher, Peer
from oxbot.robot.message_checks import FloodGuard
from oxbot.robot.messages import (
    ArmStroke,
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
from oxbot.robot.resync import with_the_visit
from oxbot.robot.wire_format import (
    BLOBS,
    FORMAT,
    FORMAT_VERSION,
    TOPICS,
    decode,
    encode,
    encode_pieces,
    message_format,
)

__all__ = [  # with the names of the modules split from this one, importable from here as before
    "BLOBS",
    "CONNECT_TIMEOUT",
    "FORMAT",
    "FORMAT_VERSION",
    "LOSSY",
    "MAX_RECORD_BYTES",
    "MAX_WATCHED_CHANGES",
    "NAME",
    "QUERY_TIMEOUT",
    "RECORDED",
    "REJOIN_SECONDS",
    "SHARED_MEMORY_FROM",
    "SHARED_MEMORY_POOL",
    "TOPICS",
    "Endpoints",
    "PartsWatcher",
    "Peer",
    "ZenohBus",
    "decode",
    "encode",
    "encode_pieces",
    "message_format",
    "open_session",
]

log = logging.getLogger(__name__)

RECORDED = (NewGame, GameState, DialogueAct, DialogueEnded, ArmStroke)
"""The messages that make the current game for a late joiner (the arm's strokes: so that a
page opened mid-game draws the robot's symbols)."""
LOSSY = (Frame, PersonFrame)
"""Camera frames come 10 times a second: under congestion an old one is dropped, not queued."""
CONNECT_TIMEOUT = 3.0
"""Seconds to reach the `connect` endpoints before BusUnreachable."""
QUERY_TIMEOUT = 1.0
"""Seconds to wait for the answers of a liveliness or state query."""
MAX_RECORD_BYTES = 16 * 1024 * 1024
"""The most a game record (the answer to a state query) may take; a whole game's is ~100 KB."""
NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")
SHARED_MEMORY_FROM = 64 * 1024
"""Payloads from this size (camera frames) are put in shared memory: a process on the same
machine maps them instead of receiving 14 TCP fragments (a 900 KB frame: 2.8 ms median, 7.8
ms p99 by TCP on loopback; 0.5 / 4.4 ms shared). Zenoh copies them for other machines."""
SHARED_MEMORY_POOL = 32 * 1024 * 1024
"""Bytes of shared memory a publishing process sets aside: about 3 s of 640x480 frames."""


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


class ZenohBus(Subscriptions):
    """The `Bus` of one robot (`robot`, a name) over Zenoh: see the module docstring.

    Each subscription is a FIFO queue, as on `LocalBus`; one Zenoh subscriber per process
    feeds them all in the order a publisher published. `close` when done.
    """

    FORMAT = FORMAT

    def __init__(
        self,
        robot: str,
        endpoints: Endpoints | None = None,
        vouched: Callable[[Peer], bool] | None = None,
    ) -> None:
        """`vouched`, for a launcher's child, tells the robot's own processes from claims on the
        network: a token of another message format that it does not vouch for is logged and
        ignored, so a peer cannot stop a respawn by declaring one (`check_formats`)."""
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
        self._vouched = vouched
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
                self._record = [with_the_visit(message, self._record)]
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
        """BusVersionError if a process of this robot speaks another message format (of a
        launcher's child: one of its siblings; another claim is logged and ignored)."""
        for peer in self.alive() if peers is None else peers:
            if peer.format != self.FORMAT:
                if self._vouched is not None and not self._vouched(peer):
                    log.warning(
                        "a token claims %s speaks message format %s (pid %d), but no process "
                        "of this launcher does: ignored",
                        peer.name,
                        peer.format,
                        peer.pid,
                    )
                    continue
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
