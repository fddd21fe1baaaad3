"""Refitting the grid's four lines to the ink, and finding where the drawn lines really cross.

A Hough line can be a few degrees off a wobbly hand-drawn line, and symbols touch the lines:
each line is refitted to the ink near it that runs its way, in a narrowing band (`refine`).
A hand-drawn line also bends, so each crossing is then found from the two lines fitted to the
ink within a third of a cell of it, a few rounds over, each looking along the lines through
the last crossings, and the outer cells are extended in the direction each line takes out
there (`local_crossings`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from oxbot.game.board import SIZE
from oxbot.perception.ink import INK, UNCLEAR
from oxbot.perception.lattice import (
    Four,
    Line,
    lattice_from_inner,
    lattice_of,
    line_crossing,
    line_frames,
)

# `_crossings_near` and `_bend_outer` index the 4x4 corners of two lines each way directly: a
# 3x3 grid only (as `lattice.py`).
assert SIZE == 3, "the grid finder finds a 3x3 grid only (two pairs of lines)"


@dataclass(frozen=True)
class RefitTuning:
    """The crossings' refit's tuned constants."""

    local_reach: float = 0.35
    """Cells along each line, either side of a crossing, of the ink fitted to find it."""
    crossing_rounds: int = 3
    """Rounds of finding the crossings, each looking along the lines through the last round's."""


REFIT = RefitTuning()


def _near_lines(
    lattice: np.ndarray, pixels: np.ndarray, band: float, ways: np.ndarray | None = None
) -> np.ndarray:
    """(4, N): which pixels lie within `band` cells of each of the four lines, from 1.3 cells
    before its first crossing to 1.3 cells after its second; given the strokes' `ways`, only
    those whose stroke runs along the line (`_running_along`)."""
    along, across, size = _along_across(lattice, pixels)
    near = (across < band * size) & (along > -1.3) & (along < 2.3)
    return near if ways is None else near & _running_along(lattice, ways)


def _running_along(lattice: np.ndarray, ways: np.ndarray) -> np.ndarray:
    """(4, N): whether each stroke direction of `ways` (degrees, `UNCLEAR` for unclear ones,
    which count) runs within `INK.agree` degrees of each of the lattice's four lines. A line
    fitted to ink near a crossing must not be pulled round by the other line's ink."""
    _, d, _, _ = line_frames(lattice)
    line_way = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 180
    off = np.abs(ways[None, :] - line_way[:, None])
    return (np.minimum(off, 180 - off) <= INK.agree) | (ways[None, :] == UNCLEAR)


def pixels_near(
    four: Four, pixels: np.ndarray, ways: np.ndarray, band: float
) -> tuple[np.ndarray, np.ndarray]:
    """The pixels within `band` cells of any of the four lines (see `_near_lines`), and the
    directions of their strokes."""
    lattice = lattice_of(*four)
    if lattice is None:
        return pixels, ways
    keep = _near_lines(lattice, pixels, band).any(axis=0)
    return pixels[keep], ways[keep]


def refine(
    four: Four,
    pixels: np.ndarray,
    ways: np.ndarray,
    bands: tuple[float, ...] = (0.2, 0.12, 0.08),
) -> Four:
    """Refit each line to the ink in a narrowing band around it.

    Hough's lines can be a few degrees off a wobbly hand-drawn line, and symbols touch the
    lines: each round fits a straight line to the ink near the current one, keeps the closer
    three quarters of it (dropping bits of symbols) and fits again. `pixels`: (N, 2) x, y of
    the ink.
    """
    for band in bands:
        lattice = lattice_of(*four)
        if lattice is None:
            return four
        near = _near_lines(lattice, pixels, band, ways)
        fitted = []
        for k in range(4):
            line = _fit_line(pixels[near[k]])
            if line is None:
                return four
            fitted.append(line)
        four = (fitted[0], fitted[1], fitted[2], fitted[3])
    return four


def local_crossings(
    four: Four, lattice: np.ndarray, pixels: np.ndarray, ways: np.ndarray
) -> np.ndarray:
    """The lattice rebuilt on where the lines really cross: a hand-drawn line bends, so each
    crossing is found from the two lines fitted within a third of a cell of it, first along
    the straight lines, then, for a few rounds, along the lines through the last crossings."""
    straight = lattice
    for _ in range(REFIT.crossing_rounds):
        moved = _crossings_near(four, lattice, pixels, ways)
        if moved is None:
            break  # the local fits disagree with the lines: keep the last crossings
        lattice = moved
    return _bend_outer(lattice, pixels, ways, straight)


def _crossings_near(
    four: Four, lattice: np.ndarray, pixels: np.ndarray, ways: np.ndarray
) -> np.ndarray | None:
    """One round of `local_crossings`: the lattice on the crossings of the lines fitted to
    the ink near each of its crossings, or None where one moves more than a quarter cell."""
    along, near, size = _along_lines(lattice, pixels)
    near &= _running_along(lattice, ways)
    around = (  # near each line's first crossing, and its second
        near & (np.abs(along) < REFIT.local_reach),
        near & (np.abs(along - 1) < REFIT.local_reach),
    )
    local = {}
    for k in range(4):
        for end in (0, 1):
            line = _fit_line(pixels[around[end][k]])
            local[k, end] = line if line is not None else four[k]
    inner = []
    for r, top_or_bottom in ((1, 2), (2, 3)):
        for c, left_or_right in ((1, 0), (2, 1)):
            # Line k's crossings run along it: verticals top to bottom, horizontals left to right.
            point = _intersect(local[left_or_right, r - 1], local[top_or_bottom, c - 1])
            if point is None or np.linalg.norm(point - lattice[r, c]) > 0.25 * size:
                return None
            inner.append(point)
    return lattice_from_inner(inner)


def _intersect(l1: Line, l2: Line) -> np.ndarray | None:
    """Where two lines cross, as an array (x, y); None for parallel lines."""
    point = line_crossing(l1, l2)
    return None if point is None else np.array(point)


def _along_across(lattice: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Where each pixel of (N, 2) lies along each of the four lines, in cells from its first
    crossing (4, N); how far across each line it lies, in pixels (4, N); the mean cell size.
    (Line by line in rows: each line's pixels are then picked out of one contiguous row.)"""
    a, d, n, size = line_frames(lattice)
    # Both projections in one product: rows 0-3 along the lines, 4-7 across them.
    both = np.concatenate([d, n]) @ pixels.T
    both -= np.concatenate([(a * d).sum(axis=1), (a * n).sum(axis=1)])[:, None]
    along = both[:4] / (d * d).sum(axis=1)[:, None]
    across = np.abs(both[4:], out=both[4:])
    return along, across, size


def _along_lines(lattice: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Where each pixel lies along each of the four lines, in cells from its first crossing
    (4, N); whether it lies within 0.12 cells of the line (4, N); and the mean cell size."""
    along, across, size = _along_across(lattice, pixels)
    return along, across < 0.12 * size, size


def _bend_outer(
    q: np.ndarray, pixels: np.ndarray, ways: np.ndarray, straight: np.ndarray
) -> np.ndarray:
    """The outer cells end one middle cell further along each line, in the direction the line
    takes out there (a bowed line turns), where the line is drawn that far. Its ink out there
    is looked for along the `straight` lattice of the whole lines: the crossings' lattice is
    true near the middle cell and may point astray beyond it."""
    q = q.copy()
    along, near, _ = _along_lines(straight, pixels)
    near &= _running_along(straight, ways)
    ends = {  # line k, its end (0 first crossing, 1 second): (the crossing, the other, outer)
        (0, 0): ((1, 1), (2, 1), (0, 1)),
        (0, 1): ((2, 1), (1, 1), (3, 1)),
        (1, 0): ((1, 2), (2, 2), (0, 2)),
        (1, 1): ((2, 2), (1, 2), (3, 2)),
        (2, 0): ((1, 1), (1, 2), (1, 0)),
        (2, 1): ((1, 2), (1, 1), (1, 3)),
        (3, 0): ((2, 1), (2, 2), (2, 0)),
        (3, 1): ((2, 2), (2, 1), (2, 3)),
    }
    for (k, end), (here, there, outer) in ends.items():
        outside = (
            (along[k] > -0.9) & (along[k] < 0.1)
            if end == 0
            else (along[k] > 0.9) & (along[k] < 1.9)
        )
        line = _fit_line(pixels[near[k] & outside])
        if line is None:
            continue
        step = q[here] - q[there]  # one middle cell, pointing outwards
        direction = np.array([-math.sin(line[1]), math.cos(line[1])])
        direction *= np.sign(direction @ step) or 1.0
        length = np.linalg.norm(step)
        if direction @ step < 0.9 * length:
            continue  # turns more than about 25 degrees: not the same line
        q[outer] = q[here] + direction * length
    # The outer corners (rows and columns 0, 3) complete parallelograms with their
    # neighbours (rows and columns 1, 2).
    q[::3, ::3] = q[::3, 1:3] + q[1:3, ::3] - q[1:3, 1:3]
    return q


def _fit_line(points: np.ndarray) -> Line | None:
    """The straight line through points, refitted without the farthest quarter of them."""
    if len(points) < 10:
        return None
    mean, centered, normal = _principal_axis(points)
    residual = np.abs(centered @ normal)
    k = (3 * len(residual)) // 4
    points = points[residual <= np.partition(residual, k)[k]]
    if len(points) < 8:
        return None
    mean, _, normal = _principal_axis(points)
    return float(mean @ normal), math.atan2(normal[1], normal[0])


def _principal_axis(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The points' mean, the points about it, and the unit normal of their direction of most
    spread."""
    # Pixel positions are whole numbers, summed exactly in any order: as a matrix product,
    # several times faster than numpy's sum down the columns.
    mean = np.ones(len(points)) @ points / len(points)
    centered = points - mean
    (sxx, sxy), (_, syy) = (centered.T @ centered).tolist()
    along = 0.5 * math.atan2(2 * sxy, sxx - syy)
    return mean, centered, np.array([-math.sin(along), math.cos(along)])
