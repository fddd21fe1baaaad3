"""A worked example of a study on simulated participants, through the real server and robots.

    .venv/bin/python bench/bench_study.py                        # 6 participants, 2 conditions
    .venv/bin/python bench/bench_study.py --participants 8 --vary manager,starter --blocks 4
    .venv/bin/python bench/bench_study.py --browser             # each participant in Chromium

Serves `oxbot study` on a free localhost port and runs each simulated participant as the page
would: consent (`POST /study/consent`), the questions about them, then each of their conditions'
games over the study's WebSocket (`oxbot.testing.player`: the page's sheet drawn in Python, the
answers typed), then SUS and the two Godspeed scales, answered at random around a leaning the
seed draws for each participant. With `--browser` each participant goes through the real page
in Debian's Chromium instead: the consent page's button, the questions' radio buttons, the game
in its frame (the answer typed, each move drawn with the mouse), the questionnaires, the end.
Then it exports the study (`oxbot study export`), checks that the experimenter page's means are
the CSV's, and prints the per-condition table docs/study.md shows. Prints; not a test
(tests/study/test_game.py plays one study game, tests/study/test_browser.py the consent page).
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
    """Answer every item of `instrument` over HTTP, as the page does."""
    for i, item in enumerate(instrument.items, start=1):
        reply = client.post(
            "/study/answer",
            json={
                "participant": pid,
                "instrument": instrument.name,
                "block": block,
                "item": item.key,
                "value": likert(instrument, i, lean, rng),
            },
        )
        reply.raise_for_status()


def likert(instrument, i: int, lean: float, rng) -> str:
    """An answer to item `i` (1-based) of `instrument`: a category at random for the questions
    about the participant, else 1-5 near `lean` (reversed for SUS's even, negative items)."""
    item = instrument.items[i - 1]
    if instrument.name == PRE.name:
        return item.values[int(rng.integers(len(item.values)))]
    centre = 6 - lean if instrument.name == "sus" and i % 2 == 0 else lean
    return str(int(np.clip(np.rint(centre + rng.normal(0, 0.8)), 1, 5)))


class InFrame:
    """The game's frame with the page's mouse: what `oxbot.testing.browser.draw` needs."""

    def __init__(self, page, frame) -> None:
        self.mouse, self.context = page.mouse, page.context
        self.get_by_test_id = frame.get_by_test_id


def browser_participant(browser, url: str, lean: float, rng, seed: int) -> str:
    """One participant through the real page in Chromium; their code."""
    from oxbot.testing.browser import draw, log_items

    move = "GameMove(gridloc="
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    page.goto(f"{url}/study")
    page.get_by_test_id("consent-yes").click()
    page.get_by_test_id("questions").wait_for()
    pid = page.get_by_test_id("participant").inner_text().split()[-1]

    def answer(instruments) -> None:
        for instrument in instruments:
            for i, item in enumerate(instrument.items, start=1):
                value = likert(instrument, i, lean, rng)
                page.get_by_test_id(f"{instrument.name}-{item.key}-{value}").check()
        page.wait_for_selector("[data-testid=questions-next]:not([disabled])")
        page.get_by_test_id("questions-next").click()

    answer([PRE])
    while True:
        page.wait_for_selector(
            "[data-testid=games]:not([hidden]), [data-testid=done]:not([hidden])"
        )
        if page.get_by_test_id("done").is_visible():
            break
        frame = page.frame_locator("[data-testid=game]")
        frame.get_by_test_id("start").click()
        inner = next(f for f in page.frames if "/study/game" in f.url)
        inner.wait_for_function("window.oxbot && window.oxbot.hello", timeout=60_000)
        hello = inner.evaluate("window.oxbot.hello")
        wait = "[...document.querySelectorAll('[data-testid=log] li[data-act]')]"
        inner.wait_for_function(
            f"{wait}.some(li => li.dataset.act === 'Request(playGame)')", timeout=60_000
        )
        frame.get_by_test_id("say").fill("yes let's play")
        frame.get_by_test_id("say").press("Enter")
        deadline, drawer = time.monotonic() + 180, InFrame(page, frame)
        game_rng = np.random.default_rng(seed)
        while not inner.evaluate("window.oxbot.ended"):
            assert time.monotonic() < deadline, f"no goodbye: {log_items(inner)}"
            items = log_items(inner)
            asked = sum(s == "sys" and a == "Request(userGameMove)" for s, a, _ in items)
            mine = [a[len(move) : -1] for s, a, _ in items if s == "usr" and a.startswith(move)]
            robots = [a[len(move) : -1] for s, a, _ in items if s == "sys" and a.startswith(move)]
            if asked <= len(mine) or inner.evaluate("window.oxbot.pending.length") > 0:
                page.wait_for_timeout(100)
                continue
            where = next(c for c in hello["cells"] if c not in mine and c not in robots)
            draw(drawer, where, hello["user_symbol"], game_rng)
            page.wait_for_timeout(300)
        page.wait_for_selector(
            "[data-testid=questions]:not([hidden]), [data-testid=games-title]", timeout=30_000
        )
        page.wait_for_selector("[data-testid=questions]:not([hidden])", timeout=30_000)
        answer(list(AFTER_CONDITION))
    page.close()
    return pid


def over_the_socket(client: httpx.Client, url: str, args, rng) -> None:
    """Every participant over HTTP and the study's WebSocket (the scripted player)."""
    ws_base = url.replace("http://", "ws://")
    for k in range(args.participants):
        p = client.post("/study/consent", json={"consent": True, "recordings": args.recordings})
        p = p.json()
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
                if client.get(f"/study/progress/{pid}").json()["games"][str(block)] >= args.games:
                    break
                time.sleep(0.1)
            for instrument in AFTER_CONDITION:
                answer_all(client, pid, instrument, block, lean, rng)


def in_chromium(url: str, args, rng) -> None:
    """Every participant through the real page in Debian's Chromium."""
    from playwright.sync_api import sync_playwright

    from oxbot.testing.browser import CHROMIUM, FLAGS

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=list(FLAGS))
        try:
            for k in range(args.participants):
                started = time.monotonic()
                lean = float(rng.uniform(2.5, 4.5))
                pid = browser_participant(browser, url, lean, rng, seed=k)
                print(f"{pid} in Chromium: {time.monotonic() - started:.0f} s", flush=True)
        finally:
            browser.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--participants", type=int, default=6)
    parser.add_argument("--vary", default="manager,starter")
    parser.add_argument("--blocks", type=int, default=2)
    parser.add_argument("--games", type=int, default=1)
    parser.add_argument("--speed", type=float, default=8.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="where to export (default: temp)")
    parser.add_argument("--browser", action="store_true", help="each participant in Chromium")
    parser.add_argument(
        "--recordings", action="store_true", help="participants agree to keep the recordings"
    )
    parser.add_argument("--folder", type=Path, default=None, help="the study's folder")
    args = parser.parse_args()
    config = load_config(
        None,
        [f"robot.speed_factor={args.speed}", "robot.answer_timeout=16", "robot.move_timeout=240"],
    )
    rng = np.random.default_rng(args.seed)
    folder = Path(tempfile.mkdtemp(prefix="oxbot-study-"))
    design = Design(tuple(args.vary.split(",")), args.games, args.blocks)
    study = Study(args.folder or folder / "study", design)
    app = create_app(config)
    add_routes(app, study, config)
    started = time.monotonic()
    with serving_in_background(app) as url, httpx.Client(base_url=url, timeout=60) as client:
        if args.browser:
            in_chromium(url, args, rng)
        else:
            over_the_socket(client, url, args, rng)
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
