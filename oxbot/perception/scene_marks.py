"""Marks people make on a grid scene's sheet besides the grid: symbols in its cells, doodles off it.

In the cells: 0-9 circles and crosses (`oxbot.perception.synth.symbol_strokes`), as a game
leaves them (turns alternate), 45-85% of a cell wide or, now and then, big enough to touch the
lines; some replaced by partial shapes (`partial_strokes`); now and then hatching or a scribble
in an empty cell. Off the grid: handwritten words, a lone line, small grids that are not 3x3
(a plus, one line crossed by two or three), boxes, spirals, symbols. Everything is plane
polylines in the grid's cell units, drawn by the caller with an ink of its choice.
"""

from __future__ import annotations

import math

import numpy as np

from oxbot.game.board import SIZE
from oxbot.perception.synth import partial_strokes, symbol_strokes

MAX_SYMBOLS = 9
"""A game's symbols: 0 to 9 of them."""
PARTIAL_SHARE = 0.12
"""Share of symbols left partial (an arc, a stroke, a tick...)."""
TOUCHING_SHARE = 0.2
"""Share of symbols big or off-centre enough to touch the cell's lines."""
SYMBOL_WIDTH = (0.45, 0.85)
"""A symbol's width as a share of its cell's side."""
HATCH_SHARE = 0.12
"""Share of grids with one empty cell hatched or scribbled over."""
DISTRACTOR_KINDS = ("text", "line", "small_grid", "doodle")


def _in_cell(lattice: np.ndarray, row: int, col: int, uv: np.ndarray) -> np.ndarray:
    """Plane points at (u, v) in [0, 1]^2 of a cell, mapped bilinearly to its four corners."""
    q00, q01 = lattice[row, col], lattice[row, col + 1]
    q10, q11 = lattice[row + 1, col], lattice[row + 1, col + 1]
    u, v = uv[:, :1], uv[:, 1:]
    return (1 - u) * (1 - v) * q00 + u * (1 - v) * q01 + u * v * q11 + (1 - u) * v * q10


def _turned(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def cell_marks(rng: np.random.Generator, lattice: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """What a game left in the cells of a plane lattice (4, 4, 2): (label, plane stroke) pairs,
    the label "circle", "cross", "partial" or "hatch"."""
    marks: list[tuple[str, np.ndarray]] = []
    cells = rng.permutation(SIZE * SIZE)
    count = int(rng.integers(0, MAX_SYMBOLS + 1))
    first = int(rng.integers(2))
    for turn, cell in enumerate(cells[:count]):
        label = ("circle", "cross")[(first + turn) % 2]
        row, col = divmod(int(cell), SIZE)
        partial = rng.random() < PARTIAL_SHARE
        strokes = partial_strokes(rng) if partial else symbol_strokes(label, rng)
        if rng.random() < TOUCHING_SHARE:
            width = rng.uniform(0.85, 1.05)
            offset = rng.uniform(-0.2, 0.2, 2)
        else:
            width = rng.uniform(*SYMBOL_WIDTH)
            offset = rng.uniform(-1, 1, 2) * (1 - width) / 2 * 0.8
        angle = rng.normal(0, 0.15)
        for stroke in strokes:
            uv = 0.5 + offset + _turned(stroke, angle) * width / 2
            marks.append(("partial" if partial else label, _in_cell(lattice, row, col, uv)))
    empty = cells[count:]
    if len(empty) and rng.random() < HATCH_SHARE:
        row, col = divmod(int(empty[0]), SIZE)
        if rng.random() < 0.5:
            strokes = [s * 0.35 for s in partial_strokes(rng, "scribble")]
        else:
            strokes = _hatching(rng)
        marks += [("hatch", _in_cell(lattice, row, col, 0.5 + s)) for s in strokes]
    return marks


def _hatching(rng: np.random.Generator) -> list[np.ndarray]:
    """Parallel strokes across the middle of a cell, centred on 0, in cell units."""
    angle = rng.uniform(0, np.pi)
    along = np.array([math.cos(angle), math.sin(angle)])
    across = np.array([-along[1], along[0]])
    count = int(rng.integers(4, 11))
    strokes = []
    for k in np.linspace(-0.32, 0.32, count):
        half = math.sqrt(max(0.35**2 - k**2, 0.01))
        t = np.linspace(-half, half, 8)[:, None]
        strokes.append(k * across + t * along + rng.normal(0, 0.01, (8, 2)))
    return strokes


def _words(rng: np.random.Generator) -> list[np.ndarray]:
    """A few handwritten words in rows, centred on 0, in cell units."""
    size = rng.uniform(0.1, 0.35)
    strokes = []
    for row in range(int(rng.integers(1, 4))):
        x, base = 0.0, row * size * 2.0
        for _ in range(int(rng.integers(1, 5))):
            n = int(rng.integers(4, 16))
            xs = x + np.arange(n) * size * 0.28 + rng.normal(0, size * 0.03, n)
            tops = np.where(rng.random(n) < 0.25, size, size * 0.55) * rng.uniform(0.8, 1.1, n)
            ys = base - np.where(np.arange(n) % 2 == 1, tops, rng.uniform(0, size * 0.1, n))
            strokes.append(np.stack([xs + (base - ys) * 0.25, ys], axis=1))  # slanted
            x = xs[-1] + size * rng.uniform(0.5, 0.9)
    return _centred(strokes)


def _centred(strokes: list[np.ndarray]) -> list[np.ndarray]:
    middle = (np.vstack(strokes).min(axis=0) + np.vstack(strokes).max(axis=0)) / 2
    return [s - middle for s in strokes]


def _small_grid(rng: np.random.Generator) -> list[np.ndarray]:
    """A plus, or one line crossed by two or three: never two lines each way (a 3x3 grid)."""
    crossing = int(rng.integers(1, 4))
    size = rng.uniform(0.5, 1.5)
    t = np.linspace(-0.5, 0.5, 16)[:, None] * size
    long_line = t * np.array([1.0, 0.0]) + rng.normal(0, 0.008, (16, 2))
    offsets = (np.arange(crossing) - (crossing - 1) / 2) * size / max(crossing, 2)
    strokes = [long_line]
    for offset in offsets:
        strokes.append(
            t * np.array([0.0, 1.0]) * 0.8 + [offset, 0.0] + rng.normal(0, 0.008, (16, 2))
        )
    return strokes


def _doodle(rng: np.random.Generator) -> list[np.ndarray]:
    """A symbol, a partial shape, a box or a spiral, about a cell across or less."""
    size = rng.uniform(0.2, 1.0)
    roll = rng.random()
    if roll < 0.3:
        return [s * size / 2 for s in symbol_strokes(("circle", "cross")[roll < 0.15], rng)]
    if roll < 0.6:
        return [s * size / 2 for s in partial_strokes(rng)]
    if roll < 0.8:
        w, h = size / 2, size / 2 * rng.uniform(0.4, 1.0)
        box = np.array([[-w, -h], [w, -h], [w, h], [-w, h], [-w, -h]])
        return [box + rng.normal(0, 0.01, box.shape)]
    t = np.linspace(0, rng.uniform(2, 5) * np.pi, 80)
    r = t / t[-1] * size / 2
    return [np.stack([r * np.cos(t), r * np.sin(t)], axis=1)]


def distractors(
    rng: np.random.Generator, count: int, avoid: np.ndarray, region: np.ndarray
) -> list[np.ndarray]:
    """Plane strokes of up to `count` drawings in the box `region` (x0, y0, x1, y1), each clear
    of the box `avoid` (the grid, with room around it)."""
    strokes: list[np.ndarray] = []
    for _ in range(count):
        kind = DISTRACTOR_KINDS[int(rng.integers(len(DISTRACTOR_KINDS)))]
        if kind == "text":
            shape = _words(rng)
        elif kind == "line":
            t = np.linspace(-0.5, 0.5, 40)[:, None] * rng.uniform(0.8, 3.0)
            shape = [t * np.array([1.0, 0.0]) + rng.normal(0, 0.006, (40, 2))]
        elif kind == "small_grid":
            shape = _small_grid(rng)
        else:
            shape = _doodle(rng)
        angle = rng.uniform(-0.3, 0.3) if kind == "text" else rng.uniform(0, np.pi)
        shape = [_turned(s, angle) for s in shape]
        for _ in range(8):  # a few tries for a place clear of the grid
            centre = rng.uniform(region[:2], region[2:])
            placed = [s + centre for s in shape]
            points = np.vstack(placed)
            lo, hi = points.min(axis=0), points.max(axis=0)
            if (hi < avoid[:2]).any() or (lo > avoid[2:]).any():
                strokes += placed
                break
    return strokes
