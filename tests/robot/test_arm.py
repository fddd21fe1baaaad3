import time

import numpy as np
import pytest

from oxbot.config import ArmConfig
from oxbot.robot.arm import ArmComponent, cell_strokes, drawing_seconds
from oxbot.robot.bus import LocalBus
from oxbot.robot.messages import ArmCommand, ArmDone, ArmStroke, ComponentFailed
from tests.robot.helpers import collect

FAST = 50.0
"""Times faster than real time."""


@pytest.mark.parametrize("symbol", ["circle", "cross"])
def test_a_symbol_takes_one_to_two_seconds_at_a_real_pen_speed(symbol):
    for seed in range(20):
        strokes = cell_strokes(symbol, np.random.default_rng(seed))
        assert 0.9 <= drawing_seconds(strokes, ArmConfig()) <= 2.2


def test_strokes_stay_inside_the_cell_with_a_margin():
    for symbol in ("circle", "cross"):
        points = np.vstack(cell_strokes(symbol, np.random.default_rng(3), fill=0.7))
        assert points.min() >= 0.15 - 1e-9 and points.max() <= 0.85 + 1e-9
        assert np.allclose((points.min(axis=0) + points.max(axis=0)) / 2, 0.5, atol=0.05)


def test_the_robots_circles_are_always_closed():
    for seed in range(200):
        (loop,) = cell_strokes("circle", np.random.default_rng(seed))
        around = loop - (loop.min(axis=0) + loop.max(axis=0)) / 2
        turned = np.abs(np.diff(np.unwrap(np.arctan2(around[:, 1], around[:, 0])))).sum()
        assert turned >= 2 * np.pi, f"seed {seed}: an open loop, {np.degrees(turned):.0f} degrees"


def test_the_arm_draws_stroke_by_stroke_then_says_done():
    bus = LocalBus()
    inbox = bus.subscribe(ArmStroke, ArmDone)
    arm = ArmComponent(bus, rng=np.random.default_rng(0), speed_factor=FAST)
    with arm:
        bus.publish(ArmCommand(where="upper left", symbol="cross"))
        first = inbox.get(timeout=5.0)
        assert arm.drawing
        got = [first, *collect(inbox, lambda m: isinstance(m, ArmDone))]
        time.sleep(0.05)
        assert not arm.drawing
    strokes, done = got[:-1], got[-1]
    assert done == ArmDone(where="upperleft", stamp=done.stamp)
    assert len(strokes) >= 2  # a cross has two strokes, a sketchy one more
    assert all(isinstance(s, ArmStroke) and s.where == "upperleft" for s in strokes)
    assert all(0.0 <= v <= 1.0 for s in strokes for p in s.points for v in p)


def test_drawing_takes_the_time_a_pen_needs():
    config = ArmConfig()
    expected = drawing_seconds(cell_strokes("circle", np.random.default_rng(7)), config) / 4.0
    bus = LocalBus()
    done = bus.subscribe(ArmDone)
    with ArmComponent(bus, config, np.random.default_rng(7), speed_factor=4.0):
        start = time.monotonic()
        bus.publish(ArmCommand(where="middle", symbol="circle"))
        assert done.get(timeout=5.0) is not None
        elapsed = time.monotonic() - start
    assert expected * 0.95 <= elapsed <= expected + 0.25


def test_commands_queue_and_a_bad_cell_is_reported_without_stopping_the_arm():
    bus = LocalBus()
    inbox = bus.subscribe(ArmStroke, ArmDone, ComponentFailed)
    with ArmComponent(bus, rng=np.random.default_rng(1), speed_factor=FAST) as arm:
        bus.publish(ArmCommand(where="middle", symbol="circle"))
        bus.publish(ArmCommand(where="nowhere", symbol="circle"))
        bus.publish(ArmCommand(where="9", symbol="cross"))
        got = collect(inbox, lambda m: isinstance(m, ArmDone) and m.where == "lowerright")
    drawn = [m for m in got if not isinstance(m, ComponentFailed)]
    cells = [m.where for m in drawn]
    first_done = next(i for i, m in enumerate(drawn) if isinstance(m, ArmDone))
    assert set(cells[:first_done]) == {"middle"}
    assert cells[first_done] == "middle" and set(cells[first_done + 1 :]) == {"lowerright"}
    failures = [m for m in got if isinstance(m, ComponentFailed)]
    assert len(failures) == 1 and "nowhere" in failures[0].error
    assert arm.failures == 1
