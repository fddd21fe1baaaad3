"""The server's memory: the malloc arenas its threads share, and what closed sessions freed
handed back to the system (glibc; elsewhere both do nothing)."""

from __future__ import annotations

import contextlib
import ctypes
import gc

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
