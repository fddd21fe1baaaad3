"""Who is up: a component process's liveliness token (`Peer`), and the watch the manager's
process keeps over them (`PartsWatcher`).

Each component process of a robot declares a token `oxbot/<robot>/alive/<name>/<format>/<zenoh
id>/<pid>` (`ZenohBus.join`, oxbot.robot.zenoh_bus), which Zenoh withdraws as soon as the
process is gone (its links close; a silent machine is dropped after the 1 s lease). Any peer
can declare, withdraw or copy a token, though: the watcher of a launched robot judges the
parts its launcher runs by the process table instead (oxbot.robot.children.Siblings).
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from oxbot.config import RobotConfig
from oxbot.robot.children import Siblings
from oxbot.robot.messages import ComponentFailed, ComponentJoined, ComponentLost, Message

log = logging.getLogger(__name__)

REJOIN_SECONDS = RobotConfig.rejoin_seconds
"""How long a component whose process ended may take to come back before the robot takes it as
lost: `robot.rejoin_seconds`'s default (the launcher passes the config's)."""
MAX_WATCHED_CHANGES = 1_000
"""The most liveliness changes `PartsWatcher` holds unread (a robot's seven parts make a few a
respawn; only a peer flooding tokens makes more). Beyond it a new change is dropped, with a log
line per burst, and once the queue has drained the watcher re-reads who is up (`alive`), so
that no death or comeback is missed for good."""


@dataclass(frozen=True)
class Peer:
    """A component process that is up, from its liveliness token."""

    name: str
    format: str
    zid: str
    pid: int


class Watched(Protocol):
    """What `PartsWatcher` needs of its bus (a `ZenohBus`)."""

    def watch(self, callback: Callable[[Peer, bool], None]) -> None: ...

    def alive(self) -> list[Peer]: ...

    def publish(self, message: Message) -> None: ...


class PartsWatcher:
    """Tells the robot, over its bus, when a component process goes and comes back.

    Run by the manager's process (it decides what the person hears). A process whose
    liveliness token is withdrawn is reported at once (ComponentFailed); one that is not back
    within `rejoin_seconds` is lost (ComponentLost: the robot says so and, if the game needs
    it, ends the game); one that comes back announces ComponentJoined, so that the manager asks
    it again what its predecessor never answered. `parts` maps a component's name to its
    (class name, part, essential), as the robot's messages name them. A token that goes counts
    even while another claims the same name (a launcher's child replaces a stale or fake one).

    In a launched robot, `siblings` (oxbot.robot.children) names the parts its launcher runs on
    this machine: for those, what counts is the process table, not the tokens, which any peer
    can declare, withdraw or copy (a token's key is public, and a copy of it keeps it up
    after its process is gone). A token is taken for such a part only when it names the pid of
    the launcher's process of that part, which is gone when that process has ended, whatever
    tokens come and go; others are logged and ignored.
    """

    def __init__(
        self,
        bus: Watched,
        parts: dict[str, tuple[str, str, bool]],
        rejoin_seconds: float = REJOIN_SECONDS,
        siblings: Siblings | None = None,
    ) -> None:
        self.bus = bus
        self.parts = parts
        self.rejoin_seconds = rejoin_seconds
        self.siblings = siblings
        self._up: dict[str, dict[str, Peer]] = {}  # name -> its processes that are up, by id
        self._down: dict[str, float] = {}  # name -> when its last process went
        self._lost: set[str] = set()
        self._ignored: set[str] = set()  # names whose fake tokens were logged
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
            if self.siblings is not None:
                self._check_processes()
            now = time.monotonic()
            for name, since in list(self._down.items()):
                if now - since >= self.rejoin_seconds and name not in self._lost:
                    self._give_up(name)

    def _launched(self, name: str) -> bool:
        """Whether part `name` is judged by the process table (see the class docstring)."""
        return self.siblings is not None and name in self.siblings.names

    def _identity(self, peer: Peer) -> str:
        """What tells a part's processes apart: the pid the launcher's table vouches for, else
        the token's Zenoh id."""
        return str(peer.pid) if self._launched(peer.name) else peer.zid

    def _runs(self, peer: Peer) -> bool:
        assert self.siblings is not None
        return self.siblings.running(peer.name, peer.pid)

    def _changed(self, peer: Peer, up: bool) -> None:
        if peer.name not in self.parts:
            return
        component, part, _ = self.parts[peer.name]
        processes = self._up.setdefault(peer.name, {})
        launched = self._launched(peer.name)
        if up:
            if launched and not self._runs(peer):
                self._ignore(peer)
                return
            processes[self._identity(peer)] = peer
            if self._down.pop(peer.name, None) is not None:
                self._lost.discard(peer.name)
                log.warning("%s is back (pid %d)", peer.name, peer.pid)
                self.bus.publish(ComponentJoined(component=component, part=part))
            return
        if self._identity(peer) not in processes:
            return
        if launched and self._runs(peer):
            return  # its process runs: a copy of its token went (`_check_processes` watches)
        del processes[self._identity(peer)]
        # one of its processes went: down until a new one comes, whatever other tokens claim
        # the name (any peer can declare one; a fake must not hide the death and stall the game)
        if peer.name not in self._down:
            self._down[peer.name] = time.monotonic()
            log.warning(
                "%s's process (pid %d) is gone; waiting for it to come back", peer.name, peer.pid
            )
            self.bus.publish(ComponentFailed(component=component, error="its process ended"))

    def _check_processes(self) -> None:
        """A launched part whose process has ended is gone, even if a token still claims it."""
        for name, processes in list(self._up.items()):
            if self._launched(name):
                for peer in list(processes.values()):
                    if not self._runs(peer):
                        self._changed(peer, False)

    def _ignore(self, peer: Peer) -> None:
        if peer.name not in self._ignored:
            self._ignored.add(peer.name)
            log.warning(
                "ignoring a token that claims to be %s (zenoh id %s, pid %d): no process this "
                "launcher started; further ones under that name are ignored unlogged",
                peer.name,
                peer.zid,
                peer.pid,
            )

    def _reread(self) -> None:
        """After dropped changes: who is up now, told as the changes that lead there."""
        with self._dropped_lock:
            dropped, self._dropped = self._dropped, 0
        log.warning("dropped %d liveliness changes; reading who is up", dropped)
        alive = [p for p in self.bus.alive() if p.name in self.parts]
        for name, processes in list(self._up.items()):
            now_up = {self._identity(p) for p in alive if p.name == name}
            for identity, peer in list(processes.items()):
                if identity not in now_up:
                    self._changed(peer, False)
        for peer in alive:
            if self._identity(peer) not in self._up.get(peer.name, {}):
                self._changed(peer, True)

    def _give_up(self, name: str) -> None:
        component, part, essential = self.parts[name]
        self._lost.add(name)
        error = f"its process ended and did not come back within {self.rejoin_seconds:.0f} s"
        log.error("%s: %s", name, error)
        self.bus.publish(
            ComponentLost(component=component, part=part, error=error, essential=essential)
        )
