"""`kill -9` during a recorded game loses at most the turn under way."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time

from oxbot.recording import RecordingStore

PLAYER = """
import sqlite3, sys, torch
torch.set_num_threads(1)
from oxbot.recording import RecordingStore
from oxbot.testing.recorded_game import play_recorded_game

folder = sys.argv[1]
store = RecordingStore(folder)
reader = sqlite3.connect(store.path)

def committed(_turns):
    count = reader.execute("SELECT COUNT(*) FROM turns").fetchone()[0]
    print(f"committed {count}", flush=True)

play_recorded_game(store, seed=4, on_turn=committed)
print("finished", flush=True)
"""


def test_kill_9_mid_game_keeps_every_committed_turn(tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    child = subprocess.Popen(
        [sys.executable, "-c", PLAYER, str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=env,
    )
    committed = 0
    deadline = time.monotonic() + 120
    try:
        for line in child.stdout:  # type: ignore[union-attr]
            if line.startswith("finished") or time.monotonic() > deadline:
                break
            if line.startswith("committed"):
                committed = int(line.split()[1])
                if committed >= 6:  # mid-game: the person has agreed, moves are under way
                    break
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait(10)
    assert committed >= 6, "the game never got going"
    assert child.returncode == -signal.SIGKILL

    db = sqlite3.connect(tmp_path / "recordings.sqlite3")
    assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    db.close()
    with RecordingStore(tmp_path) as store:
        (session,) = store.sessions()
        turns = store.session(session.id)["turns"]
    assert session.status == "playing"  # no goodbye was recorded: the game was cut short
    assert len(turns) >= committed
    assert [t["seq"] for t in turns] == list(range(1, len(turns) + 1))
    assert turns[0]["act"] == "Salutation(greeting)"
