"""Driving a robot whose components run in other processes or on other machines.

    from oxbot.robot.remote import RemoteRobot
    from oxbot.robot.zenoh_bus import Endpoints, ZenohBus

    with ZenohBus("kitchen", Endpoints(connect=("tcp/192.168.1.10:7447",))) as bus:
        with RemoteRobot(bus) as robot:      # joins the game under way, or starts one
            robot.say("yes let's play")

A `RemoteRobot` is a `Robot` (oxbot.robot.session) without components of its own: what the
person does goes on the shared bus, and the board and transcript come from it. It joins late:
its subscriptions (`robot.bus.subscribe`, as the web page's session makes) start with the game
so far, so a page opened mid-game shows the dialogue and the board. Several may drive one
robot (a terminal and web pages); one `ZenohBus` per process serves them all.
"""

from __future__ import annotations

import logging
import time

from oxbot.config import OxbotConfig
from oxbot.errors import BusError
from oxbot.robot.bus import LocalSubscription, Supervisor
from oxbot.robot.messages import (
    DialogueEnded,
    Message,
)
from oxbot.robot.session import Robot
from oxbot.robot.zenoh_bus import ZenohBus

log = logging.getLogger(__name__)


class LateJoiningBus:
    """A view of a `ZenohBus` whose subscriptions start with the game so far."""

    def __init__(self, bus: ZenohBus) -> None:
        self.zenoh = bus

    def subscribe(self, *types: type[Message]) -> LocalSubscription:
        return self.zenoh.subscribe_with_history(*types)

    def publish(self, message: Message) -> None:
        self.zenoh.publish(message)


class RemoteRobot(Robot):
    """A `Robot` whose components run elsewhere on `bus` (see the module docstring).

    `start` waits up to `wait_seconds` for `needs` (process names, by default the manager) to
    be up, then joins the game under way or, if none is, starts one; BusError if they are not.
    """

    def __init__(
        self,
        bus: ZenohBus,
        config: OxbotConfig | None = None,
        needs: tuple[str, ...] = ("manager",),
        wait_seconds: float = 30.0,
    ) -> None:
        # Robot.__init__ would build the seven components: here they run in other processes
        self.config = config if config is not None else OxbotConfig()
        self.zenoh = bus
        self.bus = LateJoiningBus(bus)
        self.needs = needs
        self.wait_seconds = wait_seconds
        self._watching_sheet = False
        self._vision = "GameMoveComponent"
        self.supervisor = Supervisor([], bus, self.config.robot)
        self._follow_games()

    def start(self) -> RemoteRobot:
        """Wait for the components it needs, then join the game under way or start one."""
        if self._started:
            return self
        deadline = time.monotonic() + self.wait_seconds
        while missing := set(self.needs) - {p.name for p in self.zenoh.alive()}:
            if time.monotonic() > deadline:
                raise BusError(
                    f"robot {self.zenoh.robot!r} has no {', '.join(sorted(missing))} after "
                    f"{self.wait_seconds:.0f} s: start it (oxbot component NAME, or oxbot robot "
                    "--launch FILE) and check both sides use the same --robot and endpoints"
                )
            time.sleep(0.1)
        self._started = True
        history = self.zenoh.game_so_far()
        if not history or any(isinstance(m, DialogueEnded) for m in history):
            self.new_game()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop driving; the components go on (they belong to their own processes)."""
        self._events.close()
        self._started = False
