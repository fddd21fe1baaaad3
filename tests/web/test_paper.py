"""Paper mode in Debian's Chromium: a whole game played on a rendered sheet that
Chromium's fake webcam films, symbols appearing stroke by stroke, with the robot's moves
virtual on the video; the camera's troubles each told once, the game going on on the canvas;
the page over HTTPS on this machine's network address, its certificate accepted.

The robot is the real one (`Robot`, seeded so that its template choices, and so its moves, are
the same each run), reached through the real server; the test watches its bus beside the page
to see which frame of the video each reading came from (`oxbot.testing.webcam.frame_index`).
"""

from __future__ import annotations

import base64
import hashlib
import re
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import Page, sync_playwright

from oxbot.config import load_config
from oxbot.game.board import CELL_NAMES, USER
from oxbot.game.solver import best_moves
from oxbot.robot.frames import frame_pixels
from oxbot.robot.manager import cell_in_words
from oxbot.robot.messages import (
    BoardProblem,
    BoardSeen,
    DialogueAct,
    DialogueEnded,
    Frame,
    GameMove,
)
from oxbot.robot.session import Robot
from oxbot.testing.browser import CHROMIUM, FLAGS, draw
from oxbot.testing.webcam import PaperVideo, frame_index
from oxbot.web.server import create_app, serving_in_background
from tests.web.test_browser import ARTIFACTS, log_items, wait_for_act

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

CONFIG = load_config(
    None,
    [
        "robot.speed_factor=8",
        "robot.answer_timeout=16",
        "robot.move_timeout=240",
        "game.robot_starts=false",
        "robot.offer_another_game=false",
    ],
)
"""The person starts (circles): the video's first symbol needs no robot move before it; the
goodbye follows the game at once, while the video still shows the board (no other game is
offered)."""
SEED = 1
MOVE = "GameMove(gridloc="
PLAYBACK = 2.0
"""The fake webcam plays the game's video this many times faster than it was scripted."""


def seeded_game() -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The person's moves (the solver's best, from the middle: a draw) and the seeded robot's
    answers, played beforehand by typing to the same robot: the video must be made before the
    game, so it draws what the robot will answer, whatever policy ships."""
    person, robot = [], []
    with Robot(CONFIG, seed=SEED) as headless:
        events = headless.bus.subscribe(DialogueAct, DialogueEnded)
        while True:
            message = events.get(30.0)
            assert message is not None, headless.transcript
            if isinstance(message, DialogueEnded):
                return tuple(person), tuple(robot)
            if message.speaker == "sys" and message.act == "Request(playGame)":
                headless.say("yes let's play")
            elif message.speaker == "sys" and message.act == "Request(userGameMove)":
                cell = 4 if not person else best_moves(headless.board, USER)[0]
                person.append(CELL_NAMES[cell])
                headless.draw(cell)
            elif message.speaker == "sys" and message.act.startswith(MOVE):
                robot.append(message.act[len(MOVE) : -1])


@dataclass(frozen=True)
class Game:
    person: tuple[str, ...]
    robot: tuple[str, ...]
    """The seeded robot's answers to `person`."""
    video: PaperVideo
    y4m: Path

    @property
    def drawn_for_robot(self) -> str:
        """The robot's cross that the person draws for it; its other moves stay virtual."""
        return self.robot[0]


@pytest.fixture(scope="module")
def game_video(tmp_path_factory) -> Game:
    """The whole game as the camera films it: 2.5 s of a sheet without a grid (the robot
    must say what to do), then the grid, and each of the person's circles drawn 3.5 s after
    the last, stroke by stroke; 640x480, 10 frames a second, played `PLAYBACK` times as fast
    (about 16 s): the page still sends a frame every 100 ms, so each drawing is read as often
    as a slower hand's would be. The sheet without a grid lasts 2.5 s as played, longer than
    the robot waits before it says what is wrong (`tracker.guidance_seconds`)."""
    person, robot = seeded_game()
    video = PaperVideo(seed=4)
    video.show("no_grid", 2.5 * PLAYBACK)
    video.hold(2.0)
    for k, cell in enumerate(person):
        video.draw(cell, "circle", stroke_seconds=0.8)
        video.hold(3.5)
        if k == 0:  # the robot has answered: its cross, drawn for it (two strokes)
            video.draw(robot[0], "cross")
            video.hold(0.5)
    video.hold(3.0)
    y4m = video.write_y4m(tmp_path_factory.mktemp("paper") / "game.y4m", speed=PLAYBACK)
    return Game(person, robot, video, y4m)


@contextmanager
def chromium(*extra: str, permissions: dict[str, list[str]] | None = None) -> Iterator:
    """A headless Chromium context with these extra flags; `permissions` maps origins to the
    permissions granted them."""
    assert Path(CHROMIUM).exists(), f"{CHROMIUM} is missing: run `make setup`"
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[*FLAGS, *extra])
        try:
            context = browser.new_context(viewport={"width": 1200, "height": 900})
            for origin, granted in (permissions or {}).items():
                context.grant_permissions(granted, origin=origin)
            yield context
        finally:
            browser.close()


class BusWatcher:
    """Records, beside the page, what the robot's bus carries: the video frame index of each
    frame the page sent, each reading's agreeing count, each move and problem."""

    def __init__(self, bus) -> None:
        self.events: list[tuple] = []
        self._subscription = bus.subscribe(Frame, BoardSeen, GameMove, BoardProblem)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            m = self._subscription.get(timeout=0.1)
            if isinstance(m, Frame):
                self.events.append(("frame", frame_index(frame_pixels(m))))
            elif isinstance(m, BoardSeen):
                self.events.append(("seen", m.agreeing, m.labels))
            elif isinstance(m, GameMove):
                self.events.append(("move", m.who, m.where))
            elif isinstance(m, BoardProblem):
                self.events.append(("problem", m.kind))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        self._subscription.close()


def start_game(page: Page, url: str) -> None:
    page.goto(url + "/")
    page.get_by_test_id("start").click()
    wait_for_act(page, "Request(playGame)")
    page.get_by_test_id("say").fill("yes let's play")
    page.get_by_test_id("say").press("Enter")
    wait_for_act(page, "Request(userGameMove)")


def cell_labels(page: Page) -> list[str]:
    return page.evaluate(
        "[...document.querySelectorAll('[data-testid=cells] > div')].map(d => d.dataset.label)"
    )


def test_a_whole_game_on_paper_through_the_fake_webcam(game_video):
    game, y4m = game_video, game_video.y4m
    app = create_app(CONFIG, robot_factory=lambda: Robot(CONFIG, seed=SEED))
    with (
        serving_in_background(app) as url,
        chromium(
            "--use-fake-ui-for-media-stream",
            "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-video-capture={y4m}",
        ) as context,
    ):
        page = context.new_page()
        start_game(page, url)
        (session,) = app.state.sessions.values()
        watcher = BusWatcher(session.robot.bus)
        try:
            play_on_paper(page, game, watcher)
        except Exception as exc:
            page.screenshot(path=ARTIFACTS / "paper-failure.png", full_page=True)
            raise AssertionError(f"{exc}\nthe page's log: {log_items(page)}") from exc
        finally:
            watcher.close()


def play_on_paper(page: Page, game: Game, watcher: BusWatcher) -> None:
    page.get_by_test_id("paper").click()
    page.wait_for_function("window.oxbot.paper.on", timeout=10_000)  # the camera opened
    assert page.get_by_test_id("paper").get_attribute("aria-pressed") == "true"
    assert "camera" in page.get_by_test_id("sees-source").inner_text()  # not the pen's lifts
    assert page.get_by_test_id("agreeing").is_visible()  # the readings of the camera's stream
    assert page.get_by_test_id("board").is_hidden()

    # no grid in view: told on the video at once, and out loud while the robot waits
    page.wait_for_function(
        "!document.querySelector('[data-testid=guidance]').hidden", timeout=10_000
    )
    # Either of the finder's refusals: on a compressed frame the index strip below the blank
    # sheet can pass for crossing lines, which then make no grid.
    assert re.match(r"no (3x3 )?grid in view", page.get_by_test_id("guidance").inner_text())
    wait_for_act(page, "Inform(problem)", timeout=10_000)
    said = [t for s, a, t in log_items(page) if a == "Inform(problem)"]
    assert said == ["I cannot see the grid. Please hold the camera over the whole sheet."]
    page.screenshot(path=ARTIFACTS / "paper-01-no-grid.png", full_page=True)

    # the grid in view: found, drawn over the video, guidance gone
    page.wait_for_function("window.oxbot.paper.grid !== null", timeout=10_000)
    assert page.get_by_test_id("guidance").is_hidden()
    page.get_by_test_id("problem").wait_for(state="hidden", timeout=2_000)

    page.wait_for_function("window.oxbot.ended", timeout=90_000)
    page.wait_for_timeout(300)
    page.screenshot(path=ARTIFACTS / "paper-02-goodbye.png", full_page=True)

    items = log_items(page)
    mine = [a[len(MOVE) : -1] for s, a, _ in items if s == "usr" and a.startswith(MOVE)]
    robots = [(a[len(MOVE) : -1], t) for s, a, t in items if s == "sys" and a.startswith(MOVE)]
    assert tuple(mine) == game.person, items
    assert tuple(cell for cell, _ in robots) == game.robot, items
    # the robot says where it plays: no arm points at the paper
    said = f"I take {cell_in_words(CELL_NAMES.index(game.robot[0]))}."
    assert robots[0][1].startswith(said), robots
    assert all(text.startswith("I take the ") for _, text in robots)
    assert items[-1][:2] == ("sys", "Salutation(closing)")
    assert ("sys", "Provide(feedback=draw)") in [(s, a) for s, a, _ in items]

    # every move accepted after its symbol was whole on the video, at the 3rd agreeing reading
    symbols = {s.cell: s for s in game.video.symbols}
    events = watcher.events
    for k, event in enumerate(events):
        if event[0] != "move":
            continue
        assert event[1] == "usr"
        symbol = symbols[event[2]]
        seen_frames = [e[1] for e in events[:k] if e[0] == "frame"]
        assert seen_frames[-1] >= symbol.complete_frame, (event, seen_frames[-5:], symbol)
        agreeing = [e[1] for e in events[:k] if e[0] == "seen"][-3:]
        assert agreeing == [1, 2, 3], (event, agreeing)
        # while the symbol was under the pen, no frame of it had made a move
        during = [e[1] for e in events[:k] if e[0] == "frame" and e[1] < symbol.complete_frame]
        assert during and max(during) >= symbol.start_frame
    moves = [e[2] for e in events if e[0] == "move"]
    assert tuple(moves) == game.person
    problems = [e[1] for e in events if e[0] == "problem"]
    assert problems == ["no_grid"], problems  # nothing impossible: the robot's cross included

    # the robot's moves on the video: virtual, but the one drawn for it is read as its own
    labels = cell_labels(page)
    names = page.evaluate("window.oxbot.hello.cells")
    for cell in game.person:
        assert labels[names.index(cell)] == "circle", labels
    assert labels[names.index(game.drawn_for_robot)] == "cross", labels
    for cell in game.robot[1:]:
        assert labels[names.index(cell)] == "nothing", labels
    assert sorted(page.evaluate("Object.keys(window.oxbot.robotStrokes)")) == sorted(game.robot)
    inked = page.evaluate(
        """() => { const c = document.getElementById('paper-overlay');
                   const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
                   let n = 0; for (let i = 0; i < d.length; i += 4)
                     if (d[i] > 100 && d[i + 1] < 60 && d[i + 3] > 150) n++;
                   return n; }"""
    )
    assert inked > 500, inked  # the virtual crosses, in the robot's ink, over the video
    assert page.evaluate("window.oxbot.paper.stats.sent.length") > 100
    last = cell_in_words(CELL_NAMES.index(game.robot[-1]))
    assert f"plays {last}:" in page.get_by_test_id("paper-hint").inner_text()


def test_camera_troubles_are_told_once_and_the_game_goes_on_on_the_canvas(game_video):
    y4m = game_video.y4m
    with (
        serving_in_background(create_app(CONFIG)) as url,
        serving_in_background(create_app(CONFIG)) as other,
    ):
        # a camera that works, granted to `url`, and refused to `other`
        with chromium(
            "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-video-capture={y4m}",
            permissions={url: ["camera"]},
        ) as context:
            page = context.new_page()
            page.goto(other + "/")
            page.get_by_test_id("paper").click()
            message = page.get_by_test_id("paper-message")
            message.wait_for(state="visible", timeout=10_000)
            assert message.get_attribute("data-kind") == "denied"
            assert "blocked" in message.inner_text()
            assert page.get_by_test_id("board").is_visible()
            assert page.evaluate("window.oxbot.paper.stats.errors") == ["denied"]

            # the camera stops mid-game, after a move on paper: told, and the game goes on on
            # the canvas, which shows the move made on paper
            page = context.new_page()
            start_game(page, url)
            page.get_by_test_id("paper").click()
            page.wait_for_function("window.oxbot.stats.moves.length > 0", timeout=20_000)
            assert page.evaluate("window.oxbot.stats.moves[0].where") == "middle"
            wait_for_act(page, "Request(userGameMove)", after=len(log_items(page)) - 1)
            page.evaluate(
                "oxbot.paper.stream.getVideoTracks()[0].dispatchEvent(new Event('ended'))"
            )  # what Chromium fires when a camera is unplugged
            message = page.get_by_test_id("paper-message")
            message.wait_for(state="visible", timeout=5_000)
            assert message.get_attribute("data-kind") == "stopped"
            assert "canvas" in message.inner_text()
            assert page.get_by_test_id("board").is_visible()
            assert page.get_by_test_id("paper").get_attribute("aria-pressed") == "false"
            assert page.evaluate("[...oxbot.paperDrawn]") == ["middle"]
            robots = [a[len(MOVE) : -1] for s, a, _ in log_items(page) if s == "sys" and MOVE in a]
            free = next(c for c in ("upperleft", "upperright", "lowerleft") if c not in robots)
            draw(page, free, "circle", np.random.default_rng(5))
            page.wait_for_function("window.oxbot.stats.moves.length > 1", timeout=10_000)
            move = page.evaluate("window.oxbot.stats.moves.at(-1)")
            assert (move["who"], move["where"]) == ("usr", free)
            assert page.evaluate("window.oxbot.paper.stats.errors") == ["stopped"]
            page.screenshot(path=ARTIFACTS / "paper-03-camera-stopped.png", full_page=True)

        # no camera at all
        with chromium("--use-fake-ui-for-media-stream") as context:
            page = context.new_page()
            page.goto(url + "/")
            page.get_by_test_id("paper").click()
            message = page.get_by_test_id("paper-message")
            message.wait_for(state="visible", timeout=10_000)
            assert message.get_attribute("data-kind") == "missing"
            assert "No camera found" in message.inner_text()
            assert page.get_by_test_id("board").is_visible()


def test_https_on_the_network_address_with_the_certificate_accepted(game_video, tmp_path):
    """What a phone does: open the page by this machine's address, over HTTPS, accept the
    self-signed certificate (here: Chromium told to trust exactly its key), and use the
    camera, which browsers lend only to secure pages off localhost."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization

    from oxbot.web.tls import ensure_certificate, local_addresses

    y4m = game_video.y4m
    host = (local_addresses() or ["127.0.0.1"])[0]
    certificate = ensure_certificate([host], folder=tmp_path)
    key = x509.load_pem_x509_certificate(certificate.cert.read_bytes()).public_key()
    spki = key.public_bytes(
        serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo
    )
    pin = base64.b64encode(hashlib.sha256(spki).digest()).decode()
    app = create_app(CONFIG, certificate=certificate)
    with (
        serving_in_background(app, host=host, certificate=certificate) as url,
        chromium(
            "--use-fake-ui-for-media-stream",
            "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-video-capture={y4m}",
            f"--ignore-certificate-errors-spki-list={pin}",
        ) as context,
    ):
        assert url.startswith(f"https://{host}:")
        page = context.new_page()
        page.goto(url + "/")
        assert page.evaluate("window.isSecureContext")
        fingerprint = page.get_by_test_id("fingerprint")
        fingerprint.wait_for(state="visible", timeout=5_000)
        assert certificate.fingerprint in fingerprint.inner_text()
        page.get_by_test_id("start").click()
        wait_for_act(page, "Salutation(greeting)")
        page.get_by_test_id("paper").click()
        page.wait_for_function("window.oxbot.paper.stats.sent.length > 3", timeout=10_000)
        assert page.get_by_test_id("paper-message").is_hidden()
        page.screenshot(path=ARTIFACTS / "paper-04-https.png", full_page=True)
        # the hardening still holds over TLS: a page from elsewhere may not open the game socket
        assert foreign_close_code(url, certificate.cert) == 1008


def foreign_close_code(url: str, cert: Path) -> int:
    """The close code a wss:// game socket opened by a page from another origin gets within
    10 s (0: it stayed open; -2: no answer within 30 s, not even to the opening handshake).

    The asyncio client, bounded as a whole: the sync client, when its TLS handshake failed,
    waited forever for its reading thread, and hung the suite."""
    import asyncio
    import ssl
    from concurrent.futures import ThreadPoolExecutor

    from websockets.asyncio.client import connect
    from websockets.exceptions import ConnectionClosed

    trusted = ssl.create_default_context(cafile=str(cert))
    trusted.check_hostname = False  # the address is checked by the certificate's pin above
    uri = url.replace("https://", "wss://") + "/ws"

    async def close_code() -> int:
        async with connect(uri, ssl=trusted, origin="https://evil.example", open_timeout=10) as ws:
            deadline = asyncio.get_running_loop().time() + 10
            while (left := deadline - asyncio.get_running_loop().time()) > 0:
                try:
                    await asyncio.wait_for(ws.recv(), left)
                except TimeoutError:
                    break
                except ConnectionClosed as closed:
                    return closed.rcvd.code if closed.rcvd else -1
        return 0

    async def bounded() -> int:
        try:
            return await asyncio.wait_for(close_code(), 30)
        except TimeoutError:
            return -2

    # in a thread of its own: Playwright's sync API keeps an event loop running on this one
    with ThreadPoolExecutor(1) as thread:
        return thread.submit(asyncio.run, bounded()).result()
