"""The page on a phone-sized screen, in Debian's Chromium (its own module: the browser game's
module keeps a Playwright session open for its whole run)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from playwright.sync_api import Page, sync_playwright

from oxbot.testing.browser import CHROMIUM
from oxbot.testing.browser import FLAGS as BROWSER_FLAGS

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart


@contextmanager
def started_on_a_phone(server_url: str) -> Iterator[Page]:
    """The page at 390x844 in Chromium, Start pressed."""
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=BROWSER_FLAGS)
        try:
            tab = browser.new_page(viewport={"width": 390, "height": 844})
            tab.goto(server_url + "/")
            tab.click("text=Start")
            yield tab
        finally:
            browser.close()


def test_on_a_phone_the_managers_table_shows_whole_act_names(server_url):
    with started_on_a_phone(server_url) as tab:
        tab.wait_for_selector("[data-testid=decision] tr[data-act]", state="attached")
        widths = tab.evaluate(
            """() => ({
              page: document.documentElement.scrollWidth,
              acts: [...document.querySelectorAll('#decision tr[data-act]')].map(tr => {
                const cell = tr.querySelector('.name');
                return [tr.dataset.act, cell.getBoundingClientRect().right,
                        cell.scrollWidth - cell.clientWidth];
              }),
            })"""
        )
    assert widths["page"] <= 390, widths["page"]  # nothing wider than the phone
    cut = [(act, right, hidden) for act, right, hidden in widths["acts"] if right > 390 or hidden]
    assert widths["acts"] and not cut, cut


def test_on_a_phone_the_answer_box_and_the_sheet_are_in_view_together(server_url):
    with started_on_a_phone(server_url) as tab:
        tab.wait_for_function("!document.getElementById('say').disabled")
        seen = []
        for scroll in ("top", "sheet", "conversation"):
            if scroll == "sheet":
                tab.locator("#board").scroll_into_view_if_needed()
            elif scroll == "conversation":
                tab.locator("#log").scroll_into_view_if_needed()
            box = tab.evaluate(
                """() => ['board', 'say'].map(id => {
                  const r = document.getElementById(id).getBoundingClientRect();
                  return [r.top, r.bottom];
                })"""
            )
            seen.append((scroll, box))
        tab.screenshot(path="test-artifacts/web/phone-answer-and-sheet.png")
    for scroll, ((board_top, board_bottom), (say_top, say_bottom)) in seen[:2]:
        # the whole sheet and the answer box on screen, the box not over the sheet
        assert board_top >= 0 and board_bottom <= say_top and say_bottom <= 844, (scroll, seen)
    (_, (_, (say_top, say_bottom))) = seen[2]
    assert say_top >= 0 and say_bottom <= 844, seen  # answering while reading the conversation
