"""Learning from real interactions: what the robot saw and heard, kept when the
person agrees (`oxbot play --record`), and the data it learns from (`oxbot learn`).

    from oxbot.recording import RecordingStore
    from oxbot.recording.recorder import joining
    store = RecordingStore("~/oxbot-data")                # recordings.sqlite3 inside
    robot = Robot(config, joining=[joining(store)])       # a Recorder joins the robot's bus
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["Recorder", "RecordingStore", "default_data_dir", "notice"]

_WHERE = {
    "Recorder": "oxbot.recording.recorder",
    "notice": "oxbot.recording.recorder",
    "RecordingStore": "oxbot.recording.store",
    "default_data_dir": "oxbot.recording.store",
}


def __getattr__(name: str) -> Any:
    # loaded on first use: `oxbot --help` should not wait for the robot's modules
    if name not in _WHERE:
        raise AttributeError(f"module 'oxbot.recording' has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
