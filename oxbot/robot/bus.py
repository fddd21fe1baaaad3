"""The message bus and the base class of the robot's components.

Components know only their messages (oxbot.robot.messages): they subscribe to message types
and publish others, through the two calls of the `Bus` protocol, so another transport (across
processes or machines) can stand in for `LocalBus`, the in-process one. In `LocalBus` each
subscription is its own FIFO queue (bounded: `MAX_QUEUED`, the oldest dropped when a reader
falls that far behind), so a burst of messages never reorders what one publisher sent, and a
slow component never holds up another; it is thread-safe, and each component runs in its own
named thread.

Components are supervised one for one, like an Erlang supervisor's children or ROS 2 launch's
respawned nodes: a component that raises is restarted after an exponentially growing wait; one
whose `handle` or `tick` hangs past its deadline is abandoned (its thread left to end on its own,
its door to the bus closed so it can never publish again) and a fresh copy takes over; one that
fails more often than `restart_limit` times within `restart_window` seconds stays off, and the
`Supervisor` announces it (ComponentLost) so the robot can say so. Failures are logged once with
a count, not with a traceback each time.
"""

from __future__ import annotations

import contextlib
import logging
import math
import queue
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

from oxbot.config import RobotConfig
from oxbot.errors import OxbotError
from oxbot.robot.messages import ComponentFailed, ComponentLost, Message

log = logging.getLogger(__name__)

MAX_QUEUED = 5_000
"""The most messages a subscription holds unread; beyond, its oldest is dropped. A component
keeps up with a game's dozens a second: only a stalled reader or a flood reaches this."""


class Subscription(Protocol):
    """The messages of some types, in the order they were published."""

    def get(self, timeout: float | None = None) -> Message | None:
        """The next message, or None after `timeout` seconds without one."""
        ...

    def drain(self) -> list[Message]:
        """Every message waiting now, oldest first."""
        ...

    def close(self) -> None:
        """Stop receiving."""
        ...


class Bus(Protocol):
    """What a component needs of a transport: subscribe to message types, publish messages."""

    def subscribe(self, *types: type[Message]) -> Subscription:
        """A new queue of the messages of `types` (all messages when none are given)."""
        ...

    def publish(self, message: Message) -> None:
        """Deliver `message` to every subscription that wants its type."""
        ...


class LocalSubscription:
    """A `Subscription` of `LocalBus`: a thread-safe FIFO queue."""

    def __init__(
        self, bus: Subscriptions, types: tuple[type[Message], ...], limit: int = 0
    ) -> None:
        self.types = types
        self._bus = bus
        self._queue: queue.Queue[Message] = queue.Queue(limit or MAX_QUEUED)
        self._put_lock = threading.Lock()
        self.dropped = 0
        """Messages dropped because the queue was full (its reader fell behind)."""

    def wants(self, message: Message) -> bool:
        return isinstance(message, self.types)

    def put(self, message: Message) -> None:
        """Queue `message`; when the queue is full, its oldest message is dropped (a reader
        that fell that far behind needs the news, not the backlog)."""
        with self._put_lock:
            while True:
                try:
                    self._queue.put_nowait(message)
                    return
                except queue.Full:
                    with contextlib.suppress(queue.Empty):
                        self._queue.get_nowait()
                    self.dropped += 1
                    if self.dropped == 1 or self.dropped % 1000 == 0:
                        log.warning(
                            "a subscription to %s fell %d messages behind: dropped %d, oldest "
                            "first",
                            ", ".join(t.__name__ for t in self.types),
                            self._queue.maxsize,
                            self.dropped,
                        )

    def get(self, timeout: float | None = None) -> Message | None:
        """The next message, or None after `timeout` seconds without one."""
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def drain(self) -> list[Message]:
        """Every message waiting now, oldest first."""
        items = []
        while True:
            try:
                items.append(self._queue.get_nowait())
            except queue.Empty:
                return items

    def close(self) -> None:
        self._bus.unsubscribe(self)


class Subscriptions:
    """The subscriptions of one process's bus, each a `LocalSubscription` queue, kept under
    one lock (`LocalBus`, and `ZenohBus`, which feeds them from the network)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._subscriptions: list[LocalSubscription] = []

    def subscribe(self, *types: type[Message]) -> LocalSubscription:
        """A new queue of the messages of `types` (all messages when none are given)."""
        subscription = LocalSubscription(self, types or (Message,))
        with self._lock:
            self._subscriptions.append(subscription)
        return subscription

    def unsubscribe(self, subscription: LocalSubscription) -> None:
        with self._lock:
            if subscription in self._subscriptions:
                self._subscriptions.remove(subscription)


class LocalBus(Subscriptions):
    """The in-process `Bus`: each published message goes to every subscription wanting it."""

    def publish(self, message: Message) -> None:
        if not isinstance(message, Message):
            raise TypeError(f"only oxbot.robot.messages types travel on the bus, not {message!r}")
        with self._lock:
            targets = [s for s in self._subscriptions if s.wants(message)]
        for subscription in targets:
            subscription.put(message)


class BusHandle:
    """A component's own door to the bus. Closed when the component is abandoned, so that a
    hung thread that wakes up later can never publish again: its replacement speaks now."""

    def __init__(self, bus: Bus) -> None:
        self.bus = bus
        self.closed = False

    def subscribe(self, *types: type[Message]) -> Subscription:
        return self.bus.subscribe(*types)

    def publish(self, message: Message) -> None:
        if not self.closed:
            self.bus.publish(message)

    def close(self) -> None:
        self.closed = True


@dataclass
class Call:
    """A `handle` or `tick` under way, stamped for the supervisor's watchdog."""

    started: float
    message: Message | None
    """The message being handled (None: a tick)."""
    expected: float = 0.0
    """Seconds the call said it needs (`Component.expect`), on top of `hang_seconds`."""

    def describe(self) -> str:
        return "tick" if self.message is None else f"handle({type(self.message).__name__})"


class Component:
    """One concurrent part of the robot: a thread that handles the messages it subscribes to.

    Subclasses set `listens_to` and implement `handle`; `tick` runs every `period` seconds when
    set. An exception in `handle` or `tick` is reported on the bus as ComponentFailed, `restart`
    resets the component, and after a backoff it goes on (messages wait meanwhile): with the
    same message again if it is one of `retries` (its sender waits for the outcome: a sentence
    to say, a symbol to draw) and the error is not an OxbotError (which says the message itself
    is wrong), else with the next one. A call that takes longer than it should is for the
    `Supervisor` to notice.

    `part` names the component for a person ("my voice"); `essential` says whether a game can
    go on without it.
    """

    listens_to: tuple[type[Message], ...] = ()
    retries: tuple[type[Message], ...] = ()
    period: float | None = None
    part: str = "a part"
    essential: bool = True

    def __new__(cls, *args: Any, **kwargs: Any) -> Component:
        self = super().__new__(cls)
        # kept so that the supervisor can build a fresh copy of a hung component
        self._made_with = (args, kwargs)
        return self

    def __init__(self, bus: Bus, name: str | None = None) -> None:
        self.bus = BusHandle(bus)
        self.name = name or type(self).__name__
        self.failures = 0
        self.supervision = RobotConfig()
        """The restart budget and hang deadline (`restart_*`, `hang_seconds`)."""
        self.lost: str | None = None
        """Why the component gave up (its restart budget spent), else None."""
        self.abandoned = False
        self._failure_times: deque[float] = deque()
        self._hang_times: deque[float] = deque()
        self._call: Call | None = None
        self._first: Message | None = None  # handled before the inbox, by a replacement
        self._backlog: list[Message] = []  # what its predecessor had not read yet
        self._inbox = bus.subscribe(*self.listens_to) if self.listens_to else None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # --- to override ---
    def handle(self, message: Message) -> None:
        """React to one message."""

    def tick(self) -> None:
        """Periodic work, every `period` seconds."""

    def restart(self) -> None:
        """Reset after a failure; by default nothing to reset."""

    def take_over(self, old: Component) -> None:
        """Carry on from `old`, abandoned while it hung: copy what the game needs of its state
        (by default nothing). `restart` follows, as after an exception."""

    # --- lifecycle ---
    def start(self, delay: float = 0.0) -> Component:
        """Run in a thread of its own (after `delay` seconds, for a restart's backoff)."""
        if self._thread is not None and self._thread.is_alive():
            return self
        self._stop.clear()
        self._thread = threading.Thread(
            target=self._run, args=(delay,), name=f"oxbot-{self.name}", daemon=True
        )
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop the thread; one that does not end within `timeout` is abandoned."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                log.warning(
                    "%s did not stop within %.1f s; its thread is abandoned", self.name, timeout
                )
                self.abandon()
        if self._inbox is not None:
            self._inbox.close()

    def abandon(self) -> None:
        """Give up on the thread (hung): tell it to stop, and close its door to the bus."""
        self.abandoned = True
        self._stop.set()
        self.bus.close()
        if self._inbox is not None:
            self._inbox.close()

    def expect(self, seconds: float) -> None:
        """The call under way will legitimately take `seconds` more (a sentence, a drawing):
        the watchdog waits that much longer before calling it hung."""
        call = self._call
        if call is not None:
            call.expected += seconds

    def waiting(self) -> list[Message]:
        """The messages received but not handled yet (taken out of the inbox)."""
        return self._inbox.drain() if self._inbox is not None else []

    def backlog(self, messages: list[Message]) -> None:
        """Handle `messages` (a predecessor's unread ones) before anything from the inbox."""
        self._backlog = list(messages)

    def hung(self, now: float) -> Call | None:
        """The call under way if it has run past its deadline, else None."""
        call = self._call
        if call is None or self.abandoned:
            return None
        overdue = now - call.started > self.supervision.hang_seconds + call.expected
        return call if overdue else None

    @property
    def running(self) -> bool:
        """True while its thread runs for the robot (an abandoned thread does not)."""
        return self._thread is not None and self._thread.is_alive() and not self.abandoned

    @property
    def thread(self) -> threading.Thread | None:
        return self._thread

    def __enter__(self) -> Component:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _run(self, delay: float) -> None:
        if delay and self._stop.wait(delay):
            return
        if self._first is not None:
            first, self._first = self._first, None
            self._guard(self.handle, first)
        # The predecessor's unread messages; the inbox may hold the same ones again, at its head.
        backlog, self._backlog = self._backlog, []
        for message in backlog:
            if self._stop.is_set():
                return
            self._guard(self.handle, message)
        repeated = {id(m) for m in backlog}
        next_tick = time.monotonic() + self.period if self.period is not None else math.inf
        while not self._stop.is_set():
            wait = min(max(0.0, next_tick - time.monotonic()), 0.05)
            message = self._inbox.get(timeout=wait) if self._inbox else None
            if self._stop.is_set():
                break
            if message is not None and repeated:
                if id(message) in repeated:
                    continue
                repeated.clear()
            if message is not None:
                self._guard(self.handle, message)
            elif self._inbox is None:
                self._stop.wait(wait)
            if time.monotonic() >= next_tick and not self._stop.is_set():
                self._guard(self.tick)
                # after a backoff, tick once, not once per period missed
                next_tick = max(next_tick + self.period, time.monotonic())  # type: ignore[operator]

    def _guard(self, function: Callable[..., None], message: Message | None = None) -> None:
        while not self._stop.is_set():
            self._call = Call(time.monotonic(), message)
            try:
                function() if message is None else function(message)
                return
            except OxbotError as exc:  # the message itself is wrong: again would not help
                self._call = None
                self._failed(exc)
                return
            except Exception as exc:
                self._call = None
                self._failed(exc)
            finally:
                self._call = None
            if not isinstance(message, self.retries):
                return

    def _failed(self, exc: Exception) -> None:
        if self.abandoned:
            return  # a hung call that ended after all: its replacement carries on
        self.failures += 1
        error = f"{type(exc).__name__}: {exc}"
        now = time.monotonic()
        delay = self.spend_restart(now)
        times = self._failure_times
        count = f"{self.name} failed {len(times)} times in {now - times[0]:.1f} s: {error}"
        self.bus.publish(ComponentFailed(component=self.name, error=error))
        if delay is None:
            log.error("%s; giving up (robot.restart_limit)", count)
            self.lost = error
            self._stop.set()
            return
        if len(times) == 1:  # the first in a while: the whole story, once
            log.error("%s failed: %s; restarting in %.1f s", self.name, error, delay, exc_info=exc)
        else:
            log.warning("%s; restarting in %.1f s", count, delay)
        try:
            self.restart()
        except Exception as again:
            log.error("%s could not restart: %s: %s", self.name, type(again).__name__, again)
        self._stop.wait(delay)

    def spend_restart(self, now: float, hung: bool = False) -> float | None:
        """Count a failure (a hang) at `now`: the wait before the restart, or None when more
        than `restart_limit` failures (`hang_limit` hangs) fell within `restart_window` s."""
        config = self.supervision
        for times in (self._failure_times, self._hang_times):
            while times and now - times[0] > config.restart_window:
                times.popleft()
        self._failure_times.append(now)
        if hung:
            self._hang_times.append(now)
        if len(self._failure_times) > config.restart_limit:
            return None
        if len(self._hang_times) > config.hang_limit:
            return None
        exponent = len(self._failure_times) - 1
        return min(config.restart_backoff * 2**exponent, config.restart_backoff_max)

    def replacement(self) -> Component:
        """A fresh copy, built as this one was, sharing its failure count."""
        args, kwargs = self._made_with
        fresh = type(self)(*args, **kwargs)
        fresh.supervision = self.supervision
        fresh.failures = self.failures
        fresh._failure_times, fresh._hang_times = self._failure_times, self._hang_times
        return fresh


class Supervisor:
    """Runs components one for one (Erlang's supervisor, ROS 2 launch's respawn).

    A component restarts itself after an exception (see `Component`); the supervisor's thread
    is the watchdog: every `WATCH_PERIOD` it looks at each component's call under way, and one
    that has run past its deadline is abandoned and replaced by a fresh copy that takes over
    (`Component.take_over`), after the same backoff and within the same restart budget. A
    component that spent its budget is announced once as ComponentLost (and to `on_lost`).
    `components` is always the list of the ones running now.
    """

    WATCH_PERIOD = 0.05

    def __init__(
        self,
        components: Iterable[Component],
        bus: Bus,
        config: RobotConfig | None = None,
        on_lost: Callable[[Component], None] | None = None,
    ) -> None:
        self.components = list(components)
        self.bus = bus
        self.config = config if config is not None else RobotConfig()
        self.on_lost = on_lost
        self.lost: list[Component] = []
        self.abandoned: list[Component] = []
        """Components whose hung thread was left behind (a daemon, told to stop)."""
        self._lock = threading.Lock()  # the watchdog and `revive` both replace components
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __iter__(self) -> Iterator[Component]:
        return iter(list(self.components))

    def start(self) -> Supervisor:
        for component in self.components:
            component.supervision = self.config
            component.start()
        self._stop.clear()
        self._thread = threading.Thread(target=self._watch, name="oxbot-supervisor", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop the watchdog, then every component, all within about `timeout` seconds: the
        ones still busy then are abandoned (daemon threads told to stop)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
        stop_all(self.components, timeout)
        self.abandoned.extend(c for c in self.components if c.abandoned and c not in self.abandoned)

    def revive(self) -> list[str]:
        """Start afresh, with a full restart budget, every component that was lost (for a new
        game); their names."""
        revived = []
        with self._lock:
            for old in list(self.lost):
                if old not in self.components:
                    continue
                fresh = old.replacement()
                fresh._failure_times, fresh._hang_times = deque(), deque()
                old.abandon()  # its inbox holds the old game's messages
                self.components[self.components.index(old)] = fresh.start()
                self.lost.remove(old)
                revived.append(old.name)
        return revived

    def _watch(self) -> None:
        while not self._stop.wait(self.WATCH_PERIOD):
            now = time.monotonic()
            with self._lock:
                for i, component in enumerate(list(self.components)):
                    if component.lost is not None and component not in self.lost:
                        self._give_up(component)
                    elif (call := component.hung(now)) is not None:
                        self._replace(i, component, call, now)

    def _replace(self, i: int, old: Component, call: Call, now: float) -> None:
        error = f"hung for {now - call.started:.1f} s in {call.describe()}"
        delay = old.spend_restart(now, hung=True)
        self.bus.publish(ComponentFailed(component=old.name, error=error))
        fresh = None
        if delay is not None:
            try:  # before the old inbox closes, so that no message falls between the two
                fresh = old.replacement()
                fresh.take_over(old)
                fresh.restart()
                if isinstance(call.message, fresh.retries):
                    fresh._first = call.message
            except Exception as exc:
                error = f"{error}; rebuilding it raised {type(exc).__name__}: {exc}"
        old.abandon()
        self.abandoned.append(old)
        if fresh is None:
            log.error("%s %s; giving up (robot.restart_limit)", old.name, error)
            old.lost = error
            self._give_up(old)
            return
        log.warning(
            "%s %s; its thread is abandoned and a fresh one starts in %.1f s",
            old.name,
            error,
            delay,
        )
        fresh.backlog(old.waiting())
        self.components[i] = fresh.start(delay)  # type: ignore[arg-type]

    def _give_up(self, component: Component) -> None:
        self.lost.append(component)
        self.bus.publish(
            ComponentLost(
                component=component.name,
                part=component.part,
                error=component.lost or "",
                essential=component.essential,
            )
        )
        if self.on_lost is not None:
            try:
                self.on_lost(component)
            except Exception as exc:
                log.error("announcing that %s stopped failed: %s", component.name, exc)


def start_all(
    components: Iterable[Component], bus: Bus | None = None, config: RobotConfig | None = None
) -> Supervisor:
    """Start every component under one supervisor (reporting on `bus`, by default the first
    component's); it, for `stop_all`."""
    components = list(components)
    if bus is None:
        bus = components[0].bus.bus if components else LocalBus()
    return Supervisor(components, bus, config).start()


def stop_all(components: Iterable[Component] | Supervisor, timeout: float = 2.0) -> None:
    """Stop every component within about `timeout` seconds in all: each is told to stop at
    once, then joined with what is left of the time."""
    if isinstance(components, Supervisor):
        components.stop(timeout)
        return
    components = list(components)
    for component in components:
        component._stop.set()
    deadline = time.monotonic() + timeout
    for component in components:
        component.stop(max(0.0, deadline - time.monotonic()))
