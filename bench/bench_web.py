"""Benchmark of the web page: how soon a person's drawing becomes a move.

    .venv/bin/python bench/bench_web.py                    # 6 scripted games, 2 in Chromium
    .venv/bin/python bench/bench_web.py --games 10 --browser-games 0 --concurrent 20

The goal: a stroke becomes a move within 0.5 s after it ends — the board is read every
100 ms and a drawing is accepted on its third agreeing reading, so about 0.2-0.3 s plus the
processing. Starts a real server (real robots) on a free localhost port and measures, from the
moment the finished sheet leaves the client to the moment the robot's GameMove arrives back:

- scripted games over the WebSocket (`oxbot.testing.player`: the page's sheet drawn in Python,
  the whole symbol sent when its last stroke ends, as the page does on pointerup);
- games in Debian's Chromium, drawn with the mouse (from `pointerup` to the GameMove message
  in the page, measured by the page's own clock);
- optionally N scripted games at once (`--concurrent`), which on 2 cores all draw within the
  same few milliseconds, the worst case for a shared server.

The robot's speech and arm run `--speed` times faster than real time (the board is read at
10 Hz whatever the speed). Prints medians; not a test.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from oxbot.config import load_config
from oxbot.testing.browser import CHROMIUM, FLAGS, draw
from oxbot.testing.player import play_game
from oxbot.web.server import create_app, serving_in_background


def summary(name: str, seconds: list[float]) -> None:
    if not seconds:
        print(f"  {name:44s} no samples")
        return
    ms = sorted(1000 * s for s in seconds)
    p90 = ms[min(len(ms) - 1, int(0.9 * len(ms)))]
    print(
        f"  {name:44s} median {statistics.median(ms):6.0f} ms   p90 {p90:6.0f} ms   "
        f"max {ms[-1]:6.0f} ms   ({len(ms)} moves)"
    )


async def scripted(ws_url: str, games: int, concurrent: int, seed: int) -> list[float]:
    latencies: list[float] = []
    for start in range(0, games, concurrent):
        batch = range(start, min(games, start + concurrent))
        records = await asyncio.gather(
            *(play_game(ws_url, seed=seed + i, timeout=300) for i in batch)
        )
        for r in records:
            if not r.ended or r.errors or r.failures:
                print(f"  session {r.session}: {r.failures or r.errors}", file=sys.stderr)
            latencies += r.latencies
    return latencies


def browser(url: str, games: int, seed: int) -> list[float]:
    """Play `games` games in Chromium with the mouse; the page's stroke-to-move times."""
    from playwright.sync_api import sync_playwright

    rng = np.random.default_rng(seed)
    latencies: list[float] = []
    with sync_playwright() as p, tempfile.TemporaryDirectory() as profile:
        context = p.chromium.launch_persistent_context(
            profile, executable_path=CHROMIUM, headless=True, args=list(FLAGS)
        )
        page = context.pages[0] if context.pages else context.new_page()
        page.goto(url + "/")
        for game in range(games):
            earlier = page.locator("[data-testid=log] li[data-act]").count()
            page.get_by_test_id("start").click()
            page.wait_for_function("window.oxbot.hello !== null")
            answered = moves = 0
            deadline = time.monotonic() + 300
            while not page.evaluate("window.oxbot.ended") and time.monotonic() < deadline:
                acts = page.evaluate(
                    "[...document.querySelectorAll('[data-testid=log] li[data-act]')]"
                    ".map(li => [li.dataset.speaker, li.dataset.act])"
                )[earlier:]  # this game's turns only
                if not answered and ["sys", "Request(playGame)"] in acts:
                    page.get_by_test_id("say").fill("yes let's play")
                    page.get_by_test_id("say").press("Enter")
                    answered = 1
                requests = acts.count(["sys", "Request(userGameMove)"])
                if requests > moves and not page.evaluate("window.oxbot.pending.length"):
                    taken = {a[len("GameMove(gridloc=") : -1] for _, a in acts if "GameMove(" in a}
                    cells = page.evaluate("window.oxbot.hello.cells")
                    where = next(c for c in cells if c not in taken)
                    before = page.evaluate("window.oxbot.stats.moves.length")
                    draw(page, where, page.evaluate("window.oxbot.hello.user_symbol"), rng)
                    page.wait_for_function(f"window.oxbot.stats.moves.length > {before}")
                    stats = page.evaluate("window.oxbot.stats")
                    latencies.append((stats["moves"][-1]["at"] - stats["lastStrokeEnd"]) / 1000)
                    moves += 1
                page.wait_for_timeout(30)
            print(f"  browser game {game + 1}: {moves} moves", file=sys.stderr)
        context.close()
    return latencies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--games", type=int, default=6, help="scripted games, one at a time")
    parser.add_argument("--browser-games", type=int, default=2, help="games in Chromium")
    parser.add_argument("--concurrent", type=int, default=0, help="also N scripted at once")
    parser.add_argument("--speed", type=float, default=4.0, help="robot speech/arm speed-up")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    config = load_config(
        None, [f"robot.speed_factor={args.speed}", f"robot.answer_timeout={2.0 * args.speed}"]
    )
    print(f"== stroke end -> accepted move (robot speech/arm x{args.speed:g}, board read 10 Hz)")
    with serving_in_background(create_app(config)) as url:
        ws_url = url.replace("http://", "ws://") + "/ws"
        asyncio.run(scripted(ws_url, 1, 1, 999))  # loads the shared models; not measured
        summary(
            "scripted WebSocket client, one game at a time",
            asyncio.run(scripted(ws_url, args.games, 1, args.seed)),
        )
        if args.browser_games:
            if not Path(CHROMIUM).exists():
                sys.exit(f"{CHROMIUM} is missing: run `make setup`")
            summary(
                "Chromium, mouse drawing (pointerup -> move)",
                browser(url, args.browser_games, args.seed),
            )
        if args.concurrent:
            summary(
                f"{args.concurrent} scripted games at once, in lockstep",
                asyncio.run(scripted(ws_url, args.concurrent, args.concurrent, 500)),
            )
    print("  goal: <= 500 ms after the stroke ends")


if __name__ == "__main__":
    main()
