"""`oxbot study export` and `oxbot study forget`: every answer and metric out, then no trace."""

from __future__ import annotations

import csv
import json

from typer.testing import CliRunner

from oxbot.cli import app
from oxbot.errors import ConfigError, DataError
from oxbot.study.export import DICTIONARY
from oxbot.study.store import StudyStore

from .test_store import CONDITION, metrics


def a_study(folder) -> list[str]:
    ids = []
    with StudyStore(folder) as store:
        for k in range(3):
            pid = store.enrol(lambda row: [CONDITION])["id"]
            ids.append(pid)
            store.answer(pid, "pre", 0, "age_band", "25-34")
            for i in range(1, 11):
                store.answer(pid, "sus", 1, f"sus{i}", str(1 + (i + k) % 5))
            store.add_game(pid, 1, CONDITION, metrics(turns=10 + k))
    return ids


def read(path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_export_writes_every_answer_and_metric_with_a_dictionary(tmp_path):
    ids = a_study(tmp_path / "study")
    out = tmp_path / "out"
    reply = CliRunner().invoke(
        app, ["study", "export", str(out), "--data-dir", str(tmp_path / "study")]
    )
    assert reply.exit_code == 0, reply.output
    answers = read(out / "answers.csv")
    assert len(answers) == 3 * 11
    games = read(out / "games.csv")
    assert sorted(int(g["turns"]) for g in games) == [10, 11, 12]
    assert set(games[0]) == set(DICTIONARY["games.csv"])
    blocks = read(out / "blocks.csv")
    assert {b["participant"] for b in blocks} == set(ids)
    assert all(b["sus"] for b in blocks)
    data = json.loads((out / "study.json").read_text())
    assert len(data["answers"]) == 33 and len(data["games"]) == 3
    meanings = read(out / "data_dictionary.csv")
    for name in DICTIONARY:
        header = (out / name).read_text().splitlines()[0].split(",")
        described = {m["column"] for m in meanings if m["file"] == name}
        assert set(header) == described, name


def test_forget_leaves_no_trace_in_the_database_or_later_exports(tmp_path):
    folder = tmp_path / "study"
    gone, *kept = a_study(folder)
    runner = CliRunner()
    reply = runner.invoke(app, ["study", "forget", gone, "--data-dir", str(folder)])
    assert reply.exit_code == 0, reply.output
    listing = runner.invoke(app, ["study", "list", "--data-dir", str(folder)]).output
    assert gone not in listing and all(k in listing for k in kept)
    out = tmp_path / "out"
    assert (
        runner.invoke(app, ["study", "export", str(out), "--data-dir", str(folder)]).exit_code == 0
    )
    for path in [*folder.iterdir(), *out.iterdir()]:
        assert gone.encode() not in path.read_bytes(), path
    again = runner.invoke(app, ["study", "forget", gone, "--data-dir", str(folder)])
    assert isinstance(again.exception, DataError) and "no participant" in str(again.exception)


def test_reading_a_study_that_never_began_creates_nothing(tmp_path):
    reply = CliRunner().invoke(app, ["study", "list", "--data-dir", str(tmp_path / "none")])
    assert isinstance(reply.exception, DataError)
    assert not (tmp_path / "none").exists()


def test_a_study_with_an_unknown_factor_is_refused_before_anything_is_made(tmp_path):
    reply = CliRunner().invoke(
        app, ["study", "--vary", "colour", "--data-dir", str(tmp_path / "study")]
    )
    assert isinstance(reply.exception, ConfigError) and "no factor colour" in str(reply.exception)
    assert not (tmp_path / "study").exists()
