"""Learning from recorded games, seed by seed: the dialogue side and the recordings' safety.

    PYTHONPATH=. .venv/bin/python bench/bench_learn_agent_seeds.py --seeds 0-29
    PYTHONPATH=. .venv/bin/python bench/bench_learn_agent_seeds.py --part crash --seeds 0-29

`--part agent` (the default): for each seed, `bench_learn.learn_agent_before_after`: 200
dialogues of the shipped policy with people who decline twice as often and are heard with twice
the noise are recorded, `oxbot learn agent` learns from them, and the shipped policy and the
one in use after it (the learnt one, or the shipped one where `learn agent` refused; the refused
one's figures are printed too) are measured against that population (`--eval-games` per
who-starts condition). The line holds when the policy in use after asks again no more often than
before (`repeated_questions_per_dialogue`) and none of its dialogues is ill formed by its own
fault (`ill_formed_by_the_policy`: what `wellformed.blame` does not put on a mishearing the
policy could not know of; docs/learning.md).

`--part crash`: for each seed, a recorded game (`oxbot.testing.recorded_game`, that seed) is
killed with SIGKILL after a number of committed turns drawn from the seed (4-12); the line holds
when the database passes `PRAGMA integrity_check`, every committed turn is there in order, and
`forget` then leaves no trace of the session in the data folder's files (a crop's bytes, the
robot's and the person's words).

Not a test: it plays real games and trains for real (about 2 minutes a seed for the agent).
"""

from __future__ import annotations

import argparse
import os
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from bench_learn import learn_agent_before_after
from bench_learn_seeds import seed_range

from oxbot.recording import RecordingStore

PLAYER = """
import sqlite3, sys, torch
torch.set_num_threads(1)
from oxbot.recording import RecordingStore
from oxbot.testing.recorded_game import play_recorded_game

store = RecordingStore(sys.argv[1])
reader = sqlite3.connect(store.path)

def committed(_turns):
    count = reader.execute("SELECT COUNT(*) FROM turns").fetchone()[0]
    print(f"committed {count}", flush=True)

play_recorded_game(store, seed=int(sys.argv[2]), on_turn=committed)
print("finished", flush=True)
"""


def agent_line(seed: int, args: argparse.Namespace) -> bool:
    """One seed of the dialogue line; prints its figures and returns whether it holds."""
    metrics, before, candidate, seconds, refused = learn_agent_before_after(
        seed, args.dialogues, args.steps, args.eval_games
    )
    after = before if refused else candidate  # a refused policy leaves the shipped one in use
    repeats = (before["repeated_questions_per_dialogue"], after["repeated_questions_per_dialogue"])
    own = (before["ill_formed_by_the_policy"], after["ill_formed_by_the_policy"])
    holds = repeats[1] <= repeats[0] and own[1] == 0
    print(
        f"seed {seed:3d}: asked again {repeats[0]:.3f} -> {repeats[1]:.3f}, ill formed by the "
        f"policy {own[0]} -> {own[1]} (all ill formed {before['ill_formed']} -> "
        f"{after['ill_formed']}), losses {after['losses']}, kept piece {metrics['kept']}, "
        f"{seconds:.0f} s: {'holds' if holds else 'NOT'}",
        flush=True,
    )
    if refused:
        print(
            f"          refused, so the shipped policy stays; the refused one: asked again "
            f"{candidate['repeated_questions_per_dialogue']:.3f}, ill formed by the policy "
            f"{candidate['ill_formed_by_the_policy']} (all {candidate['ill_formed']}), losses "
            f"{candidate['losses']}",
            flush=True,
        )
    if own[1]:
        print(f"          problems after: {after['problems']}", flush=True)
    return holds


def crash_line(seed: int) -> bool:
    """One seed of the kill -9 and forget line; prints its figures and returns whether it holds."""
    kill_after = int(np.random.default_rng(seed).integers(4, 13))
    with tempfile.TemporaryDirectory() as folder:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
        child = subprocess.Popen(
            [sys.executable, "-c", PLAYER, folder, str(seed)],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=env,
        )
        committed, deadline = 0, time.monotonic() + 150
        try:
            for line in child.stdout:  # type: ignore[union-attr]
                if line.startswith("finished") or time.monotonic() > deadline:
                    break
                if line.startswith("committed"):
                    committed = int(line.split()[1])
                    if committed >= kill_after:
                        break
        finally:
            os.kill(child.pid, signal.SIGKILL)
            child.wait(10)
        db = sqlite3.connect(Path(folder) / "recordings.sqlite3")
        integrity = db.execute("PRAGMA integrity_check").fetchone()[0]
        db.close()
        with RecordingStore(folder) as store:
            (session,) = store.sessions()
            turns = store.session(session.id)["turns"]
            crops = store.query("SELECT image FROM crops WHERE session_id = ?", (session.id,))
            words = [t["text"].encode() for t in turns if len(t["text"]) >= 6]
            traces = [c["image"][20:60] for c in crops] + words
            store.forget(session.id)
            left = len(store.sessions())
        raw = b"".join(p.read_bytes() for p in Path(folder).iterdir() if p.is_file())
    kept = len(turns) >= committed and [t["seq"] for t in turns] == list(range(1, len(turns) + 1))
    traced = sum(trace in raw for trace in traces)
    holds = integrity == "ok" and kept and left == 0 and traced == 0 and committed >= kill_after
    print(
        f"seed {seed:3d}: killed after {committed} committed turns (aimed at {kill_after}), "
        f"integrity {integrity}, {len(turns)} turns kept in order: {kept}; after forget "
        f"{left} sessions, {traced} of {len(traces)} traces left: {'holds' if holds else 'NOT'}",
        flush=True,
    )
    return holds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("agent", "crash"), default="agent")
    parser.add_argument("--seeds", default="0-29", help="e.g. 0-29 or 3,5")
    parser.add_argument("--dialogues", type=int, default=200, help="recorded dialogues (agent)")
    parser.add_argument("--steps", type=int, default=30_000, help="fine-tuning steps (agent)")
    parser.add_argument("--eval-games", type=int, default=1_000, help="per condition (agent)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    seeds = seed_range(args.seeds)
    held = [agent_line(s, args) if args.part == "agent" else crash_line(s) for s in seeds]
    print(f"{args.part}: the line holds at {sum(held)} of {len(held)} seeds")


if __name__ == "__main__":
    main()
