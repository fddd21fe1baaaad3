"""Timing a function over many inputs on a shared machine: the median time per call over
several passes, wall clock and CPU, as `bench_board.py` and `bench_perception.py` print it; and
the one core the board benches time on."""

from __future__ import annotations

import contextlib
import statistics
import time
from collections.abc import Callable, Sequence
from typing import Any

import cv2
import torch


def one_core() -> None:
    """Limit torch and OpenCV to one thread each, so that a time is one core's."""
    torch.set_num_threads(1)
    cv2.setNumThreads(1)


def per_call_ms(
    function: Callable[[Any], object],
    inputs: Sequence[Any],
    passes: int,
    ignore: tuple[type[BaseException], ...] = (),
) -> tuple[float, float]:
    """Median over `passes` passes of the time per call of `function(x)` for each x of `inputs`,
    in ms: wall time, and the process's CPU time (which other jobs on a shared machine inflate
    less). A call that raises one of `ignore` (a frame without a grid) counts as a call."""
    wall, cpu = [], []
    for _ in range(passes):
        started, started_cpu = time.perf_counter(), time.process_time()
        for x in inputs:
            with contextlib.suppress(*ignore):
                function(x)
        wall.append((time.perf_counter() - started) / len(inputs) * 1000)
        cpu.append((time.process_time() - started_cpu) / len(inputs) * 1000)
    return statistics.median(wall), statistics.median(cpu)
