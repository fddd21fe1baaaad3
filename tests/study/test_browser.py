"""The participant's page in Chromium: a no keeps nothing; a yes, then each answer, is kept;
the game's frame shows only the condition's way to answer."""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import sync_playwright

from oxbot.config import OxbotConfig
from oxbot.study.conditions import Design
from oxbot.study.page import add_routes
from oxbot.study.session import Study
from oxbot.testing.browser import CHROMIUM, FLAGS
from oxbot.web.server import create_app, serving_in_background

pytestmark = pytest.mark.realtime  # timed by the wall clock: `make test` runs these apart

PRE = ["pre-age_band-25-34", "pre-robot_experience-never", "pre-game_experience-often"]


def test_the_consent_page_keeps_nothing_without_a_yes_and_each_answer_after_it(tmp_path):
    assert Path(CHROMIUM).exists(), f"{CHROMIUM} is missing: run `make setup`"
    study = Study(tmp_path / "study", Design(vary=("input",)))
    config = OxbotConfig()
    app = create_app(config)
    add_routes(app, study, config)
    with serving_in_background(app) as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=list(FLAGS))
        try:
            page = browser.new_page()
            page.goto(f"{url}/study")
            page.get_by_test_id("consent-yes").wait_for()
            assert "Nothing at all is kept" in page.get_by_test_id("consent-text").inner_text()
            page.get_by_test_id("consent-no").click()
            page.get_by_test_id("declined").wait_for()
            assert not (tmp_path / "study").exists()

            page = browser.new_page()  # another person, who agrees
            page.goto(f"{url}/study")
            page.get_by_test_id("consent-yes").click()
            page.get_by_test_id("questions").wait_for()
            code = page.get_by_test_id("participant").inner_text().split()[-1]
            for name in PRE[:2]:
                page.get_by_test_id(name).check()
            assert page.get_by_test_id("questions-next").is_disabled()
            page.get_by_test_id(PRE[2]).check()
            page.wait_for_selector("[data-testid=questions-next]:not([disabled])")
            answers = study.store().answers(code)

            # the game page in the frame shows only the condition's way to answer, and never
            # the manager's Q-values (participants are blind to the manager)
            shown = {}
            for way in ("voice", "typing"):
                game = browser.new_page()
                game.goto(f"{url}/study/game?participant={code}&block=1&input={way}")
                game.get_by_test_id("board").wait_for()
                shown[way] = {
                    part: game.get_by_test_id(part).is_visible()
                    for part in ("say", "talk", "hands-free", "decision", "record")
                }
        finally:
            browser.close()
    assert sorted((a["item"], a["value"]) for a in answers) == [
        ("age_band", "25-34"),
        ("game_experience", "often"),
        ("robot_experience", "never"),
    ]
    assert shown["voice"] == {
        "say": False,
        "talk": True,
        "hands-free": True,
        "decision": False,
        "record": False,
    }
    assert shown["typing"] == {
        "say": True,
        "talk": False,
        "hands-free": False,
        "decision": False,
        "record": False,
    }
