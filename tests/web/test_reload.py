"""A reload mid-game, in Debian's Chromium, as a person does it: the same game comes back (the
log, the person's symbols on the sheet, the robot's ink) and can be finished. Reloaded while the
robot speaks, then twice in a row; reloaded after the goodbye, the page starts afresh."""

from __future__ import annotations

import time

import httpx
import numpy as np
import pytest
from playwright.sync_api import Error as PlaywrightError
from playwright.sync_api import Page, sync_playwright

from oxbot.testing.browser import CHROMIUM, draw, log_items
from oxbot.testing.browser import FLAGS as BROWSER_FLAGS
from tests.web.test_browser import ARTIFACTS, wait_for_act

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

MOVE = "GameMove(gridloc="

INK = """([id, where]) => {
  const canvas = document.getElementById(id), i = oxbot.hello.cells.indexOf(where);
  const step = (360 - 60) / 3, x = 30 + (i % 3) * step, y = 30 + Math.floor(i / 3) * step;
  const px = canvas.getContext("2d").getImageData(x + 10, y + 10, step - 20, step - 20).data;
  let inked = 0;
  for (let k = 0; k < px.length; k += 4) {
    const dark = px[k] + px[k + 1] + px[k + 2] < 450 && px[k + 3] > 128;
    if (dark) inked++;
  }
  return inked;
}"""
"""How many pixels of a cell's middle are ink on a canvas (the sheet, or the robot's layer)."""
ROBOT_INKED = f"(cells) => cells.every((c) => ({INK})(['robot-ink', c]) > 50)"
"""Whether the robot's layer shows ink in each of the cells."""


def moves(page: Page, speaker: str) -> list[str]:
    return [a[len(MOVE) : -1] for s, a, _ in log_items(page) if s == speaker and a.startswith(MOVE)]


def sessions(url: str) -> int:
    return httpx.get(url + "/health").json()["sessions"]


def wait_resumed(page: Page) -> None:
    page.wait_for_function(
        "/back after the reload/.test(document.getElementById('status').textContent)",
        timeout=15_000,
    )


def reload_again(page: Page) -> None:
    """Reload a page whose last reload has only just committed. Chromium may not yet have
    attached the debugging protocol to the new document then ("Not attached to an active
    page"): the person's second press of F5 is tried again, as their key would be."""
    for attempt in range(5):
        try:
            page.reload()
            return
        except PlaywrightError as error:
            if "Not attached" not in str(error) or attempt == 4:
                raise
            page.wait_for_timeout(50)


def play_a_move(page: Page, rng: np.random.Generator) -> str:
    """Wait until the robot asks for a move, draw one in a free cell, wait until it is taken."""
    page.wait_for_function(
        """() => { const acts = [...document.querySelectorAll('[data-testid=log] li[data-act]')];
                   const sys = acts.filter(li => li.dataset.speaker === 'sys');
                   return oxbot.ended || (sys.length
                     && sys[sys.length - 1].dataset.act === 'Request(userGameMove)'
                     && oxbot.pending.length === 0); }""",
        timeout=30_000,
    )
    if page.evaluate("oxbot.ended"):
        return ""
    taken = set(moves(page, "usr")) | set(moves(page, "sys"))
    where = next(c for c in page.evaluate("oxbot.hello.cells") if c not in taken)
    before = page.evaluate("oxbot.stats.moves.length")
    draw(page, where, page.evaluate("oxbot.hello.user_symbol"), rng)
    page.wait_for_function(f"oxbot.stats.moves.length > {before}", timeout=20_000)
    return where


def test_a_reload_mid_game_brings_the_same_game_back_and_it_can_be_finished(server_url):
    rng = np.random.default_rng(11)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=BROWSER_FLAGS)
        tab = browser.new_page(viewport={"width": 1200, "height": 900})
        try:
            tab.goto(server_url + "/")
            tab.get_by_test_id("start").click()
            wait_for_act(tab, "Request(playGame)")
            tab.get_by_test_id("say").fill("yes let's play")
            tab.get_by_test_id("say").press("Enter")
            wait_for_act(tab, "Confirm(playGame=yes)", speaker="usr")
            session = tab.evaluate("oxbot.hello.session")
            mine = play_a_move(tab, rng)

            # reloaded while the robot speaks (its answer to the move)
            tab.wait_for_function("oxbot.speaking", timeout=15_000)
            before = log_items(tab)
            started = time.monotonic()
            tab.reload()
            wait_resumed(tab)
            resumed_in = time.monotonic() - started
            after = log_items(tab)
            assert after[: len(before)] == before, (before, after)
            assert tab.evaluate("oxbot.hello.session") == session
            assert tab.evaluate(INK, ["board", mine]) > 50  # the person's symbol, on the sheet
            robots = moves(tab, "sys")
            try:  # drawn again over a few frames (more on a busy machine)
                tab.wait_for_function(ROBOT_INKED, arg=robots, timeout=5_000)
            except PlaywrightError:
                inks = [tab.evaluate(INK, ["robot-ink", r]) for r in robots]
                raise AssertionError(f"the robot's ink in {robots}: {inks}") from None
            tab.screenshot(path=ARTIFACTS / "reload-resumed.png", full_page=True)

            # twice in a row, the second before the first page has settled
            tab.reload(wait_until="commit")
            reload_again(tab)
            wait_resumed(tab)
            assert log_items(tab)[: len(after)] == after
            assert tab.evaluate("oxbot.hello.session") == session and sessions(server_url) == 1
            assert tab.evaluate(INK, ["board", mine]) > 50

            # and the game goes on to its end on the sheet brought back
            deadline = time.monotonic() + 120
            while not tab.evaluate("oxbot.ended"):
                assert time.monotonic() < deadline, f"no goodbye; log: {log_items(tab)}"
                play_a_move(tab, rng)
            items = log_items(tab)
            assert items[-1][:2] == ("sys", "Salutation(closing)")
            assert not [t for s, a, t in items if a == "Inform(problem)"], items
            tab.screenshot(path=ARTIFACTS / "reload-finished.png", full_page=True)

            # a reload after the goodbye: a fresh page, and the game's robot is stopped
            tab.reload()
            tab.wait_for_timeout(500)
            assert not log_items(tab) and tab.evaluate("oxbot.ws") is None
            assert "Press Start" in tab.get_by_test_id("status").inner_text()
            deadline = time.monotonic() + 10
            while sessions(server_url):
                assert time.monotonic() < deadline, "the finished game's robot was kept"
                time.sleep(0.1)
        except Exception as exc:
            tab.screenshot(path=ARTIFACTS / "failure-reload.png", full_page=True)
            raise AssertionError(f"{exc}\nthe page's log: {log_items(tab)}") from exc
        finally:
            browser.close()
    assert resumed_in < 5, resumed_in


def test_a_game_that_cannot_be_brought_back_is_said_so_plainly(server_url):
    """A reload after the server forgot the game (restarted, or the page was away too long):
    the page says so, and a new game starts."""
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=BROWSER_FLAGS)
        try:
            tab = browser.new_page()
            tab.goto(server_url + "/")
            tab.evaluate("sessionStorage.setItem('oxbot.resume', 'a-game-long-gone')")
            tab.reload()
            wait_for_act(tab, "Salutation(greeting)")
            status = tab.get_by_test_id("status").inner_text()
            notes = tab.evaluate(
                "[...document.querySelectorAll('[data-testid=log] li.note')]"
                ".map(li => li.textContent)"
            )
        finally:
            browser.close()
    assert "could not be brought back" in status, status
    assert any("could not be brought back" in n and "new game" in n for n in notes), notes
