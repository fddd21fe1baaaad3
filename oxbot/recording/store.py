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

The file uses WAL journaling, and `Recorder` writes one transaction per turn, so a crash loses
at most the turn under way. `forget` deletes a session's rows with `secure_delete` on (freed
pages are zeroed), deletes its derived files, then VACUUMs and truncates the WAL: the file keeps
no byte of it. The schema's version is SQLite's `user_version`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import sqlite3
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from oxbot.errors import DataError

log = logging.getLogger(__name__)

SCHEMA_VERSION = 1
DB_NAME = "recordings.sqlite3"

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
    PRIMARY KEY (path, session_id)
);
"""
TABLES = ("sessions", "turns", "answers", "crops")
"""The tables `export` writes, one Parquet file each."""


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


class RecordingStore:
    """The recordings database in `data_dir` (created on first use); thread-safe.

    Use as a context manager or call `close`. Every method that writes runs in one transaction.
    """

    def __init__(self, data_dir: str | Path | None = None) -> None:
        self.data_dir = Path(data_dir) if data_dir is not None else default_data_dir()
        self.path = self.data_dir / DB_NAME
        try:
            self.data_dir.mkdir(parents=True, exist_ok=True)
            self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")  # WAL: durable at each checkpoint
            self._db.execute("PRAGMA foreign_keys=ON")
            self._db.execute("PRAGMA secure_delete=ON")  # forgotten rows are zeroed, not freed
            version = self._db.execute("PRAGMA user_version").fetchone()[0]
        except sqlite3.Error as exc:
            raise DataError(
                f"the recordings database {self.path} cannot be opened ({exc}); "
                "choose another folder with --data-dir"
            ) from None
        except OSError as exc:
            raise DataError(f"cannot create the data folder {self.data_dir}: {exc}") from None
        if version > SCHEMA_VERSION:
            raise DataError(
                f"the recordings database {self.path} has schema version {version}; this oxbot "
                f"reads version {SCHEMA_VERSION}: update oxbot"
            )
        self._lock = threading.RLock()
        if version == 0:  # a new file: the tables and the version in one transaction
            self._db.executescript(f"BEGIN; {SCHEMA} PRAGMA user_version={SCHEMA_VERSION}; COMMIT;")

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

    def close(self) -> None:
        with self._lock:
            self._db.close()

    def __enter__(self) -> RecordingStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def query(self, sql: str, args: Sequence[Any] = ()) -> list[dict[str, Any]]:
        """Rows of a read-only query, as dicts by column name."""
        with self._lock:
            cursor = self._db.execute(sql, args)
            names = [d[0] for d in cursor.description]
            return [dict(zip(names, row, strict=True)) for row in cursor.fetchall()]

    # --- writing (the Recorder's side) ---

    def new_session(
        self,
        db: sqlite3.Connection,
        robot_starts: bool,
        mode: str = "",
        keep_audio: bool = False,
    ) -> int:
        """A new session's row (inside the caller's transaction); its id."""
        cursor = db.execute(
            "INSERT INTO sessions (started_at, mode, robot_starts, keep_audio) VALUES (?,?,?,?)",
            (time.time(), mode, int(robot_starts), int(keep_audio)),
        )
        return int(cursor.lastrowid)  # type: ignore[arg-type]

    # --- reading ---

    def sessions(self) -> list[SessionSummary]:
        """Every session, oldest first, with its counts."""
        rows = self.query(
            """SELECT s.*,
                (SELECT COUNT(*) FROM turns t WHERE t.session_id = s.id) AS n_turns,
                (SELECT COUNT(*) FROM answers a WHERE a.session_id = s.id) AS n_answers,
                (SELECT COUNT(*) FROM answers a WHERE a.session_id = s.id AND a.repeated = 1)
                    AS n_repeated,
                (SELECT COUNT(*) FROM crops c WHERE c.session_id = s.id) AS n_crops,
                (SELECT COUNT(*) FROM crops c WHERE c.session_id = s.id AND c.label IS NOT NULL)
                    AS n_labelled
               FROM sessions s ORDER BY s.id"""
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
        rows = self.query("SELECT * FROM sessions WHERE id = ?", (session_id,))
        if not rows:
            known = ", ".join(str(s.id) for s in self.sessions()) or "none recorded yet"
            raise DataError(f"no recorded session {session_id} (sessions: {known})")
        answers = self.query(
            "SELECT seq, t, source, nbest, words, understood, after_act, repeated, "
            "audio IS NOT NULL AS has_audio FROM answers WHERE session_id = ? ORDER BY seq",
            (session_id,),
        )
        for a in answers:
            a["nbest"], a["words"] = json.loads(a["nbest"]), json.loads(a["words"])
        return {
            **rows[0],
            "turns": self.query(
                "SELECT seq, t, speaker, act, text FROM turns WHERE session_id = ? ORDER BY seq",
                (session_id,),
            ),
            "answers": answers,
            "crops": self.query(
                "SELECT label, COUNT(*) AS n FROM crops WHERE session_id = ? GROUP BY label",
                (session_id,),
            ),
            "derived": [
                r["path"]
                for r in self.query("SELECT path FROM derived WHERE session_id = ?", (session_id,))
            ],
        }

    def session_ids(self) -> list[int]:
        return [r["id"] for r in self.query("SELECT id FROM sessions ORDER BY id")]

    def labelled_crops(self, session_ids: Sequence[int] | None = None) -> list[dict[str, Any]]:
        """Crops with a confirmed label: session_id, reading, cell, t, image (PNG bytes),
        read_as, confidence, label; oldest first."""
        where, args = _in_sessions(session_ids)
        return self.query(
            "SELECT session_id, reading, cell, t, image, read_as, confidence, label FROM crops "
            f"WHERE label IS NOT NULL {where} ORDER BY session_id, reading, cell",
            args,
        )

    def dialogues(self, session_ids: Sequence[int] | None = None) -> list[dict[str, Any]]:
        """Each finished or interrupted session with its turns and answers, for fitting the
        simulated person."""
        where, args = _in_sessions(session_ids, "id")
        out = []
        for row in self.query(f"SELECT * FROM sessions WHERE 1 {where} ORDER BY id", args):
            sid = row["id"]
            turns = self.query(
                "SELECT seq, speaker, act, text FROM turns WHERE session_id = ? ORDER BY seq",
                (sid,),
            )
            answers = self.query(
                "SELECT seq, source, nbest, words, understood, after_act, repeated "
                "FROM answers WHERE session_id = ? ORDER BY seq",
                (sid,),
            )
            for a in answers:
                a["nbest"], a["words"] = json.loads(a["nbest"]), json.loads(a["words"])
            out.append({**row, "turns": turns, "answers": answers})
        return out

    # --- derived files, forgetting, exporting ---

    def register_derived(
        self, paths: Sequence[Path], session_ids: Sequence[int], kind: str
    ) -> None:
        """Note that `paths` were made from `session_ids` (forgetting one deletes them)."""
        with self.transaction() as db:
            db.executemany(
                "INSERT OR IGNORE INTO derived (path, session_id, kind) VALUES (?,?,?)",
                [(str(Path(p).resolve()), sid, kind) for p in paths for sid in session_ids],
            )

    def forget(self, session_id: int) -> list[Path]:
        """Delete a session, everything recorded in it and every file derived from it; leave
        no byte of it in the database file. The files deleted."""
        self.session(session_id)  # a DataError naming the sessions if there is no such one
        paths = [
            Path(r["path"])
            for r in self.query(
                "SELECT DISTINCT path FROM derived WHERE session_id = ?", (session_id,)
            )
        ]
        deleted = []
        for path in paths:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
                deleted.append(path)
        with self.transaction() as db:
            placeholders = ",".join("?" * len(paths))
            # a derived file mixes sessions: gone for all of them
            db.execute(
                f"DELETE FROM derived WHERE path IN ({placeholders})", [str(p) for p in paths]
            )
            for table in ("turns", "answers", "crops"):
                db.execute(f"DELETE FROM {table} WHERE session_id = ?", (session_id,))
            db.execute("DELETE FROM sessions WHERE id = ?", (session_id,))
        self.compact()
        return deleted

    def compact(self) -> None:
        """Rewrite the file without free pages and empty the WAL (after `forget`)."""
        with self._lock:
            self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            self._db.execute("VACUUM")
            self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")

    def export(self, folder: str | Path, session_ids: Sequence[int] | None = None) -> list[Path]:
        """Write sessions, turns, answers and crops as Parquet files in `folder` (each written
        to a temporary file, then renamed); the files written."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        from oxbot.atomic import atomic_write

        folder = Path(folder)
        ids = list(session_ids) if session_ids is not None else self.session_ids()
        for sid in ids:
            self.session(sid)
        written = []
        for table in TABLES:
            key = "id" if table == "sessions" else "session_id"
            where, args = _in_sessions(ids, key)
            rows = self.query(f"SELECT * FROM {table} WHERE 1 {where}", args)
            columns = [r[1] for r in self._db.execute(f"PRAGMA table_info({table})")]
            data = (
                pa.table({c: [r[c] for r in rows] for c in columns})
                if rows
                else pa.table({c: pa.array([], type=pa.null()) for c in columns})
            )
            path = folder / f"{table}.parquet"
            with atomic_write(path) as handle:
                pq.write_table(data, handle)
            written.append(path)
        if ids:
            self.register_derived(written, ids, "export")
        return written


def _in_sessions(session_ids: Sequence[int] | None, column: str = "session_id") -> tuple[str, list]:
    if session_ids is None:
        return "", []
    ids = [int(s) for s in session_ids]
    return f"AND {column} IN ({','.join('?' * len(ids)) or 'NULL'})", ids
