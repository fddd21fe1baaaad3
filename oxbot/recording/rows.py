"""Checking the rows the recordings database gives back before anything uses them.

SQLite keeps whatever a column is given (a REAL column may hold text), and a recordings file
may have been edited, damaged or made by another program; so each value read is checked for
its type, and each JSON list for its shape and size, and a bad one is a `DataError` naming the
table, the session and what to do, never a traceback further on.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from oxbot.errors import DataError

NUMBER = (int, float)
MAX_JSON_BYTES = 1_000_000
"""The most a recorded N-best or word list may take (one answer's is a few hundred bytes)."""
MAX_CROP_BYTES = 100_000
"""The most a recorded crop's PNG may take (a 40x40 gray PNG is under 2 KB)."""

COLUMNS: dict[str, dict[str, tuple[type, ...]]] = {
    "sessions": {
        "id": (int,),
        "started_at": NUMBER,
        "ended_at": (*NUMBER, type(None)),
        "mode": (str,),
        "robot_starts": (int,),
        "outcome": (str, type(None)),
        "final_board": (str, type(None)),
        "status": (str,),
        "keep_audio": (int,),
    },
    "turns": {
        "session_id": (int,),
        "seq": (int,),
        "t": NUMBER,
        "speaker": (str,),
        "act": (str,),
        "text": (str,),
    },
    "answers": {
        "session_id": (int,),
        "seq": (int,),
        "t": NUMBER,
        "source": (str,),
        "nbest": (str,),
        "words": (str,),
        "understood": (str, type(None)),
        "after_act": (str, type(None)),
        "repeated": (int, type(None)),
        "audio": (bytes, type(None)),
    },
    "crops": {
        "session_id": (int,),
        "reading": (int,),
        "cell": (int,),
        "t": NUMBER,
        "image": (bytes,),
        "read_as": (str,),
        "confidence": NUMBER,
        "cell_state": (int,),
        "label": (str, type(None)),
    },
}
"""The type each column's values must have (the columns a query selects are checked)."""


def damaged(table: str, row: dict[str, Any], what: str) -> DataError:
    """The error for a damaged row of `table`."""
    session = row.get("session_id", row.get("id", "?"))
    return DataError(
        f"the recordings database has a damaged {table} row (session {session}): {what}; "
        f"forget that session (oxbot data forget {session}) or restore the file from a backup"
    )


def checked(table: str, rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """`rows` of `table`, each known column's value checked for its type; JSON lists parsed."""
    types = COLUMNS[table]
    for row in rows:
        for column, value in row.items():
            allowed = types.get(column)
            if allowed is None:
                continue
            if not isinstance(value, allowed) or isinstance(value, bool):
                raise damaged(table, row, f"{column} is {type(value).__name__} {value!r:.40}")
        if table == "answers":
            for column in ("nbest", "words"):
                if column in row:
                    row[column] = _scored_list(table, row, column)
        if table == "crops" and "image" in row and len(row["image"]) > MAX_CROP_BYTES:
            raise damaged(table, row, f"a crop of {len(row['image']):,} bytes")
    return rows


def _scored_list(table: str, row: dict[str, Any], column: str) -> list[list[Any]]:
    """A JSON list of [text, score] pairs, as the recorder writes N-best and word lists."""
    text = row[column]
    if len(text) > MAX_JSON_BYTES:
        raise damaged(table, row, f"{column} is {len(text):,} bytes long")
    try:
        value = json.loads(text)
    except (ValueError, RecursionError):
        raise damaged(table, row, f"{column} is not JSON") from None
    if not isinstance(value, list) or not all(
        isinstance(p, list)
        and len(p) == 2
        and isinstance(p[0], str)
        and isinstance(p[1], NUMBER)
        and not isinstance(p[1], bool)
        for p in value
    ):
        raise damaged(table, row, f"{column} is not a list of [text, score] pairs")
    return value


def in_sessions(session_ids: Sequence[int] | None, column: str = "session_id") -> tuple[str, list]:
    """The SQL condition (and its arguments) keeping only `session_ids` (all when None)."""
    if session_ids is None:
        return "", []
    ids = [int(s) for s in session_ids]
    return f"AND {column} IN ({','.join('?' * len(ids)) or 'NULL'})", ids
