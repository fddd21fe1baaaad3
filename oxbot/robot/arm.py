"""The robot's arm, simulated: it draws its symbol in a cell stroke by stroke (paper §3.1).

The paper's arm drew the robot's symbol on the sheet and said when it was done; the next
utterance waited for it. This arm takes as long as a real pen would: each stroke's length at
`pen_speed`, a pen lift between strokes, and the moves to the cell and back to rest. It
publishes every stroke as it finishes it (points in the cell's unit square, (0, 0) upper left,
so a page or a rendered sheet can show the ink appear), then ArmDone.
"""

from __future__ import annotations

import logging

import numpy as np

from oxbot.config import ArmConfig
from oxbot.errors import ConfigError
from oxbot.game.board import CELL_NAMES, cell_index
from oxbot.perception.synth import symbol_strokes
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import ArmCommand, ArmDone, ArmStroke, Message

log = logging.getLogger(__name__)


def cell_strokes(symbol: str, rng: np.random.Generator, fill: float = 0.7) -> list[np.ndarray]:
    """A hand-drawn `symbol`'s strokes in the cell's unit square, centred, spanning `fill`: a
    cross as the handwriting synthesiser draws one, a circle always closed (`closed_circle`)."""
    strokes = [closed_circle(rng)] if symbol == "circle" else symbol_strokes(symbol, rng)
    return [0.5 + 0.5 * fill * stroke for stroke in strokes]


def closed_circle(rng: np.random.Generator) -> np.ndarray:
    """The robot's own circle, a (K, 2) polyline in the unit box [-1, 1]^2: one loop, a little
    oval and tilted as a hand draws it, whose end runs a little past its start.

    Not the synthesiser's: a quarter of its circles are open loops, a "C", which the perceiver
    must learn to read as people draw them but a person would not take for a circle."""
    sweep = rng.uniform(1.03, 1.1)  # a turn and a little more: closed, a short overlap
    start, direction = rng.uniform(0, 2 * np.pi), rng.choice((-1.0, 1.0))
    t = start + direction * np.linspace(0.0, 2 * np.pi * sweep, 72)
    radius = 1.0 + rng.uniform(0, 0.04) * np.sin(2 * t + rng.uniform(0, 2 * np.pi))
    aspect, tilt = rng.uniform(0.8, 1.0), rng.uniform(0, np.pi)
    x, y = radius * np.cos(t), radius * aspect * np.sin(t)
    c, s = np.cos(tilt), np.sin(tilt)
    points = np.stack([c * x - s * y, s * x + c * y], axis=1)
    return points / np.abs(points).max()


def stroke_seconds(stroke: np.ndarray, config: ArmConfig) -> float:
    """Real time to draw one stroke (unit-square points) at the configured pen speed."""
    length = float(np.linalg.norm(np.diff(stroke, axis=0), axis=1).sum()) * config.cell_size
    return length / config.pen_speed


def drawing_seconds(strokes: list[np.ndarray], config: ArmConfig) -> float:
    """Real time for the whole symbol: travel there, strokes and pen lifts, travel back."""
    lifts = max(0, len(strokes) - 1) * config.pen_lift
    return 2 * config.travel + lifts + sum(stroke_seconds(s, config) for s in strokes)


class ArmComponent(Component):
    """On ArmCommand draws the symbol (ArmStroke per stroke) and then publishes ArmDone.

    Commands queue: the arm draws one symbol at a time. `drawing` is True from the first move
    towards the cell until the arm is back at rest.
    """

    listens_to = (ArmCommand,)
    retries = (ArmCommand,)  # the manager waits for ArmDone
    part = "arm"

    def __init__(
        self,
        bus: Bus,
        config: ArmConfig | None = None,
        rng: np.random.Generator | None = None,
        speed_factor: float = 1.0,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        if not speed_factor > 0:
            raise ConfigError(f"speed_factor must be positive; got {speed_factor}")
        self.config = config if config is not None else ArmConfig()
        self.rng = rng if rng is not None else np.random.default_rng()
        self.speed_factor = speed_factor
        self.drawing = False

    def handle(self, message: Message) -> None:
        assert isinstance(message, ArmCommand)
        where = CELL_NAMES[cell_index(message.where)]
        strokes = cell_strokes(message.symbol, self.rng, self.config.fill)
        log.info(
            "arm draws a %s in %s (%.1f s)",
            message.symbol,
            where,
            drawing_seconds(strokes, self.config),
        )
        self.drawing = True
        self.expect(drawing_seconds(strokes, self.config) / self.speed_factor)
        try:
            if not self._take(self.config.travel):
                return
            for i, stroke in enumerate(strokes):
                if i and not self._take(self.config.pen_lift):
                    return
                if not self._take(stroke_seconds(stroke, self.config)):
                    return
                points = tuple((round(float(x), 4), round(float(y), 4)) for x, y in stroke)
                self.bus.publish(ArmStroke(where=where, points=points))
            if not self._take(self.config.travel):
                return
        finally:
            self.drawing = False
        self.bus.publish(ArmDone(where=where))

    def restart(self) -> None:
        self.drawing = False

    def _take(self, seconds: float) -> bool:
        """Let `seconds` of arm time pass; False if the component is being stopped meanwhile."""
        return not self._stop.wait(seconds / self.speed_factor)
