"""Ctrl-C during training: finish the step in hand, save a checkpoint, then stop.

A training loop runs inside `deferred_interrupt()` and checks `stop.requested` where its state is
whole (between two steps); there it saves and raises `TrainingInterrupted`. Stopping at an
arbitrary bytecode instead could save a replay memory one experience ahead of its step count.
Long work that changes nothing until it ends (an evaluation) runs in `stop.immediately()`, where
Ctrl-C stops it at once, to be redone on resuming. A second Ctrl-C interrupts at once, without
saving, as it would without this.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from types import FrameType

log = logging.getLogger(__name__)


@dataclass
class StopRequest:
    """Set when Ctrl-C asked the loop to stop at its next step boundary."""

    requested: bool = False
    at_once: bool = False
    """Inside `immediately()`: Ctrl-C raises KeyboardInterrupt without waiting."""

    @contextlib.contextmanager
    def immediately(self) -> Iterator[None]:
        """Let Ctrl-C raise KeyboardInterrupt at once inside the block: for work with no
        effect until it ends (an evaluation, a fit), which is simply redone on resuming."""
        self.at_once = True
        try:
            if self.requested:
                raise KeyboardInterrupt
            yield
        finally:
            self.at_once = False


@contextlib.contextmanager
def deferred_interrupt() -> Iterator[StopRequest]:
    """While the block runs, the first SIGINT only sets `requested` on the yielded object.

    Outside the main thread, or when SIGINT is ignored, nothing is changed: signals can only
    be handled in the main thread, and an ignored Ctrl-C should stay ignored.
    """
    stop = StopRequest()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.SIG_IGN:
        yield stop
        return

    def on_sigint(signum: int, frame: FrameType | None) -> None:
        if stop.requested:
            raise KeyboardInterrupt
        stop.requested = True
        if stop.at_once:
            raise KeyboardInterrupt
        log.info("Ctrl-C: saving a checkpoint after this step (Ctrl-C again: quit, no save)")

    signal.signal(signal.SIGINT, on_sigint)
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, previous)
