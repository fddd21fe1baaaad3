"""The lattice of a grid's cell corners, made from its four lines, and its check against the ink.

Four lines (left, right, top, bottom: `Four`) cross in the middle cell's four corners; one
more cell along each line gives the 4x4 lattice of cell corners (`lattice_of`), in frame
pixels, with the corners completing parallelograms. A lattice is refused when its middle cell
is not a plausible cell (not convex, too small, too oblong, opposite sides unalike).
`line_support` says how closely ink that runs each line's way follows the four lines, for
many candidate lattices at once: the line choice (`lines.py`) ranks quadruples by it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.game.board import SIZE
from oxbot.perception.ink import Strokes

# The finder looks for exactly two pairs of lines, so it finds a 3x3 grid and no other: the
# lattice code here (`lattice_of`, `lattices_of`, `lattice_from_inner`, `line_frames`) and in
# `refit.py` indexes the 4x4 corners of two lines each way directly. A bigger board needs a new
# finder.
assert SIZE == 3, "the grid finder finds a 3x3 grid only (two pairs of lines)"


@dataclass(frozen=True)
class LatticeTuning:
    """The tuned limits of a plausible middle cell and of a line's stretch in view."""

    min_opposite_ratio: float = 0.6
    """The middle cell's opposite sides are alike: one over the other lies between this and
    its inverse."""
    min_aspect: float = 0.5
    """The middle cell is not too oblong: its left side over its top lies between this and its
    inverse."""
    min_in_view: float = 0.6
    """Least share of a line's length across the grid that must be in the frame to be judged."""
    min_middle_in_view: float = 0.9
    """The same for its stretch along the middle cell."""


LATTICE = LatticeTuning()

# The middle cell's side ratios (left to right side, top to bottom, left to top) lie strictly
# between these.
_RATIO_LOW = np.array(
    [LATTICE.min_opposite_ratio, LATTICE.min_opposite_ratio, LATTICE.min_aspect], np.float32
)
_RATIO_HIGH = np.array(
    [1 / LATTICE.min_opposite_ratio, 1 / LATTICE.min_opposite_ratio, 1 / LATTICE.min_aspect],
    np.float32,
)


Line = tuple[float, float]
"""A straight line (rho, theta): the points x cos(theta) + y sin(theta) = rho."""


def line_crossing(l1: Line, l2: Line) -> tuple[float, float] | None:
    """Where two lines cross, as plain floats (a numpy array per crossing costs more than
    the arithmetic); None for parallel lines."""
    (r1, t1), (r2, t2) = l1, l2
    a, b, c, d = math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2)
    det = a * d - b * c
    if abs(det) < 1e-6:
        return None
    return (r1 * d - r2 * b) / det, (a * r2 - c * r1) / det


Four = tuple[Line, Line, Line, Line]
"""The grid's lines: left and right vertical, then top and bottom horizontal."""


def lattice_of(
    left: Line, right: Line, top: Line, bottom: Line, min_side: float = 1.0
) -> np.ndarray | None:
    """The (4, 4, 2) lattice of cell corners of four lines, or None if they make no grid."""
    inner = [line_crossing(v, hz) for hz in (top, bottom) for v in (left, right)]
    if None in inner:
        return None
    middle = np.array([inner[0], inner[1], inner[3], inner[2]], np.float32)  # clockwise
    if not np.isfinite(middle).all() or not cv2.isContourConvex(middle.reshape(-1, 1, 2)):
        return None
    sides = np.sqrt(((middle - middle[[3, 0, 1, 2]]) ** 2).sum(axis=1))
    # Opposite sides alike (0 to 2, 1 to 3), and the cell not too oblong (0 to 1).
    ratios = sides[[0, 1, 0]] / sides[[2, 3, 1]]
    if sides.min() < min_side or not ((ratios > _RATIO_LOW) & (ratios < _RATIO_HIGH)).all():
        return None
    return lattice_from_inner(inner)


def lattices_of(fours: list[Four], min_side: float) -> list[np.ndarray | None]:
    """`lattice_of` of each of many quadruples of lines at once (numpy's cost per call, not per
    quadruple, dominates the candidates' checks)."""
    if not fours:
        return []
    rho, theta = np.moveaxis(np.array(fours, np.float64), -1, 0)  # (C, 4) each
    c, s = np.cos(theta), np.sin(theta)

    def crossing(v: int, hz: int) -> np.ndarray:  # (C, 2); nan for parallel lines
        det = c[:, v] * s[:, hz] - s[:, v] * c[:, hz]
        det = np.where(np.abs(det) < 1e-6, np.nan, det)
        x = (rho[:, v] * s[:, hz] - rho[:, hz] * s[:, v]) / det
        y = (c[:, v] * rho[:, hz] - c[:, hz] * rho[:, v]) / det
        return np.stack([x, y], axis=1)

    # Left 0, right 1, top 2, bottom 3: crossings a, b (top), c, d (bottom), as `lattice_of`.
    a, b, cc, d = crossing(0, 2), crossing(1, 2), crossing(0, 3), crossing(1, 3)
    middle = np.stack([a, b, d, cc], axis=1)  # clockwise (C, 4, 2)
    edges = np.roll(middle, -1, axis=1) - middle
    turns = (
        edges[:, :, 0] * np.roll(edges, -1, axis=1)[:, :, 1]
        - edges[:, :, 1] * np.roll(edges, -1, axis=1)[:, :, 0]
    )
    with np.errstate(invalid="ignore"):
        convex = (turns > 0).all(axis=1) | (turns < 0).all(axis=1)
        sides = np.sqrt(((middle - middle[:, [3, 0, 1, 2]]) ** 2).sum(axis=2))
        ratios = sides[:, [0, 1, 0]] / sides[:, [2, 3, 1]]
        ok = (
            np.isfinite(middle).all(axis=(1, 2))
            & convex
            & (sides.min(axis=1) >= min_side)
            & ((ratios > _RATIO_LOW) & (ratios < _RATIO_HIGH)).all(axis=1)
        )
    return [
        lattice_from_inner([a[k], b[k], cc[k], d[k]]) if ok[k] else None for k in range(len(fours))
    ]


def lattice_from_inner(inner: list) -> np.ndarray:
    """The (4, 4, 2) lattice of its four inner points (x, y), row by row (at (1, 1), (1, 2),
    (2, 1), (2, 2)): the outer points lie one middle cell further out along each line, and
    the corners complete parallelograms. (In plain floats: numpy would spend more time per
    call than on the arithmetic.)"""
    a, b, c, d = ((float(x), float(y)) for x, y in inner)

    def beyond(p: tuple, o: tuple) -> tuple[float, float]:  # one cell past p, away from o
        return 2 * p[0] - o[0], 2 * p[1] - o[1]

    def corner(row: tuple, column: tuple, diagonal: tuple) -> tuple[float, float]:
        return row[0] + column[0] - diagonal[0], row[1] + column[1] - diagonal[1]

    top_a, top_b, bottom_c, bottom_d = beyond(a, c), beyond(b, d), beyond(c, a), beyond(d, b)
    left_a, right_b, left_c, right_d = beyond(a, b), beyond(b, a), beyond(c, d), beyond(d, c)
    return np.array(
        [
            [corner(top_a, left_a, a), top_a, top_b, corner(top_b, right_b, b)],
            [left_a, a, b, right_b],
            [left_c, c, d, right_d],
            [corner(bottom_c, left_c, c), bottom_c, bottom_d, corner(bottom_d, right_d, d)],
        ]
    )


def line_frames(lattice: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For the four lines (left, right, top, bottom) of a lattice (4, 4, 2), or of each of a
    stack of them (..., 4, 4, 2): a crossing A on each (..., 4, 2), the step D of one cell
    along it, its unit normal N, and the mean cell size (...)."""
    # Left from q[1, 1] to q[2, 1], right q[1, 2] to q[2, 2], top q[1, 1] to q[1, 2],
    # bottom q[2, 1] to q[2, 2].
    a = lattice[..., [1, 1, 1, 2], [1, 2, 1, 1], :]
    d = lattice[..., [2, 2, 1, 2], [1, 2, 2, 2], :] - a
    length = np.sqrt((d * d).sum(axis=-1, keepdims=True))
    n = d[..., ::-1] * _TURN_LEFT / np.maximum(length, 1e-9)
    return a, d, n, length[..., 0].sum(axis=-1) / 4  # (np.mean, less its overhead)


_TURN_LEFT = np.array([-1.0, 1.0])  # (dx, dy)[::-1] * this = (-dy, dx)


# Points along each inner line (in cells from its first crossing) and small steps across it:
# ink is looked for within ±0.12 cells of the line, because hand-drawn lines wobble; ink
# nearer the line counts for more, so that of two candidate lines the one on the ink wins.
_ALONG = np.linspace(-0.88, 1.88, 24)
_ACROSS = np.linspace(-0.12, 0.12, 13)
_CLOSENESS = 1 - np.abs(_ACROSS) / 0.18
_MIDDLE = (_ALONG > 0.1) & (_ALONG < 0.9)  # the stretch between the line's two crossings


def line_support(
    lattices: np.ndarray, strokes: Strokes
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each of a stack of lattices (C, 4, 4, 2): the share of each of its four lines along
    which ink is found (C, 4), the same along the middle cell only (C, 4), and how close to
    the lines the ink lies, 0-1 (C,), all over the lines' stretches in the frame. Only ink
    whose stroke runs the line's way counts: a line
    through a symbol crosses its strokes. (All candidates at once: numpy's cost per call,
    not per point, dominates.)"""
    ink = strokes.mask
    a, d, n, size = line_frames(lattices)
    across = (_ACROSS[None, :] * size[:, None])[:, None, None, :]
    # The points looked at, x and y: (C, line, along, across).
    x, y = (
        np.round(
            a[:, :, None, None, k]
            + _ALONG[:, None] * d[:, :, None, None, k]
            + across * n[:, :, None, None, k]
        ).astype(np.int64)
        for k in (0, 1)
    )
    h, w = ink.shape
    inside = (x >= 0) & (x < w) & (y >= 0) & (y < h)
    hit = inside & (ink.ravel().take(np.where(inside, y * w + x, 0)) > 0)
    way = np.degrees(np.arctan2(d[..., 1], d[..., 0])) % 180  # each line's direction (C, 4)
    hits = np.flatnonzero(hit)
    hit.ravel()[hits] = strokes.runs_along(
        x.ravel()[hits], y.ravel()[hits], way.ravel()[hits // (len(_ALONG) * len(_ACROSS))]
    )
    closeness = (hit * _CLOSENESS).max(axis=3)
    inked = hit.any(axis=3)
    # A grid may run off the frame: only the stretches of line in view are judged (the ink
    # mask is blank within 2 px of the frame's edge), as long as most of each line is.
    centre = len(_ACROSS) // 2
    cx, cy = x[..., centre], y[..., centre]
    seen = (cx >= 2) & (cx < w - 2) & (cy >= 2) & (cy < h - 2)
    in_view = seen.mean(axis=2)
    middle_in_view = seen[:, :, _MIDDLE].mean(axis=2)
    enough = (in_view >= LATTICE.min_in_view) & (middle_in_view >= LATTICE.min_middle_in_view)
    support = np.where(enough, inked.sum(axis=2) / np.maximum(seen.sum(axis=2), 1), 0.0)
    middle_support = np.where(
        enough,
        inked[:, :, _MIDDLE].sum(axis=2) / np.maximum(seen[:, :, _MIDDLE].sum(axis=2), 1),
        0.0,
    )
    # Half from the middle stretch, which every grid has: ink beyond the crossings may be a
    # symbol's as well as the line's, which may stop short there. (Summed one lattice at a
    # time: a sum over several axes adds in another order, and candidates that tie must
    # still tie.)
    middle, beyond = closeness[:, :, _MIDDLE], closeness[:, :, ~_MIDDLE]
    seen_middle, seen_beyond = seen[:, :, _MIDDLE], seen[:, :, ~_MIDDLE]
    score = np.array(
        [
            0.5 * (m.sum() / max(sm.sum(), 1)) + 0.5 * (b.sum() / max(sb.sum(), 1))
            for m, b, sm, sb in zip(middle, beyond, seen_middle, seen_beyond, strict=True)
        ]
    )
    return support, middle_support, score
