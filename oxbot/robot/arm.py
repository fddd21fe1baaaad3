"""The robot's arm, simulated: it draws its symbol in a cell stroke by stroke (paper §3.1).

The paper's arm drew the robot's symbol on the sheet and said when it was done; the next
utterance waited for it. This arm takes as long as a real pen would: each stroke's length at
`pen_speed`, a pen lift between strokes, and the moves to the cell and back to rest. It
publishes every stroke as it finishes it (points in the cell's unit square, (0, 0) upper left,
so a page or a rendered sheet can show the ink appear), then ArmDone.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from oxbot.errors import InvalidInputError
from oxbot.game.board import CELL_NAMES, cell_index
from oxbot.perception.synth import symbol_strokes
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import ArmCommand, ArmDone, ArmStroke, Message

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ArmConfig:
    """How big the cells are and how fast the simulated pen moves."""

    cell_size: float = 0.05
    """Metres across one cell of the drawn grid (a 15 cm grid on an A4 sheet)."""
    fill: float = 0.7
    """Fraction of the cell the symbol spans, leaving a margin clear of the grid lines."""
    pen_speed: float = 0.15
    """Metres per second along a stroke: a steady hand, so a symbol takes one to two seconds."""
    pen_lift: float = 0.2
    """Seconds to lift the pen and put it down at the next stroke's start."""
    travel: float = 0.3
    """Seconds to move from rest to the cell, and again from the cell back to rest."""
    speed_factor: float = 1.0
    """How many times faster than real time the arm runs (tests use large values)."""

    def __post_init__(self) -> None:
        if not 0 < self.fill <= 1:
            raise InvalidInputError(f"fill must lie in (0, 1]; got {self.fill}")
        if min(self.cell_size, self.pen_speed, self.speed_factor) <= 0:
            raise InvalidInputError("cell_size, pen_speed and speed_factor must be positive")
        if min(self.pen_lift, self.travel) < 0:
            raise InvalidInputError("pen_lift and travel are durations; they cannot be negative")


def cell_strokes(symbol: str, rng: np.random.Generator, fill: float = 0.7) -> list[np.ndarray]:
    """A hand-drawn `symbol`'s strokes in the cell's unit square, centred, spanning `fill`."""
    return [0.5 + 0.5 * fill * stroke for stroke in symbol_strokes(symbol, rng)]


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

    def __init__(
        self,
        bus: Bus,
        config: ArmConfig = ArmConfig(),
        rng: np.random.Generator | None = None,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        self.config = config
        self.rng = rng if rng is not None else np.random.default_rng()
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
        return not self._stop.wait(seconds / self.config.speed_factor)
