"""The recordings database and the Recorder, on a real recorded game."""

from __future__ import annotations

import sqlite3

import numpy as np
import pyarrow.parquet as pq
import pytest

from oxbot.errors import DataError
from oxbot.game.board import EMPTY, USER
from oxbot.recording import RecordingStore
from oxbot.recording.export import export
from oxbot.recording.store import SCHEMA_VERSION


def test_a_recorded_game_keeps_its_transcript_outcome_and_answers(recorded):
    folder, game = recorded
    with RecordingStore(folder) as store:
        (summary,) = store.sessions()
        record = store.session(summary.id)
    assert summary.status == "ended" and summary.outcome == game.outcome
    assert [t["seq"] for t in record["turns"]] == list(range(1, len(record["turns"]) + 1))
    assert record["turns"][0]["act"] == "Salutation(greeting)"
    assert record["turns"][-1]["act"] == "Salutation(closing)"
    times = [t["t"] for t in record["turns"]]
    assert times == sorted(times) and times[-1] > 0
    (answer, *_) = record["answers"]
    assert answer["nbest"][0][0] == "yes let's play"
    assert answer["understood"] == "Confirm(playGame=yes)"
    assert answer["after_act"] == "Request(playGame)" and answer["repeated"] == 0
    assert record["final_board"].count(str(USER)) == len(game.drawn)


def test_crops_are_labelled_by_the_finished_game_not_by_the_classifier(recorded):
    folder, _ = recorded
    with RecordingStore(folder) as store:
        (summary,) = store.sessions()
        board = [int(v) for v in store.session(summary.id)["final_board"].split(",")]
        crops = store.query("SELECT cell, cell_state, label, image, read_as FROM crops")
    assert crops and all(len(c["image"]) > 50 for c in crops)
    for c in crops:
        if board[c["cell"]] == EMPTY:
            assert c["label"] == "nothing"
        elif board[c["cell"]] == USER and c["cell_state"] == USER:
            assert c["label"] == "cross"  # the robot started: the person drew crosses
        elif board[c["cell"]] == USER:  # before the move was accepted: once the ink was there
            assert c["label"] == ("cross" if c["read_as"] != "nothing" else None), c
        else:  # the robot's cells
            assert c["label"] is None
    labels = {c["label"] for c in crops}
    assert {"cross", "nothing", None} <= labels


def test_the_database_uses_wal_and_carries_its_schema_version(recorded):
    folder, _ = recorded
    db = sqlite3.connect(folder / "recordings.sqlite3")
    assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert db.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    db.close()


def test_a_newer_schema_is_refused_with_a_clear_error(tmp_path):
    RecordingStore(tmp_path).close()
    db = sqlite3.connect(tmp_path / "recordings.sqlite3")
    db.execute(f"PRAGMA user_version={SCHEMA_VERSION + 1}")
    db.close()
    with pytest.raises(DataError, match="update oxbot"):
        RecordingStore(tmp_path)


def test_export_writes_one_parquet_file_per_table(recordings, tmp_path):
    folder, _ = recordings
    with RecordingStore(folder) as store:
        written = export(store, tmp_path / "export")
        n_crops = len(store.query("SELECT cell FROM crops"))
    names = sorted(p.name for p in written)
    assert names == ["answers.parquet", "crops.parquet", "sessions.parquet", "turns.parquet"]
    crops = pq.read_table(tmp_path / "export" / "crops.parquet")
    assert crops.num_rows == n_crops
    assert set(crops.column_names) >= {"image", "label", "read_as", "confidence"}
    assert not list((tmp_path / "export").glob(".*.tmp"))  # written then renamed


def test_forget_leaves_no_trace_of_the_session(recordings, tmp_path):
    folder, _ = recordings
    with RecordingStore(folder) as store:
        (sid,) = store.session_ids()
        crop = store.query("SELECT image FROM crops WHERE label = 'cross' LIMIT 1")[0]["image"]
        exported = export(store, tmp_path / "export")
        store.register_derived([tmp_path / "model.pt"], [sid], "perceiver")
        (tmp_path / "model.pt").write_bytes(b"weights")
        deleted = store.forget(sid).deleted
        assert store.sessions() == []
        with pytest.raises(DataError, match="no recorded session"):
            store.session(sid)
    assert sorted(deleted) == sorted([*exported, (tmp_path / "model.pt").resolve()])
    assert not any(p.exists() for p in deleted)
    raw = b"".join(p.read_bytes() for p in folder.iterdir() if p.is_file())
    for trace in (crop[20:60], b"yes let's play", b"Salutation(greeting)", b"Confirm(playGame"):
        assert trace not in raw, trace
    assert np.frombuffer(crop, np.uint8).size > 60
