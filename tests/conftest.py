"""Settings for the whole suite."""

from __future__ import annotations

import os


def pytest_xdist_auto_num_workers(config) -> int:
    """`-n auto` (pyproject's addopts): one worker more than there are cores. Many tests wait
    on real time — a robot's sentence, a browser's video, a process's restart — and the extra
    worker keeps the cores busy meanwhile; a module's tests stay on one worker."""
    return (os.cpu_count() or 1) + 1
