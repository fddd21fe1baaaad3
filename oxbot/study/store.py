"""The study's database: participants, their answers and their games' metrics, in one SQLite file.

`study.sqlite3` in the study's folder (`oxbot study --data-dir`, default `study` in the user's
data folder). The folder is made 0700 and the file 0600 (SQLite gives its WAL and shared-memory
files the database file's permissions), so only the experimenter's account reads it. Tables:

- `schema_version`: one row per migration applied (version, when);
- `design`: the study's design (its conditions, games per condition, conditions per
  participant) and how many participants were enrolled, so a restarted server carries the
  rotation on;
- `participants`: a random id (`secrets`, never a name), when they consented, their row of
  the counterbalancing, the conditions in their order (JSON), and whether they also agreed to
  keep their games' recordings (`keep_recordings`, from version 2);
- `answers`: one row per questionnaire item answered (instrument, block, item, value, when);
- `games`: one row per game played, with its condition and the metrics measured on it
  (oxbot.study.metrics), the transcript as JSON.

Every answer is written in its own transaction (WAL, `synchronous=FULL`, `busy_timeout`), so a
crash or kill -9 of the server loses nothing already answered. `forget` deletes a participant's
rows with `secure_delete` on, then VACUUMs and truncates the WAL: no byte of them remains.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import sqlite3
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from oxbot.errors import DataError

DB_NAME = "study.sqlite3"
BUSY_TIMEOUT_MS = 5000
"""How long a writer waits for another's lock before SQLite says the database is busy."""

MIGRATION_1 = """
CREATE TABLE design (
    key TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE participants (
    id TEXT PRIMARY KEY,
    consented_at REAL NOT NULL,
    order_row INTEGER NOT NULL,
    conditions TEXT NOT NULL
);
CREATE TABLE answers (
    participant_id TEXT NOT NULL REFERENCES participants(id) ON DELETE CASCADE,
    instrument TEXT NOT NULL,
    block INTEGER NOT NULL,
    item TEXT NOT NULL,
    value TEXT NOT NULL,
    answered_at REAL NOT NULL,
    PRIMARY KEY (participant_id, instrument, block, item)
);
CREATE TABLE games (
    participant_id TEXT NOT NULL REFERENCES participants(id) ON DELETE CASCADE,
    block INTEGER NOT NULL,
    game INTEGER NOT NULL,
    manager TEXT NOT NULL,
    starter TEXT NOT NULL,
    input TEXT NOT NULL,
    status TEXT NOT NULL,
    outcome TEXT,
    success INTEGER NOT NULL,
    turns INTEGER NOT NULL,
    moves INTEGER NOT NULL,
    duration REAL NOT NULL,
    time_per_move REAL,
    confidence REAL,
    spoken INTEGER NOT NULL,
    typed INTEGER NOT NULL,
    asked_again INTEGER NOT NULL,
    corrected INTEGER NOT NULL,
    well_formed INTEGER NOT NULL,
    problem TEXT NOT NULL,
    transcript TEXT NOT NULL,
    ended_at REAL NOT NULL,
    PRIMARY KEY (participant_id, block, game)
);
"""
MIGRATION_2 = """
ALTER TABLE participants ADD COLUMN keep_recordings INTEGER NOT NULL DEFAULT 0;
"""
"""Version 2: whether the participant also agreed to keep what the robot saw and heard."""
MIGRATIONS: list[str] = [MIGRATION_1, MIGRATION_2]
"""Migration k (1-based) takes the database from version k-1 to k; append, never edit."""

GAME_COLUMNS = (
    "status",
    "outcome",
    "success",
    "turns",
    "moves",
    "duration",
    "time_per_move",
    "confidence",
    "spoken",
    "typed",
    "asked_again",
    "corrected",
    "well_formed",
    "problem",
    "transcript",
)
"""The metrics a game row holds besides its participant, block, game number and condition."""


def schema_version(db: sqlite3.Connection) -> int:
    """The highest migration applied to `db` (0 for a new or foreign file)."""
    db.execute(
        "CREATE TABLE IF NOT EXISTS schema_version "
        "(version INTEGER PRIMARY KEY, applied_at REAL NOT NULL)"
    )
    row = db.execute("SELECT MAX(version) FROM schema_version").fetchone()
    return int(row[0] or 0)


def migrate(db: sqlite3.Connection, migrations: Sequence[str] = MIGRATIONS) -> int:
    """Apply the migrations `db` has not had, each in its own transaction; the version after."""
    version = schema_version(db)
    if version > len(migrations):
        raise DataError(
            f"the study database has schema version {version}; this oxbot reads up to "
            f"{len(migrations)}: update oxbot"
        )
    for number, script in enumerate(migrations[version:], start=version + 1):
        # executescript commits first; the BEGIN makes the migration and its row one transaction
        try:
            db.executescript(
                f"BEGIN IMMEDIATE; {script}; "
                f"INSERT INTO schema_version VALUES ({number}, {time.time()!r}); COMMIT;"
            )
        except sqlite3.Error:
            if db.in_transaction:
                db.execute("ROLLBACK")
            raise
    return len(migrations)


def private_folder(folder: Path) -> None:
    """Make `folder` (and its parents) if needed, readable by this account alone."""
    try:
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
        os.chmod(folder, 0o700)
    except OSError as exc:
        raise DataError(f"cannot make the study folder {folder}: {exc}") from None


def new_participant_id() -> str:
    """A random participant id: 8 hex digits from `secrets`, nothing of the person."""
    return "p" + secrets.token_hex(4)


class StudyStore:
    """The study database in `folder` (made on first use); thread-safe. Each write method is one
    transaction."""

    def __init__(self, folder: str | Path, migrations: Sequence[str] = MIGRATIONS) -> None:
        self.folder = Path(folder).expanduser()
        self.path = self.folder / DB_NAME
        private_folder(self.folder)
        try:
            # made 0600 before SQLite opens it: its -wal and -shm files take these permissions
            os.close(os.open(self.path, os.O_CREAT | os.O_RDWR, 0o600))
            os.chmod(self.path, 0o600)
            self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
            self._db.execute(f"PRAGMA busy_timeout={BUSY_TIMEOUT_MS}")
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")  # each answer on disk when committed
            self._db.execute("PRAGMA foreign_keys=ON")
            self._db.execute("PRAGMA secure_delete=ON")  # forgotten rows are zeroed, not freed
            self.version = migrate(self._db, migrations)
        except sqlite3.Error as exc:
            raise DataError(
                f"the study database {self.path} cannot be opened ({exc}); "
                "choose another folder with --data-dir"
            ) from None
        self._lock = threading.RLock()

    # --- plumbing ---

    @contextlib.contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """One transaction: committed when the block ends, rolled back if it raises."""
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield self._db
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")

    def query(self, sql: str, args: Sequence[Any] = ()) -> list[dict[str, Any]]:
        """Rows of a read-only query, as dicts by column name."""
        with self._lock:
            cursor = self._db.execute(sql, args)
            names = [d[0] for d in cursor.description]
            return [dict(zip(names, row, strict=True)) for row in cursor.fetchall()]

    def close(self) -> None:
        """Close the connection (the file stays)."""
        with self._lock:
            self._db.close()

    def __enter__(self) -> StudyStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- the design ---

    def design(self) -> dict[str, Any] | None:
        """The design saved by `save_design`, or None."""
        rows = self.query("SELECT value FROM design WHERE key = 'design'")
        return json.loads(rows[0]["value"]) if rows else None

    def save_design(self, design: dict[str, Any]) -> None:
        """Keep the study's design, so that a restarted study can be checked against it."""
        with self.transaction() as db:
            db.execute(
                "INSERT OR REPLACE INTO design (key, value) VALUES ('design', ?)",
                (json.dumps(design, sort_keys=True),),
            )

    # --- participants ---

    def enrol(
        self, conditions_for: Callable[[int], list[dict[str, str]]], keep_recordings: bool = False
    ) -> dict[str, Any]:
        """A new participant, who has just consented: a fresh random id, the next row of the
        counterbalancing and `conditions_for(row)`, in one transaction. Their row as a dict."""
        with self.transaction() as db:
            counted = db.execute("SELECT value FROM design WHERE key = 'enrolled'").fetchone()
            row = int(counted[0]) if counted else 0
            conditions = conditions_for(row)
            while True:
                pid = new_participant_id()
                if not db.execute("SELECT 1 FROM participants WHERE id = ?", (pid,)).fetchone():
                    break
            db.execute(
                "INSERT INTO participants (id, consented_at, order_row, conditions, "
                "keep_recordings) VALUES (?,?,?,?,?)",
                (pid, time.time(), row, json.dumps(conditions), int(keep_recordings)),
            )
            db.execute(
                "INSERT OR REPLACE INTO design (key, value) VALUES ('enrolled', ?)", (str(row + 1),)
            )
        return self.participant(pid)

    def participant(self, pid: str) -> dict[str, Any]:
        """A participant's row, conditions decoded; a DataError if there is no such id."""
        rows = self.query("SELECT * FROM participants WHERE id = ?", (pid,))
        if not rows:
            raise DataError(f"no participant {pid!r} in {self.path} (`oxbot study list`)")
        row = rows[0]
        row["conditions"] = json.loads(row["conditions"])
        return row

    def participants(self) -> list[dict[str, Any]]:
        """Every participant, in the order they consented."""
        rows = self.query("SELECT * FROM participants ORDER BY consented_at, id")
        for row in rows:
            row["conditions"] = json.loads(row["conditions"])
        return rows

    # --- answers and games ---

    def answer(self, pid: str, instrument: str, block: int, item: str, value: str) -> None:
        """Keep one answer (a changed answer replaces the earlier one), in its own transaction."""
        with self.transaction() as db:
            db.execute(
                "INSERT OR REPLACE INTO answers (participant_id, instrument, block, item, value, "
                "answered_at) VALUES (?,?,?,?,?,?)",
                (pid, instrument, block, item, value, time.time()),
            )

    def answers(self, pid: str | None = None) -> list[dict[str, Any]]:
        """Every answer kept (or one participant's), by participant, block, instrument, item."""
        where, args = ("WHERE participant_id = ?", [pid]) if pid is not None else ("", [])
        return self.query(
            f"SELECT * FROM answers {where} ORDER BY participant_id, block, instrument, item", args
        )

    def add_game(
        self, pid: str, block: int, condition: dict[str, str], metrics: dict[str, Any]
    ) -> int:
        """Keep a finished game's metrics as the participant's next game in `block`; its number."""
        with self.transaction() as db:
            (count,) = db.execute(
                "SELECT COUNT(*) FROM games WHERE participant_id = ? AND block = ?", (pid, block)
            ).fetchone()
            values = [metrics[c] for c in GAME_COLUMNS]
            names = ", ".join(GAME_COLUMNS)
            db.execute(
                f"INSERT INTO games (participant_id, block, game, manager, starter, input, "
                f"{names}, ended_at) VALUES ({','.join('?' * (len(GAME_COLUMNS) + 7))})",
                [
                    pid,
                    block,
                    count + 1,
                    condition["manager"],
                    condition["starter"],
                    condition["input"],
                    *values,
                    time.time(),
                ],
            )
        return count + 1

    def games(self, pid: str | None = None) -> list[dict[str, Any]]:
        """Every game kept (or one participant's), by participant, block and game."""
        where, args = ("WHERE participant_id = ?", [pid]) if pid is not None else ("", [])
        return self.query(f"SELECT * FROM games {where} ORDER BY participant_id, block, game", args)

    # --- forgetting ---

    def forget(self, pid: str) -> None:
        """Delete everything of a participant and leave no byte of it in the file."""
        self.participant(pid)  # a DataError if there is no such id
        with self.transaction() as db:
            for table in ("answers", "games"):
                db.execute(f"DELETE FROM {table} WHERE participant_id = ?", (pid,))
            db.execute("DELETE FROM participants WHERE id = ?", (pid,))
        with self._lock:
            self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            self._db.execute("VACUUM")
            self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")


def integrity(path: str | Path) -> str:
    """`PRAGMA integrity_check` of a study database: "ok" when it is sound."""
    db = sqlite3.connect(path)
    try:
        return str(db.execute("PRAGMA integrity_check").fetchone()[0])
    finally:
        db.close()
