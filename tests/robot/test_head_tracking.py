import logging
import time

import cv2
import numpy as np
import pytest
from skimage import data

from oxbot.config import HeadConfig
from oxbot.errors import InvalidInputError
from oxbot.perception.sources import ImageFolderSource
from oxbot.robot.bus import LocalBus
from oxbot.robot.head_tracking import HeadTracker, HeadTrackingComponent
from oxbot.robot.messages import HeadDirection

H, W = 768, 1024


@pytest.fixture(scope="module")
def astronaut():
    return data.astronaut()


def scene(photo, dx=0, dy=0):
    """The photo on a larger grey canvas, moved `dx` right and `dy` down from the middle."""
    canvas = np.full((H, W, 3), 128, np.uint8)
    h, w = photo.shape[:2]
    top, left = (H - h) // 2 + dy, (W - w) // 2 + dx
    canvas[top : top + h, left : left + w] = photo
    return canvas


def calibrated(photo):
    tracker = HeadTracker()
    tracker.calibrate(scene(photo))
    return tracker


def test_moving_the_face_gives_the_persons_direction(astronaut):
    tracker = calibrated(astronaut)
    assert tracker.direction(scene(astronaut)) == "centre"
    assert tracker.direction(scene(astronaut, dx=12, dy=-8)) == "centre"
    # The camera faces the person: their left is the image's right.
    assert tracker.direction(scene(astronaut, dx=150)) == "left"
    assert tracker.direction(scene(astronaut, dx=-150)) == "right"
    assert tracker.direction(scene(astronaut, dy=-100)) == "up"
    assert tracker.direction(scene(astronaut, dy=100)) == "down"


def test_a_mirroring_camera_swaps_left_and_right(astronaut):
    tracker = HeadTracker(HeadConfig(mirrored=True))
    tracker.calibrate(scene(astronaut))
    assert tracker.direction(scene(astronaut, dx=150)) == "right"
    assert tracker.direction(scene(astronaut, dx=-150)) == "left"


def test_a_flipped_photo_is_tracked_too(astronaut):
    flipped = astronaut[:, ::-1].copy()
    tracker = calibrated(flipped)
    assert tracker.direction(scene(flipped)) == "centre"
    assert tracker.direction(scene(flipped, dx=150)) == "left"
    assert tracker.direction(scene(flipped, dx=-150)) == "right"
    assert tracker.direction(scene(flipped, dy=100)) == "down"


def test_a_blank_frame_has_no_direction_and_cannot_calibrate(astronaut):
    tracker = calibrated(astronaut)
    blank = np.full((H, W, 3), 128, np.uint8)
    assert tracker.direction(blank) is None
    with pytest.raises(InvalidInputError, match="no face"):
        HeadTracker().calibrate(blank)


def test_the_first_detections_calibrate_the_centre(astronaut):
    tracker = HeadTracker(HeadConfig(calibration_detections=2))
    right = scene(astronaut, dx=150)
    assert tracker.direction(right) == "centre"  # calibrating: the person looks ahead
    assert not tracker.calibrated
    assert tracker.direction(right) == "centre"
    assert tracker.calibrated
    assert tracker.direction(scene(astronaut)) == "right"


def test_the_component_publishes_only_changes(astronaut):
    bus = LocalBus()
    heads = bus.subscribe(HeadDirection)
    component = HeadTrackingComponent(bus, calibrated(astronaut))
    frames = [scene(astronaut), scene(astronaut), scene(astronaut, dx=150)]
    frames += [np.full((H, W, 3), 128, np.uint8), scene(astronaut, dx=150), scene(astronaut)]
    with component:
        for frame in frames:
            component.push(frame)
        deadline = time.monotonic() + 10
        got = []
        while len(got) < 3 and time.monotonic() < deadline:
            message = heads.get(timeout=0.1)
            if message is not None:
                got.append(message.direction)
    assert got == ["centre", "left", "centre"]
    assert heads.drain() == []
    assert component.failures == 0


def test_the_component_reads_a_frame_source_until_it_ends(astronaut, tmp_path, caplog):
    moves = [(0, 0), (0, 0), (150, 0), (0, 100)]
    for i, (dx, dy) in enumerate(moves):
        cv2.imwrite(
            str(tmp_path / f"{i:02d}.png"),
            cv2.cvtColor(scene(astronaut, dx, dy), cv2.COLOR_RGB2BGR),
        )
    bus = LocalBus()
    heads = bus.subscribe(HeadDirection)
    tracker = HeadTracker(HeadConfig(calibration_detections=1))
    with (
        caplog.at_level(logging.INFO),
        HeadTrackingComponent(bus, tracker, ImageFolderSource(tmp_path)),
    ):
        got = [heads.get(timeout=5.0) for _ in range(3)]
        time.sleep(0.3)
    assert [m.direction for m in got] == ["centre", "left", "down"]
    assert any("no more frames" in r.getMessage() for r in caplog.records)


def test_a_missing_source_turns_head_tracking_off_with_one_warning(tmp_path, caplog):
    bus = LocalBus()
    inbox = bus.subscribe()
    with (
        caplog.at_level(logging.WARNING),
        HeadTrackingComponent(
            bus, source=ImageFolderSource(tmp_path / "no camera here")
        ) as component,
    ):
        time.sleep(0.5)  # five ticks
    assert inbox.drain() == [] and component.failures == 0
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "head tracking is off" in warnings[0].getMessage()
