"""Benchmark of paper mode: from the last stroke of a symbol to the robot's answer.

    .venv/bin/python bench/bench_paper.py               # 2 games in Chromium, 640x480 video
    .venv/bin/python bench/bench_paper.py --games 4 --size 1280x720
    .venv/bin/python bench/bench_paper.py --strokes     # how slow a circle may be drawn

The target: ≤ 0.6 s median with 640x480 video. A whole game is played in Debian's
Chromium on a rendered sheet that its fake webcam films (`oxbot.testing.webcam`: symbols drawn
stroke by stroke; each frame carries its index), against the real server and a real, seeded
robot. For each of the person's moves:

- *last stroke*: when the page grabbed the first camera frame showing the whole symbol (page
  clock; the bench matches the page's k-th sent frame with the k-th frame on the robot's bus,
  whose index it reads); and, earlier by up to a frame period, when the fake camera delivered
  that frame (the video's own clock: frame k at t0 + k/fps, t0 from the earliest grabs);
- *the robot's answer*: its next dialogue act shown in the page (the decision: "I take the
  ..."), and the start of its speech (SpeakingStarted, the synthesised audio arriving).

`--strokes` measures instead, without a browser, when the tracker accepts a circle drawn over
0.5-3 s, read once per video frame at the page's send width: the frames after (or, negative,
before) the one completing the stroke, with the ink of the stillness check measured as the
component does (each cell's fixed square) and as it did before (the classifier's crops).

The robot's speech runs `--speed` times faster than real time, which shortens nothing measured
here but the waits between moves. Prints medians; not a test.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import tempfile
import threading
from pathlib import Path

from playwright.sync_api import sync_playwright

from oxbot.config import load_config
from oxbot.errors import InvalidInputError
from oxbot.robot.frames import frame_pixels
from oxbot.robot.messages import Frame, GameMove
from oxbot.robot.session import Robot
from oxbot.testing.browser import CHROMIUM, FLAGS
from oxbot.testing.webcam import PaperVideo, frame_index
from oxbot.web.server import create_app, serving_in_background

PERSON = ("middle", "upperleft", "lowermiddle", "upperright", "middleleft")
"""The person's circles; with robot seed 1 the robot answers lowerright, lowerleft,
uppermiddle, middleright (tests/web/test_paper.py plays the same game)."""
SEED = 1


def game_video(size: tuple[int, int], folder: Path) -> tuple[PaperVideo, Path]:
    video = PaperVideo(seed=4, size=size)
    video.hold(2.0)
    for cell in PERSON:
        video.draw(cell, "circle", stroke_seconds=0.8)
        video.hold(3.5)
    video.hold(3.0)
    return video, video.write_y4m(folder / "game.y4m")


def play(video: PaperVideo, y4m: Path, speed: float) -> dict[str, list[float]]:
    """One game; the latencies of its moves, in seconds, by what they end at."""
    config = load_config(
        None,
        [
            f"robot.speed_factor={speed}",
            "robot.answer_timeout=16",
            "robot.move_timeout=240",
            "game.robot_starts=false",
        ],
    )
    app = create_app(config, robot_factory=lambda: Robot(config, seed=SEED))
    frames: list[int] = []  # the video index of each frame of the camera's on the bus
    stop = threading.Event()
    flags = [
        *FLAGS,
        "--use-fake-ui-for-media-stream",
        "--use-fake-device-for-media-stream",
        f"--use-file-for-fake-video-capture={y4m}",
    ]
    with serving_in_background(app) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=flags)
        page = browser.new_page(viewport={"width": 1200, "height": 900})
        page.goto(url + "/")
        page.get_by_test_id("start").click()
        page.wait_for_function("oxbot.stats.acts.some(a => a.act === 'Request(playGame)')")
        page.get_by_test_id("say").fill("yes let's play")
        page.get_by_test_id("say").press("Enter")
        page.wait_for_function("oxbot.stats.acts.some(a => a.act === 'Request(userGameMove)')")
        (session,) = app.state.sessions.values()
        inbox = session.robot.bus.subscribe(Frame, GameMove)

        def watch() -> None:
            while not stop.is_set():
                m = inbox.get(timeout=0.1)
                if isinstance(m, Frame):
                    # a canvas frame carries no index: not the camera's
                    with contextlib.suppress(InvalidInputError):
                        frames.append(frame_index(frame_pixels(m)))

        watcher = threading.Thread(target=watch, daemon=True)
        watcher.start()
        page.get_by_test_id("paper").click()
        page.wait_for_function("window.oxbot.ended", timeout=120_000)
        page.wait_for_timeout(300)
        stats = page.evaluate(
            "({sent: oxbot.paper.stats.sent, acts: oxbot.stats.acts, "
            "speaking: oxbot.stats.speaking, size: [oxbot.paper.width]})"
        )
        stop.set()
        watcher.join(2)
        browser.close()
    sent = stats["sent"]  # page clock (ms) of each camera frame sent, in order
    n = min(len(sent), len(frames))
    t0 = min(sent[k] - 1000 * frames[k] / video.fps for k in range(n))
    out: dict[str, list[float]] = {"grab→act": [], "grab→speech": [], "camera→act": []}
    acts = stats["acts"]
    for symbol in video.symbols:
        shown = next((k for k in range(n) if frames[k] >= symbol.complete_frame), None)
        move = next(
            (a for a in acts if a["speaker"] == "usr" and a["act"].endswith(f"={symbol.cell})")),
            None,
        )
        if shown is None or move is None:
            print(f"  no move for {symbol.cell}")
            continue
        answer = next(a for a in acts if a["speaker"] == "sys" and a["at"] >= move["at"])
        speech = next(t for t in stats["speaking"] if t >= move["at"])
        out["grab→act"].append((answer["at"] - sent[shown]) / 1000)
        out["grab→speech"].append((speech - sent[shown]) / 1000)
        camera = t0 + 1000 * symbol.complete_frame / video.fps
        out["camera→act"].append((answer["at"] - camera) / 1000)
    print(f"  frames sent {len(sent)}, on the bus {len(frames)}, last send width {stats['size']}")
    return out


def stroke_table(width: int = 354) -> None:
    """When a circle drawn at various speeds is accepted, relative to its last frame."""
    import cv2

    from oxbot.perception.board import default_reader
    from oxbot.perception.tracker import AcceptedDrawing, MoveTracker
    from oxbot.robot.game_moves import still_readings

    print("circle drawn over: accepted N frames after its stroke ended (3 sheets each)")
    for seconds in (0.5, 0.8, 1.2, 1.6, 2.0, 3.0):
        row = {"fixed squares": [], "crops": []}
        for seed in (1, 2, 3):
            video = PaperVideo(seed=seed)
            video.hold(0.3)
            symbol = video.draw("middle", "circle", stroke_seconds=seconds)
            video.hold(0.5)
            frames = [
                cv2.resize(f, (width, width * 3 // 4), interpolation=cv2.INTER_AREA)
                for f in video.frames()
            ]
            readings = [default_reader().read(f) for f in frames]
            for name, ink in (("fixed squares", still_readings), ("crops", None)):
                tracker = MoveTracker(robot_starts=False)
                for k, r in enumerate(readings):
                    event = tracker.update(r.labels, ink(r) if ink else r.readings)
                    if isinstance(event, AcceptedDrawing):
                        row[name].append(k - symbol.complete_frame)
                        break
        print(f"  {seconds:3.1f} s: " + "   ".join(f"{n} {v}" for n, v in row.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--games", type=int, default=2)
    parser.add_argument("--size", default="640x480", help="the fake webcam's video size")
    parser.add_argument("--speed", type=float, default=8.0)
    parser.add_argument("--strokes", action="store_true", help="the slow-stroke table only")
    args = parser.parse_args()
    if args.strokes:
        stroke_table()
        return
    size = tuple(int(v) for v in args.size.split("x"))
    results: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as folder:
        video, y4m = game_video(size, Path(folder))
        for game in range(args.games):
            print(f"game {game + 1}/{args.games}, {args.size} video")
            for name, values in play(video, y4m, args.speed).items():
                results.setdefault(name, []).extend(values)
    print(f"last stroke → robot's answer, {args.size}, {args.games} games:")
    for name, values in results.items():
        ms = sorted(1000 * v for v in values)
        if ms:
            print(
                f"  {name:12s} median {statistics.median(ms):5.0f} ms   min {ms[0]:5.0f}   "
                f"max {ms[-1]:5.0f}   ({len(ms)} moves)"
            )
    target = results.get("camera→act", [])
    if target:
        verdict = "met" if statistics.median(target) <= 0.6 else "NOT met"
        print(f"target ≤ 600 ms median (camera frame → answer): {verdict}")


if __name__ == "__main__":
    main()
