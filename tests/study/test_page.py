"""The study's routes: consent, answers, progress, the experimenter's token, results and plots."""

from __future__ import annotations

import csv
import io
from statistics import fmean

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from oxbot.config import OxbotConfig
from oxbot.errors import ConfigError
from oxbot.study.conditions import Design
from oxbot.study.instruments import score
from oxbot.study.page import add_routes
from oxbot.study.session import Study
from oxbot.web.server import create_app

SUS_ANSWERS = ["4241524251", "3333333333", "5151515151"]


def metrics(outcome: str, turns: int) -> dict:
    return {
        "status": "ended",
        "outcome": outcome,
        "success": int(outcome in ("win", "draw", "loss")),
        "turns": turns,
        "moves": 3,
        "duration": 30.0,
        "time_per_move": 3.0,
        "confidence": None,
        "spoken": 0,
        "typed": 2,
        "asked_again": 0,
        "corrected": 0,
        "well_formed": 1,
        "problem": "",
        "transcript": "[]",
    }


@pytest.fixture
def study(tmp_path) -> Study:
    return Study(tmp_path / "study", Design(vary=("manager",), games=2))


@pytest.fixture
def client(study) -> TestClient:
    config = OxbotConfig()
    app = create_app(config)
    add_routes(app, study, config)
    # no lifespan: no robot models loaded; a Host the server takes for its own
    return TestClient(app, base_url="http://127.0.0.1:8000")


def enrol(client: TestClient) -> dict:
    reply = client.post("/study/consent", json={"consent": True})
    assert reply.status_code == 200
    return reply.json()


def answer(client, pid, instrument, block, item, value):
    return client.post(
        "/study/answer",
        json={
            "participant": pid,
            "instrument": instrument,
            "block": block,
            "item": item,
            "value": value,
        },
    )


def test_without_a_yes_nothing_is_written(client, study, tmp_path):
    assert "Nothing at all is kept" in client.get("/study/setup").json()["consent"]
    assert client.post("/study/consent", json={"consent": False}).json() == {"kept": False}
    assert client.post("/study/consent", content=b"yes").status_code == 415
    assert answer(client, "p00000000", "sus", 1, "sus1", "3").status_code == 404
    assert client.get(f"/study/results?token={study.token}").json()["participants"] == []
    assert client.get(f"/study/plot/sus.png?token={study.token}").status_code == 200
    assert list(tmp_path.iterdir()) == []  # not even the study's folder


def test_the_consent_page_says_what_is_kept_how_long_and_how_to_withdraw(client, study):
    text = client.get("/study/setup").json()["consent"]
    assert study.retention in text
    for words in ("What is kept", "withdraw", "never asked", "stop at any time"):
        assert words in text


def test_a_yes_enrols_a_participant_with_their_conditions(client, study):
    first, second = enrol(client), enrol(client)
    assert first["participant"] != second["participant"]
    assert [c["manager"] for c in first["conditions"]] == ["dqn", "rules"]
    assert [c["manager"] for c in second["conditions"]] == ["rules", "dqn"]
    assert (study.folder / "study.sqlite3").exists()
    assert study.store().participant(first["participant"])["keep_recordings"] == 0
    third = client.post("/study/consent", json={"consent": True, "recordings": True}).json()
    assert study.store().participant(third["participant"])["keep_recordings"] == 1
    assert not (study.folder / "recordings.sqlite3").exists()  # made at their first game


def test_answers_are_checked_and_kept(client, study):
    pid = enrol(client)["participant"]
    assert answer(client, pid, "pre", 0, "age_band", "25-34").status_code == 200
    assert answer(client, pid, "sus", 1, "sus1", "6").status_code == 400
    assert answer(client, pid, "sus", 3, "sus1", "3").status_code == 400  # 2 blocks
    assert answer(client, pid, "pre", 1, "age_band", "25-34").status_code == 400
    assert answer(client, pid, "sus", 2, "sus1", "3").status_code == 200
    kept = [(a["instrument"], a["block"], a["value"]) for a in study.store().answers(pid)]
    assert kept == [("pre", 0, "25-34"), ("sus", 2, "3")]


def test_progress_counts_each_blocks_games(client, study):
    p = enrol(client)
    pid = p["participant"]
    study.store().add_game(pid, 1, p["conditions"][0], metrics("win", 10))
    assert client.get(f"/study/progress/{pid}").json() == {"games": {"1": 1, "2": 0}}
    assert client.get("/study/progress/nobody").status_code == 404


def test_the_experimenters_pages_need_the_token(client, study):
    for path in (
        "/study/experimenter",
        "/study/results",
        "/study/plot/sus.png",
        "/study/export.csv",
    ):
        assert client.get(path).status_code == 403, path
        assert client.get(f"{path}?token=wrong").status_code == 403, path
        reply = client.get(path, headers={"X-Study-Token": study.token})
        assert reply.status_code == 200, path
    assert client.get(f"/study/plot/sus.png?token={study.token}").content[:4] == b"\x89PNG"
    assert client.get(f"/study/plot/nothing.png?token={study.token}").status_code == 404


def test_the_game_page_is_the_robots_with_the_studys_script(client):
    page = client.get("/study/game?participant=x&block=1").text
    assert 'data-testid="board"' in page and "/study/static/game.js" in page
    assert "socketPath" in client.get("/study/static/game.js").text


def refusal(client, url: str) -> tuple[int, str]:
    with pytest.raises(WebSocketDisconnect) as closed, client.websocket_connect(url) as ws:
        ws.receive_text()
    return closed.value.code, closed.value.reason


def test_a_game_socket_for_no_participant_or_a_finished_block_is_closed(client, study):
    assert refusal(client, "/study/ws?participant=nobody&block=1")[0] == 1008
    p = enrol(client)
    pid = p["participant"]
    assert refusal(client, f"/study/ws?participant={pid}&block=3")[0] == 1008
    for _ in range(2):  # the design's 2 games
        study.store().add_game(pid, 1, p["conditions"][0], metrics("win", 10))
    assert refusal(client, f"/study/ws?participant={pid}&block=1") == (
        1008,
        "this part's games are all played",
    )


def test_the_pages_means_match_a_recomputation_from_the_csv(client, study):
    token = study.token
    for k, sus in enumerate(SUS_ANSWERS):
        p = enrol(client)
        pid = p["participant"]
        for block, condition in enumerate(p["conditions"], start=1):
            for game in range(2):
                outcome = ("win", "declined", "draw")[(k + block + game) % 3]
                study.store().add_game(pid, block, condition, metrics(outcome, 8 + k + game))
            for i, value in enumerate(sus, start=1):
                assert answer(client, pid, "sus", block, f"sus{i}", value).status_code == 200
    summary = client.get(f"/study/results?token={token}").json()["summary"]
    rows = list(csv.DictReader(io.StringIO(client.get(f"/study/export.csv?token={token}").text)))
    assert len(rows) == 6
    for condition, measures in summary.items():
        mine = [r for r in rows if r["condition"] == condition]
        assert measures["sus"]["n"] == len(mine) == 3
        assert measures["sus"]["mean"] == pytest.approx(fmean(float(r["sus"]) for r in mine))
        assert measures["turns"]["mean"] == pytest.approx(fmean(float(r["turns"]) for r in mine))
        low, high = measures["sus"]["low"], measures["sus"]["high"]
        assert low < measures["sus"]["mean"] < high
    # and from the raw answers, scored again by hand-worked rules
    by_hand = [score("sus", {f"sus{i}": v for i, v in enumerate(s, start=1)}) for s in SUS_ANSWERS]
    assert by_hand == [85.0, 50.0, 100.0]
    both = fmean(by_hand)
    assert all(m["sus"]["mean"] == pytest.approx(both) for m in summary.values())


def test_a_study_carried_on_must_keep_its_design(tmp_path):
    folder = tmp_path / "study"
    Study(folder, Design(vary=("manager",))).enrol()
    Study(folder, Design(vary=("manager",)))  # the same design: carries on
    with pytest.raises(ConfigError, match="same --vary"):
        Study(folder, Design(vary=("input",)))


def test_another_sites_page_cannot_enrol_or_answer(client, tmp_path):
    evil = {"Origin": "http://evil.example"}
    assert client.post("/study/consent", json={"consent": True}, headers=evil).status_code == 403
    # a form or no-cors post sends no JSON content type: refused before it is read
    plain = {"Content-Type": "text/plain"}
    reply = client.post("/study/consent", content=b'{"consent": true}', headers=plain)
    assert reply.status_code == 415
    rebound = {"Host": "attacker.example:8000"}
    assert client.post("/study/consent", json={"consent": True}, headers=rebound).status_code == 403
    assert list(tmp_path.iterdir()) == []
    own = {"Origin": "http://127.0.0.1:8000"}
    assert client.post("/study/consent", json={"consent": True}, headers=own).json()["kept"]
