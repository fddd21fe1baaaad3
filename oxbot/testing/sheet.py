"""The web page's game sheet, drawn in Python: the same paper, grid and pens as the page
(oxbot/web/static/app.js, whose constants must match these).

The page (static/app.js) draws a hand-drawn-looking 3x3 grid on a square canvas of
`SIDE` pixels and the person draws on it with a dark pen; it sends the canvas to the server,
where `read_board` reads it. Scripted clients (tests, `bench/bench_web.py`) use `Sheet` to make
the same images without a browser: `Sheet(seed).draw("middle", "cross").png()`.

Geometry is shared with the page: the grid spans [`MARGIN`, `SIDE` - `MARGIN`] on both axes,
cell (r, c) is the square between lines r, r+1 and c, c+1 of `grid_lines()`.
"""

from __future__ import annotations

import io

import cv2
import numpy as np
from PIL import Image

from oxbot.errors import InvalidInputError
from oxbot.game.board import CELL_NAMES, SIZE, cell_index

SIDE = 360
"""Width and height of the page's canvas in pixels (what the server receives)."""
MARGIN = 30
"""Paper around the grid, in pixels."""
PAPER = (250, 248, 240)
"""The sheet's colour (RGB): warm white paper."""
INK = (30, 34, 60)
"""The pen's colour (RGB): dark blue-black ink, as the board reader expects."""
GRID_WIDTH = 4
"""Thickness of the grid lines in pixels."""
PEN_WIDTH = 5
"""Thickness of the person's pen in pixels (the page uses the same)."""


def grid_lines() -> tuple[float, ...]:
    """The SIZE + 1 lines' positions (x or y, pixels) bounding the columns and rows."""
    step = (SIDE - 2 * MARGIN) / SIZE
    return tuple(MARGIN + i * step for i in range(SIZE + 1))


def cell_box(cell: int | str) -> tuple[float, float, float, float]:
    """The cell's (left, top, right, bottom) in canvas pixels."""
    index = cell if isinstance(cell, int) else cell_index(cell)
    lines = grid_lines()
    row, col = divmod(index, SIZE)
    return lines[col], lines[row], lines[col + 1], lines[row + 1]


def unit_to_canvas(cell: int | str, points: np.ndarray, inset: float = 0.0) -> np.ndarray:
    """Points in the cell's unit square ((0, 0) upper left) as canvas pixels."""
    left, top, right, bottom = cell_box(cell)
    left, top = left + inset, top + inset
    right, bottom = right - inset, bottom - inset
    points = np.asarray(points, dtype=np.float64)
    return np.stack(
        [left + points[:, 0] * (right - left), top + points[:, 1] * (bottom - top)], axis=1
    )


def _wobbly(start: np.ndarray, end: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A hand-drawn straight line: a gentle bow and a little tremor."""
    t = np.linspace(0.0, 1.0, 40)[:, None]
    direction = end - start
    normal = np.array([-direction[1], direction[0]]) / max(np.linalg.norm(direction), 1e-6)
    bow = rng.uniform(-3.0, 3.0) * np.sin(np.pi * t)
    tremor = np.cumsum(rng.normal(0.0, 0.25, size=(40, 1)), axis=0)
    tremor -= t * tremor[-1]
    return start + t * direction + (bow + tremor) * normal


def hand_grid(rng: np.random.Generator) -> list[np.ndarray]:
    """The inner grid strokes (polylines in canvas pixels), overshooting a little."""
    lines = grid_lines()
    strokes = []
    for i in range(1, SIZE):
        for vertical in (True, False):
            pos = lines[i] + rng.uniform(-3, 3)
            a = lines[0] - rng.uniform(-4, 10)
            b = lines[SIZE] + rng.uniform(-4, 10)
            if vertical:
                start, end = np.array([pos, a]), np.array([pos + rng.uniform(-4, 4), b])
            else:
                start, end = np.array([a, pos]), np.array([b, pos + rng.uniform(-4, 4)])
            strokes.append(_wobbly(start, end, rng))
    return strokes


def person_strokes(symbol: str, rng: np.random.Generator) -> list[np.ndarray]:
    """A person's circle or cross in the unit square of a cell, as a hand draws it."""
    centre = 0.5 + rng.uniform(-0.06, 0.06, size=2)
    size = rng.uniform(0.26, 0.34)
    if symbol == "cross":
        a = rng.uniform(-0.05, 0.05, size=4)
        ends = np.array(
            [
                [[-size, -size + a[0]], [size, size + a[1]]],
                [[size, -size + a[2]], [-size, size + a[3]]],
            ]
        )
        return [centre + ends[0], centre + ends[1]]
    if symbol == "circle":
        start = rng.uniform(0, 2 * np.pi)
        t = start + np.linspace(0, 2 * np.pi * rng.uniform(1.0, 1.08), 48)
        aspect = rng.uniform(0.85, 1.1)
        return [np.stack([centre[0] + size * np.cos(t), centre[1] + size * aspect * np.sin(t)], 1)]
    raise InvalidInputError(f"a symbol is 'circle' or 'cross', not {symbol!r}")


class Sheet:
    """A canvas image of the page's game sheet that symbols can be drawn on.

    `seed` fixes the hand-drawn grid (as the page draws one grid per game).
    """

    def __init__(self, seed: int = 0) -> None:
        self.rng = np.random.default_rng(seed)
        self.image = np.empty((SIDE, SIDE, 3), np.uint8)
        self.image[:] = PAPER
        for stroke in hand_grid(self.rng):
            self.stroke(stroke, GRID_WIDTH)

    def stroke(self, points: np.ndarray, width: int = PEN_WIDTH) -> Sheet:
        """Draw one polyline (canvas pixels) with the pen."""
        pts = np.round(np.asarray(points) * 4).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(self.image, [pts], False, INK, width, cv2.LINE_AA, shift=2)
        return self

    def draw(self, cell: int | str, symbol: str, strokes: int | None = None) -> Sheet:
        """Draw a person's `symbol` in `cell` (only its first `strokes` strokes, if given)."""
        drawn = person_strokes(symbol, self.rng)
        return self.draw_strokes(cell, drawn[: strokes if strokes is not None else len(drawn)])

    def draw_strokes(self, cell: int | str, strokes: list[np.ndarray]) -> Sheet:
        """Draw strokes given in the cell's unit square ((0, 0) its upper left) in `cell`."""
        for points in strokes:
            self.stroke(unit_to_canvas(cell, points))
        return self

    def copy(self) -> Sheet:
        """The same sheet as it is now, to draw on without changing this one."""
        twin = Sheet.__new__(Sheet)
        twin.rng = np.random.default_rng(self.rng.integers(2**63))
        twin.image = self.image.copy()
        return twin

    def png(self) -> bytes:
        """The sheet as PNG bytes, as the page's `canvas.toDataURL('image/png')` sends it."""
        buffer = io.BytesIO()
        Image.fromarray(self.image).save(buffer, format="PNG")
        return buffer.getvalue()


__all__ = ["CELL_NAMES", "SIDE", "Sheet", "cell_box", "grid_lines", "unit_to_canvas"]
