"""Held-out drawings for the cell reader: what people draw in a cell, circles and crosses and
everything that is not a move, made without the training synthesiser.

The reader must call a circle a circle and a cross a cross, and must never turn a scribble, a
star, a letter or a digit into a move. This module draws both kinds of ink so a bench or a test
can count how often it does. It is held out: it was written from scratch, without reading the
reader (`oxbot.perception`), the training synthesiser or `oxbot.testing.odd_cells`, and it
shares no code or random stream with them. A reader tuned on those cannot pass by having learnt
their quirks; it passes only if it reads what a person would.

Every drawing is a list of strokes, each an (N, 2) float array of pen positions in the cell's
unit square ((0, 0) its upper left, (1, 1) its lower right), which is what
`oxbot.testing.sheet.Sheet.draw_strokes` takes:

    from oxbot.testing.heldout_drawings import heldout_set
    from oxbot.testing.sheet import Sheet

    for kind, cell, strokes in heldout_set(n_per_kind=30, seed=7):
        png = Sheet(seed=1).draw_strokes(cell, strokes).png()
        # read the sheet; a kind in SYMBOLS must come back as that symbol, a kind in
        # NOT_MOVES as anything but a circle or a cross

How a drawing is made: a shape's strokes are laid out in a canonical box, then drawn by a
"hand" with its own habits for that drawing: a size of 0.35-0.85 of the cell (a dot and a tick
are smaller), a stretch of up to 20% along one axis, a slant of up to 20 degrees, a place off
the cell's centre, a slow wobble across each stroke and a faint tremor, and a pen sampled
densely or sparsely (a mouse, a finger, a stylus), unevenly along the stroke. Strokes often
overshoot where they end; a closed shape's end runs past its start.

Kinds (`KINDS`):

- `SYMBOLS`: a `circle` (one closed stroke, starting anywhere, either way round, its ends
  meeting or overlapping a little, width over height 0.8-1.2) and a `cross` (two strokes
  crossing near their middles, arms of about the same length, each 30-60 degrees off the
  horizontal: a handwritten X).
- `NOT_MOVES`: a `scribble` (a tangled ball of loops, or a patch filled back and forth), a
  `zigzag`, a `star` (a five-pointed star in one stroke, as a pentagram or as an outline, or an
  asterisk of 3-4 lines), a `spiral`, a `triangle`, a `square`, a `dot`, `hatching` (parallel
  lines), a `tick`, a `plus` (upright: it is slanted at most 10 degrees, so that it stays
  unlike a cross), a `half_circle`, an `arc`, a `single_stroke`; the capital letters A, E, H,
  K, L, M, N, T, V and Z (`letter_a`...) and the digits 1, 2, 3, 4, 5 and 7 (`digit_1`...).

Left out on purpose, because a fair reader may take them for a circle: the letter O and the
digit 0 (a ring), and the digits 6, 8 and 9, whose closed loops are rings of half the digit's
height or more; a quick 6 or 9 is a circle with a tail.

`quickdraw_drawings(category)` gives people's real drawings of simple shapes from Google's
Quick, Draw! dataset (CC BY 4.0) in the same form, when the files are in `bench/data/quickdraw/`
(not in git; its SOURCES.md says where they come from and how to restore them).

>>> import numpy as np
>>> strokes = heldout_drawing("star", np.random.default_rng(3))
>>> all(s.ndim == 2 and s.shape[1] == 2 for s in strokes)
True
"""

from __future__ import annotations

import itertools
import json
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from oxbot.game.board import CELL_NAMES

SYMBOLS: tuple[str, ...] = ("circle", "cross")
"""Kinds a reader must read as that symbol (a move)."""

LETTERS = ("a", "e", "h", "k", "l", "m", "n", "t", "v", "z")
DIGITS = ("1", "2", "3", "4", "5", "7")

NOT_MOVES: tuple[str, ...] = (
    "scribble",
    "zigzag",
    "star",
    "spiral",
    "triangle",
    "square",
    "dot",
    "hatching",
    "tick",
    "plus",
    "half_circle",
    "arc",
    "single_stroke",
    *(f"letter_{letter}" for letter in LETTERS),
    *(f"digit_{digit}" for digit in DIGITS),
)
"""Kinds a reader must never read as a circle or a cross."""

KINDS: tuple[str, ...] = SYMBOLS + NOT_MOVES
"""Every kind `heldout_drawing` draws."""

MARGIN = 0.06
"""Clear paper kept between a drawing and the cell's edge (unit square): the grid's lines and
the pen's own width (0.05 of a cell) sit there."""

QUICKDRAW_FOLDER = Path(__file__).resolve().parents[2] / "bench" / "data" / "quickdraw"
"""Where `quickdraw_drawings` looks for the Quick, Draw! files (not in git)."""

QUICKDRAW_SYMBOLS: tuple[str, ...] = ("circle",)
"""Quick, Draw! categories that are a move; every other category there is not."""

Drawing = list[np.ndarray]


# --- the hand: how canonical strokes become a person's strokes in a cell ---------------------


def _densify(points: np.ndarray, step: float) -> np.ndarray:
    """The polyline with points at most `step` apart (its corners kept)."""
    points = np.asarray(points, dtype=np.float64)
    out = [points[:1]]
    for a, b in itertools.pairwise(points):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        t = np.linspace(0.0, 1.0, n + 1)[1:, None]
        out.append(a + (b - a) * t)
    return np.concatenate(out)


def _arclength(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def _resample(points: np.ndarray, spacing: float, rng: np.random.Generator) -> np.ndarray:
    """The stroke as a pen samples it: about `spacing` apart, unevenly (the hand speeds up
    mid-stroke), both ends kept."""
    s = _arclength(points)
    length = s[-1]
    if length < 1e-9:
        return np.repeat(points[:1], 2, axis=0)
    gaps = spacing * rng.uniform(0.5, 1.5, size=int(length / (0.5 * spacing)) + 2)
    where = np.cumsum(gaps)
    where = np.concatenate([[0.0], where[where < length], [length]])
    xy = np.stack([np.interp(where, s, points[:, i]) for i in (0, 1)], axis=1)
    return xy if len(xy) >= 2 else np.repeat(points[:1], 2, axis=0)


def _wobble(points: np.ndarray, amplitude: float, rng: np.random.Generator) -> np.ndarray:
    """The stroke bent by a slow sideways drift of up to about `amplitude`, as a hand is never
    quite straight; the drift is smooth along the stroke, so corners stay corners."""
    if len(points) < 3 or amplitude <= 0:
        return points
    s = _arclength(points)
    u = s / max(s[-1], 1e-9)
    drift = np.zeros_like(u)
    for _ in range(3):
        cycles = rng.uniform(0.3, 2.5)
        drift += rng.normal(0, amplitude / 2) * np.sin(2 * np.pi * cycles * u + rng.uniform(0, 7))
    tangent = np.gradient(points, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    return points + normal * drift[:, None]


def _overshoot(points: np.ndarray, length: float) -> np.ndarray:
    """The stroke carried on straight past its end by `length`."""
    back = points[-1] - points[max(0, len(points) - 4)]
    norm = np.linalg.norm(back)
    if norm < 1e-9 or length <= 0:
        return points
    return np.concatenate([points, [points[-1] + back / norm * length]])


def _rotation(degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def _by_hand(
    strokes: list[np.ndarray],
    rng: np.random.Generator,
    size: tuple[float, float] = (0.35, 0.85),
    slant: float = 20.0,
    stretch: float = 0.2,
) -> Drawing:
    """Canonical strokes (about the box [-0.5, 0.5]², y down) drawn in a cell by one hand.

    The drawing's larger side becomes `size` (a range) of the cell, after a stretch of up to
    `stretch` along a random axis and a slant of up to `slant` degrees; it is placed off the
    centre as room allows, wobbled and resampled."""
    strokes = [_densify(s, 0.01) for s in strokes]
    # stretch along x or y (a person's circle is rarely round), then slant
    scale = 1.0 + rng.uniform(-stretch, stretch)
    squash = np.array([scale, 1.0]) if rng.random() < 0.5 else np.array([1.0, scale])
    turn = _rotation(rng.uniform(-slant, slant))
    strokes = [(s * squash) @ turn.T for s in strokes]

    every = np.concatenate(strokes)
    low, high = every.min(axis=0), every.max(axis=0)
    extent = max(float((high - low).max()), 1e-6)
    target = rng.uniform(*size)
    strokes = [(s - (low + high) / 2) * (target / extent) for s in strokes]

    # the slow wobble grows with the movement (a big stroke drifts further); the tremor is the
    # hand's own, in cell units, whatever the drawing's size
    amplitude = rng.uniform(0.008, 0.025) * target
    tremor = rng.uniform(0.0, 0.0025)
    spacing = rng.choice([rng.uniform(0.006, 0.012), rng.uniform(0.012, 0.04)])
    drawn = []
    for s in strokes:
        s = _wobble(s, amplitude, rng)
        s = _resample(s, spacing, rng)
        s = s + rng.normal(0, tremor, size=s.shape)
        drawn.append(s)

    # keep clear of the grid: shrink what is too big for the cell, then place it off-centre
    every = np.concatenate(drawn)
    low, high = every.min(axis=0), every.max(axis=0)
    room = 1.0 - 2 * MARGIN
    fit = min(1.0, room / max(float((high - low).max()), 1e-6))
    drawn = [(s - (low + high) / 2) * fit for s in drawn]
    half = (high - low) * fit / 2
    slack = np.maximum(room / 2 - half, 0.0)
    # people aim for the middle: offsets are drawn from a hump, not evenly
    offset = slack * (rng.uniform(-1, 1, 2) + rng.uniform(-1, 1, 2)) / 2
    return [s + 0.5 + offset for s in drawn]


def _spline(points: np.ndarray, per_segment: int = 12) -> np.ndarray:
    """A Catmull-Rom curve through the key points (for a pen's curves)."""
    p = np.asarray(points, dtype=np.float64)
    p = np.concatenate([p[:1] * 2 - p[1:2], p, p[-1:] * 2 - p[-2:-1]])
    t = np.linspace(0, 1, per_segment, endpoint=False)[:, None]
    out = []
    for i in range(1, len(p) - 2):
        p0, p1, p2, p3 = p[i - 1], p[i], p[i + 1], p[i + 2]
        out.append(
            0.5
            * (
                2 * p1
                + (-p0 + p2) * t
                + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2
                + (-p0 + 3 * p1 - 3 * p2 + p3) * t**3
            )
        )
    out.append(p[-2:-1])
    return np.concatenate(out)


def _jitter(points, rng: np.random.Generator, amount: float) -> np.ndarray:
    """Key points moved a little each: no two people put a corner in the same place."""
    points = np.asarray(points, dtype=np.float64)
    return points + rng.normal(0, amount, size=points.shape)


def _maybe_reversed(stroke: np.ndarray, rng: np.random.Generator, p: float = 0.5) -> np.ndarray:
    return stroke[::-1].copy() if rng.random() < p else stroke


def _glyph(strokes, rng: np.random.Generator, width: tuple[float, float]) -> list[np.ndarray]:
    """Strokes given in a letter's box ((0, 0) upper left, (1, 1) lower right; y down), made
    `width` (a range) as wide as tall, their key points jittered, centred on the origin."""
    w = rng.uniform(*width)
    out = []
    for s in strokes:
        s = _jitter(s, rng, 0.025) if not isinstance(s, _Curve) else s.points(rng)
        out.append((s - 0.5) * np.array([w, 1.0]))
    return out


class _Curve:
    """Key points a glyph's stroke passes through smoothly (a digit's bowl), as opposed to the
    plain lists of corners its straight strokes are."""

    def __init__(self, *parts: tuple[str, list[tuple[float, float]]]) -> None:
        self.parts = parts

    def points(self, rng: np.random.Generator) -> np.ndarray:
        out = []
        for how, keys in self.parts:
            keys = _jitter(keys, rng, 0.02)
            out.append(_spline(keys) if how == "curve" else keys)
        return np.concatenate(out)


# --- the symbols -----------------------------------------------------------------------------


def _circle(rng: np.random.Generator) -> list[np.ndarray]:
    start = rng.uniform(0, 2 * np.pi)
    # closed: the pen comes back to its start, a little short or a little past it
    sweep = 2 * np.pi + np.radians(rng.uniform(-4, 25))
    direction = rng.choice([-1.0, 1.0])
    t = start + direction * np.linspace(0, sweep, 120)
    # a hand's radius drifts slowly round the ring (an egg, a flat side), less than 8%
    u = np.linspace(0, 1, len(t))
    radius = 0.5 * (1 + rng.normal(0, 0.03) * np.sin(2 * np.pi * u + rng.uniform(0, 7)))
    radius *= 1 + rng.normal(0, 0.02) * np.sin(4 * np.pi * u + rng.uniform(0, 7))
    # the end comes in a little inside or outside the start, where the overlap is
    radius *= 1 + rng.uniform(-0.04, 0.04) * np.clip((u - 0.9) / 0.1, 0, 1)
    aspect = rng.uniform(0.8, 1.2)
    ring = np.stack([np.cos(t) * aspect, np.sin(t)], axis=1) * radius[:, None]
    return _by_hand([ring], rng, stretch=0.0)


def _cross(rng: np.random.Generator) -> list[np.ndarray]:
    # each arm 30-60 degrees off the horizontal, one falling, one rising
    falling = np.radians(rng.uniform(30, 60))
    rising = np.radians(rng.uniform(30, 60))
    strokes = []
    for angle, sign in ((falling, 1.0), (rising, -1.0)):
        length = rng.uniform(0.9, 1.1)
        # where the arms cross: near the middle of each, not exactly at it
        at = rng.uniform(0.42, 0.58)
        direction = np.array([np.cos(angle), sign * np.sin(angle)])
        centre = rng.normal(0, 0.03, 2)
        a = centre - direction * length * at
        b = centre + direction * length * (1 - at)
        bow = rng.normal(0, 0.03)  # a stroke drawn fast bows a little
        mid = (a + b) / 2 + np.array([-direction[1], direction[0]]) * bow
        stroke = _spline([a, mid, b], per_segment=20)
        # a falling stroke is drawn from its top, a rising one from either end
        if sign < 0:
            stroke = _maybe_reversed(stroke, rng)
        if rng.random() < 0.3:
            stroke = _overshoot(stroke, rng.uniform(0.02, 0.06))
        strokes.append(stroke)
    if rng.random() < 0.3:  # some draw the rising arm first
        strokes.reverse()
    return _by_hand(strokes, rng, slant=8.0, stretch=0.15)


# --- what is never a move ----------------------------------------------------------------------


def _scribble(rng: np.random.Generator) -> list[np.ndarray]:
    # not too small: a tiny scribble is a blot, which the `dot` kind already stands for
    if rng.random() < 0.5:
        return _by_hand([_loop_scribble(rng)], rng, size=(0.45, 0.85))
    return _by_hand([_fill_scribble(rng)], rng, size=(0.45, 0.85))


def _loop_scribble(rng: np.random.Generator) -> np.ndarray:
    """A tangled ball: loop after loop whose centre and size wander."""
    loops = rng.uniform(3, 7)
    t = np.linspace(0, 1, int(loops * 40))
    centre = np.zeros((len(t), 2))
    for _ in range(3):
        cycles = rng.uniform(0.3, 1.5)
        shift = rng.uniform(0, 7, 2)
        centre += rng.normal(0, 0.22, 2) * np.sin(2 * np.pi * cycles * t[:, None] + shift)
    radius = 0.22 + 0.1 * np.sin(2 * np.pi * rng.uniform(0.5, 2) * t + rng.uniform(0, 7))
    phase = rng.choice([-1.0, 1.0]) * 2 * np.pi * loops * t
    squash = rng.uniform(0.6, 1.0)
    return centre + radius[:, None] * np.stack([np.cos(phase), squash * np.sin(phase)], axis=1)


def _fill_scribble(rng: np.random.Generator) -> np.ndarray:
    """A patch coloured in: quick strokes back and forth, each a little further on."""
    passes = int(rng.integers(6, 15))
    y = np.linspace(-0.5, 0.5, passes) + rng.normal(0, 0.02, passes)
    half = 0.5 * rng.uniform(0.75, 1.0, passes)
    x = np.where(np.arange(passes) % 2 == 0, -half, half) + rng.normal(0, 0.04, passes)
    # the turns are tight but round, as the pen never lifts
    return _spline(np.stack([x, y], axis=1), per_segment=10)


def _zigzag(rng: np.random.Generator) -> list[np.ndarray]:
    teeth = int(rng.integers(4, 9))
    x = np.linspace(-0.5, 0.5, teeth + 1)
    height = rng.uniform(0.25, 0.6)
    y = np.where(np.arange(teeth + 1) % 2 == 0, height / 2, -height / 2)
    stroke = _jitter(np.stack([x, y], axis=1), rng, 0.02)
    if rng.random() < 0.3:  # drawn upright, as a column of teeth
        stroke = stroke[:, ::-1]
    return _by_hand([_maybe_reversed(stroke, rng)], rng)


def _star(rng: np.random.Generator) -> list[np.ndarray]:
    style = rng.choice(["pentagram", "pentagram", "outline", "asterisk"])
    base = -np.pi / 2 + rng.normal(0, 0.1)
    if style == "pentagram":
        # one stroke, point to every second point, ending back at the first
        order = np.arange(6) * 2 % 5
        t = base + order * 2 * np.pi / 5
        stroke = _jitter(np.stack([np.cos(t), np.sin(t)], axis=1) * 0.5, rng, 0.02)
        if rng.random() < 0.4:
            stroke = _overshoot(stroke, rng.uniform(0.03, 0.1))
        return _by_hand([stroke], rng)
    if style == "outline":
        t = base + np.arange(11) * np.pi / 5
        r = np.where(np.arange(11) % 2 == 0, 0.5, 0.5 * rng.uniform(0.35, 0.5))
        stroke = _jitter(np.stack([np.cos(t) * r, np.sin(t) * r], axis=1), rng, 0.015)
        return _by_hand([stroke], rng)
    lines = int(rng.choice([3, 4]))
    turn = rng.uniform(0, np.pi)
    strokes = []
    for k in range(lines):
        a = turn + k * np.pi / lines + np.radians(rng.normal(0, 6))
        d = np.array([np.cos(a), np.sin(a)]) * 0.5 * rng.uniform(0.85, 1.1)
        c = rng.normal(0, 0.03, 2)
        strokes.append(_maybe_reversed(np.stack([c - d, c + d]), rng))
    return _by_hand(strokes, rng)


def _spiral(rng: np.random.Generator) -> list[np.ndarray]:
    # a spiral in a cell is drawn big enough for its turns to stay apart under the pen: a
    # small one of many turns is a blot, which is a `dot` or a `scribble`, not a spiral
    size = rng.uniform(0.5, 0.85)
    turns = rng.uniform(1.7, 2.0 + 2.0 * (size - 0.5))
    t = np.linspace(0, 2 * np.pi * turns, int(turns * 60))
    r = 0.03 + 0.47 * t / t[-1]
    t = t * rng.choice([-1.0, 1.0]) + rng.uniform(0, 2 * np.pi)
    stroke = np.stack([np.cos(t) * r, np.sin(t) * r], axis=1)
    return _by_hand([_maybe_reversed(stroke, rng, p=0.3)], rng, size=(size, size))


def _closed_polygon(corners: np.ndarray, rng: np.random.Generator) -> list[np.ndarray]:
    """A polygon as people draw one: mostly in one stroke round from any corner, its end
    running past the start; otherwise a stroke per side or two."""
    n = len(corners)
    first = int(rng.integers(n))
    corners = np.roll(corners, -first, axis=0)
    if rng.random() < 0.5:
        corners = corners[::-1]
    how = rng.random()
    if how < 0.6:
        stroke = np.concatenate([corners, corners[:1]])
        if rng.random() < 0.5:
            stroke = _overshoot(stroke, rng.uniform(0.03, 0.1))
        return [stroke]
    if how < 0.8:
        half = n // 2
        return [corners[: half + 1], np.concatenate([corners[half:], corners[:1]])]
    return [
        _overshoot(np.stack([corners[i], corners[(i + 1) % n]]), rng.uniform(0, 0.06))
        for i in range(n)
    ]


def _triangle(rng: np.random.Generator) -> list[np.ndarray]:
    corners = np.array([[0.0, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    corners[0, 0] += rng.uniform(-0.25, 0.25)  # not every triangle is isosceles
    if rng.random() < 0.2:  # upside down
        corners[:, 1] *= -1
    return _by_hand(_closed_polygon(_jitter(corners, rng, 0.03), rng), rng)


def _square(rng: np.random.Generator) -> list[np.ndarray]:
    corners = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    return _by_hand(_closed_polygon(_jitter(corners, rng, 0.03), rng), rng)


def _dot(rng: np.random.Generator) -> list[np.ndarray]:
    # a tap, a short dab, or a tiny blob circled in place
    how = rng.random()
    if how < 0.4:
        stroke = rng.normal(0, 0.002, (2, 2))
    elif how < 0.7:
        stroke = np.stack([[0.0, 0.0], rng.normal(0, 0.02, 2)])
    else:
        t = np.linspace(0, 2 * np.pi * rng.uniform(1, 3), 20)
        stroke = np.stack([np.cos(t), np.sin(t)], axis=1) * rng.uniform(0.005, 0.02)
    centre = 0.5 + rng.uniform(-0.25, 0.25, 2)
    return [stroke + centre]


def _hatching(rng: np.random.Generator) -> list[np.ndarray]:
    lines = int(rng.integers(3, 8))
    slopes = [rng.uniform(-60, -30), rng.uniform(30, 60), rng.uniform(-10, 10)]
    angle = np.radians(rng.choice(slopes))
    along = np.array([np.cos(angle), np.sin(angle)])
    across = np.array([-along[1], along[0]])
    strokes = []
    for k, offset in enumerate(np.linspace(-0.5, 0.5, lines)):
        # the lines fill a roundish patch: shorter at its edges
        half = 0.5 * np.sqrt(max(1 - (offset / 0.6) ** 2, 0.1)) * rng.uniform(0.85, 1.1)
        c = across * (offset + rng.normal(0, 0.02)) + along * rng.normal(0, 0.04)
        stroke = np.stack([c - along * half, c + along * half])
        # one hand draws them all the same way, or alternately
        strokes.append(stroke[::-1] if k % 2 and rng.random() < 0.5 else stroke)
    return _by_hand(strokes, rng)


def _tick(rng: np.random.Generator) -> list[np.ndarray]:
    corner = rng.uniform(0.25, 0.45)
    keys = [[0.0, rng.uniform(0.45, 0.65)], [corner, 1.0], [1.0, 0.0]]
    stroke = _jitter(keys, rng, 0.03) - 0.5
    return _by_hand([stroke], rng, size=(0.25, 0.6), slant=15.0)


def _plus(rng: np.random.Generator) -> list[np.ndarray]:
    strokes = [
        np.array([[-0.5, rng.normal(0, 0.04)], [0.5, rng.normal(0, 0.04)]]),
        np.array([[rng.normal(0, 0.04), -0.5], [rng.normal(0, 0.04), 0.5]]),
    ]
    strokes = [_maybe_reversed(s * rng.uniform(0.85, 1.1), rng, p=0.2) for s in strokes]
    if rng.random() < 0.4:
        strokes.reverse()
    # upright: slanted by more, a plus becomes the cross it must not be read as
    return _by_hand(strokes, rng, slant=10.0)


def _arc_of(sweep_degrees: float, rng: np.random.Generator) -> np.ndarray:
    sweep = np.radians(sweep_degrees)
    start = rng.uniform(0, 2 * np.pi)
    t = start + np.linspace(0, sweep, max(8, int(sweep_degrees / 4)))
    return _maybe_reversed(np.stack([np.cos(t), np.sin(t)], axis=1) * 0.5, rng)


def _half_circle(rng: np.random.Generator) -> list[np.ndarray]:
    return _by_hand([_arc_of(rng.uniform(160, 200), rng)], rng)


def _arc(rng: np.random.Generator) -> list[np.ndarray]:
    return _by_hand([_arc_of(rng.uniform(50, 120), rng)], rng)


def _single_stroke(rng: np.random.Generator) -> list[np.ndarray]:
    angle = rng.uniform(0, np.pi)
    d = np.array([np.cos(angle), np.sin(angle)]) * 0.5
    bow = np.array([-d[1], d[0]]) * rng.normal(0, 0.08)
    stroke = _spline([-d, bow, d], per_segment=20)
    return _by_hand([stroke], rng, slant=0.0)


# Letters and digits: strokes in a glyph's box ((0, 0) upper left, (1, 1) lower right), in the
# order and direction most people write them. Each is a list of alternatives.
_LETTERS: dict[str, list[list]] = {
    "a": [
        [[(0.0, 1.0), (0.5, 0.0), (1.0, 1.0)], [(0.22, 0.62), (0.78, 0.62)]],
        [[(0.5, 0.0), (0.0, 1.0)], [(0.5, 0.0), (1.0, 1.0)], [(0.25, 0.6), (0.75, 0.6)]],
    ],
    "e": [
        [[(0.9, 0.0), (0.05, 0.0), (0.05, 1.0), (0.9, 1.0)], [(0.05, 0.5), (0.7, 0.5)]],
        [
            [(0.05, 0.0), (0.05, 1.0)],
            [(0.05, 0.0), (0.9, 0.0)],
            [(0.05, 0.5), (0.7, 0.5)],
            [(0.05, 1.0), (0.9, 1.0)],
        ],
    ],
    "h": [[[(0.05, 0.0), (0.05, 1.0)], [(0.95, 0.0), (0.95, 1.0)], [(0.05, 0.5), (0.95, 0.5)]]],
    "k": [
        [[(0.1, 0.0), (0.1, 1.0)], [(0.9, 0.0), (0.12, 0.55), (0.9, 1.0)]],
        [[(0.1, 0.0), (0.1, 1.0)], [(0.9, 0.0), (0.12, 0.55)], [(0.35, 0.4), (0.9, 1.0)]],
    ],
    "l": [[[(0.1, 0.0), (0.1, 1.0), (0.9, 1.0)]]],
    "m": [[[(0.0, 1.0), (0.08, 0.0), (0.5, 0.65), (0.92, 0.0), (1.0, 1.0)]]],
    "n": [[[(0.05, 1.0), (0.05, 0.0), (0.95, 1.0), (0.95, 0.0)]]],
    "t": [[[(0.0, 0.0), (1.0, 0.0)], [(0.5, 0.0), (0.5, 1.0)]]],
    "v": [[[(0.0, 0.0), (0.5, 1.0), (1.0, 0.0)]]],
    "z": [
        [[(0.05, 0.0), (0.95, 0.0), (0.05, 1.0), (0.95, 1.0)]],
        [[(0.05, 0.0), (0.95, 0.0), (0.05, 1.0), (0.95, 1.0)], [(0.25, 0.5), (0.75, 0.5)]],
    ],
}
_LETTER_WIDTH = {"m": (0.8, 1.05), "h": (0.6, 0.85), "l": (0.5, 0.7), "t": (0.6, 0.85)}

_DIGITS: dict[str, list[list]] = {
    "1": [
        [[(0.15, 0.25), (0.65, 0.0), (0.65, 1.0)]],
        [[(0.15, 0.25), (0.6, 0.0), (0.6, 1.0)], [(0.2, 1.0), (0.95, 1.0)]],
        [[(0.55, 0.0), (0.55, 1.0)]],
    ],
    "2": [
        [
            _Curve(
                ("curve", [(0.05, 0.28), (0.3, 0.03), (0.65, 0.02), (0.92, 0.25), (0.78, 0.5)]),
                ("line", [(0.05, 1.0), (0.95, 1.0)]),
            )
        ]
    ],
    "3": [
        [
            _Curve(
                ("curve", [(0.08, 0.12), (0.45, 0.0), (0.85, 0.18), (0.7, 0.4), (0.4, 0.47)]),
                ("curve", [(0.45, 0.48), (0.9, 0.65), (0.85, 0.9), (0.45, 1.0), (0.05, 0.88)]),
            )
        ],
        [
            [(0.05, 0.0), (0.9, 0.0), (0.4, 0.42)],
            _Curve(("curve", [(0.4, 0.42), (0.88, 0.6), (0.8, 0.92), (0.4, 1.0), (0.05, 0.88)])),
        ],
    ],
    "4": [
        [[(0.65, 0.0), (0.0, 0.68), (0.95, 0.68)], [(0.72, 0.25), (0.72, 1.0)]],
        [[(0.1, 0.0), (0.05, 0.6), (0.95, 0.6)], [(0.75, 0.0), (0.75, 1.0)]],
    ],
    "5": [
        [
            _Curve(
                ("line", [(0.2, 0.0), (0.15, 0.45)]),
                (
                    "curve",
                    [
                        (0.15, 0.45),
                        (0.55, 0.38),
                        (0.9, 0.62),
                        (0.75, 0.93),
                        (0.35, 1.0),
                        (0.05, 0.88),
                    ],
                ),
            ),
            [(0.2, 0.0), (0.9, 0.0)],
        ]
    ],
    "7": [
        [[(0.05, 0.05), (0.95, 0.0), (0.4, 1.0)]],
        [[(0.05, 0.05), (0.95, 0.0), (0.4, 1.0)], [(0.35, 0.52), (0.85, 0.5)]],
    ],
}
_DIGIT_WIDTH = {"1": (0.3, 0.5)}


def _character(
    forms: list, width: tuple[float, float]
) -> Callable[[np.random.Generator], list[np.ndarray]]:
    """A letter or digit drawn by hand: one of its `forms`, `width` of the cell wide."""

    def draw(rng: np.random.Generator) -> list[np.ndarray]:
        form = forms[int(rng.integers(len(forms)))]
        return _by_hand(_glyph(form, rng, width), rng, slant=12.0, stretch=0.1)

    return draw


_DRAW: dict[str, Callable[[np.random.Generator], list[np.ndarray]]] = {
    "circle": _circle,
    "cross": _cross,
    "scribble": _scribble,
    "zigzag": _zigzag,
    "star": _star,
    "spiral": _spiral,
    "triangle": _triangle,
    "square": _square,
    "dot": _dot,
    "hatching": _hatching,
    "tick": _tick,
    "plus": _plus,
    "half_circle": _half_circle,
    "arc": _arc,
    "single_stroke": _single_stroke,
    **{f"letter_{c}": _character(_LETTERS[c], _LETTER_WIDTH.get(c, (0.65, 0.9))) for c in LETTERS},
    **{f"digit_{c}": _character(_DIGITS[c], _DIGIT_WIDTH.get(c, (0.55, 0.75))) for c in DIGITS},
}
assert set(_DRAW) == set(KINDS)


def heldout_drawing(kind: str, rng: np.random.Generator) -> list[np.ndarray]:
    """One drawing of `kind` (one of `KINDS`) in a cell's unit square, as strokes of (N, 2)
    float points; `rng` makes every choice, so the same generator state gives the same drawing.

    Raises ValueError for a kind this module does not draw."""
    try:
        draw = _DRAW[kind]
    except KeyError:
        known = ", ".join(KINDS)
        raise ValueError(f"no held-out drawing of kind {kind!r}; kinds: {known}") from None
    return [np.asarray(s, dtype=np.float64) for s in draw(rng)]


def heldout_set(n_per_kind: int, seed: int) -> list[tuple[str, str, list[np.ndarray]]]:
    """`n_per_kind` drawings of every kind in `KINDS`, as (kind, cell name, strokes).

    Each kind's drawings go to the 9 cells in turn (`CELL_NAMES` order), so every kind is seen
    in every cell. Each kind has its own random stream, keyed by its name and `seed`: the same
    seed gives the same set, and adding a kind changes no other kind's drawings."""
    out = []
    for kind in KINDS:
        rng = np.random.default_rng([seed, zlib.crc32(kind.encode())])
        for i in range(n_per_kind):
            out.append((kind, CELL_NAMES[i % len(CELL_NAMES)], heldout_drawing(kind, rng)))
    return out


# --- real people's drawings: Quick, Draw! ------------------------------------------------------


def quickdraw_categories(folder: Path = QUICKDRAW_FOLDER) -> tuple[str, ...]:
    """The Quick, Draw! categories whose file is in `folder`, sorted."""
    return tuple(sorted(p.stem for p in Path(folder).glob("*.ndjson")))


def quickdraw_drawings(
    category: str, folder: Path = QUICKDRAW_FOLDER, margin: float = 0.15
) -> list[list[np.ndarray]]:
    """People's drawings of a Quick, Draw! `category` ("circle", "square", "star"...) from
    `folder`/`category`.ndjson, in file order, as strokes in the cell's unit square.

    Only drawings the game recognised are kept (the others may be anything). Each is scaled as
    a whole, keeping its shape, so that its larger side spans the square less `margin` on each
    side, and centred. Raw (x, y, t) and simplified (x, y) records are both read. A category in
    `QUICKDRAW_SYMBOLS` is a move; every other one is not.

    Raises FileNotFoundError naming bench/data/quickdraw/SOURCES.md when the file is missing."""
    path = Path(folder) / f"{category}.ndjson"
    if not path.exists():
        raise FileNotFoundError(
            f"{path} is missing: the Quick, Draw! files are not in git; "
            "bench/data/quickdraw/SOURCES.md says how to restore them"
        )
    drawings = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        record = json.loads(line)
        if not record.get("recognized", True):
            continue
        strokes = [
            np.stack([np.asarray(s[0], np.float64), np.asarray(s[1], np.float64)], axis=1)
            for s in record["drawing"]
            if len(s[0]) > 0
        ]
        if strokes:
            drawings.append(_fit_unit_square(strokes, margin))
    return drawings


def _fit_unit_square(strokes: list[np.ndarray], margin: float) -> list[np.ndarray]:
    every = np.concatenate(strokes)
    low, high = every.min(axis=0), every.max(axis=0)
    scale = (1 - 2 * margin) / max(float((high - low).max()), 1e-9)
    out = []
    for s in strokes:
        s = (s - (low + high) / 2) * scale + 0.5
        # a tap is one point; a pen draws it as a dot, a polyline needs two
        out.append(np.repeat(s, 2, axis=0) if len(s) == 1 else s)
    return out


__all__ = [
    "KINDS",
    "NOT_MOVES",
    "QUICKDRAW_FOLDER",
    "QUICKDRAW_SYMBOLS",
    "SYMBOLS",
    "heldout_drawing",
    "heldout_set",
    "quickdraw_categories",
    "quickdraw_drawings",
]
