"""The page in Debian's Chromium: a whole game drawn with the mouse and answered by typing,
then a round answered by speech through Chromium's fake microphone.

Chromium is the system's (`/usr/bin/chromium`, installed by `make setup`); Playwright's own
browser download is never used. Screenshots go to test-artifacts/web/.
"""

from __future__ import annotations

import shutil
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import Page, sync_playwright
from skimage import data

from oxbot.testing.browser import CHROMIUM, draw, log_items
from oxbot.testing.browser import FLAGS as BROWSER_FLAGS

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts" / "web"
FLAGS = [*BROWSER_FLAGS, "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream"]
MOVE = "GameMove(gridloc="


@pytest.fixture(scope="module")
def answer_wav(tmp_path_factory) -> Path:
    """The person's spoken answer, made with espeak-ng (installed by `make setup`)."""
    assert shutil.which("espeak-ng"), "espeak-ng is missing: run `make setup`"
    path = tmp_path_factory.mktemp("voice") / "yes.wav"
    subprocess.run(["espeak-ng", "-w", str(path), "yes, let's play"], check=True)
    return path


@pytest.fixture(scope="module")
def webcam_y4m(tmp_path_factory) -> Path:
    """A fake webcam: a face looking at the robot for 3 s, then moved to the image's left
    (the person's right, as a camera facing them sees it) for 3 s; 320x240 at 10 fps."""
    face = data.astronaut()[0:360, 100:460]
    frames = []
    for dx in (140, 0):
        scene = np.full((480, 640, 3), 200, np.uint8)
        scene[60:420, 64 + dx : 424 + dx] = face
        frames += [scene[::2, ::2]] * 30
    path = tmp_path_factory.mktemp("webcam") / "face.y4m"
    with path.open("wb") as out:
        out.write(b"YUV4MPEG2 W320 H240 F10:1 Ip A1:1 C420jpeg\n")
        for rgb in frames:
            r, g, b = (rgb[..., i].astype(np.float32) for i in range(3))
            y = 16 + 0.257 * r + 0.504 * g + 0.098 * b
            u = 128 - 0.148 * r - 0.291 * g + 0.439 * b
            v = 128 + 0.439 * r - 0.368 * g - 0.071 * b
            planes = [y] + [c.reshape(120, 2, 160, 2).mean((1, 3)) for c in (u, v)]
            out.write(b"FRAME\n")
            for plane in planes:
                out.write(np.clip(plane, 0, 255).round().astype(np.uint8).tobytes())
    return path


@pytest.fixture(scope="module")
def page(server_url, answer_wav, webcam_y4m, tmp_path_factory):
    assert Path(CHROMIUM).exists(), f"{CHROMIUM} is missing: run `make setup`"
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    profile = tmp_path_factory.mktemp("chromium-profile")
    # %noloop: the phrase plays once from each getUserMedia call, then silence (the page
    # opens the microphone at its first press of push-to-talk and keeps it open)
    args = [
        *FLAGS,
        f"--use-file-for-fake-audio-capture={answer_wav}%noloop",
        f"--use-file-for-fake-video-capture={webcam_y4m}",
    ]
    with sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(profile),
            executable_path=CHROMIUM,
            headless=True,
            args=args,
            viewport={"width": 1200, "height": 900},
            has_touch=True,
        )
        try:
            tab = context.pages[0] if context.pages else context.new_page()
            tab.goto(server_url + "/")
            yield tab
        finally:
            context.close()


def wait_for_act(page: Page, act: str, speaker: str = "sys", after: int = 0, timeout=30_000):
    """Wait until the log holds `act` by `speaker` among its items from index `after`."""
    page.wait_for_function(
        """([act, speaker, after]) =>
             [...document.querySelectorAll('[data-testid=log] li[data-act]')].slice(after)
               .some(li => li.dataset.act === act && li.dataset.speaker === speaker)""",
        arg=[act, speaker, after],
        timeout=timeout,
    )


def test_a_whole_game_with_mouse_and_keyboard_then_a_spoken_answer(page: Page):
    try:
        play_a_whole_game_then_answer_by_voice(page)
    except Exception as exc:
        page.screenshot(path=ARTIFACTS / "failure.png", full_page=True)
        raise AssertionError(f"{exc}\nthe page's log: {log_items(page)}") from exc


def play_a_whole_game_then_answer_by_voice(page: Page) -> None:
    rng = np.random.default_rng(7)
    page.screenshot(path=ARTIFACTS / "01-before-start.png", full_page=True)
    page.get_by_test_id("start").click()
    wait_for_act(page, "Salutation(greeting)")
    hello = page.evaluate("window.oxbot.hello")
    user = hello["user_symbol"]
    assert user == "cross"  # the robot starts, and the starter draws circles

    # the mouth moves while the robot's speech plays
    page.wait_for_function("window.oxbot.stats.mouthMoves > 0", timeout=10_000)
    wait_for_act(page, "Request(playGame)")
    page.get_by_test_id("say").fill("yes let's play")
    page.get_by_test_id("say").press("Enter")
    wait_for_act(page, "Confirm(playGame=yes)", speaker="usr")

    cells = hello["cells"]
    latencies, tried_taken_cell = [], False
    deadline = time.monotonic() + 120
    while not page.evaluate("window.oxbot.ended"):
        assert time.monotonic() < deadline, f"no goodbye; log: {log_items(page)}"
        items = log_items(page)
        requests = sum(1 for s, a, _ in items if s == "sys" and a == "Request(userGameMove)")
        mine = [a[len(MOVE) : -1] for s, a, _ in items if s == "usr" and a.startswith(MOVE)]
        robots = [a[len(MOVE) : -1] for s, a, _ in items if s == "sys" and a.startswith(MOVE)]
        if requests <= len(mine) or page.evaluate("window.oxbot.pending.length") > 0:
            page.wait_for_timeout(50)
            continue
        if not tried_taken_cell:
            # drawing over the robot's circle is refused in words; the board does not change
            tried_taken_cell = True
            draw(page, robots[0], user, rng)
            wait_for_act(page, "Inform(problem)", timeout=10_000)
            problem = page.get_by_test_id("problem")
            # the robot's own sentence, not the tracker's technical reason
            assert "already taken" in problem.inner_text()
            page.screenshot(path=ARTIFACTS / "02-occupied-cell.png", full_page=True)
            page.wait_for_function("window.oxbot.pending.length === 0", timeout=5_000)
            assert not any(a == f"{MOVE}{robots[0]})" for s, a, _ in log_items(page) if s == "usr")
            continue
        where = next(c for c in cells if c not in mine and c not in robots)
        moves_before = page.evaluate("window.oxbot.stats.moves.length")
        finger = len(latencies) == 1  # the second move by touch
        draw(page, where, user, rng, finger=finger)
        strokes = 2 if user == "cross" else 1
        inked = page.evaluate(
            f"[...oxbot.committed, ...oxbot.pending].slice(-{strokes}).map(s => s.length)"
        )
        assert min(inked) > 5, (
            f"strokes with too few points: {inked}, finger={finger}, "
            f"{page.evaluate('window.oxbot.stats')}"
        )
        try:
            page.wait_for_function(
                f"window.oxbot.stats.moves.length > {moves_before}", timeout=20_000
            )
        except Exception as exc:  # what the page held when the move was not seen
            seen = page.evaluate(
                "({drawing: !!oxbot.drawing, pending: oxbot.pending.length, dirty: oxbot.dirty,"
                " problem: document.querySelector('[data-testid=problem]').innerText,"
                " seen: oxbot.lastSeen && {labels: oxbot.lastSeen.labels,"
                " agreeing: oxbot.lastSeen.agreeing, readings: oxbot.lastSeen.readings},"
                " stats: oxbot.stats})"
            )
            raise AssertionError(f"{where} by {'touch' if finger else 'mouse'}: {seen}") from exc
        stats = page.evaluate("window.oxbot.stats")
        move = stats["moves"][-1]
        assert (move["who"], move["where"]) == ("usr", where)
        latencies.append((move["at"] - stats["lastStrokeEnd"]) / 1000)
        if len(latencies) == 2:
            page.wait_for_timeout(400)  # the robot's answer on the sheet and in the panel
            page.screenshot(path=ARTIFACTS / "03-mid-game.png", full_page=True)

    page.screenshot(path=ARTIFACTS / "04-goodbye.png", full_page=True)
    pointers = page.evaluate("window.oxbot.stats.pointers")
    assert pointers.get("mouse") and pointers.get("touch"), pointers
    items = log_items(page)
    assert items[-1][:2] == ("sys", "Salutation(closing)")
    assert any(a.startswith("Provide(feedback=") for s, a, _ in items if s == "sys")
    assert latencies and max(latencies) < 2.0, latencies
    # what the robot sees: nine crops with labels, and the manager's Q-values
    labels = page.evaluate(
        "[...document.querySelectorAll('[data-testid=crops] .crop')].map(c => c.dataset.label)"
    )
    assert len(labels) == 9 and labels.count(user) == len(latencies)
    assert page.locator("[data-testid=decision] tr.chosen").count() == 1

    # after the goodbye the page sends no more drawings until a new game (words still go: "new
    # game" starts one), and never shows the protocol's words to the person
    sent = page.evaluate("window.oxbot.stats.framesSent")
    draw(page, "middle", user, rng)
    page.wait_for_timeout(300)
    assert page.evaluate("window.oxbot.stats.framesSent") == sent
    assert "type" not in page.get_by_test_id("problem").text_content()

    # a new game, answered by voice: push-to-talk through Chromium's fake microphone
    before = len(log_items(page))
    page.get_by_test_id("start").click()
    wait_for_act(page, "Request(playGame)", after=before)
    talk = page.get_by_test_id("talk")
    talk.hover()
    page.mouse.down()
    page.wait_for_timeout(2_500)  # espeak's "yes, let's play" lasts about 1.3 s
    page.mouse.up()
    wait_for_act(page, "Confirm(playGame=yes)", speaker="usr", after=before, timeout=30_000)
    spoken = [t for s, a, t in log_items(page)[before:] if s == "usr"]
    assert "yes" in spoken[0] and "play" in spoken[0], spoken
    wait_for_act(page, "Reply(playGame=yes)", after=before, timeout=30_000)
    page.screenshot(path=ARTIFACTS / "05-spoken-answer.png", full_page=True)

    # sound off: the robot's speech is muted (the mouth still moves)
    page.get_by_test_id("sound").click()
    assert page.get_by_test_id("sound").inner_text() == "Sound: off"
    assert page.evaluate("window.oxbot.gain.gain.value") == 0

    # the webcam (Chromium's fake camera): the person looks ahead, then turns to their
    # right; the robot's eyes mirror them and turn to its left
    page.get_by_test_id("camera").click()
    page.wait_for_function(
        "document.querySelector('[data-testid=face]').dataset.gaze === 'left'", timeout=20_000
    )
    assert page.get_by_test_id("camera").inner_text() == "Camera: on"
    page.screenshot(path=ARTIFACTS / "06-eyes-mirror-the-person.png", full_page=True)
    notes = page.evaluate(
        "[...document.querySelectorAll('[data-testid=log] li.note')].map(li => li.textContent)"
    )
    troubles = [n for n in notes if "camera" in n or "failed" in n or "server:" in n]
    assert all("game is over" in n for n in troubles), troubles


def arc_path(page: Page, where: str, start_deg: float, end_deg: float) -> list[tuple[float, float]]:
    """Page coordinates along an arc of the circle a person draws in cell `where`."""
    from oxbot.testing.sheet import SIDE, unit_to_canvas

    box = page.get_by_test_id("board").bounding_box()
    t = np.deg2rad(np.linspace(start_deg, end_deg, 40))
    unit = np.stack([0.5 + 0.3 * np.cos(t), 0.5 + 0.3 * np.sin(t)], axis=1)
    points = unit_to_canvas(where, unit) * (box["width"] / SIDE) + (box["x"], box["y"])
    return [(float(x), float(y)) for x, y in points]


@contextmanager
def person_starts_tab(page: Page, *settings: str) -> Iterator[Page]:
    """A tab beside the first test's, on a server of its own where the person starts (circles),
    in a game they have agreed to and where it is their turn."""
    from oxbot.config import load_config
    from tests.web.conftest import running_server

    fast = ["robot.speed_factor=8", "robot.answer_timeout=16", "robot.move_timeout=240"]
    config = load_config(None, [*fast, "game.robot_starts=false", *settings])
    with running_server(config=config) as url:
        tab = page.context.new_page()
        try:
            tab.goto(url + "/")
            tab.get_by_test_id("start").click()
            wait_for_act(tab, "Request(playGame)")
            assert tab.evaluate("window.oxbot.hello")["user_symbol"] == "circle"
            tab.get_by_test_id("say").fill("yes let's play")
            tab.get_by_test_id("say").press("Enter")
            wait_for_act(tab, "Request(userGameMove)")
            yield tab
        finally:
            tab.close()
            page.bring_to_front()


def trace(page: Page, path: list[tuple[float, float]], lift: bool = True) -> None:
    """Move the mouse along `path` with the button down; lift it at the end if `lift`."""
    page.mouse.move(*path[0])
    page.mouse.down()
    for x, y in path[1:]:
        page.mouse.move(x, y)
    if lift:
        page.mouse.up()


def test_a_circle_is_a_move_only_once_the_pen_lifts(page: Page):
    """The person starts (circles). Half a circle, the pen held down, sends nothing and is no
    move; the circle finished and the pen lifted, it is a move, and the cells show it."""
    with person_starts_tab(page) as tab:
        try:
            cell = "middle"
            label = "document.querySelectorAll('[data-testid=cells] > div')[4].dataset.label"

            # half a circle, the pen still down: nothing goes to the robot
            sent = tab.evaluate("window.oxbot.stats.framesSent")
            trace(tab, arc_path(tab, cell, 0, 180), lift=False)
            tab.wait_for_timeout(1_200)  # many more ticks than the 3 readings a move needs
            assert tab.evaluate("window.oxbot.stats.framesSent") == sent
            assert tab.evaluate("window.oxbot.stats.moves.length") == 0

            # the circle finished in the same stroke and the pen lifted: now it is a move
            for x, y in arc_path(tab, cell, 180, 370)[1:]:
                tab.mouse.move(x, y)
            tab.mouse.up()
            tab.wait_for_function("window.oxbot.stats.moves.length > 0", timeout=10_000)
            move = tab.evaluate("window.oxbot.stats.moves[0]")
            assert (move["who"], move["where"]) == ("usr", cell)
            assert tab.evaluate(label) == "circle"
        except Exception:
            tab.screenshot(path=ARTIFACTS / "failure-half-drawn.png", full_page=True)
            raise


def test_ink_that_is_not_a_whole_symbol_is_named_in_words_and_is_no_move(page: Page):
    """Half a circle, the pen lifted and the person waiting: the robot says it cannot tell what
    is in that cell and what to draw, and makes no move of it; a whole circle elsewhere then is
    the move."""
    with person_starts_tab(page, "tracker.unclear_seconds=2") as tab:
        try:
            before = len(log_items(tab))
            trace(tab, arc_path(tab, "upperleft", 0, 180))
            wait_for_act(tab, "Inform(problem)", after=before, timeout=15_000)
            told = [t for s, a, t in log_items(tab)[before:] if a == "Inform(problem)"]
            assert "cannot tell what is in the upper left" in told[0], told
            assert "whole circle" in told[0], told
            # the red box holds the robot's words, not the tracker's technical reason
            assert tab.locator("#problem").inner_text() == told[-1]
            assert tab.evaluate("window.oxbot.stats.moves.length") == 0
            assert tab.get_by_test_id("agreeing").is_hidden()  # no stream to agree on a canvas
            tab.screenshot(path=ARTIFACTS / "07-unclear-ink.png", full_page=True)

            # the dialogue moves on (the person asks something): the red box does not stay
            before = len(log_items(tab))
            tab.get_by_test_id("say").fill("what do you mean")
            tab.get_by_test_id("say").press("Enter")
            wait_for_act(tab, "Unknown", speaker="usr", after=before, timeout=10_000)
            tab.wait_for_function("document.getElementById('problem').hidden", timeout=10_000)

            trace(tab, arc_path(tab, "lowerright", 0, 370))
            tab.wait_for_function("window.oxbot.stats.moves.length > 0", timeout=10_000)
            move = tab.evaluate("window.oxbot.stats.moves[0]")
            assert (move["who"], move["where"]) == ("usr", "lowerright")
        except Exception:
            tab.screenshot(path=ARTIFACTS / "failure-unclear-ink.png", full_page=True)
            raise
