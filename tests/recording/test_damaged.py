"""Damaged, foreign or odd recordings, and odd places to export to: a clear error each, no
traceback, nothing made, nothing learnt."""

from __future__ import annotations

import io
import os
import sqlite3

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from oxbot.cli import app
from oxbot.errors import DataError
from oxbot.recording import RecordingStore
from oxbot.recording.export import export
from oxbot.recording.perceiver import decode_crops, learn_perceiver
from oxbot.testing.hostile import break_an_index
from tests.recording.test_forget import one_session

runner = CliRunner()


def run(*args: str):
    """The command's result; a traceback (an exception that is not oxbot's) fails the test."""
    result = runner.invoke(app, list(args))
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        from oxbot.errors import OxbotError

        assert isinstance(result.exception, OxbotError), repr(result.exception)
    return result


def refused(folder, *command: str) -> str:
    result = run(*command, "--data-dir", str(folder))
    assert result.exit_code != 0, result.output
    return str(result.exception) + result.output


def test_another_programs_sqlite_file_is_refused_and_left_alone(tmp_path):
    db = sqlite3.connect(tmp_path / "recordings.sqlite3")
    db.execute("CREATE TABLE contacts (name TEXT)")
    db.commit()
    db.close()
    before = (tmp_path / "recordings.sqlite3").read_bytes()
    assert "another program's SQLite file" in refused(tmp_path, "data", "list")
    assert (tmp_path / "recordings.sqlite3").read_bytes() == before


@pytest.mark.parametrize("content", [b"\0" * 8192, b"SQLite format 3\0" + os.urandom(5000)])
def test_a_file_that_is_not_a_database_is_a_clear_error(tmp_path, content):
    (tmp_path / "recordings.sqlite3").write_bytes(content)
    for command in (("data", "list"), ("data", "show", "1"), ("data", "forget", "1")):
        assert "recordings.sqlite3" in refused(tmp_path, *command)


def test_dev_zero_as_the_database_is_refused_at_once(tmp_path):
    os.symlink("/dev/zero", tmp_path / "recordings.sqlite3")
    assert "not a regular file" in refused(tmp_path, "data", "list")


def test_garbage_in_the_middle_of_the_file_is_a_clear_error(tmp_path):
    with RecordingStore(tmp_path) as store:
        for _ in range(3):
            one_session(store)
        with store.transaction() as db:  # pages of crops, to damage
            db.executemany(
                "INSERT INTO crops VALUES (1, ?, 0, 0.0, ?, 'cross', 1.0, 2, 'cross')",
                [(i, os.urandom(3000)) for i in range(40)],
            )
        store.compact()
    path = tmp_path / "recordings.sqlite3"
    data = bytearray(path.read_bytes())
    data[4096 * 6 : 4096 * 8] = os.urandom(4096 * 2)
    path.write_bytes(bytes(data))
    for command in (("data", "list"), ("data", "show", "1"), ("data", "forget", "1")):
        assert "damaged" in refused(tmp_path, *command)


def test_learning_refuses_a_file_that_fails_the_integrity_check(tmp_path):
    with RecordingStore(tmp_path) as store:
        one_session(store)
        with store.transaction() as db:
            break_an_index(db)
    with RecordingStore(tmp_path, create=False) as store:
        assert len(store.sessions()) == 1  # readable, yet damaged
        with pytest.raises(DataError, match="integrity check"):
            learn_perceiver(store, tmp_path / "model.pt", show_progress=False)
        with pytest.raises(DataError, match="integrity check"):
            export(store, tmp_path / "export")
    assert not (tmp_path / "model.pt").exists() and not (tmp_path / "export").exists()


def test_wrong_types_in_a_row_are_a_clear_error(tmp_path):
    with RecordingStore(tmp_path) as store:
        sid = one_session(store)
        with store.transaction() as db:
            db.execute("UPDATE sessions SET started_at = 'yesterday' WHERE id = ?", (sid,))
    assert "started_at is str" in refused(tmp_path, "data", "list")


def test_an_oversized_crop_is_refused_before_it_is_decoded():
    buffer = io.BytesIO()
    Image.fromarray(np.zeros((4000, 4000), np.uint8)).save(buffer, "PNG")
    with pytest.raises(DataError, match="4000x4000"):
        decode_crops([{"image": buffer.getvalue(), "cell": 0, "session_id": 1}])
    with pytest.raises(DataError, match="not a readable 40x40 PNG"):
        decode_crops([{"image": b"\x89PNG garbage", "cell": 0, "session_id": 1}])


def test_data_list_makes_no_folder(tmp_path):
    result = run("data", "list", "--data-dir", str(tmp_path / "none"))
    assert result.exit_code == 0 and "0 sessions" in result.output
    assert not (tmp_path / "none").exists()
    assert "no recordings" in refused(tmp_path / "none", "data", "show", "1")
    assert not (tmp_path / "none").exists()


def test_export_to_a_file_a_dangling_link_dev_null_or_a_read_only_folder_is_a_clear_error(
    tmp_path,
):
    with RecordingStore(tmp_path / "data") as store:
        one_session(store)
    (tmp_path / "file").write_text("x")
    os.symlink(tmp_path / "nowhere", tmp_path / "dangling")
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    targets = {
        tmp_path / "file": "not a folder",
        tmp_path / "dangling": "link to nothing",
        "/dev/null": "not a folder",
        "/sys/oxbot-export": "cannot make the folder",  # a read-only file system, even for root
    }
    if os.geteuid() != 0:  # root writes anywhere
        targets[locked] = "not writable"
    for target, words in targets.items():
        assert words in refused(tmp_path / "data", "data", "export", str(target)), target
    assert (tmp_path / "file").read_text() == "x" and not (tmp_path / "nowhere").exists()
