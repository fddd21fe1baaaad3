"""`forget` deletes only what is the session's, all of it, and the files oxbot makes are private."""

from __future__ import annotations

import os
import shutil
import sqlite3
import stat

from oxbot.errors import DataError
from oxbot.game.board import EMPTY_BOARD
from oxbot.recording import Recorder, RecordingStore
from oxbot.recording.export import export
from oxbot.robot.bus import LocalBus
from oxbot.robot.messages import DialogueAct, GameState, SpeechHypotheses

ASK = DialogueAct(speaker="sys", act="Request(playGame)", text="Shall we play?")
HEARD = SpeechHypotheses(nbest=(("yes", 0.8),), words=(("yes", 0.8),))
YES = DialogueAct(speaker="usr", act="Confirm(playGame=yes)", text="yes")


def one_session(store: RecordingStore) -> int:
    """A short recorded session in `store`; its id."""
    recorder = Recorder(LocalBus(), store)
    for message in (GameState(board=EMPTY_BOARD, robot_starts=True), ASK, HEARD, YES):
        recorder.handle(message)
    return recorder.sessions[-1]


def test_a_crafted_database_naming_an_outside_file_deletes_nothing_outside(tmp_path):
    victim = tmp_path / "precious.txt"
    victim.write_text("mine")
    data = tmp_path / "data"
    with RecordingStore(data) as store:
        sid = one_session(store)
    db = sqlite3.connect(data / "recordings.sqlite3")
    for path in (str(victim), "../precious.txt", "recordings.sqlite3", "derived.key", "."):
        db.execute("INSERT INTO derived (path, session_id, kind) VALUES (?,?,?)", (path, sid, "x"))
    db.commit()
    db.close()
    with RecordingStore(data) as store:
        forgotten = store.forget(sid)
        assert store.sessions() == []
    assert victim.read_text() == "mine"
    assert forgotten.deleted == [] and len(forgotten.refused) == 5
    assert (data / "recordings.sqlite3").exists()


def test_a_copied_data_folder_forgets_its_own_files_not_the_originals(tmp_path):
    original = tmp_path / "original"
    with RecordingStore(original) as store:
        sid = one_session(store)
        model = original / "learned" / "model.pt"
        export = tmp_path / "export.parquet"
        store.register_derived([model, export], [sid], "perceiver")
        model.write_bytes(b"weights")
        export.write_bytes(b"table")
    copy = tmp_path / "copy"
    shutil.copytree(original, copy)
    with RecordingStore(copy) as store:
        forgotten = store.forget(sid)
    assert forgotten.deleted == [copy / "learned" / "model.pt"]
    assert model.read_bytes() == b"weights" and export.read_bytes() == b"table"
    with RecordingStore(original) as store:  # the original, sealed by its own folder: deleted
        forgotten = store.forget(sid)
    assert sorted(forgotten.deleted) == sorted([model, export.resolve()])


def test_forget_deletes_the_temporary_files_a_killed_write_left(tmp_path):
    with RecordingStore(tmp_path) as store:
        sid = one_session(store)
        model = tmp_path / "learned" / "perceiver.pt"
        store.register_derived([model], [sid], "perceiver")
        left = model.parent / ".perceiver.pt.k3j9x.tmp"  # kill -9 before the rename
        left.write_bytes(b"weights learnt from the session")
        unrelated = model.parent / ".other.pt.abc.tmp"
        unrelated.write_bytes(b"not this session's")
        forgotten = store.forget(sid)
    assert forgotten.deleted == [left] and not left.exists() and unrelated.exists()


def test_a_session_with_a_damaged_row_can_still_be_forgotten(tmp_path):
    with RecordingStore(tmp_path) as store:
        sid = one_session(store)
        with store.transaction() as db:
            db.execute(
                "UPDATE answers SET nbest = '{not json', t = 'late' WHERE session_id = ?", (sid,)
            )
        try:
            store.session(sid)
        except DataError as exc:
            assert "damaged answers row" in str(exc) and f"forget {sid}" in str(exc)
        else:
            raise AssertionError("a damaged row was read without a word")
        store.forget(sid)
        assert store.session_ids() == []


def test_the_data_folder_is_private_and_its_files_too(tmp_path):
    old = os.umask(0o022)
    try:
        with RecordingStore(tmp_path / "data") as store:
            sid = one_session(store)
            store.register_derived([tmp_path / "data" / "learned" / "m.pt"], [sid], "x")
            exported = export(store, tmp_path / "out")
    finally:
        os.umask(old)

    def mode(path):
        return stat.S_IMODE(path.stat().st_mode)

    assert mode(tmp_path / "data") == 0o700 and mode(tmp_path / "data" / "learned") == 0o700
    assert mode(tmp_path / "out") == 0o700
    files = [p for p in (tmp_path / "data").iterdir() if p.is_file()] + exported
    assert files and {mode(p) for p in files} == {0o600}, {p.name: oct(mode(p)) for p in files}
