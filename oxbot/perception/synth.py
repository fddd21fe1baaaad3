"""The handwriting synthesiser: hand-drawn circles and crosses on paper, as a camera sees them.

It models real pens and real sheets: open and closed loops, ovals, overlapping tails, crosses
with unequal or curved strokes, pen widths, pencil grain against marker ink; paper with uneven
lighting, texture, smudges and shadows, and the remnants of grid lines that grid removal leaves
at a cell's border. Every image is dark ink on light paper, uint8 grayscale.

The public functions, each taking the random generator it draws from:

    symbol_strokes(label, rng) -> list[np.ndarray]
        the pen's strokes of one "circle" or "cross" as (K, 2) polylines (x right, y down)
        in a unit box [-1, 1]^2; what the simulated arm draws, stroke by stroke.
    draw_symbol(canvas, label, rng, centre=None, size=None, pen=None) -> canvas
        draws one symbol in place into a uint8 grayscale canvas of any size; `centre` is (x, y)
        in pixels (default: the middle), `size` the symbol's width in pixels (default: 70% of
        the canvas' smaller side), `pen` a `Pen` (default: `Pen.random(rng, size)`).
        "nothing" draws nothing.
    paper(shape, rng) -> np.ndarray
        a blank sheet: uneven light, texture and noise.
    draw_cell(label, rng, size=40) -> np.ndarray
        one whole cell: paper, then a symbol at a random place and size or, for "nothing",
        smudges, specks and shadows; grid remnants at the border for every label.
    partial_strokes(rng) -> list[np.ndarray]
        ink that is not a whole symbol yet: an arc, one stroke, a plus, a tick,
        a scribble, in the unit box like `symbol_strokes`.
    add_texture(image, rng) / add_ghost(image, rng)
        squared, dotted or ruled paper; a faint erased mark. Never a symbol.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.errors import InvalidInputError
from oxbot.game.board import LABELS

PARTIAL = "partial"
"""oxbot: what the network calls ink that is not a whole symbol; not a public label."""
OUTPUTS: tuple[str, ...] = (*LABELS, PARTIAL)
"""The network's outputs: the public labels at 0-2 (kept there), then PARTIAL at 3."""

_SUPERSAMPLE = 4  # strokes are drawn 4x larger, then averaged down: cheap anti-aliasing


@dataclass(frozen=True)
class Pen:
    """How a stroke looks: its width, how dark its ink is, and how grainy (pencil) it is."""

    width: float
    """Stroke width in pixels of the canvas drawn on."""
    darkness: float
    """Fraction of the paper's brightness the ink takes away, in (0, 1]; marker near 1."""
    grain: float = 0.0
    """Fraction of a stroke's pixels the pencil misses, showing paper; 0 for ink."""

    @classmethod
    def random(cls, rng: np.random.Generator, symbol_size: float = 28.0) -> Pen:
        """A pencil, a ballpoint, a felt-tip or a marker, its width scaled to the symbol's size."""
        kind = rng.choice(4, p=(0.25, 0.35, 0.25, 0.15))
        scale = symbol_size / 28.0
        if kind == 0:  # pencil: thin, grey, grainy
            return cls(
                rng.uniform(0.8, 2.2) * scale, rng.uniform(0.30, 0.65), rng.uniform(0.1, 0.4)
            )
        if kind == 1:  # ballpoint: thin, dark
            return cls(rng.uniform(0.8, 2.0) * scale, rng.uniform(0.55, 0.9))
        if kind == 2:  # felt-tip
            return cls(rng.uniform(1.8, 3.2) * scale, rng.uniform(0.65, 0.95))
        return cls(rng.uniform(3.0, 4.8) * scale, rng.uniform(0.75, 1.0))  # marker


def _check_label(label: str) -> None:
    if label not in LABELS:
        raise InvalidInputError(f"unknown label {label!r}; labels are {', '.join(LABELS)}")


def _circle_strokes(rng: np.random.Generator) -> list[np.ndarray]:
    """One loop: an oval, maybe open, maybe overshooting into a tail, maybe a second turn."""
    roll = rng.random()
    if roll < 0.25:
        sweep = rng.uniform(0.80, 0.97)  # open loop
    elif roll < 0.9:
        sweep = rng.uniform(0.97, 1.18)  # closed, or an overlapping tail
    else:
        sweep = rng.uniform(1.4, 1.95)  # a second turn
    start = rng.uniform(0, 2 * np.pi)
    direction = rng.choice((-1.0, 1.0))
    t = start + direction * np.linspace(0.0, 2 * np.pi * sweep, max(24, int(64 * sweep)))
    progress = np.linspace(0.0, 1.0, t.size)
    radius = (
        1.0
        + rng.uniform(-0.12, 0.12) * progress  # spiral drift: the end misses the start
        + rng.uniform(0, 0.07) * np.sin(2 * t + rng.uniform(0, 2 * np.pi))
        + rng.uniform(0, 0.05) * np.sin(3 * t + rng.uniform(0, 2 * np.pi))
    )
    aspect = rng.uniform(0.65, 1.0) if rng.random() < 0.75 else rng.uniform(0.35, 0.65)
    x, y = radius * np.cos(t), radius * aspect * np.sin(t)
    tilt = rng.uniform(0, np.pi)
    c, s = np.cos(tilt), np.sin(tilt)
    points = np.stack([c * x - s * y, s * x + c * y], axis=1)
    return [_fit_unit_box(points)]


def _cursive_x_strokes(rng: np.random.Generator) -> list[np.ndarray]:
    """The cursive x: two arcs back to back, ")(", touching or just crossing in the middle."""
    u = np.linspace(0.0, 1.0, 24)[:, None]
    strokes = []
    for side in (-1.0, 1.0):
        reach = rng.uniform(0.7, 1.0)
        start = np.array([side * reach, -1.0 + rng.uniform(0, 0.2)])
        end = np.array([side * reach * rng.uniform(0.8, 1.1), 1.0 - rng.uniform(0, 0.2)])
        control = np.array([-side * rng.uniform(0.75, 1.2), rng.uniform(-0.15, 0.15)])
        strokes.append((1 - u) ** 2 * start + 2 * (1 - u) * u * control + u**2 * end)
    return strokes


def _cross_strokes(rng: np.random.Generator) -> list[np.ndarray]:
    """Two strokes crossing near the middle, of unequal length, maybe curved or hooked."""
    if rng.random() < 0.12:
        strokes = _cursive_x_strokes(rng)
        scale, offset = _unit_box_transform(np.vstack(strokes))
        return [(s - offset) * scale for s in strokes]
    strokes = []
    for base in (np.pi / 4, 3 * np.pi / 4):
        angle = base + rng.uniform(-0.25, 0.25)
        half = rng.uniform(0.65, 1.0)
        centre = rng.uniform(-0.12, 0.12, size=2)
        d = np.array([np.cos(angle), np.sin(angle)])
        normal = np.array([-d[1], d[0]])
        start, end = centre - half * d * rng.uniform(0.8, 1.2), centre + half * d
        if rng.random() < 0.5:
            start, end = end, start
        bend = rng.uniform(-0.25, 0.25) * half
        u = np.linspace(0.0, 1.0, 24)[:, None]
        control = (start + end) / 2 + bend * normal
        curve = (1 - u) ** 2 * start + 2 * (1 - u) * u * control + u**2 * end
        if rng.random() < 0.2:  # a small hook where the pen lifts
            hook_dir = normal * rng.choice((-1.0, 1.0)) - d * 0.3
            hook = curve[-1] + np.linspace(0.0, rng.uniform(0.08, 0.2), 5)[1:, None] * hook_dir
            curve = np.vstack([curve, hook])
        strokes.append(curve)
        if rng.random() < 0.15:  # a sketchy hand goes over the stroke again, near or apart
            apart = rng.uniform(0.03, 0.3) * rng.choice((-1.0, 1.0))
            strokes.append(curve + apart * normal + rng.normal(0, 0.01, curve.shape))
    aspect = rng.uniform(0.7, 1.15)  # narrow or wide crosses, like an X written in a word
    strokes = [s * np.array([aspect, 1.0]) for s in strokes]
    points = np.vstack(strokes)
    scale, offset = _unit_box_transform(points)
    return [(s - offset) * scale for s in strokes]


def _unit_box_transform(points: np.ndarray) -> tuple[float, np.ndarray]:
    lo, hi = points.min(axis=0), points.max(axis=0)
    return 2.0 / max(float((hi - lo).max()), 1e-6), (lo + hi) / 2


def _fit_unit_box(points: np.ndarray) -> np.ndarray:
    scale, offset = _unit_box_transform(points)
    return (points - offset) * scale


def symbol_strokes(label: str, rng: np.random.Generator) -> list[np.ndarray]:
    """The pen strokes of one hand-drawn symbol, (K, 2) polylines in the unit box [-1, 1]^2."""
    _check_label(label)
    if label == "circle":
        return _circle_strokes(rng)
    if label == "cross":
        return _cross_strokes(rng)
    return []


def ink_mask(
    shape: tuple[int, int],
    strokes: list[np.ndarray],
    pen: Pen,
    rng: np.random.Generator,
) -> np.ndarray:
    """How much ink covers each pixel, float32 in [0, 1], for strokes given in pixels."""
    h, w = shape
    big = np.zeros((h * _SUPERSAMPLE, w * _SUPERSAMPLE), np.uint8)
    for stroke in strokes:
        pts = np.round(stroke * _SUPERSAMPLE * 16).astype(np.int32)  # 4 fractional bits
        # Pressure varies along a stroke: draw it in a few pieces of different width.
        pieces = np.array_split(np.arange(len(pts)), max(1, len(pts) // 8))
        for piece in pieces:
            segment = pts[max(0, piece[0] - 1) : piece[-1] + 1]
            if len(segment) < 2:
                continue
            width = pen.width * rng.uniform(0.8, 1.15) * _SUPERSAMPLE
            cv2.polylines(big, [segment], False, 255, max(1, round(width)), cv2.LINE_AA, shift=4)
    mask = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
    if pen.grain > 0:
        grain = rng.random(mask.shape, dtype=np.float32) > pen.grain
        mask *= 0.45 + 0.55 * grain
    return mask


def draw_symbol(
    canvas: np.ndarray,
    label: str,
    rng: np.random.Generator,
    centre: tuple[float, float] | None = None,
    size: float | None = None,
    pen: Pen | None = None,
) -> np.ndarray:
    """Draw one hand-made `label` into `canvas` (uint8 grayscale, any size) in place."""
    _check_label(label)
    if canvas.ndim != 2 or canvas.dtype != np.uint8:
        raise InvalidInputError(
            f"draw_symbol needs a uint8 grayscale canvas; got {canvas.dtype} of shape "
            f"{canvas.shape}"
        )
    if label == "nothing":
        return canvas
    h, w = canvas.shape
    size = float(size) if size is not None else 0.7 * min(h, w)
    cx, cy = centre if centre is not None else ((w - 1) / 2, (h - 1) / 2)
    pen = pen if pen is not None else Pen.random(rng, size)
    half = max(size / 2 - pen.width / 2, 1.0)
    strokes = [s * half + np.array([cx, cy]) for s in symbol_strokes(label, rng)]
    mask = ink_mask((h, w), strokes, pen, rng)
    canvas[:] = np.clip(canvas * (1.0 - pen.darkness * mask), 0, 255).astype(np.uint8)
    return canvas


def _smooth_noise(shape: tuple[int, int], rng: np.random.Generator, cells: int) -> np.ndarray:
    """Low-frequency noise in [-1, 1]: a coarse random grid upsampled smoothly."""
    coarse = rng.uniform(-1, 1, size=(cells, cells)).astype(np.float32)
    return cv2.resize(coarse, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)


def paper(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """A blank sheet under uneven light: brightness, gradient, texture and sensor noise."""
    h, w = shape
    base = rng.uniform(150, 245)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    angle = rng.uniform(0, 2 * np.pi)
    ramp = (np.cos(angle) * xx / max(w, 1) + np.sin(angle) * yy / max(h, 1)) * rng.uniform(0, 40)
    sheet = base + ramp - ramp.mean()
    sheet += _smooth_noise(shape, rng, int(rng.integers(3, 7))) * rng.uniform(0, 8)
    sheet += rng.normal(0, rng.uniform(0.5, 5), size=shape)
    return np.clip(sheet, 0, 255).astype(np.uint8)


def darken(image: np.ndarray, amount: np.ndarray) -> np.ndarray:
    """`image` with the fraction `amount` (broadcastable, in [0, 1]) of its light taken away."""
    return np.clip(image * (1.0 - np.clip(amount, 0, 1)), 0, 255).astype(np.uint8)


def add_clutter(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Smudges, specks and a shadow: what a blank cell of a used sheet has on it."""
    h, w = image.shape
    amount = np.zeros((h, w), np.float32)
    for _ in range(rng.integers(0, 3)):  # smudges: soft grey blobs
        blob = np.zeros((h, w), np.float32)
        centre = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        axes = (int(rng.integers(2, max(3, w // 3))), int(rng.integers(2, max(3, h // 3))))
        cv2.ellipse(blob, centre, axes, float(rng.uniform(0, 180)), 0, 360, 1.0, -1)
        amount += cv2.GaussianBlur(blob, (0, 0), rng.uniform(1.5, 4)) * rng.uniform(0.04, 0.18)
    for _ in range(rng.integers(0, 4)):  # specks of dust or a pen touching down
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        cv2.circle(amount, (x, y), int(rng.integers(0, 2)), float(rng.uniform(0.2, 0.6)), -1)
    if rng.random() < 0.3:  # a hand's or the robot arm's shadow
        angle = rng.uniform(0, 2 * np.pi)
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        side = np.cos(angle) * (xx - w / 2) + np.sin(angle) * (yy - h / 2)
        edge = rng.uniform(-w / 3, w / 3)
        amount += rng.uniform(0.1, 0.35) / (1 + np.exp(-(side - edge) / rng.uniform(1, 5)))
    return darken(image, amount)


def add_grid_remnants(
    image: np.ndarray, rng: np.random.Generator, probability: float = 0.5
) -> np.ndarray:
    """Bits of the grid's lines left at the border of a cell by imperfect grid removal."""
    h, w = image.shape
    amount = np.zeros((h, w), np.float32)
    pen = Pen.random(rng, min(h, w) * 0.7)
    pen = Pen(min(pen.width, 0.06 * min(h, w)), pen.darkness, pen.grain)  # grids: thin pens
    for side in range(4):
        if rng.random() >= probability:
            continue
        depth = rng.uniform(-1.0, min(h, w) * 0.05)  # distance of the line from the border
        tilt = rng.uniform(-0.06, 0.06) * min(h, w)
        start, end = sorted(rng.uniform(-0.2, 1.2, size=2))
        if end - start < 0.2:
            end = start + 0.2
        length = w if side < 2 else h
        a, b = start * length, end * length
        if side == 0:  # top
            pts = [(a, depth), (b, depth + tilt)]
        elif side == 1:  # bottom
            pts = [(a, h - 1 - depth), (b, h - 1 - depth - tilt)]
        elif side == 2:  # left
            pts = [(depth, a), (depth + tilt, b)]
        else:  # right
            pts = [(w - 1 - depth, a), (w - 1 - depth - tilt, b)]
        width = Pen(pen.width * rng.uniform(0.7, 1.3), pen.darkness, pen.grain)
        amount = np.maximum(amount, ink_mask((h, w), [np.array(pts)], width, rng))
    return darken(image, amount * pen.darkness * rng.uniform(0.5, 1.0))


def draw_cell(
    label: str, rng: np.random.Generator, size: int = 40, remnants: float = 0.3
) -> np.ndarray:
    """One synthetic cell of a game sheet: paper, the symbol (or clutter), grid remnants.

    `remnants` is the probability of a grid line's remnant along each of the four borders.
    """
    _check_label(label)
    cell = paper((size, size), rng)
    if label == "nothing":
        cell = add_clutter(cell, rng)
    else:
        width = rng.uniform(0.45, 0.85) * size
        slack = max(size - width, 0.0) / 2
        centre = tuple((size - 1) / 2 + rng.uniform(-slack, slack, size=2) * 0.8)
        draw_symbol(cell, label, rng, centre=centre, size=width)
    return add_grid_remnants(cell, rng, probability=remnants) if remnants > 0 else cell


PARTIAL_KINDS = ("arc", "stroke", "plus", "tick", "scribble", "corner")
"""The kinds of ink that are not a whole symbol, drawn by `partial_strokes`."""


def partial_strokes(rng: np.random.Generator, kind: str | None = None) -> list[np.ndarray]:
    """Ink that is not a whole symbol, as (K, 2) polylines in the unit box [-1, 1]^2.

    What a person leaves while drawing or by mistake: an arc of up to 0.55 of a turn (a whole
    circle here starts at 0.8 of a turn, `_circle_strokes`), one stroke, a
    plus (a cross is diagonal), a tick, a scribble, two strokes meeting at a corner.
    """
    kind = kind if kind is not None else PARTIAL_KINDS[int(rng.integers(len(PARTIAL_KINDS)))]
    u = np.linspace(0.0, 1.0, 24)[:, None]
    if kind == "arc":
        # Up to 0.55 of a turn: well below the open circles (0.8) that still read as one.
        sweep = rng.uniform(0.12, 0.55)
        t = rng.uniform(0, 2 * np.pi) + np.linspace(0, 2 * np.pi * sweep, 48)
        aspect = rng.uniform(0.6, 1.0)
        r = 1.0 + rng.uniform(-0.08, 0.08) * np.linspace(0, 1, t.size)
        strokes = [np.stack([r * np.cos(t), r * aspect * np.sin(t)], axis=1)]
        # An arc keeps the size of the circle it belongs to, not the unit box.
        return [s * rng.uniform(0.8, 1.0) for s in strokes]
    if kind == "stroke":
        angle = rng.uniform(0, np.pi)
        d = np.array([np.cos(angle), np.sin(angle)])
        bend = rng.uniform(-0.2, 0.2) * np.array([-d[1], d[0]])
        strokes = [(1 - u) ** 2 * -d + 2 * (1 - u) * u * bend + u**2 * d]
    elif kind == "plus":
        tilt = rng.uniform(-0.1, 0.1)  # within 6 degrees of upright: an X turned by 45
        strokes = []
        for base in (tilt, tilt + np.pi / 2):
            d = np.array([np.cos(base), np.sin(base)])
            c = rng.uniform(-0.1, 0.1, size=2)
            strokes.append(c + (u * 2 - 1) * d * rng.uniform(0.8, 1.0))
    elif kind == "tick":
        low = np.array([rng.uniform(-0.4, 0.0), rng.uniform(0.5, 0.9)])
        start = low + np.array([-rng.uniform(0.3, 0.6), -rng.uniform(0.3, 0.6)])
        end = low + np.array([rng.uniform(0.8, 1.4), -rng.uniform(1.2, 1.8)])
        strokes = [np.vstack([start + u * (low - start), low + u[1:] * (end - low)])]
    elif kind == "scribble":
        points = np.cumsum(rng.normal(0, 0.6, size=(int(rng.integers(4, 9)), 2)), axis=0)
        t = np.linspace(0, len(points) - 1, 16 * len(points))
        line = np.stack([np.interp(t, np.arange(len(points)), points[:, k]) for k in (0, 1)], 1)
        strokes = [cv2.blur(line[None].astype(np.float32), (5, 1))[0].astype(np.float64)]
    elif kind == "corner":  # an L or a V: two strokes meeting at their ends
        corner = rng.uniform(-0.3, 0.3, size=2)
        angles = rng.uniform(0, 2 * np.pi) + np.array([0.0, rng.uniform(0.5, 2.0)])
        strokes = [corner + u * np.array([np.cos(a), np.sin(a)]) for a in angles]
    else:
        raise InvalidInputError(f"unknown partial kind {kind!r}; kinds are {PARTIAL_KINDS}")
    scale, offset = _unit_box_transform(np.vstack(strokes))
    return [(s - offset) * scale for s in strokes]


def draw_partial(
    canvas: np.ndarray, rng: np.random.Generator, centre: tuple[float, float], size: float
) -> np.ndarray:
    """Draw one `partial_strokes` shape into `canvas` (uint8 grayscale) in place."""
    pen = Pen.random(rng, size)
    half = max(size / 2 - pen.width / 2, 1.0)
    strokes = [s * half + np.array(centre) for s in partial_strokes(rng)]
    mask = ink_mask(canvas.shape, strokes, pen, rng)
    canvas[:] = np.clip(canvas * (1.0 - pen.darkness * mask), 0, 255).astype(np.uint8)
    return canvas


def add_texture(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The sheet's own print: squared, dotted or ruled paper, faint and regular."""
    h, w = image.shape
    kind = int(rng.integers(3))
    step = rng.uniform(5.0, 12.0)
    amount = np.zeros((h, w), np.float32)
    angle = rng.uniform(-0.08, 0.08)  # the print is square to the grid, nearly
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    u = np.cos(angle) * xx + np.sin(angle) * yy + rng.uniform(0, step)
    v = -np.sin(angle) * xx + np.cos(angle) * yy + rng.uniform(0, step)
    width = rng.uniform(0.5, 1.3)

    def near(coord: np.ndarray) -> np.ndarray:  # 1 on a printed line, falling off within `width`
        dist = np.abs((coord + step / 2) % step - step / 2)
        return np.clip(1.0 - dist / width, 0.0, 1.0)

    if kind == 0:  # squared
        amount = np.maximum(near(u), near(v))
    elif kind == 1:  # dotted
        amount = near(u) * near(v)
        amount = np.clip(amount * 2.5, 0, 1)
    else:  # ruled, sometimes with a margin line
        amount = near(v)
        if rng.random() < 0.2:
            x = rng.uniform(0, w)
            amount = np.maximum(amount, np.clip(1.0 - np.abs(xx - x) / width, 0, 1))
    return darken(image, amount * rng.uniform(0.06, 0.3))


def add_ghost(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A mark that was erased: a symbol or a stroke, faint, blurred and broken."""
    h, w = image.shape
    size = rng.uniform(0.4, 0.85) * min(h, w)
    centre = ((w - 1) / 2 + rng.uniform(-4, 4), (h - 1) / 2 + rng.uniform(-4, 4))
    roll = rng.random()
    if roll < 0.7:
        strokes = symbol_strokes(("circle", "cross")[int(rng.integers(2))], rng)
    else:
        strokes = partial_strokes(rng)
    pen = Pen.random(rng, size)
    half = max(size / 2 - pen.width / 2, 1.0)
    mask = ink_mask((h, w), [s * half + np.array(centre) for s in strokes], pen, rng)
    mask = cv2.GaussianBlur(mask, (0, 0), rng.uniform(0.6, 1.6))
    mask *= rng.random(mask.shape, dtype=np.float32) > rng.uniform(0.0, 0.5)  # rubbed away
    return darken(image, mask * rng.uniform(0.05, 0.18))
