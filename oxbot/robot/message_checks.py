"""Checking a message that came from another process before any component sees it.

Any Zenoh peer can publish on a robot's keys, so what arrives is checked: the JSON's size and
nesting before it is parsed (`check_json`), then every field against its type hint (str, int,
float, bool, bytes, Literal, tuples, None) and its limits (`MAX_TEXT`, `MAX_ITEMS`,
`MAX_BYTES`, finite numbers), then what the game gives meaning to: cell names, the board's 9
cells of 0/1/2, a reading's 9 cells, confidences in [0, 1], stroke points near their cell, the
mouth's visemes.
A message that fails is an InvalidInputError; the bus drops it with one log line.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
import re
import types
import typing
from typing import Any

from oxbot.errors import InvalidInputError
from oxbot.game.board import CELL_NAMES
from oxbot.speech.visemes import VISEMES

log = logging.getLogger(__name__)

MAX_JSON_BYTES = 1_000_000
"""The most a message's JSON (without its blobs) may take; the largest, a reading's, is ~5 KB."""
MAX_DEPTH = 16
"""The deepest nesting of lists and objects a message's JSON may have (oxbot's have 4)."""
MAX_TEXT = 10_000
"""The longest text field: a sentence to say, a transcript's words, an error."""
MAX_ITEMS = 10_000
"""The most items a tuple field may have (a stroke's points, an N-best list)."""
MAX_BYTES = 64 * 1024 * 1024
"""The most a bytes field may take (a raw 4K camera frame is 25 MB)."""
MAX_SIDE = 10_000
"""The widest or tallest a raw frame may be."""

_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"')
_BRACKET = re.compile(rb"[\[\]{}]")


def check_json(raw: bytes | str, what: str = "a message") -> None:
    """InvalidInputError if `raw` is larger than MAX_JSON_BYTES or nests deeper than MAX_DEPTH
    (checked before parsing: a deep document would exhaust the parser's recursion)."""
    data = raw.encode() if isinstance(raw, str) else raw
    if len(data) > MAX_JSON_BYTES:
        raise InvalidInputError(f"{what} of {len(data):,} bytes (the limit is {MAX_JSON_BYTES:,})")
    depth = deepest = 0
    for bracket in _BRACKET.finditer(_STRING.sub(b'""', data)):
        depth += 1 if bracket.group() in (b"[", b"{") else -1
        deepest = max(deepest, depth)
        if deepest > MAX_DEPTH:
            raise InvalidInputError(f"{what} nested deeper than {MAX_DEPTH} levels")


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def check_message(message: Any) -> Any:
    """`message` itself if every field has its type and is within its limits and the game's
    rules; else InvalidInputError naming the field."""
    name = type(message).__name__
    hints = _hints(type(message))
    for f in dataclasses.fields(message):
        value = getattr(message, f.name)
        problem = _problem(value, hints[f.name])
        if problem is None:
            problem = _rule(f.name, value)
        if problem is not None:
            raise InvalidInputError(f"field {f.name!r} of a {name} message: {problem}")
    problem = _whole(message)
    if problem is not None:
        raise InvalidInputError(f"a {name} message: {problem}")
    return message


def _problem(value: Any, hint: Any) -> str | None:
    """Why `value` does not fit type `hint`, or None."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Literal:
        return (
            None
            if value in args and type(value) is type(args[0])
            else f"{value!r:.40} is not one of {args}"
        )
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        problems = [_problem(value, a) for a in args if a is not type(None)]
        return None if None in problems else problems[0]
    if origin is tuple:
        if not isinstance(value, tuple):
            return f"{type(value).__name__} is not a list"
        if len(args) == 2 and args[1] is Ellipsis:
            if len(value) > MAX_ITEMS:
                return f"{len(value):,} items (the limit is {MAX_ITEMS:,})"
            return next((p for p in (_problem(v, args[0]) for v in value) if p), None)
        if len(value) != len(args):
            return f"{len(value)} items, not {len(args)}"
        return next((p for p in map(_problem, value, args) if p), None)
    if hint is bool:
        return None if isinstance(value, bool) else f"{type(value).__name__} is not true or false"
    if hint is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
        return None if ok else f"{type(value).__name__} is not an integer"
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return f"{type(value).__name__} is not a number"
        return None if math.isfinite(value) else f"{value} is not a finite number"
    if hint is str:
        if not isinstance(value, str):
            return f"{type(value).__name__} is not text"
        return (
            None
            if len(value) <= MAX_TEXT
            else f"{len(value):,} characters (the limit is {MAX_TEXT:,})"
        )
    if hint is bytes:
        if not isinstance(value, bytes):
            return f"{type(value).__name__} is not bytes"
        return (
            None
            if len(value) <= MAX_BYTES
            else f"{len(value):,} bytes (the limit is {MAX_BYTES:,})"
        )
    return None


def _rule(field: str, value: Any) -> str | None:
    """Why a field breaks the game's rules (by its name, wherever it appears), or None."""
    if field == "where" and value not in CELL_NAMES:
        return f"{value!r:.40} is not a cell ({', '.join(CELL_NAMES)})"
    if field == "cells" and value and isinstance(value[0], str):
        bad = [c for c in value if c not in CELL_NAMES]
        return f"{bad[0]!r:.40} is not a cell" if bad else None
    if field == "board":
        ok = len(value) == len(CELL_NAMES) and all(v in (0, 1, 2) for v in value)
        return None if ok else "not 9 cells of 0 (empty), 1 (the robot's) or 2 (the person's)"
    if field in ("confidences", "keywords") and not all(0.0 <= c <= 1.0 for c in value):
        return "a value outside [0, 1]"
    if field in ("nbest", "words") and not all(0.0 <= c <= 1.0 for _, c in value):
        return "a confidence outside [0, 1]"
    if field == "points" and not all(-1.0 <= c <= 2.0 for p in value for c in p):
        return "a point far outside its cell"
    if field == "visemes" and not all(0 <= t <= 3600 and v in VISEMES for t, v in value):
        return f"not (seconds, one of {', '.join(VISEMES)}) pairs"
    if field in ("agreeing", "seconds") and not 0 <= value <= 3600:
        return f"{value} is out of range"
    if field == "shape" and (
        len(value) not in (0, 2, 3) or not all(0 < s <= MAX_SIDE for s in value)
    ):
        return f"{value!r:.40} is not an image's shape"
    return None


def _whole(message: Any) -> str | None:
    """Why the fields do not fit together, or None."""
    nine = len(CELL_NAMES)
    if type(message).__name__ == "BoardSeen":
        for name in ("labels", "cells", "readings", "confidences"):
            if len(getattr(message, name)) not in (0, nine):
                return f"{name} has {len(getattr(message, name))} items, not 0 or 9"
        if len(message.grid) not in (0, 32):
            return "grid is not 16 corners"
    if getattr(message, "format", None) == "raw":
        shape = message.shape
        if not shape or math.prod(shape) != len(message.image):
            return f"a raw image of {len(message.image):,} bytes is not of shape {shape}"
    return None


RATES: dict[str, tuple[float, float]] = {
    "game/new": (2.0, 2.0),
    "speech/say": (5.0, 10.0),
    "arm/command": (2.0, 4.0),
    "recording/switch": (5.0, 5.0),
}
"""Messages per second (and burst) a topic may bring from the network; others `DEFAULT_RATE`.
A person starts a game, and the robot speaks or draws, a few times a minute."""
DEFAULT_RATE = (100.0, 300.0)
"""Any other topic's rate and burst (a reading 10 times a second, a stroke's updates)."""


class FloodGuard:
    """Drops what a topic brings beyond its rate (a token bucket per topic, `RATES`), so that
    a peer flooding 2,000 NewGames leaves at most a few greetings behind; logs once per topic
    per `report_every` seconds how many it dropped. Not thread-safe: call it under a lock."""

    def __init__(self, report_every: float = 5.0) -> None:
        self.report_every = report_every
        self._tokens: dict[str, tuple[float, float]] = {}  # topic -> (tokens, when)
        self._dropped: dict[str, tuple[int, float]] = {}  # topic -> (count, since)

    def admit(self, topic: str, now: float) -> bool:
        """Whether a message of `topic` arriving `now` (monotonic seconds) is let through."""
        rate, burst = RATES.get(topic, DEFAULT_RATE)
        tokens, when = self._tokens.get(topic, (burst, now))
        tokens = min(burst, tokens + (now - when) * rate)
        if tokens >= 1.0:
            self._tokens[topic] = (tokens - 1.0, now)
            return True
        self._tokens[topic] = (tokens, now)
        count, since = self._dropped.get(topic, (0, now))
        count += 1
        if now - since >= self.report_every or count == 1:
            log.warning(
                "dropped %d %s messages over its rate (%g a second): a peer floods the bus",
                count,
                topic,
                rate,
            )
            count, since = 0, now
        self._dropped[topic] = (count, since)
        return False
