"""Benchmark of the opening: how long from the page's Start to the robot's invitation to play.

    .venv/bin/python bench/bench_start.py                 # 10 starts, the person keeps quiet
    .venv/bin/python bench/bench_start.py --starts 5 --pause 0   # the waits before the pause

Starts a real server as `oxbot play` does (real robots, Piper's voice making every sentence in
the background, real time: speed factor 1) on a free localhost port, waits `--settle` seconds
(a person opening the printed address), and opens Debian's Chromium on it; each start is a
fresh tab that clicks Start and keeps quiet. Measured by the page's own clock, from the click to
the log's "Request(playGame)" (the invitation is shown as the robot begins to say it), with when
the greeting and the introduction appeared. The goal: at most 4 s. Prints each start, the median
and the 90th percentile; not a test.
"""

from __future__ import annotations

import argparse
import statistics
import time

from oxbot.config import load_config
from oxbot.robot.session import prepare_voice
from oxbot.testing.browser import CHROMIUM, FLAGS
from oxbot.web.server import create_app, serving_in_background

TIMES = """() => {
  const acts = window.oxbot.stats.acts;
  const at = (act) => { const a = acts.find((x) => x.act === act); return a ? a.at : null; };
  return [at("Salutation(greeting)"), at("Provide(name)"), at("Request(playGame)")];
}"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--starts", type=int, default=10)
    parser.add_argument("--pause", type=float, default=None, help="robot.pause_timeout")
    parser.add_argument(
        "--settle", type=float, default=5.0, help="seconds from the server's start to the first"
    )
    args = parser.parse_args()
    settings = [] if args.pause is None else [f"robot.pause_timeout={args.pause}"]
    config = load_config(None, settings)
    from playwright.sync_api import sync_playwright

    rows = []
    with serving_in_background(create_app(config)) as url, sync_playwright() as p:
        prepare_voice(config)  # as `oxbot play` does once its port is free
        time.sleep(args.settle)
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=list(FLAGS))
        try:
            for k in range(args.starts):
                page = browser.new_page()
                page.goto(url + "/")
                clicked = page.evaluate("performance.now()")
                page.get_by_test_id("start").click()
                page.wait_for_function(
                    """() => window.oxbot.stats.acts.some((a) => a.act === "Request(playGame)")""",
                    timeout=60_000,
                )
                greeting, name, invitation = (
                    (t - clicked) / 1e3 if t is not None else float("nan")
                    for t in page.evaluate(TIMES)
                )
                rows.append(invitation)
                print(
                    f"start {k + 1}: greeting {greeting:.2f} s, name {name:.2f} s, "
                    f"invitation {invitation:.2f} s",
                    flush=True,
                )
                page.close()
        finally:
            browser.close()
    p90 = statistics.quantiles(rows, n=10)[-1] if len(rows) >= 2 else rows[0]
    print(
        f"Start to the invitation over {len(rows)} starts (pause_timeout "
        f"{config.robot.pause_timeout:g} s): median {statistics.median(rows):.2f} s, "
        f"p90 {p90:.2f} s, max {max(rows):.2f} s (goal: at most 4 s)"
    )


if __name__ == "__main__":
    main()
