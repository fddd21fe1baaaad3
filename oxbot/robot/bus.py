"""The message bus and the base class of the robot's components.

Components know only their messages (oxbot.robot.messages): they subscribe to message types
and publish others, through the two calls of the `Bus` protocol, so another transport (across
processes or machines) can stand in for `LocalBus`, the in-process one. In `LocalBus` each
subscription is its own FIFO queue, so a burst of messages never reorders what one publisher
sent, and a slow component never holds up another; it is thread-safe, and each component runs
in its own named thread.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
import traceback
from collections.abc import Iterable
from typing import Protocol

from oxbot.robot.messages import ComponentFailed, Message

log = logging.getLogger(__name__)


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

    def __init__(self, bus: LocalBus, types: tuple[type[Message], ...]) -> None:
        self.types = types
        self._bus = bus
        self._queue: queue.SimpleQueue[Message] = queue.SimpleQueue()

    def wants(self, message: Message) -> bool:
        return isinstance(message, self.types)

    def put(self, message: Message) -> None:
        self._queue.put(message)

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


class LocalBus:
    """The in-process `Bus`: each published message goes to every subscription wanting it."""

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

    def publish(self, message: Message) -> None:
        if not isinstance(message, Message):
            raise TypeError(f"only oxbot.robot.messages types travel on the bus, not {message!r}")
        with self._lock:
            targets = [s for s in self._subscriptions if s.wants(message)]
        for subscription in targets:
            subscription.put(message)


class Component:
    """One concurrent part of the robot: a thread that handles the messages it subscribes to.

    Subclasses set `listens_to` and implement `handle`; `tick` runs every `period` seconds when
    set. An exception in `handle` or `tick` is reported on the bus as ComponentFailed, `restart`
    resets the component, and it goes on with the next message: the game does not end.
    """

    listens_to: tuple[type[Message], ...] = ()
    period: float | None = None

    def __init__(self, bus: Bus, name: str | None = None) -> None:
        self.bus = bus
        self.name = name or type(self).__name__
        self.failures = 0
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

    # --- lifecycle ---
    def start(self) -> Component:
        if self._thread is not None and self._thread.is_alive():
            return self
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"oxbot-{self.name}", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)
            if self._thread.is_alive():
                log.warning("%s did not stop within %.1f s", self.name, timeout)
        if self._inbox is not None:
            self._inbox.close()

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def __enter__(self) -> Component:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _run(self) -> None:
        next_tick = time.monotonic() + self.period if self.period is not None else math.inf
        while not self._stop.is_set():
            wait = min(max(0.0, next_tick - time.monotonic()), 0.05)
            message = self._inbox.get(timeout=wait) if self._inbox else None
            if self._stop.is_set():
                break
            if message is not None:
                self._guard(self.handle, message)
            elif self._inbox is None:
                self._stop.wait(wait)
            if time.monotonic() >= next_tick:
                self._guard(self.tick)
                next_tick += self.period  # type: ignore[operator]

    def _guard(self, function, *args) -> None:
        try:
            function(*args)
        except Exception as exc:
            self.failures += 1
            log.error("%s failed: %s\n%s", self.name, exc, traceback.format_exc())
            self.bus.publish(
                ComponentFailed(component=self.name, error=f"{type(exc).__name__}: {exc}")
            )
            try:
                self.restart()
            except Exception:
                log.exception("%s could not restart", self.name)


def start_all(components: Iterable[Component]) -> list[Component]:
    """Start every component; the list, for `stop_all`."""
    return [c.start() for c in components]


def stop_all(components: Iterable[Component], timeout: float = 2.0) -> None:
    for component in components:
        component.stop(timeout)
