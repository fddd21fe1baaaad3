import pytest

from oxbot.robot.bus import LocalBus
from oxbot.robot.head_movement import HeadMovementComponent, mirror
from oxbot.robot.messages import HeadDirection, HeadMove


@pytest.mark.parametrize(
    ("person", "robot"),
    [("left", "right"), ("right", "left"), ("up", "up"), ("down", "down"), ("centre", "centre")],
)
def test_the_robot_mirrors_the_person(person, robot):
    assert mirror(person) == robot


def test_the_component_turns_the_head_once_per_change():
    bus = LocalBus()
    moves = bus.subscribe(HeadMove)
    people = ["centre", "left", "left", "up", "right", "centre"]
    with HeadMovementComponent(bus):
        for direction in people:
            bus.publish(HeadDirection(direction=direction))
        got = [moves.get(timeout=2.0) for _ in range(5)]
    assert [m.direction for m in got] == ["centre", "right", "up", "left", "centre"]
    assert moves.drain() == []
