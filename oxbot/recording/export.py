"""`oxbot data export`: the recordings as Parquet files, one per table, registered as derived
from the sessions they hold before they are written (so `forget` deletes them)."""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from pathlib import Path

from oxbot.errors import DataError
from oxbot.recording.derived import make_private, private_dir
from oxbot.recording.rows import in_sessions
from oxbot.recording.store import RecordingStore

TABLES = ("sessions", "turns", "answers", "crops")
"""The tables exported, one Parquet file each."""


def export(
    store: RecordingStore, folder: str | Path, session_ids: Sequence[int] | None = None
) -> list[Path]:
    """Write sessions, turns, answers and crops as Parquet files (0600) in `folder`: each
    registered as derived from the sessions, then written to a temporary file and renamed; the
    files written. A DataError, before anything is written, for a folder that cannot take them
    or a database that fails its integrity check."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from oxbot.atomic import atomic_write

    folder = Path(folder)
    ids = list(session_ids) if session_ids is not None else store.session_ids()
    for sid in ids:
        store.session_exists(sid)
    store.check_integrity()
    check_export_folder(folder)
    paths = [folder / f"{table}.parquet" for table in TABLES]
    if ids:
        store.register_derived(paths, ids, "export")
    for table, path in zip(TABLES, paths, strict=True):
        key = "id" if table == "sessions" else "session_id"
        where, args = in_sessions(ids, key)
        rows = store.rows(table, f"SELECT * FROM {table} WHERE 1 {where}", args)
        columns = [r["name"] for r in store.query(f"PRAGMA table_info({table})")]
        for r in rows:  # the checked lists back to the JSON text the table holds
            for c in ("nbest", "words"):
                if c in r:
                    r[c] = json.dumps(r[c])
        data = (
            pa.table({c: [r[c] for r in rows] for c in columns})
            if rows
            else pa.table({c: pa.array([], type=pa.null()) for c in columns})
        )
        try:
            with atomic_write(path) as handle:
                pq.write_table(data, handle)
        except OSError as exc:
            raise DataError(f"cannot write {path}: {exc}; choose another folder") from None
        make_private([path])
    return paths


def check_export_folder(folder: Path) -> None:
    """A DataError unless `folder` is, or can be made as, a writable folder."""
    if folder.is_symlink() and not folder.exists():
        raise DataError(f"{folder} is a link to nothing; give a folder to export into")
    if folder.exists() and not folder.is_dir():
        raise DataError(f"{folder} exists and is not a folder; give a folder to export into")
    try:
        private_dir(folder)
    except OSError as exc:
        raise DataError(f"cannot make the folder {folder}: {exc}; choose another") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise DataError(f"the folder {folder} is not writable; choose another")
