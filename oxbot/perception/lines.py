"""The grid's four lines: straight lines proposed through the ink, and the four chosen.

The Hough transform proposes straight lines in bands of direction, each band voted for only
by ink whose stroke runs its way, so that circles and crosses cannot crowd out the grid's
lines (`hough_lines`). The grid is a pair of near-parallel lines and a pair crossing it near a
right angle, whichever way they are turned, spaced as a grid's, whose ink runs along all four
across the whole grid: the best-voted such quadruples are checked against the ink
(`lattice.line_support`), the leaders refitted to it (`refit.refine`) and judged again
(`best_grid`). Of the two pairs, the one nearer the frame's vertical holds the columns
(`_order`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.perception.ink import UNCLEAR, Strokes
from oxbot.perception.lattice import Four, lattice_of, lattices_of, line_crossing, line_support
from oxbot.perception.refit import refine


@dataclass(frozen=True)
class LinesTuning:
    """The line proposals' and the choice's tuned constants."""

    bands: tuple[int, ...] = (0, 30, 60, 90, 120, 150)
    """Directions (degrees, 0 along x) lines are sought in, one band of direction each."""
    band_half: int = 16
    """Degrees either side of a band's direction its lines may run."""
    family_agree: int = 40
    """Degrees: a stroke this near a band's direction votes for its lines."""
    max_hough: int = 200
    """Strongest Hough lines looked at in each band (they come sorted by votes)."""
    max_lines_per_band: int = 8
    """Distinct Hough lines kept from one band of directions."""
    max_lines: int = 20
    """Distinct Hough lines considered, over all the bands."""
    max_pair_angle: float = math.radians(12)
    """Radians: the two lines of a pair differ by at most this angle."""
    max_off_right_angle: float = math.radians(30)
    """Radians: the two pairs cross at a right angle give or take this angle."""
    max_grids: int = 40
    """Quadruples of lines checked against the ink, best voted first (a cluttered sheet
    cannot blow the time budget)."""
    min_support: float = 0.35
    """Least share of a line's length across the grid that must be inked."""
    min_mean_support: float = 0.6
    """Least mean share over the four lines."""
    min_middle_support_unfitted: float = 0.6
    """Least share of a Hough line's stretch along the middle cell that must be inked (a Hough
    line may be a few degrees off a wobbly one)."""
    finalists: int = 2
    """Best quadruples refitted to the ink before the final choice."""
    min_middle_support: float = 0.75
    """Least share of a refitted line's stretch along the middle cell that must be inked."""


LINES = LinesTuning()


def hough_lines(strokes: Strokes, votes: int) -> list[tuple[float, float, float]]:
    """Distinct straight lines through the ink as (rho, theta, votes), strongest first.

    The grid may be turned any way, so lines are looked for in bands of direction
    (`LINES.bands`), each band voted for only by ink whose stroke runs its way (or is unclear):
    the arcs of circles and the strokes of crosses, at 45 degrees to the grid, then cannot
    add up to lines that crowd out the grid's own.
    """
    x, y = strokes.pixels.T.astype(np.intp)
    seen = strokes.direction[y, x].astype(np.int16)
    kept: list[tuple[float, float, float]] = []
    for way in LINES.bands:
        off = np.abs(seen - way)
        voters = (np.minimum(off, 180 - off) <= LINES.family_agree) | (seen == UNCLEAR)
        mask = np.zeros_like(strokes.mask)
        mask[y[voters], x[voters]] = 255
        # Hough's normals run from 0 to 180 degrees: a band whose normals wrap round there
        # (lines near vertical) is looked for in the transposed image, where it is not.
        flip = abs(((way + 90) % 180) - 90) > 90 - LINES.band_half
        if flip:
            mask = np.ascontiguousarray(mask.T)
        normal = math.radians(((90 - way if flip else way) + 90) % 180)
        found = cv2.HoughLinesWithAccumulator(
            mask,
            2,
            math.pi / 180,
            votes,
            min_theta=normal - math.radians(LINES.band_half),
            max_theta=normal + math.radians(LINES.band_half) + 1e-6,
        )  # 2 px, 1 degree
        if found is None:
            continue
        band = found[: LINES.max_hough, 0, :].tolist()
        if flip:  # back from the transposed image: x and y swap, theta mirrors
            band = [_untransposed(rho, theta, count) for rho, theta, count in band]
        kept += _distinct(band, strokes.mask.shape, LINES.max_lines_per_band)
    kept.sort(key=lambda line: -line[2])
    # Neighbouring bands overlap: a line found in both is kept once, with its larger vote.
    return _distinct([list(line) for line in kept], strokes.mask.shape, LINES.max_lines)


def any_crossing(lines: list[tuple[float, float, float]]) -> bool:
    """Whether any two of the lines cross near a right angle, as a grid's do. (Lines found in
    one direction only are a desk's grain or the edge of something, not yet a grid.)"""
    theta = np.array([line[1] for line in lines])
    crossing = np.abs(_angle_between(theta[:, None], theta[None, :]) - math.pi / 2)
    return bool((crossing <= LINES.max_off_right_angle).any())


def _distinct(
    lines: list[list[float]], shape: tuple[int, ...], most: int
) -> list[tuple[float, float, float]]:
    """The first `most` of Hough's lines (rho, theta, votes) that are not one already kept
    again: within 6 degrees of it, with its point nearest the image's centre within 6 px of
    it. Plain floats: a few hundred such checks per frame, too few for numpy to pay."""
    cx, cy = shape[1] / 2, shape[0] / 2
    same_angle = math.radians(6)
    kept: list[tuple[float, float, float]] = []
    normals: list[tuple[float, float, float, float]] = []  # the kept lines' rho, theta, cos, sin
    for rho, theta, count in lines:
        c, s = math.cos(theta), math.sin(theta)
        off = cx * c + cy * s - rho
        fx, fy = cx - off * c, cy - off * s
        for r, t, kc, ks in normals:
            d = abs(theta - t) % math.pi  # _angle_between on plain floats
            if min(d, math.pi - d) < same_angle and abs(fx * kc + fy * ks - r) < 6:
                break  # a line kept already
        else:
            kept.append((float(rho), float(theta), float(count)))
            normals.append((rho, theta, c, s))
            if len(kept) == most:
                break
    return kept


def _untransposed(rho: float, theta: float, count: float) -> tuple[float, float, float]:
    """A line (rho, theta) of the transposed image as a line of the image."""
    theta = math.pi / 2 - theta
    return (-rho, theta + math.pi, count) if theta < 0 else (rho, theta, count)


def _angle_between(t1: np.ndarray | float, t2: np.ndarray | float) -> np.ndarray:
    """Angle between two line directions, 0 to pi/2 (elementwise for arrays)."""
    d = np.abs(np.subtract(t1, t2)) % math.pi
    return np.minimum(d, math.pi - d)


def _spacing(l1: tuple, l2: tuple, center: np.ndarray) -> np.ndarray:
    """Distance from line 2 to the point of line 1 nearest `center`; lines are (rho, theta),
    elementwise for arrays of them."""
    (r1, t1), (r2, t2) = l1, l2
    c1, s1 = np.cos(t1), np.sin(t1)
    off = center[0] * c1 + center[1] * s1 - r1
    fx, fy = center[0] - off * c1, center[1] - off * s1
    return np.abs(fx * np.cos(t2) + fy * np.sin(t2) - r2)


def best_grid(
    lines: list[tuple[float, float, float]],
    strokes: Strokes,
    min_spacing: float,
    max_spacing: float,
    center: np.ndarray,
) -> tuple[Four, float] | None:
    """The four lines, among `lines`, along which ink runs most closely; or None."""
    rho, theta, votes = np.array(lines).T

    def pairs(family: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Indices (first, second) of the near-parallel pairs of lines of a family spaced
        as a grid's, in the order of itertools.combinations."""
        i, j = np.triu_indices(len(family), 1)
        first, second = family[i], family[j]
        spacing = _spacing((rho[first], theta[first]), (rho[second], theta[second]), center)
        ok = (
            (_angle_between(theta[first], theta[second]) < LINES.max_pair_angle)
            & (spacing >= min_spacing)
            & (spacing <= max_spacing)
        )
        return first[ok], second[ok]

    # The grid may be turned any way: every pair with every later pair that crosses it near
    # a right angle (`_order` then tells which pair runs down the sheet).
    va, vb = pairs(np.arange(len(lines)))
    ha, hb = va, vb
    crossing = np.abs(_angle_between(theta[va][:, None], theta[ha][None, :]) - math.pi / 2)
    p, q = np.nonzero(np.triu(crossing <= LINES.max_off_right_angle, 1))
    # The grid's lines are the longest in view: try the best-voted quadruples first, and only
    # so many of them, so that a cluttered sheet cannot blow the time budget.
    total = votes[va[p]] + votes[vb[p]] + votes[ha[q]] + votes[hb[q]]
    tried = np.argsort(-total, kind="stable")[: LINES.max_grids]
    tried_fours = [
        _order((lines[va[p[k]]], lines[vb[p[k]]]), (lines[ha[q[k]]], lines[hb[q[k]]]))
        for k in tried
    ]
    fours, lattices, totals = [], [], []
    for k, four, lattice in zip(
        tried, tried_fours, lattices_of(tried_fours, 0.8 * min_spacing), strict=True
    ):
        if lattice is not None:
            fours.append(four)
            lattices.append(lattice)
            totals.append(float(total[k]))
    passed: list[tuple[float, Four]] = []
    if lattices:
        support, middle, closeness = line_support(np.array(lattices), strokes)
        ok = (
            (support.min(axis=1) >= LINES.min_support)
            & (support.mean(axis=1) >= LINES.min_mean_support)
            & (middle.min(axis=1) >= LINES.min_middle_support_unfitted)
        )
        passed = [(float(closeness[k]) + 1e-4 * totals[k], fours[k]) for k in np.flatnonzero(ok)]
    # A Hough line a few degrees off a wobbly grid line can score below a line that grazes
    # several symbols; fitted to the ink, the grid's real lines win. So the leaders are
    # refitted once and judged again.
    fitted_fours, lattices = [], []
    for _, four in sorted(passed, key=lambda x: -x[0])[: LINES.finalists]:
        fitted = refine(four, strokes.pixels, strokes.ways, bands=(0.15,))
        lattice = lattice_of(*fitted, min_side=0.8 * min_spacing)
        if lattice is not None:
            fitted_fours.append(fitted)
            lattices.append(lattice)
    best: tuple[float, Four] | None = None
    if lattices:
        _, middle, closeness = line_support(np.array(lattices), strokes)
        for k, fitted in enumerate(fitted_fours):
            if middle[k].min() >= LINES.min_middle_support and (
                best is None or closeness[k] > best[0]
            ):
                best = (float(closeness[k]), fitted)
    return None if best is None else (best[1], best[0])


def _order(p: tuple, q: tuple) -> Four:
    """Two pairs of lines as (left, right, top, bottom)."""
    # The pair whose normals point more along x holds the vertical lines. All four lines are
    # weighed: near 45 degrees in perspective one line of a pair can lean past it alone.
    if _uprightness(q, p) > _uprightness(p, q):
        p, q = q, p
    mid = line_crossing(p[0][:2], q[0][:2]) or (0.0, 0.0)

    def position(line: tuple, axis: int) -> float:
        # Where the line crosses the other family's direction through `mid`: its x or y.
        # (Plain floats; the two lines of a pair lie far apart, so rounding cannot swap them.)
        rho, theta = line[0], line[1]
        n = (math.cos(theta), math.sin(theta))
        off = mid[0] * n[0] + mid[1] * n[1] - rho
        return mid[axis] - off * n[axis]

    left, right = sorted((p[0][:2], p[1][:2]), key=lambda line: position(line, 0))
    top, bottom = sorted((q[0][:2], q[1][:2]), key=lambda line: position(line, 1))
    return left, right, top, bottom


def _uprightness(verticals: tuple, horizontals: tuple) -> float:
    """How near the frame's axes two pairs of lines lie when the first pair holds the columns:
    the summed share of each line's normal along its axis (4 for an upright grid)."""
    return sum(abs(math.cos(line[1])) for line in verticals) + sum(
        abs(math.sin(line[1])) for line in horizontals
    )
