"""A reload mid-game, in Debian's Chromium: the game is lost with its socket, and the page says
so plainly instead of showing a blank sheet as if nothing had happened."""

from __future__ import annotations

from playwright.sync_api import sync_playwright

from oxbot.testing.browser import CHROMIUM
from oxbot.testing.browser import FLAGS as BROWSER_FLAGS


def test_a_reload_mid_game_says_the_game_is_lost_and_how_to_play_again(server_url):
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=BROWSER_FLAGS)
        try:
            tab = browser.new_page()
            tab.goto(server_url + "/")
            assert tab.locator("#problem").is_hidden()  # a first visit: nothing was lost
            tab.click("text=Start")
            tab.wait_for_selector("[data-testid=log] li[data-act]")  # the robot has greeted
            tab.reload()
            tab.wait_for_selector("#problem:not([hidden])", timeout=5_000)
            told = tab.locator("#problem").inner_text()
            tab.reload()  # told once: a reload before any game loses nothing
            again = tab.locator("#problem").is_hidden()
        finally:
            browser.close()
    assert "reloaded" in told and "Press Start" in told, told
    assert again
