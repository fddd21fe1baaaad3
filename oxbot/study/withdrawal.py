"""A participant's withdrawal: everything of theirs deleted, the study's rows and the games the
robot recorded for them (`oxbot study forget ID`).

A participant who agreed to keep their games' recordings has them in `recordings.sqlite3` in
the study's folder (oxbot.recording.store), each session marked `study:<id>` in its `mode`;
forgetting the participant forgets those sessions too, and every model or export made from them.
"""

from __future__ import annotations

import os
from pathlib import Path

from oxbot.recording.store import DB_NAME as RECORDINGS
from oxbot.recording.store import RecordingStore
from oxbot.study.store import StudyStore


def recording_mode(pid: str) -> str:
    """The `mode` a participant's recorded sessions carry."""
    return f"study:{pid}"


def open_recordings(folder: Path) -> RecordingStore:
    """The study's recordings database, made readable by this account alone."""
    store = RecordingStore(folder)
    for path in folder.glob(f"{RECORDINGS}*"):
        os.chmod(path, 0o600)
    return store


def forget_participant(folder: Path, pid: str) -> list[Path]:
    """Delete everything of participant `pid` in the study in `folder`; the derived files that
    were deleted with their recordings (learnt models, exports of `oxbot data export`)."""
    deleted: list[Path] = []
    with StudyStore(folder) as store:
        store.participant(pid)  # a DataError naming the command that lists them
        if (folder / RECORDINGS).exists():
            with open_recordings(folder) as recordings:
                # by id alone: a damaged row elsewhere must not stop a withdrawal
                rows = recordings.query(
                    "SELECT id FROM sessions WHERE mode = ?", (recording_mode(pid),)
                )
                for row in rows:
                    deleted += recordings.forget(row["id"]).deleted
        store.forget(pid)
    return deleted
