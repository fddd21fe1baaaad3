"""Every error a user of oxbot can see.

Each message says what was wrong and what to do about it. Catch `OxbotError` to handle them
all; the command line prints the message alone, without a traceback.
"""

from __future__ import annotations

from pathlib import Path


class OxbotError(Exception):
    """Base class of all errors oxbot raises on purpose."""


class ConfigError(OxbotError, ValueError):
    """A configuration file or option is malformed or out of range."""


class IllegalMoveError(OxbotError, ValueError):
    """A move names a cell that does not exist or is already taken."""


class OpponentError(OxbotError, ValueError):
    """An opponent callable returned something that is not an empty cell's index."""


class DataError(OxbotError, ValueError):
    """Shipped or user data (images, dialogues, templates) is missing or malformed."""


class DatabaseBusy(DataError):
    """The recordings database stayed locked by another connection for longer than allowed."""


class InvalidInputError(OxbotError, ValueError):
    """An array, image or audio clip handed to oxbot has the wrong shape, type or content."""


class ModelFileError(OxbotError, ValueError):
    """A saved model or policy file is missing, truncated or from another architecture."""


class NoGridFound(OxbotError):
    """No hand-drawn 3x3 grid is visible in the frame."""


class FrameSourceError(OxbotError):
    """A camera, video file or image folder cannot be opened or read."""


class SpeechUnavailable(OxbotError):
    """Speech synthesis or recognition cannot run here (espeak-ng or pocketsphinx missing)."""


class TrainingInterrupted(OxbotError):
    """Training stopped on Ctrl-C after saving a checkpoint it can resume from.

    `checkpoint` is the file written, `step` how far training got. The command line prints the
    message with the command that resumes and exits with 130, as for any Ctrl-C.
    """

    def __init__(self, message: str, checkpoint: Path, step: int) -> None:
        super().__init__(message)
        self.checkpoint = checkpoint
        self.step = step


class BusError(OxbotError):
    """A robot's components cannot work together across processes (the Zenoh transport)."""


class BusUnreachable(BusError):
    """No Zenoh peer or router answers at the endpoints given (`--connect`)."""


class BusVersionError(BusError):
    """Another process of the robot speaks another version of the message format."""


class ComponentAlreadyRunning(BusError):
    """The component is already up in another process of the same robot."""


class LearningRefused(OxbotError):
    """`oxbot learn` trained a model that is worse than the one it would replace, and kept the
    old one. `result` holds the refused model and its figures."""

    def __init__(self, message: str, result: object = None) -> None:
        super().__init__(message)
        self.result = result
