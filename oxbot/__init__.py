"""oxbot: a talking robot that learns to play noughts and crosses on paper.

Two learners — a CNN+SVM that perceives hand-drawn symbols (`oxbot.perception`) and a DQN
interaction manager that chooses what to say and where to draw (`oxbot.dialogue`) — joined by
a runtime of concurrent components (`oxbot.robot`). docs/ARCHITECTURE.md has the map.

    import oxbot
    oxbot.read_board(frame)                     # a photo of the sheet -> 9 labels
    env = oxbot.InteractiveGameEnv()            # the Gymnasium environment
    policy = oxbot.load_policy()                # the shipped interaction manager
    with oxbot.Robot(oxbot.load_config()) as robot: ...   # the whole robot

The names load their modules on first use, so `import oxbot` stays light (no torch).
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_API = {
    "read_board": "oxbot.perception.board",
    "load_classifier": "oxbot.perception.classifier",
    "InteractiveGameEnv": "oxbot.dialogue.env",
    "load_policy": "oxbot.dialogue.agent",
    "recognize": "oxbot.speech.recognition",
    "Robot": "oxbot.robot.session",
    "load_config": "oxbot.config",
    "OxbotConfig": "oxbot.config",
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'oxbot' has no attribute {name!r}")
