import time

import numpy as np
import pytest
from skimage import data

from oxbot.errors import InvalidInputError
from oxbot.robot.bus import Bus
from oxbot.robot.head_tracking import HeadTracker, HeadTrackingComponent, HeadTrackingConfig
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
    tracker = HeadTracker(HeadTrackingConfig(mirrored=True))
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
    tracker = HeadTracker(HeadTrackingConfig(calibration_detections=2))
    right = scene(astronaut, dx=150)
    assert tracker.direction(right) == "centre"  # calibrating: the person looks ahead
    assert not tracker.calibrated
    assert tracker.direction(right) == "centre"
    assert tracker.calibrated
    assert tracker.direction(scene(astronaut)) == "right"


def test_the_component_publishes_only_changes(astronaut):
    bus = Bus()
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
