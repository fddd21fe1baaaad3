"""A worked example of a study on simulated participants, through the real server and robots.

    .venv/bin/python bench/bench_study.py                        # 6 participants, 2 conditions
    .venv/bin/python bench/bench_study.py --participants 8 --vary manager,starter --blocks 4

Serves `oxbot study` on a free localhost port and runs each simulated participant as the page
would: consent (`POST /study/consent`), the questions about them, then each of their conditions'
games over the study's WebSocket (`oxbot.testing.player`: the page's sheet drawn in Python, the
answers typed), then SUS and the two Godspeed scales, answered at random around a leaning the
seed draws for each participant. Then it exports the study (`oxbot study export`), checks that
the experimenter page's means are the CSV's, and prints the per-condition table docs/study.md
shows. Prints; not a test (tests/study/test_game.py plays one study game).
"""

from __future__ import annotations

import argparse
import asyncio
import csv
import sys
import tempfile
import time
from pathlib import Path
from statistics import fmean

import httpx
import numpy as np

from oxbot.config import load_config
from oxbot.study.conditions import Design
from oxbot.study.export import export
from oxbot.study.instruments import AFTER_CONDITION, PRE
from oxbot.study.page import add_routes
from oxbot.study.session import Study
from oxbot.testing.player import play_game
from oxbot.web.server import create_app, serving_in_background


def answer_all(client: httpx.Client, pid: str, instrument, block: int, lean: float, rng) -> None:
    """Answer every item of `instrument`: a category at random, or 1-5 near `lean` (reversed
    for SUS's even, negative items)."""
    for i, item in enumerate(instrument.items, start=1):
        if instrument.name == PRE.name:
            value = item.values[int(rng.integers(len(item.values)))]
        else:
            centre = 6 - lean if instrument.name == "sus" and i % 2 == 0 else lean
            value = str(int(np.clip(np.rint(centre + rng.normal(0, 0.8)), 1, 5)))
        reply = client.post(
            "/study/answer",
            json={
                "participant": pid,
                "instrument": instrument.name,
                "block": block,
                "item": item.key,
                "value": value,
            },
        )
        reply.raise_for_status()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--participants", type=int, default=6)
    parser.add_argument("--vary", default="manager,starter")
    parser.add_argument("--blocks", type=int, default=2)
    parser.add_argument("--games", type=int, default=1)
    parser.add_argument("--speed", type=float, default=8.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="where to export (default: temp)")
    args = parser.parse_args()
    config = load_config(
        None,
        [f"robot.speed_factor={args.speed}", "robot.answer_timeout=16", "robot.move_timeout=240"],
    )
    rng = np.random.default_rng(args.seed)
    folder = Path(tempfile.mkdtemp(prefix="oxbot-study-"))
    design = Design(tuple(args.vary.split(",")), args.games, args.blocks)
    study = Study(folder / "study", design)
    app = create_app(config)
    add_routes(app, study, config)
    started = time.monotonic()
    with serving_in_background(app) as url, httpx.Client(base_url=url, timeout=60) as client:
        ws_base = url.replace("http://", "ws://")
        for k in range(args.participants):
            p = client.post("/study/consent", json={"consent": True}).json()
            pid, lean = p["participant"], float(rng.uniform(2.5, 4.5))
            answer_all(client, pid, PRE, 0, lean, rng)
            for block, condition in enumerate(p["conditions"], start=1):
                for game in range(args.games):
                    ws = f"{ws_base}/study/ws?participant={pid}&block={block}"
                    record = asyncio.run(play_game(ws, seed=100 * k + 10 * block + game))
                    print(
                        f"{pid} block {block} {'/'.join(condition.values())}: "
                        f"{record.outcome} in {record.seconds:.1f} s",
                        flush=True,
                    )
                deadline = time.monotonic() + 10  # the game's metrics are kept at its goodbye
                while time.monotonic() < deadline:
                    done = client.get(f"/study/progress/{pid}").json()["games"][str(block)]
                    if done >= args.games:
                        break
                    time.sleep(0.1)
                for instrument in AFTER_CONDITION:
                    answer_all(client, pid, instrument, block, lean, rng)
        results = client.get(f"/study/results?token={study.token}").json()
    out = args.out or folder / "export"
    export(study.store(), out)
    with open(out / "blocks.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    mismatches = 0
    for condition, measures in results["summary"].items():
        for measure in ("success", "turns", "sus", "likeability", "intelligence"):
            mine = [float(r[measure]) for r in rows if r["condition"] == condition and r[measure]]
            if mine and abs(fmean(mine) - measures[measure]["mean"]) > 1e-9:
                mismatches += 1
    print(
        f"\n{args.participants} participants, {len(rows)} blocks in "
        f"{time.monotonic() - started:.0f} s; exported to {out}"
    )
    print(f"experimenter page's means that differ from blocks.csv's: {mismatches}")
    print("\n| condition | blocks | success | turns | SUS | likeability | intelligence |")
    print("|---|---|---|---|---|---|---|")
    for condition, m in results["summary"].items():
        cells = []
        for measure in ("success", "turns", "sus", "likeability", "intelligence"):
            s = m[measure]
            if s["low"] is None:
                cells.append(f"{s['mean']:.2f}" if s["mean"] is not None else "-")
            else:
                cells.append(f"{s['mean']:.2f} [{s['low']:.2f}, {s['high']:.2f}]")
        print(f"| {condition} | {m['sus']['n']} | " + " | ".join(cells) + " |")
    study.close()
    return 1 if mismatches else 0


if __name__ == "__main__":
    sys.exit(main())
