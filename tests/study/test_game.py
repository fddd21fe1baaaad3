"""A study's game through the real server and robot: the block's condition, its metrics kept,
its recording kept with the participant's yes, and all of it forgotten when they withdraw."""

from __future__ import annotations

import asyncio
import stat
import time

import httpx

from oxbot.config import load_config
from oxbot.recording.store import RecordingStore
from oxbot.study.conditions import Design
from oxbot.study.page import add_routes
from oxbot.study.session import Study
from oxbot.study.withdrawal import forget_participant
from oxbot.testing.player import play_game
from oxbot.web.server import create_app, serving_in_background

FAST = load_config(
    None, ["robot.speed_factor=8", "robot.answer_timeout=16", "robot.move_timeout=240"]
)


def test_a_study_game_plays_in_its_condition_and_keeps_its_metrics(tmp_path):
    study = Study(tmp_path / "study", Design(vary=("starter",), games=1))
    app = create_app(FAST)
    add_routes(app, study, FAST)
    with serving_in_background(app) as url, httpx.Client(base_url=url, timeout=30) as client:
        p = client.post("/study/consent", json={"consent": True, "recordings": True}).json()
        pid = p["participant"]
        assert [c["starter"] for c in p["conditions"]] == ["robot", "person"]
        ws = url.replace("http://", "ws://") + f"/study/ws?participant={pid}&block=2"
        record = asyncio.run(play_game(ws, seed=5, timeout=90, answer="no thanks"))
        assert record.ended, record
        assert record.user_symbol == "circle"  # the person starts, so draws circles
        deadline = time.monotonic() + 10
        while not (games := study.store().games(pid)) and time.monotonic() < deadline:
            time.sleep(0.1)
    assert len(games) == 1
    game = games[0]
    assert (game["block"], game["starter"], game["input"]) == (2, "person", "typing")
    assert game["outcome"] == record.outcome == "declined"
    assert game["status"] == "ended" and game["typed"] >= 1 and game["spoken"] == 0
    assert game["turns"] == len(record.transcript)
    assert game["well_formed"] == 1, game["problem"]

    # they agreed to keep the recordings too: the game is in the study's recordings, private
    folder = study.folder
    recordings = study.recordings()
    assert [s.mode for s in recordings.sessions()] == [f"study:{pid}"]
    study.close()
    assert stat.S_IMODE((folder / "recordings.sqlite3").stat().st_mode) == 0o600
    # withdrawing deletes both, and no byte of the id stays in either file
    forget_participant(folder, pid)
    with RecordingStore(folder) as after:
        assert after.sessions() == []
    for path in folder.iterdir():
        assert pid.encode() not in path.read_bytes(), path
