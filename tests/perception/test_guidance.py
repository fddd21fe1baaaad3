"""What the robot tells a person whose camera cannot show it the board: rendered
webcam frames of a sheet, dark, blurred, under a hand, out of the picture, read by the real
board reader and diagnosed."""

import cv2
import numpy as np
import pytest

from oxbot.errors import NoGridFound
from oxbot.perception.board import default_reader
from oxbot.perception.grid import as_gray, find_grid
from oxbot.perception.guidance import diagnose
from oxbot.testing.webcam import PaperVideo

VIEWS = ("sheet", "no_grid", "off_edge", "dark", "blurred", "hand")


@pytest.fixture(scope="module")
def frames():
    video = PaperVideo(seed=2)
    video.draw("upperleft", "cross")
    for view in VIEWS:
        video.show(view, 0.1)
    return dict(zip(VIEWS, list(video.frames())[-len(VIEWS) :], strict=True))


def refusal(frame):
    try:
        default_reader().read(frame)
    except NoGridFound as exc:
        return str(exc)
    return ""


@pytest.mark.parametrize("scale", [1.0, 0.5])
def test_each_unreadable_view_is_told_with_what_to_do(frames, scale):
    sheet = frames["sheet"]
    h, w = sheet.shape[:2]
    corners = find_grid(as_gray(sheet)).corners() / np.array([w, h])
    assert refusal(sheet) == ""  # the video's sheet itself is readable
    kinds = {}
    for view in VIEWS[1:]:
        frame = cv2.resize(frames[view], None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        reason = refusal(frame)
        assert reason, f"the reader read the {view} frame"
        kinds[view] = diagnose(frame, reason, corners)
    assert {v: g.kind for v, g in kinds.items()} == {
        "no_grid": "no_grid",
        "off_edge": "off_edge",
        "dark": "too_dark",
        "blurred": "blurred",
        "hand": "hand",
    }
    assert "move the camera to the right" in kinds["off_edge"].text
    assert "light" in kinds["dark"].text and "hold the camera still" in kinds["blurred"].text
    assert kinds["no_grid"].text.startswith("no grid in view")  # the finder's own words


def test_a_hand_needs_a_grid_seen_before_and_a_blank_desk_is_no_blur():
    blank = np.full((480, 640, 3), 235, np.uint8)
    assert diagnose(blank, "no grid in view").kind == "no_grid"
    video = PaperVideo(seed=2)
    video.show("hand", 0.1)
    (hand,) = video.frames()
    assert diagnose(hand, "no 3x3 grid").kind == "no_grid"  # no grid seen yet: who knows
