"""N-best lists: what every recogniser gives the robot, and what a recogniser must do.

Beside the recognisers and below them, so that the recognisers, the keyword model and the
robot share one hypothesis type without importing each other.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from typing import Protocol


@dataclass(frozen=True)
class Hypothesis:
    """One entry of an N-best list."""

    text: str
    confidence: float
    words: tuple[tuple[str, float], ...] = ()
    """Each word with its confidence in [0, 1]; filled for the best hypothesis."""


def normalise(text: str) -> str:
    """Lower case, letters, digits and apostrophes only: the form the recogniser speaks in."""
    return " ".join(re.sub(r"[^a-z0-9' ]+", " ", text.lower()).split())


class Recognizer(Protocol):
    """What the robot needs of a speech recogniser: a recording in, an N-best list out.

    Another recogniser plugs in by having this method, passed to the robot as an object or
    named in the config as `speech.recognizer = "module:factory"`, where `factory(phrases,
    nbest)` builds it (`load_recognizer`)."""

    def recognize(self, wav: str | os.PathLike[str] | bytes) -> list[Hypothesis]:
        """N-best hypotheses for a WAV (path or bytes), best first; empty if nothing was heard."""
        ...
