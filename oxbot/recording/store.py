"""The recordings database: what the robot saw and heard in the games it was allowed to keep.

One SQLite file (`recordings.sqlite3`) in the user's data folder (`default_data_dir`, or
`--data-dir`). A *session* is one dialogue: from the robot's greeting to its goodbye, one game.
It holds:

- `sessions`: when it started and ended, who started, the outcome, the final board, and whether
  it ended (`status` "playing" until the goodbye, and after a crash; "interrupted" when a new
  game cut it short; "left" when the robot stopped first: quit, Ctrl-C, the tab closed);
- `turns`: the transcript, each turn with its time in seconds from the session's start;
- `answers`: each answer heard, its N-best list, word confidences, the act it was understood as,
  the robot act it answered, whether the robot then had to ask again, and (only with
  `keep_audio`) the recording;
- `crops`: the 40x40 cells the tracker read (PNG), the classifier's reading and confidence, and
  the label the finished game confirmed (`label`, NULL when the game cannot vouch for it);
- `derived`: files made from sessions (learnt models, exports), so that forgetting a session
  deletes them too.

The file (0600, in a 0700 folder when oxbot makes it) uses WAL journaling, and `Recorder`
writes one transaction per turn, so a crash loses at most the turn under way; a lock held by
another connection is waited for (`busy_timeout`), then reported (`DatabaseBusy`), never
left half done. What is read is checked (`oxbot.recording.rows`): a damaged or foreign file is
a `DataError`. Derived files are registered before they are written (oxbot.recording.derived).
`forget` deletes a session's rows with `secure_delete` on (freed pages are zeroed), deletes its
derived files inside the data folder, or sealed by it, with their temporary files, then VACUUMs
and truncates the WAL: the file keeps no byte of it. The schema's version is `user_version`.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sqlite3
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import quote

from oxbot.errors import DatabaseBusy, DataError
from oxbot.recording.derived import PRIVATE_FILE, DerivedFiles, make_private, private_dir
from oxbot.recording.rows import checked, in_sessions

log = logging.getLogger(__name__)

SCHEMA_VERSION = 2
"""1: the first; 2: derived files carry a seal (oxbot.recording.derived)."""
DB_NAME = "recordings.sqlite3"
DB_FILES = (DB_NAME, DB_NAME + "-wal", DB_NAME + "-shm", DB_NAME + "-journal")
"""The database's files: never deleted as a session's derived file."""
BUSY_TIMEOUT = 10.0
"""Seconds a command waits for another connection's lock before saying so."""

SCHEMA = """
CREATE TABLE IF NOT EXISTS sessions (
    id INTEGER PRIMARY KEY,
    started_at REAL NOT NULL,
    ended_at REAL,
    mode TEXT NOT NULL DEFAULT '',
    robot_starts INTEGER NOT NULL,
    outcome TEXT,
    final_board TEXT,
    status TEXT NOT NULL DEFAULT 'playing',
    keep_audio INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS turns (
    session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
    seq INTEGER NOT NULL,
    t REAL NOT NULL,
    speaker TEXT NOT NULL,
    act TEXT NOT NULL,
    text TEXT NOT NULL,
    PRIMARY KEY (session_id, seq)
);
CREATE TABLE IF NOT EXISTS answers (
    session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
    seq INTEGER NOT NULL,
    t REAL NOT NULL,
    source TEXT NOT NULL,
    nbest TEXT NOT NULL,
    words TEXT NOT NULL,
    understood TEXT,
    after_act TEXT,
    repeated INTEGER,
    audio BLOB,
    PRIMARY KEY (session_id, seq)
);
CREATE TABLE IF NOT EXISTS crops (
    session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
    reading INTEGER NOT NULL,
    cell INTEGER NOT NULL,
    t REAL NOT NULL,
    image BLOB NOT NULL,
    read_as TEXT NOT NULL,
    confidence REAL NOT NULL,
    cell_state INTEGER NOT NULL,
    label TEXT,
    PRIMARY KEY (session_id, reading, cell)
);
CREATE TABLE IF NOT EXISTS derived (
    path TEXT NOT NULL,
    session_id INTEGER NOT NULL REFERENCES sessions(id) ON DELETE CASCADE,
    kind TEXT NOT NULL,
    seal TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (path, session_id)
);
"""
EXPECTED_COLUMNS = {
    "sessions": {"id", "started_at", "ended_at", "mode", "robot_starts", "outcome", "status"},
    "turns": {"session_id", "seq", "t", "speaker", "act", "text"},
    "answers": {"session_id", "seq", "t", "source", "nbest", "words", "understood", "repeated"},
    "crops": {"session_id", "reading", "cell", "t", "image", "read_as", "confidence", "label"},
    "derived": {"path", "session_id", "kind", "seal"},
}
"""The columns oxbot reads from each table: a file without them is not oxbot's."""


def default_data_dir() -> Path:
    """The user's data folder for oxbot (e.g. ~/.local/share/oxbot on Linux)."""
    import platformdirs

    return Path(platformdirs.user_data_dir("oxbot", appauthor=False))


@dataclass(frozen=True)
class SessionSummary:
    """One row of `oxbot data list`."""

    id: int
    started_at: float
    ended_at: float | None
    mode: str
    robot_starts: bool
    outcome: str | None
    status: str
    turns: int
    answers: int
    repeated: int
    crops: int
    labelled: int


@dataclass(frozen=True)
class Forgotten:
    """What `forget` did with the files made from a session."""

    deleted: list[Path]
    """The files deleted (temporary files left by a crash included)."""
    refused: list[str]
    """Files the database named that were not touched: outside the data folder and not sealed
    by it (a copied folder's, or a crafted database's)."""


class RecordingStore:
    """The recordings database in `data_dir`; thread-safe.

    With `create` the folder (0700) and the file (0600) are made on first use; without, a
    missing database is a `DataError`. A write waits up to `busy_timeout` seconds for another
    connection's lock, then raises `DatabaseBusy`. Use as a context manager or call `close`.
    Every method that writes runs in one transaction.
    """

    def __init__(
        self,
        data_dir: str | Path | None = None,
        create: bool = True,
        busy_timeout: float = BUSY_TIMEOUT,
    ) -> None:
        self.data_dir = Path(data_dir) if data_dir is not None else default_data_dir()
        self.path = self.data_dir / DB_NAME
        self.busy_timeout = busy_timeout
        self._lock = threading.RLock()
        self._db = self._connect(create)
        try:
            version = self._prepare()
        except BaseException:
            self._db.close()
            raise
        self.derived_files = DerivedFiles(self.data_dir, DB_FILES)
        log.debug("opened %s (schema %d)", self.path, version)

    def _connect(self, create: bool) -> sqlite3.Connection:
        """The connection to the file, made (private) when `create`; refusing what is not a
        database file."""
        if self.data_dir.exists() and not self.data_dir.is_dir():
            raise DataError(f"{self.data_dir} is not a folder; choose another with --data-dir")
        if not self.path.exists():
            if not create:
                raise DataError(
                    f"no recordings in {self.data_dir}: nothing was kept there yet "
                    "(oxbot play --record), or choose the folder with --data-dir"
                )
            try:
                private_dir(self.data_dir)
                os.close(os.open(self.path, os.O_WRONLY | os.O_CREAT, PRIVATE_FILE))
            except OSError as exc:
                raise DataError(
                    f"cannot create {self.path}: {exc}; choose another --data-dir"
                ) from None
        if not self.path.is_file():  # /dev/zero, a fifo, a folder: SQLite would hang or fail
            raise DataError(
                f"{self.path} is not a regular file; move it away or choose another --data-dir"
            )
        uri = f"file:{quote(str(self.path.absolute()))}?mode=rw"
        try:
            return sqlite3.connect(
                uri, uri=True, check_same_thread=False, isolation_level=None, timeout=0
            )
        except sqlite3.Error as exc:
            raise DataError(
                f"the recordings database {self.path} cannot be opened ({exc}); "
                "choose another folder with --data-dir"
            ) from None

    def _prepare(self) -> int:
        """Set the connection up, make or upgrade the schema, check it; its version."""
        db = self._db
        try:  # what the file is, before anything changes it
            db.execute(f"PRAGMA busy_timeout={int(self.busy_timeout * 1000)}")
            version = db.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master")}
        except sqlite3.Error as exc:
            raise self._error(exc) from None
        if version > SCHEMA_VERSION:
            raise DataError(
                f"the recordings database {self.path} has schema version {version}; this oxbot "
                f"reads version {SCHEMA_VERSION}: update oxbot"
            )
        if version == 0 and tables:
            raise DataError(
                f"{self.path} is another program's SQLite file, not oxbot's recordings; move it "
                "away or choose another --data-dir"
            )
        make_private([self.path, *(self.path.with_name(DB_NAME + s) for s in ("-wal", "-shm"))])
        try:
            db.execute("PRAGMA journal_mode=WAL")
            db.execute("PRAGMA synchronous=NORMAL")  # WAL: durable at each checkpoint
            db.execute("PRAGMA foreign_keys=ON")
            db.execute("PRAGMA secure_delete=ON")  # forgotten rows are zeroed, not freed
        except sqlite3.Error as exc:
            raise self._error(exc) from None
        if version < SCHEMA_VERSION:  # a reader of an up-to-date file takes no write lock
            with self.transaction() as tx:
                if version == 0:  # a new file: the tables and the version in one transaction
                    for statement in SCHEMA.split(";"):  # executescript would commit first
                        if statement.strip():
                            tx.execute(statement)
                elif version == 1:  # derived files gained their seal
                    tx.execute("ALTER TABLE derived ADD COLUMN seal TEXT NOT NULL DEFAULT ''")
                tx.execute(f"PRAGMA user_version={SCHEMA_VERSION}")
        for table, columns in EXPECTED_COLUMNS.items():
            found = {r["name"] for r in self.query(f"PRAGMA table_info({table})")}
            if not columns <= found:
                raise DataError(
                    f"{self.path} lacks the columns {sorted(columns - found)} of table "
                    f"{table!r}: it is not an oxbot recordings file, or it is damaged; move it "
                    "away or choose another --data-dir"
                )
        return SCHEMA_VERSION

    # --- plumbing ---

    def _error(self, exc: sqlite3.Error) -> DataError:
        """A SQLite error as the DataError a person can act on."""
        text = str(exc)
        if "locked" in text or "busy" in text:
            return DatabaseBusy(
                f"the recordings database {self.path} stayed locked by another program for "
                f"{self.busy_timeout:g} s ({text}); close the other oxbot command and try again"
            )
        return DataError(
            f"the recordings database {self.path} is damaged or not oxbot's ({text}); restore "
            "it from a backup, or move it away to start a new one"
        )

    @contextlib.contextmanager
    def transaction(self, timeout: float | None = None) -> Iterator[sqlite3.Connection]:
        """One transaction: committed when the block ends, rolled back if it raises. Waits up
        to `timeout` seconds (default `busy_timeout`) for a lock, then raises `DatabaseBusy`;
        any other SQLite failure is a DataError."""
        with self._lock:
            try:
                if timeout is not None:
                    self._db.execute(f"PRAGMA busy_timeout={int(timeout * 1000)}")
                try:
                    self._db.execute("BEGIN IMMEDIATE")
                finally:
                    if timeout is not None:
                        self._db.execute(f"PRAGMA busy_timeout={int(self.busy_timeout * 1000)}")
            except sqlite3.Error as exc:
                raise self._error(exc) from None
            try:
                yield self._db
                self._db.execute("COMMIT")
            except BaseException as exc:
                if self._db.in_transaction:  # COMMIT itself may fail (busy): never left open
                    self._db.execute("ROLLBACK")
                if isinstance(exc, sqlite3.Error):
                    raise self._error(exc) from None
                raise

    def close(self) -> None:
        with self._lock:
            self._db.close()

    def __enter__(self) -> RecordingStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def query(self, sql: str, args: Sequence[Any] = ()) -> list[dict[str, Any]]:
        """Rows of a read-only query, as dicts by column name; a DataError if the file is
        damaged or locked."""
        with self._lock:
            try:
                cursor = self._db.execute(sql, args)
                names = [d[0] for d in cursor.description]
                return [dict(zip(names, row, strict=True)) for row in cursor.fetchall()]
            except sqlite3.Error as exc:
                raise self._error(exc) from None

    def check_integrity(self) -> None:
        """A DataError unless SQLite's `integrity_check` finds the file whole."""
        problems = [r["integrity_check"] for r in self.query("PRAGMA integrity_check")]
        if problems != ["ok"]:
            raise DataError(
                f"the recordings database {self.path} fails SQLite's integrity check "
                f"({'; '.join(map(str, problems[:3]))}); nothing was learned or written from "
                "it: restore it from a backup, or forget the damaged sessions"
            )

    # --- writing (the Recorder's side) ---

    def new_session(
        self,
        db: sqlite3.Connection,
        robot_starts: bool,
        mode: str = "",
        keep_audio: bool = False,
        started_at: float | None = None,
    ) -> int:
        """A new session's row (inside the caller's transaction); its id. `started_at` is the
        wall clock's time (default: now)."""
        cursor = db.execute(
            "INSERT INTO sessions (started_at, mode, robot_starts, keep_audio) VALUES (?,?,?,?)",
            (
                time.time() if started_at is None else started_at,
                mode,
                int(robot_starts),
                int(keep_audio),
            ),
        )
        return int(cursor.lastrowid)  # type: ignore[arg-type]

    # --- reading ---

    def sessions(self) -> list[SessionSummary]:
        """Every session, oldest first, with its counts."""
        rows = self.rows(
            "sessions",
            """SELECT s.*,
                (SELECT COUNT(*) FROM turns t WHERE t.session_id = s.id) AS n_turns,
                (SELECT COUNT(*) FROM answers a WHERE a.session_id = s.id) AS n_answers,
                (SELECT COUNT(*) FROM answers a WHERE a.session_id = s.id AND a.repeated = 1)
                    AS n_repeated,
                (SELECT COUNT(*) FROM crops c WHERE c.session_id = s.id) AS n_crops,
                (SELECT COUNT(*) FROM crops c WHERE c.session_id = s.id AND c.label IS NOT NULL)
                    AS n_labelled
               FROM sessions s ORDER BY s.id""",
        )
        return [
            SessionSummary(
                id=r["id"],
                started_at=r["started_at"],
                ended_at=r["ended_at"],
                mode=r["mode"],
                robot_starts=bool(r["robot_starts"]),
                outcome=r["outcome"],
                status=r["status"],
                turns=r["n_turns"],
                answers=r["n_answers"],
                repeated=r["n_repeated"],
                crops=r["n_crops"],
                labelled=r["n_labelled"],
            )
            for r in rows
        ]

    def session(self, session_id: int) -> dict[str, Any]:
        """One session: its row, transcript, answers (without audio) and crop counts."""
        self.session_exists(session_id)
        rows = self.rows("sessions", "SELECT * FROM sessions WHERE id = ?", (session_id,))
        answers = self.rows(
            "answers",
            "SELECT session_id, seq, t, source, nbest, words, understood, after_act, repeated, "
            "audio IS NOT NULL AS has_audio FROM answers WHERE session_id = ? ORDER BY seq",
            (session_id,),
        )
        return {
            **rows[0],
            "turns": self.rows(
                "turns",
                "SELECT session_id, seq, t, speaker, act, text FROM turns WHERE session_id = ? "
                "ORDER BY seq",
                (session_id,),
            ),
            "answers": answers,
            "crops": self.rows(
                "crops",
                "SELECT label, COUNT(*) AS n FROM crops WHERE session_id = ? GROUP BY label",
                (session_id,),
            ),
            "derived": [  # files inside the data folder are named relative to it
                str(self.data_dir / r["path"])
                for r in self.query("SELECT path FROM derived WHERE session_id = ?", (session_id,))
            ],
        }

    def session_exists(self, session_id: int) -> None:
        """A DataError naming the sessions there are if there is no session `session_id`."""
        if not self.query("SELECT 1 FROM sessions WHERE id = ?", (session_id,)):
            known = ", ".join(map(str, self.session_ids())) or "none recorded yet"
            raise DataError(f"no recorded session {session_id} (sessions: {known})")

    def rows(self, table: str, sql: str, args: Sequence[Any] = ()) -> list[dict[str, Any]]:
        """A query's rows from `table`, their values checked (oxbot.recording.rows)."""
        return checked(table, self.query(sql, args))

    def session_ids(self) -> list[int]:
        return [r["id"] for r in self.rows("sessions", "SELECT id FROM sessions ORDER BY id")]

    def labelled_crops(self, session_ids: Sequence[int] | None = None) -> list[dict[str, Any]]:
        """Crops with a confirmed label: session_id, reading, cell, t, image (PNG bytes),
        read_as, confidence, label; oldest first."""
        where, args = in_sessions(session_ids)
        return self.rows(
            "crops",
            "SELECT session_id, reading, cell, t, image, read_as, confidence, label FROM crops "
            f"WHERE label IS NOT NULL {where} ORDER BY session_id, reading, cell",
            args,
        )

    def dialogues(self, session_ids: Sequence[int] | None = None) -> list[dict[str, Any]]:
        """Each finished or interrupted session with its turns and answers, for fitting the
        simulated person."""
        where, args = in_sessions(session_ids, "id")
        out = []
        sql = f"SELECT * FROM sessions WHERE 1 {where} ORDER BY id"
        for row in self.rows("sessions", sql, args):
            sid = row["id"]
            turns = self.rows(
                "turns",
                "SELECT session_id, seq, speaker, act, text FROM turns WHERE session_id = ? "
                "ORDER BY seq",
                (sid,),
            )
            answers = self.rows(
                "answers",
                "SELECT session_id, seq, source, nbest, words, understood, after_act, repeated "
                "FROM answers WHERE session_id = ? ORDER BY seq",
                (sid,),
            )
            out.append({**row, "turns": turns, "answers": answers})
        return out

    # --- derived files, forgetting, exporting ---

    def register_derived(
        self, paths: Sequence[Path], session_ids: Sequence[int], kind: str
    ) -> None:
        """Note that `paths` are made from `session_ids`, so that forgetting one deletes them.

        Call it *before* writing them (then write each to a temporary file and rename it): a
        crash in between leaves a registered name, never an unregistered file. Folders made
        for them inside the data folder are private (0700)."""
        rows = []
        for sid in session_ids:
            for p in paths:
                name, seal = self.derived_files.name(Path(p), int(sid), kind)
                rows.append((name, int(sid), kind, seal))
        with self.transaction() as db:
            db.executemany(
                "INSERT OR REPLACE INTO derived (path, session_id, kind, seal) VALUES (?,?,?,?)",
                rows,
            )

    def forget(self, session_id: int) -> Forgotten:
        """Delete a session, everything recorded in it and every file derived from it (inside
        the data folder, or sealed by it: oxbot.recording.derived), temporary files included;
        leave no byte of it in the database file. Works on damaged rows."""
        self.session_exists(session_id)
        named = self.query(
            "SELECT DISTINCT path, session_id, kind, seal FROM derived WHERE session_id = ?",
            (session_id,),
        )
        deleted: list[Path] = []
        refused: list[str] = []
        for row in named:
            target = None
            if all(isinstance(row[k], str) for k in ("path", "kind", "seal")):
                target = self.derived_files.target(
                    row["path"], session_id, row["kind"], row["seal"]
                )
            if target is None:
                log.warning(
                    "%r is named as made from session %d but lies outside %s: not touched",
                    row["path"],
                    session_id,
                    self.data_dir,
                )
                refused.append(str(row["path"]))
                continue
            deleted += self.derived_files.delete(target)
        with self.transaction() as db:
            # a derived file mixes sessions: gone for all of them
            db.executemany("DELETE FROM derived WHERE path = ?", [(r["path"],) for r in named])
            for table in ("turns", "answers", "crops", "derived"):
                db.execute(f"DELETE FROM {table} WHERE session_id = ?", (session_id,))
            db.execute("DELETE FROM sessions WHERE id = ?", (session_id,))
        self.compact()
        return Forgotten(deleted, refused)

    def compact(self) -> None:
        """Rewrite the file without free pages and empty the WAL (after `forget`)."""
        with self._lock:
            try:
                self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
                self._db.execute("VACUUM")
                self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            except sqlite3.Error as exc:
                raise self._error(exc) from None
