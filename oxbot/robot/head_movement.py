"""Head movement: the robot mirrors the person's head (paper §3.1).

The paper's robot turned its head as a mirror image of the person's: when the person turns to
their left, the robot, facing them, turns to its right. Up, down and centre stay as they are.
"""

from __future__ import annotations

from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import Direction, HeadDirection, HeadMove, Message

MIRROR: dict[Direction, Direction] = {
    "left": "right",
    "right": "left",
    "up": "up",
    "down": "down",
    "centre": "centre",
}
"""The robot's head direction for each of the person's (paper §3.1: person left = robot right)."""


def mirror(direction: Direction) -> Direction:
    """Where the robot turns when the person's head points `direction`."""
    return MIRROR[direction]


class HeadMovementComponent(Component):
    """On HeadDirection, publishes the mirroring HeadMove (once per change of direction)."""

    listens_to = (HeadDirection,)
    part = "head"
    essential = False  # the game goes on with the robot looking straight ahead

    def __init__(self, bus: Bus, name: str | None = None) -> None:
        super().__init__(bus, name)
        self.current: Direction | None = None

    def handle(self, message: Message) -> None:
        assert isinstance(message, HeadDirection)
        move = mirror(message.direction)
        if move != self.current:
            self.current = move
            self.bus.publish(HeadMove(direction=move))

    def restart(self) -> None:
        self.current = None

    def take_over(self, old: Component) -> None:
        assert isinstance(old, HeadMovementComponent)
        self.current = old.current
