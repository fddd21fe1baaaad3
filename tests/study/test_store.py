"""The study's database: its migrations, its permissions, random ids, and forgetting."""

from __future__ import annotations

import json
import sqlite3
import stat

import pytest

from oxbot.errors import DataError
from oxbot.study.conditions import Design
from oxbot.study.store import DB_NAME, MIGRATIONS, StudyStore, integrity, migrate, schema_version

CONDITION = {"manager": "dqn", "starter": "robot", "input": "typing"}


def metrics(**changes):
    base = {
        "status": "ended",
        "outcome": "win",
        "success": 1,
        "turns": 12,
        "moves": 3,
        "duration": 40.0,
        "time_per_move": 4.5,
        "confidence": 0.8,
        "spoken": 2,
        "typed": 1,
        "asked_again": 1,
        "corrected": 0,
        "well_formed": 1,
        "problem": "",
        "transcript": "[]",
    }
    return {**base, **changes}


def test_a_new_file_is_migrated_to_the_latest_version(tmp_path):
    with StudyStore(tmp_path) as store:
        assert store.version == len(MIGRATIONS) == 2
        tables = {r["name"] for r in store.query("SELECT name FROM sqlite_master")}
    assert {"schema_version", "design", "participants", "answers", "games"} <= tables


def test_an_empty_sqlite_file_is_migrated(tmp_path):
    sqlite3.connect(tmp_path / DB_NAME).close()  # a file with no tables, version 0
    with StudyStore(tmp_path) as store:
        assert store.version == 2
        assert store.participants() == []


def test_a_version_1_study_keeps_its_data_through_the_migration_to_2(tmp_path):
    with StudyStore(tmp_path, migrations=MIGRATIONS[:1]) as store:  # as the first release made it
        assert store.version == 1
        pid = "p0123abcd"
        with store.transaction() as db:  # the first release's enrolment
            db.execute(
                "INSERT INTO participants (id, consented_at, order_row, conditions) "
                "VALUES (?, 0, 0, ?)",
                (pid, json.dumps([CONDITION])),
            )
        store.answer(pid, "sus", 1, "sus1", "4")
        store.add_game(pid, 1, CONDITION, metrics())
    with StudyStore(tmp_path) as store:
        assert store.version == 2
        assert store.participant(pid)["keep_recordings"] == 0  # nobody was asked then
        assert store.answers(pid)[0]["value"] == "4"
        assert store.games(pid)[0]["outcome"] == "win"
        assert [r["version"] for r in store.query("SELECT version FROM schema_version")] == [1, 2]
        assert store.enrol(lambda row: [CONDITION], keep_recordings=True)["keep_recordings"] == 1


def test_a_failed_migration_leaves_the_older_version(tmp_path):
    StudyStore(tmp_path).close()
    broken = [*MIGRATIONS, "CREATE TABLE extra (x); SELECT * FROM no_such_table"]
    with pytest.raises(DataError):
        StudyStore(tmp_path, migrations=broken)
    db = sqlite3.connect(tmp_path / DB_NAME)
    assert schema_version(db) == 2
    assert not db.execute("SELECT 1 FROM sqlite_master WHERE name = 'extra'").fetchone()
    assert migrate(db) == 2  # and a sound oxbot opens it as before


def test_a_newer_database_is_refused_with_what_to_do(tmp_path):
    StudyStore(tmp_path, migrations=[*MIGRATIONS, "CREATE TABLE later (x)"]).close()
    with pytest.raises(DataError, match="update oxbot"):
        StudyStore(tmp_path)


def test_the_folder_and_files_are_private(tmp_path):
    folder = tmp_path / "study"
    with StudyStore(folder) as store:
        store.enrol(lambda row: [CONDITION])
        files = [p for p in folder.iterdir() if p.name.startswith(DB_NAME)]
        assert {p.name for p in files} >= {DB_NAME, f"{DB_NAME}-wal"}
        for path in files:
            assert stat.S_IMODE(path.stat().st_mode) == 0o600, path
    assert stat.S_IMODE(folder.stat().st_mode) == 0o700
    assert store.query  # the store kept its settings
    assert integrity(folder / DB_NAME) == "ok"


def test_the_database_waits_for_a_busy_writer_and_journals_ahead(tmp_path):
    with StudyStore(tmp_path) as store:
        assert store.query("PRAGMA journal_mode")[0]["journal_mode"] == "wal"
        assert store.query("PRAGMA busy_timeout")[0]["timeout"] >= 1000


def test_participants_get_random_ids_and_the_next_row(tmp_path):
    design = Design(vary=("manager", "starter"))
    with StudyStore(tmp_path) as store:
        enrolled = [store.enrol(design.order) for _ in range(5)]
    ids = [p["id"] for p in enrolled]
    assert len(set(ids)) == 5
    assert all(len(i) == 9 and i.startswith("p") and int(i[1:], 16) >= 0 for i in ids)
    assert [p["order_row"] for p in enrolled] == [0, 1, 2, 3, 4]
    assert enrolled[0]["conditions"] == design.order(0)
    assert enrolled[4]["conditions"] == design.order(0)  # 4 conditions: the square again


def test_a_changed_answer_replaces_the_earlier_one(tmp_path):
    with StudyStore(tmp_path) as store:
        pid = store.enrol(lambda row: [CONDITION])["id"]
        store.answer(pid, "sus", 1, "sus1", "2")
        store.answer(pid, "sus", 1, "sus1", "5")
        assert [a["value"] for a in store.answers(pid)] == ["5"]


def test_games_are_numbered_within_their_block(tmp_path):
    with StudyStore(tmp_path) as store:
        pid = store.enrol(lambda row: [CONDITION, CONDITION])["id"]
        assert store.add_game(pid, 1, CONDITION, metrics()) == 1
        assert store.add_game(pid, 1, CONDITION, metrics(outcome="loss")) == 2
        assert store.add_game(pid, 2, CONDITION, metrics()) == 1
        assert [g["outcome"] for g in store.games(pid)] == ["win", "loss", "win"]


def test_forget_leaves_no_byte_of_the_participant(tmp_path):
    with StudyStore(tmp_path) as store:
        gone = store.enrol(lambda row: [CONDITION])["id"]
        kept = store.enrol(lambda row: [CONDITION])["id"]
        for pid in (gone, kept):
            store.answer(pid, "pre", 0, "age_band", "25-34")
            store.add_game(pid, 1, CONDITION, metrics(transcript=f'[{{"text": "{pid}"}}]'))
        store.forget(gone)
        assert [p["id"] for p in store.participants()] == [kept]
        assert {a["participant_id"] for a in store.answers()} == {kept}
        assert {g["participant_id"] for g in store.games()} == {kept}
        with pytest.raises(DataError, match="no participant"):
            store.forget(gone)
    for path in tmp_path.iterdir():
        data = path.read_bytes()
        assert gone.encode() not in data, path
    assert kept.encode() in (tmp_path / DB_NAME).read_bytes()
    assert integrity(tmp_path / DB_NAME) == "ok"
