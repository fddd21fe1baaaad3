"""Development drawings for the wholeness check: what people draw in a cell that is not a whole
circle or cross, and whole circles and crosses in many hands.

The wholeness check (`oxbot.perception.wholeness`) was tuned on these; measure it elsewhere too.
Every drawing is a list of pen strokes, polylines in a cell's unit square ((0, 0) its upper
left), drawn as a hand draws: a size, a place, a slant and a turn of its own, wobbly strokes.
They go on the page's sheet (`on_sheets`, read by the board reader) or into a 40x40 cell
(`cell_image`, read as `test_odd_cells` reads its cells).

    drawing = draw_kind("pentagram", rng)          # [array (K, 2), ...]
    cells = np.stack([cell_image(draw_kind(k, rng), rng) for k in REFUSED_KINDS])
    for sheet, kinds in on_sheets(kinds, rng): reader.read(sheet.image)
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from oxbot.testing.sheet import Sheet, unit_to_canvas

SIZE = 40
_UP = 8  # cells drawn 8x larger, then shrunk

LETTERS = "AEFHKLMNTVWYZ"
DIGITS = "123457"
REFUSED_KINDS: tuple[str, ...] = (
    "scribble",
    "zigzag",
    *(f"letter_{c}" for c in LETTERS),
    *(f"digit_{d}" for d in DIGITS),
    "pentagram",
    "asterisk",
    "spiral",
    "triangle",
    "square",
    "dot",
    "hatching",
    "tick",
    "plus",
    "half_circle",
    "arc",
    "stroke",
)
"""Drawings that are no whole circle or cross: none may read as a circle or a cross."""
WHOLE_KINDS = ("circle", "cross")
"""Whole symbols in many hands (see `draw_kind`)."""

Stroke = np.ndarray
"""float (K, 2): x, y in the cell's unit square."""

# Templates in [-0.5, 0.5]^2, y down. Curves are (centre x, centre y, radius, from, to) arcs in
# degrees, y down (90 is the bottom).
_Arc = tuple[float, float, float, float, float]


def _arc(cx: float, cy: float, r: float, a0: float, a1: float, n: int = 24) -> np.ndarray:
    t = np.radians(np.linspace(a0, a1, n))
    return np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1)


def _poly(*points: tuple[float, float]) -> np.ndarray:
    return np.array(points, float)


def _letter(c: str, rng: np.random.Generator) -> list[np.ndarray]:
    """Block capitals as people print them (sometimes with a variant)."""
    p = _poly
    if c == "A":
        return [p((-0.4, 0.5), (0, -0.5), (0.4, 0.5)), p((-0.22, 0.12), (0.24, 0.1))]
    if c == "E":
        return [
            p((0.35, -0.5), (-0.35, -0.5), (-0.35, 0.5), (0.35, 0.5)),
            p((-0.35, 0.0), (0.22, 0.0)),
        ]
    if c == "F":
        return [p((0.35, -0.5), (-0.3, -0.5), (-0.3, 0.5)), p((-0.3, 0.0), (0.2, 0.0))]
    if c == "H":
        return [
            p((-0.35, -0.5), (-0.35, 0.5)),
            p((0.35, -0.5), (0.35, 0.5)),
            p((-0.35, 0), (0.35, 0)),
        ]
    if c == "K":
        if rng.random() < 0.5:
            return [p((-0.3, -0.5), (-0.3, 0.5)), p((0.35, -0.5), (-0.3, 0.05), (0.35, 0.5))]
        return [
            p((-0.3, -0.5), (-0.3, 0.5)),
            p((0.35, -0.5), (-0.3, 0.08)),
            p((-0.1, -0.05), (0.38, 0.5)),
        ]
    if c == "L":
        return [p((-0.3, -0.5), (-0.3, 0.5), (0.3, 0.5))]
    if c == "M":
        return [p((-0.4, 0.5), (-0.35, -0.5), (0, 0.2), (0.35, -0.5), (0.4, 0.5))]
    if c == "N":
        return [p((-0.35, 0.5), (-0.35, -0.5), (0.35, 0.5), (0.35, -0.5))]
    if c == "T":
        return [p((-0.4, -0.5), (0.4, -0.5)), p((0, -0.5), (0.02, 0.5))]
    if c == "V":
        return [p((-0.4, -0.5), (0, 0.5), (0.4, -0.5))]
    if c == "W":
        return [p((-0.5, -0.5), (-0.25, 0.5), (0, -0.2), (0.25, 0.5), (0.5, -0.5))]
    if c == "Y":
        return [p((-0.4, -0.5), (0, 0), (0.4, -0.5)), p((0, 0), (0, 0.5))]
    if c == "Z":
        return [p((-0.35, -0.5), (0.35, -0.5), (-0.35, 0.5), (0.38, 0.5))]
    raise ValueError(f"no letter {c!r}")


def _digit(d: str, rng: np.random.Generator) -> list[np.ndarray]:
    p = _poly
    if d == "1":
        strokes = [p((-0.2, -0.3), (0.05, -0.5), (0.05, 0.5))]
        if rng.random() < 0.4:
            strokes.append(p((-0.2, 0.5), (0.3, 0.5)))
        return strokes
    if d == "2":
        top = _arc(0, -0.2, 0.3, 190, 400)
        return [np.concatenate([top, p((-0.35, 0.5), (0.38, 0.5))])]
    if d == "3":
        return [np.concatenate([_arc(0, -0.25, 0.25, 200, 450), _arc(0, 0.25, 0.25, 270, 520)])]
    if d == "4":
        if rng.random() < 0.5:
            return [p((0.15, 0.5), (0.15, -0.5), (-0.35, 0.2), (0.35, 0.2))]
        return [p((-0.2, -0.5), (-0.35, 0.15), (0.35, 0.15)), p((0.15, -0.3), (0.15, 0.5))]
    if d == "5":
        belly = _arc(-0.02, 0.2, 0.3, 225, 510)
        return [np.concatenate([p((0.3, -0.5), (-0.25, -0.5), (-0.25, -0.02)), belly])]
    if d == "7":
        strokes = [p((-0.35, -0.5), (0.35, -0.5), (-0.1, 0.5))]
        if rng.random() < 0.3:
            strokes.append(p((-0.1, 0.0), (0.25, 0.0)))
        return strokes
    raise ValueError(f"no digit {d!r}")


def _ring(n: int, rng: np.random.Generator, turn: float = 1.0) -> np.ndarray:
    """`n` corners of a regular polygon, turned at random, radius 0.5."""
    start = rng.uniform(0, 360)
    t = np.radians(start + np.arange(n) * 360.0 * turn / n)
    return np.stack([0.5 * np.cos(t), 0.5 * np.sin(t)], axis=1)


def _closed(corners: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A polygon drawn in one stroke, its end overshooting or stopping short of its start."""
    pts = np.concatenate([corners, corners[:1]])
    end = pts[-2] + (pts[-1] - pts[-2]) * rng.uniform(0.92, 1.12)
    return np.concatenate([pts[:-1], end[None]])


def _template(kind: str, rng: np.random.Generator) -> list[np.ndarray]:
    """A drawing of `kind` in [-0.5, 0.5]^2 (before the hand's size, slant and wobble)."""
    if kind.startswith("letter_"):
        return _letter(kind[-1], rng)
    if kind.startswith("digit_"):
        return _digit(kind[-1], rng)
    if kind == "scribble":
        n = int(rng.integers(6, 14))
        pts = rng.uniform(-0.5, 0.5, (n, 2))
        return [_smooth(pts, rng.integers(2, 5))]
    if kind == "zigzag":
        n = int(rng.integers(4, 8))
        xs = np.linspace(-0.5, 0.5, n)
        ys = np.where(np.arange(n) % 2 == 0, -0.3, 0.3) * rng.uniform(0.6, 1.6)
        return [np.stack([xs, ys + rng.normal(0, 0.04, n)], axis=1)]
    if kind == "pentagram":
        c = _ring(5, rng)
        return [np.concatenate([c[[0, 2, 4, 1, 3]], c[:1]])]
    if kind == "asterisk":
        lines = int(rng.integers(3, 5))
        start = rng.uniform(0, 180)
        out = []
        for k in range(lines):
            a = math.radians(start + k * 180 / lines + rng.normal(0, 5))
            d = np.array([math.cos(a), math.sin(a)]) * 0.5
            out.append(np.stack([-d * rng.uniform(0.8, 1), d * rng.uniform(0.8, 1)]))
        return out
    if kind == "spiral":
        turns = rng.uniform(1.5, 3.0)
        t = np.linspace(0, 2 * math.pi * turns, int(60 * turns))
        r = 0.5 * (0.08 + 0.92 * t / t[-1])
        spiral = np.stack([r * np.cos(t), r * np.sin(t)], axis=1)
        return [spiral if rng.random() < 0.5 else spiral[::-1]]
    if kind == "triangle":
        c = _ring(3, rng)
        c += rng.normal(0, 0.04, c.shape)
        if rng.random() < 0.5:  # an upright one
            c = _poly((0, -0.5), (0.5, 0.4), (-0.5, 0.4)) + rng.normal(0, 0.04, (3, 2))
        return [_closed(c, rng)]
    if kind == "square":
        c = _poly((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5))
        c *= [1.0, rng.uniform(0.7, 1.1)]
        if rng.random() < 0.25:  # a diamond
            c = _poly((0, -0.5), (0.5, 0), (0, 0.5), (-0.5, 0))
        c = c + rng.normal(0, 0.03, c.shape)
        return [_closed(np.roll(c, int(rng.integers(4)), axis=0), rng)]
    if kind == "dot":
        r = rng.uniform(0.0, 0.06)
        t = np.linspace(0, 4 * math.pi, 20)
        return [np.stack([r * np.cos(t), r * np.sin(t)], axis=1) + 1e-3]
    if kind == "hatching":
        n = int(rng.integers(3, 7))
        a = rng.uniform(0, math.pi)
        d = np.array([math.cos(a), math.sin(a)]) * 0.5
        normal = np.array([-d[1], d[0]])
        offsets = np.linspace(-0.9, 0.9, n)
        out = [np.stack([o * normal - d, o * normal + d]) for o in offsets]
        if rng.random() < 0.3:  # cross-hatched: a grid of lines
            out += [np.stack([o * d - normal, o * d + normal]) for o in offsets]
        return out
    if kind == "tick":
        return [_poly((-0.5, 0.0), (-0.15, 0.45), (0.5, -0.5))]
    if kind == "plus":
        tilt = math.radians(rng.uniform(-5, 5))  # and the hand's turn
        out = []
        for a in (tilt, tilt + math.pi / 2):
            d = np.array([math.cos(a), math.sin(a)]) * 0.5
            shift = rng.uniform(-0.1, 0.1, 2)
            out.append(np.stack([-d + shift, d + shift]))
        return out
    if kind in ("half_circle", "arc"):
        turn = rng.uniform(0.42, 0.6) if kind == "half_circle" else rng.uniform(0.12, 0.42)
        start = rng.uniform(0, 360)
        return [_arc(0, 0, 0.5, start, start + 360 * turn, 40)]
    if kind == "stroke":
        a = rng.uniform(0, math.pi)
        d = np.array([math.cos(a), math.sin(a)]) * 0.5
        return [np.stack([-d, d])]
    if kind == "circle":
        return [_hand_circle(rng)]
    if kind == "cross":
        return _hand_cross(rng)
    raise ValueError(f"unknown kind {kind!r}; kinds are {REFUSED_KINDS + WHOLE_KINDS}")


def _hand_circle(rng: np.random.Generator) -> np.ndarray:
    """A circle or an O as hands draw them: closed with its ends overlapping (and straying in or
    out), or a little open; round or oval, lumpy."""
    turn = rng.uniform(1.0, 1.15) if rng.random() < 0.7 else rng.uniform(0.88, 1.0)
    n = 80
    t = np.linspace(0, 2 * math.pi * turn, n)
    drift = rng.uniform(-0.1, 0.1) * t / (2 * math.pi)  # the end lands inside or outside
    lumps = sum(rng.uniform(0, 0.04) * np.cos(k * t + rng.uniform(0, 2 * math.pi)) for k in (2, 3))
    r = 0.5 * (1 + drift + lumps)
    aspect = rng.uniform(0.65, 1.0)
    pts = np.stack([r * np.cos(t), aspect * r * np.sin(t)], axis=1)
    a = rng.uniform(0, math.pi)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    pts = pts @ rot.T
    return pts if rng.random() < 0.5 else pts[::-1]


def _hand_cross(rng: np.random.Generator) -> list[np.ndarray]:
    """Two strokes crossing: uneven arms, off-centre crossings, bowed strokes, turned."""
    out = []
    base = rng.uniform(-20, 20)
    for k, angle in enumerate((45.0, 135.0)):
        a = math.radians(angle + base + rng.normal(0, 7))
        d = np.array([math.cos(a), math.sin(a)])
        half = 0.5 * rng.uniform(0.7, 1.05)
        at = rng.uniform(-0.22, 0.22)  # where along it the other stroke crosses
        t = np.linspace(-half, half, 20)[:, None] - at * half
        bow = rng.uniform(-0.12, 0.12) * (1 - (np.linspace(-1, 1, 20) ** 2))[:, None]
        stroke = t * d + bow * np.array([-d[1], d[0]])
        out.append(stroke if rng.random() < 0.5 else stroke[::-1])
        if k == 0 and rng.random() < 0.3:
            out[0] = out[0] + rng.uniform(-0.08, 0.08, 2)
    return out


def _smooth(points: np.ndarray, passes: int) -> np.ndarray:
    """A smooth curve through roughly `points` (Chaikin's corner cutting)."""
    pts = points
    for _ in range(int(passes)):
        q = 0.75 * pts[:-1] + 0.25 * pts[1:]
        r = 0.25 * pts[:-1] + 0.75 * pts[1:]
        pts = np.concatenate([pts[:1], np.stack([q, r], axis=1).reshape(-1, 2), pts[-1:]])
    return pts


def _resample(stroke: np.ndarray, step: float) -> np.ndarray:
    seg = np.hypot(*np.diff(stroke, axis=0).T)
    length = np.concatenate([[0.0], np.cumsum(seg)])
    if length[-1] == 0:
        return stroke
    s = np.linspace(0, length[-1], max(2, int(length[-1] / step) + 1))
    return np.stack([np.interp(s, length, stroke[:, i]) for i in (0, 1)], axis=1)


def draw_kind(kind: str, rng: np.random.Generator) -> list[Stroke]:
    """One drawing of `kind` (REFUSED_KINDS, WHOLE_KINDS) in a cell's unit square, by a hand of
    its own: size 0.35-0.75 of the cell, off the middle, slanted and turned a little, wobbly."""
    strokes = _template(kind, rng)
    size = rng.uniform(0.35, 0.75)
    return by_hand(strokes, rng, 1.0 if kind == "dot" else size)


def by_hand(
    template: Sequence[Stroke], rng: np.random.Generator, size: float, turn_sd: float = 8.0
) -> list[Stroke]:
    """A template in [-0.5, 0.5]^2 drawn `size` of the cell wide in its unit square: off the
    middle, slanted, turned (`turn_sd` degrees), squashed, with a tremor."""
    slant = rng.uniform(-0.2, 0.2)
    turn = math.radians(rng.normal(0, turn_sd))
    squash = rng.uniform(0.85, 1.15)
    m = np.array([[1.0, slant], [0.0, 1.0]]) @ np.array(
        [[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]]
    )
    m = m * [[1.0], [squash]]
    room = max(0.0, 0.5 - 0.5 * size - 0.04)
    centre = 0.5 + rng.uniform(-room, room, 2) * 0.6
    tremor = rng.uniform(0.0005, 0.004)
    out = []
    for stroke in template:
        pts = _resample(np.asarray(stroke, float) @ m.T * size, 0.01)
        wobble = np.cumsum(rng.normal(0, tremor, pts.shape), axis=0)
        wobble -= np.linspace(0, 1, len(pts))[:, None] * wobble[-1]  # keep the ends
        out.append(centre + pts + wobble + rng.normal(0, 0.002, pts.shape))
    return out


def cell_image(strokes: Sequence[Stroke], rng: np.random.Generator) -> np.ndarray:
    """The drawing in a 40x40 cell, uint8, dark ink on light paper: a pen 1-3.5 pixels wide,
    paper of its own tone, a little blur and noise."""
    side = SIZE * _UP
    paper = np.full((side, side), rng.uniform(170, 240), np.float32)
    mask = np.zeros((side, side), np.uint8)
    thick = max(1, round(rng.uniform(1.0, 3.5) * _UP))
    for stroke in strokes:
        pts = np.round(np.asarray(stroke) * side).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(mask, [pts], False, 255, thick, cv2.LINE_AA)
    ink = paper * (1.0 - rng.uniform(0.45, 0.9) * mask.astype(np.float32) / 255.0)
    cell = cv2.resize(ink, (SIZE, SIZE), interpolation=cv2.INTER_AREA)
    if rng.random() < 0.5:
        cell = cv2.GaussianBlur(cell, (3, 3), rng.uniform(0.3, 0.9))
    cell = cell + rng.normal(0, rng.uniform(0.5, 3.0), cell.shape)
    return np.clip(cell, 0, 255).astype(np.uint8)


def on_sheets(
    kinds: Sequence[str], rng: np.random.Generator
) -> list[tuple[Sheet, list[str | None]]]:
    """The drawings of `kinds` (one each) on page sheets, nine to a sheet, each with a pen 3-8
    pixels wide (the page's is 5); with each sheet's kinds cell by cell (None: left blank)."""
    out = []
    for first in range(0, len(kinds), 9):
        part = list(kinds[first : first + 9])
        sheet = Sheet(int(rng.integers(2**31)))
        for cell, kind in enumerate(part):
            width = int(rng.integers(3, 9))
            for points in draw_kind(kind, rng):
                sheet.stroke(unit_to_canvas(cell, points), width)
        out.append((sheet, part + [None] * (9 - len(part))))
    return out


def dev_kinds(per_kind: int, kinds: Sequence[str]) -> list[str]:
    """`per_kind` of each of `kinds`, interleaved (so each sheet holds several kinds)."""
    return [k for _ in range(per_kind) for k in kinds]
