"""Finding the hand-drawn 3x3 grid in a photo: where its 4x4 lattice of cell corners lies.

Paper §3.1 "Game Move Recognition": grayscale → remove the grid → split into 9 images. The
paper's arm camera saw a fixed grid from a fixed pose; here the grid may be anywhere in view,
turned up to 45° (issue 15; SPEC §2 asks for ±15°) and in perspective, so it is found first:

1. *Ink*: pixels clearly darker than the paper around them in any colour channel (a
   morphological closing estimates the paper), on a copy of the frame at most `WORK_SIDE`
   pixels wide, shrunk so that thin pen lines stay dark. A thin blue or green marker line,
   faint in gray, is dark in the channel it absorbs. Desk edges, shadows and lighting
   gradients are not thin and dark.
2. *Lines*: the Hough transform proposes straight lines in six bands of direction, each band
   voted for only by ink whose stroke runs its way, so that circles and crosses cannot crowd
   out the grid's lines; the grid is a pair of near-parallel lines and a pair crossing it near
   a right angle, whichever way they are turned, whose ink runs along all four, across the
   whole grid. Hand-drawn lines wobble, overshoot or stop short; the check asks for ink along
   most of each line, and along most of its stretch beside the middle cell.
3. *Fit*: each of the four lines is refitted to the ink near it that runs its way, and each
   crossing to such ink within a third of a cell of it, three times over, each time looking
   along the lines through the last crossings (a hand-drawn line bends). The four crossings
   and one more cell along each line give a 4x4 lattice of cell corners (`Grid`), in *cell
   units* (inner lines at 1 and 2, cells filling [0, 3]²). Of the pairs, the one nearer the
   frame's vertical holds the columns.

This module owns the search (`find_grid`) and its result (`Grid`); the frame's check
(`as_image`, `as_gray`) is `frame.py`'s, imported here as well. `NoGridFound` is raised rather
than a guess when no such four lines exist (a blank sheet, an empty desk). A grid cut by the
frame's edge is found as long as its four lines are; `Grid.in_view` says which cells are too
far out of the frame to read. What follows the search is `rectify.py` (the grid seen from
straight above) and `cells.py` (the grid lines painted over, nine 40x40 cells cut).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.errors import NoGridFound
from oxbot.game.board import SIZE
from oxbot.perception.frame import as_gray, as_image

__all__ = ["Grid", "NoGridFound", "as_gray", "as_image", "find_grid"]

# The finder looks for exactly two pairs of lines, so it finds a 3x3 grid and no other: the
# lattice code below (`_lattice`, `_extend`, `_line_frames`, `_crossings_near`, `_bend_outer`)
# indexes the 4x4 corners of two lines each way directly. A bigger board needs a new finder.
assert SIZE == 3, "grid.py finds a 3x3 grid only (two pairs of lines)"

WORK_SIDE = 320
"""Longest side, in pixels, of the copy of the frame the grid is searched in at most (the
frame is shrunk a whole number of times: 800 pixels to 267, 1280 to 320)."""
MIN_GRID_SHARE = 0.15
"""The grid's side must be at least this share of the frame's shorter side."""

_INK_CONTRAST = 0.12  # ink is at least this much darker than the paper around it
_MAX_LINES = 20  # distinct Hough lines considered
_MAX_LINES_PER_BAND = 8  # distinct Hough lines kept from one band of directions
_BAND_HALF = 16  # degrees either side of a band's direction its lines may run
_BANDS = (0, 30, 60, 90, 120, 150)  # directions (degrees, 0 along x) lines are sought in
_MAX_HOUGH = 200  # strongest Hough lines looked at (they come sorted by votes)
_FINALISTS = 2  # best quadruples refitted to the ink before the final choice
_MAX_GRIDS = 40  # quadruples of lines checked against the ink, best voted first
_PARALLEL = math.radians(12)  # the two lines of a pair differ by at most this angle
_CROSSING = math.radians(30)  # the two pairs cross at 90° give or take this angle
_MIN_IN_VIEW = 0.6  # least share of a line's length across the grid that must be in the frame
_MIN_MIDDLE_IN_VIEW = 0.9  # the same for its stretch along the middle cell
_MIN_SUPPORT = 0.35  # least share of a line's length across the grid that must be inked
_MIN_MEAN_SUPPORT = 0.6  # least mean share over the four lines
_MIN_MIDDLE_SUPPORT = 0.75  # least share of a line's stretch along the middle cell
_MIN_MIDDLE_SUPPORT_UNFITTED = 0.6  # the same for a Hough line, a few degrees off a wobbly one
_AGREE = 25  # degrees: a stroke this near a line's direction runs its way
_FAMILY_AGREE = 40  # degrees: a stroke this near a band's direction votes for its lines
_MIN_CLEARNESS = 0.3  # strokes less clear-cut than this (crossings, blobs) count either way
_UNCLEAR = 255  # the direction of such strokes


Line = tuple[float, float]
"""A straight line (rho, theta): the points x cos(theta) + y sin(theta) = rho."""


@dataclass(frozen=True)
class Grid:
    """A grid found in a frame: where its 4x4 lattice of cell corners lies, in frame pixels.

    `lattice[r, c]` is the point at cell units (x=c, y=r). The four inner points are the
    crossings of the drawn lines; the outer ones extend each line by one cell, as long as the
    middle cell is along that line. Extending along the lines, rather than through a
    homography fitted to the middle cell, keeps a hand-drawn grid's irregular spacing from
    being mistaken for strong perspective and blown up at the outer corners.
    """

    lattice: np.ndarray
    """float (4, 4, 2): frame pixels of the cell corners, rows top to bottom."""
    support: float
    """How closely ink follows the four lines, 0-1: how sure the finder is."""
    in_view: tuple[bool, ...] = (True,) * (SIZE * SIZE)
    """For each cell, row-major: whether its middle is in the frame (`IN_VIEW`), so that
    what is drawn there can be read. A grid cut by the frame's edge has some cells False."""

    def cells_out_of_view(self) -> list[int]:
        """The cells (0-8, row-major) too far out of the frame to read."""
        return [i for i, seen in enumerate(self.in_view) if not seen]

    def corners(self) -> np.ndarray:
        """(4, 2) frame pixels of the grid's outer corners, clockwise from the upper left."""
        q = self.lattice
        return np.array([q[0, 0], q[0, SIZE], q[SIZE, SIZE], q[SIZE, 0]])

    def cell_size(self) -> float:
        """The mean side of a cell in frame pixels."""
        q = self.lattice
        return float(
            (
                np.linalg.norm(np.diff(q, axis=0), axis=2).mean()
                + np.linalg.norm(np.diff(q, axis=1), axis=2).mean()
            )
            / 2
        )


def _ink_mask(image: np.ndarray, kernel: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """uint8 mask (0/255) of thin dark strokes, pixels well below the paper's closing in any
    colour channel; and float32 darkness, the largest share of the paper's light a pixel
    takes away in one channel (0 paper, 1 black), whose structure gives strokes' directions.
    Each channel against its own paper: a tinted sheet on a desk of another colour."""
    smooth = cv2.GaussianBlur(image, (3, 3), 0)
    paper = cv2.morphologyEx(smooth, cv2.MORPH_CLOSE, np.ones((kernel, kernel), np.uint8))
    darker = cv2.subtract(paper, smooth).astype(np.float32)
    lit = paper.astype(np.float32)
    ink = ((darker > _INK_CONTRAST * lit) & (darker > 12)).astype(np.uint8) * 255
    darkness = darker / np.maximum(lit, 8.0)
    if image.ndim == 3:  # OpenCV's maximum over the channels: numpy's is many times slower
        ink = cv2.max(cv2.max(ink[..., 0], ink[..., 1]), ink[..., 2])
        channels = cv2.split(darkness)
        darkness = cv2.max(cv2.max(channels[0], channels[1]), channels[2])
    return ink, darkness


def _shrink_keeping_strokes(image: np.ndarray, k: int) -> np.ndarray:
    """`image` shrunk k times (k > 1 a whole number: OpenCV's fast area averaging) so that a
    pen line one pixel wide stays dark: each pixel first takes the darkest value around it (as
    wide as the pixels that merge), then areas are averaged."""
    darkest = cv2.erode(image, np.ones((k, k), np.uint8))
    return cv2.resize(darkest, None, fx=1 / k, fy=1 / k, interpolation=cv2.INTER_AREA)


def find_grid(frame: np.ndarray) -> Grid:
    """The hand-drawn 3x3 grid in a frame (uint8 gray or RGB); NoGridFound when there is none.

    The grid may run off the frame: `Grid.in_view` says which cells are seen well enough to
    read. A grid with a cell out of view is still found, so that the reader can say which.
    """
    h, w = frame.shape[:2]
    shrink = math.ceil(max(h, w) / WORK_SIDE)
    scale = 1 / shrink
    small = frame if shrink == 1 else _shrink_keeping_strokes(frame, shrink)
    ink, darkness = _ink_mask(small)
    # The paper's closing brightens the frame's edge, where the desk then looks like ink.
    ink[:2, :] = ink[-2:, :] = ink[:, :2] = ink[:, -2:] = 0
    short = min(ink.shape)
    min_spacing = MIN_GRID_SHARE * short / SIZE
    strokes = _Strokes.of(darkness, ink)
    lines = _hough_lines(strokes, votes=max(12, int(0.6 * SIZE * min_spacing)))
    if len(lines) < 4 or not _any_crossing(lines):
        raise NoGridFound(
            "no grid in view: found no long pen lines crossing (a blank sheet or an empty "
            "desk?); draw the 3x3 grid with a dark pen and keep all of it in the picture"
        )
    center = np.array(ink.shape[::-1], np.float64) / 2
    best = _best_grid(lines, strokes, min_spacing, short / 2, center)
    if best is None:
        raise NoGridFound(
            "no 3x3 grid in view: no two pairs of crossing pen lines run across a whole grid; "
            "keep all four lines of the grid in the picture"
        )
    four, support = best
    # The fits below look only at ink near the four lines, a small part of all the ink.
    pixels, ways = _pixels_near(four, strokes.pixels, strokes.ways, band=0.3)
    refined = _refine(four, pixels, ways)
    lattice = _lattice(*refined)
    if lattice is None:
        lattice = _lattice(*four)
    else:
        lattice = _local_crossings(refined, lattice, pixels, ways)
    assert lattice is not None
    lattice = lattice / scale
    return Grid(lattice=lattice, support=support, in_view=_cells_in_view(lattice, w, h))


def _hough_lines(strokes: _Strokes, votes: int) -> list[tuple[float, float, float]]:
    """Distinct straight lines through the ink as (rho, theta, votes), strongest first.

    The grid may be turned any way, so lines are looked for in bands of direction
    (`_BANDS`), each band voted for only by ink whose stroke runs its way (or is unclear):
    the arcs of circles and the strokes of crosses, at 45 degrees to the grid, then cannot
    add up to lines that crowd out the grid's own.
    """
    x, y = strokes.pixels.T.astype(np.intp)
    seen = strokes.direction[y, x].astype(np.int16)
    kept: list[tuple[float, float, float]] = []
    for way in _BANDS:
        off = np.abs(seen - way)
        voters = (np.minimum(off, 180 - off) <= _FAMILY_AGREE) | (seen == _UNCLEAR)
        mask = np.zeros_like(strokes.mask)
        mask[y[voters], x[voters]] = 255
        # Hough's normals run from 0 to 180 degrees: a band whose normals wrap round there
        # (lines near vertical) is looked for in the transposed image, where it is not.
        flip = abs(((way + 90) % 180) - 90) > 90 - _BAND_HALF
        if flip:
            mask = np.ascontiguousarray(mask.T)
        normal = math.radians(((90 - way if flip else way) + 90) % 180)
        found = cv2.HoughLinesWithAccumulator(
            mask,
            2,
            math.pi / 180,
            votes,
            min_theta=normal - math.radians(_BAND_HALF),
            max_theta=normal + math.radians(_BAND_HALF) + 1e-6,
        )  # 2 px, 1 degree
        if found is None:
            continue
        band = found[:_MAX_HOUGH, 0, :].tolist()
        if flip:  # back from the transposed image: x and y swap, theta mirrors
            band = [_untransposed(rho, theta, count) for rho, theta, count in band]
        kept += _distinct(band, strokes.mask.shape, _MAX_LINES_PER_BAND)
    kept.sort(key=lambda line: -line[2])
    # Neighbouring bands overlap: a line found in both is kept once, with its larger vote.
    return _distinct([list(line) for line in kept], strokes.mask.shape, _MAX_LINES)


def _any_crossing(lines: list[tuple[float, float, float]]) -> bool:
    """Whether any two of the lines cross near a right angle, as a grid's do. (Lines found in
    one direction only are a desk's grain or the edge of something, not yet a grid.)"""
    theta = np.array([line[1] for line in lines])
    crossing = np.abs(_angle_between(theta[:, None], theta[None, :]) - math.pi / 2)
    return bool((crossing <= _CROSSING).any())


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


def _intersect(l1: Line, l2: Line) -> np.ndarray | None:
    point = _crossing(l1, l2)
    return None if point is None else np.array(point)


def _crossing(l1: Line, l2: Line) -> tuple[float, float] | None:
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


def _best_grid(
    lines: list[tuple[float, float, float]],
    strokes: _Strokes,
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
            (_angle_between(theta[first], theta[second]) < _PARALLEL)
            & (spacing >= min_spacing)
            & (spacing <= max_spacing)
        )
        return first[ok], second[ok]

    # The grid may be turned any way: every pair with every later pair that crosses it near
    # a right angle (`_order` then tells which pair runs down the sheet).
    va, vb = pairs(np.arange(len(lines)))
    ha, hb = va, vb
    crossing = np.abs(_angle_between(theta[va][:, None], theta[ha][None, :]) - math.pi / 2)
    p, q = np.nonzero(np.triu(crossing <= _CROSSING, 1))
    # The grid's lines are the longest in view: try the best-voted quadruples first, and only
    # so many of them, so that a cluttered sheet cannot blow the time budget.
    total = votes[va[p]] + votes[vb[p]] + votes[ha[q]] + votes[hb[q]]
    tried = np.argsort(-total, kind="stable")[:_MAX_GRIDS]
    tried_fours = [
        _order((lines[va[p[k]]], lines[vb[p[k]]]), (lines[ha[q[k]]], lines[hb[q[k]]]))
        for k in tried
    ]
    fours, lattices, totals = [], [], []
    for k, four, lattice in zip(
        tried, tried_fours, _lattices(tried_fours, 0.8 * min_spacing), strict=True
    ):
        if lattice is not None:
            fours.append(four)
            lattices.append(lattice)
            totals.append(float(total[k]))
    passed: list[tuple[float, Four]] = []
    if lattices:
        support, middle, closeness = _line_support(np.array(lattices), strokes)
        ok = (
            (support.min(axis=1) >= _MIN_SUPPORT)
            & (support.mean(axis=1) >= _MIN_MEAN_SUPPORT)
            & (middle.min(axis=1) >= _MIN_MIDDLE_SUPPORT_UNFITTED)
        )
        passed = [(float(closeness[k]) + 1e-4 * totals[k], fours[k]) for k in np.flatnonzero(ok)]
    # A Hough line a few degrees off a wobbly grid line can score below a line that grazes
    # several symbols; fitted to the ink, the grid's real lines win. So the leaders are
    # refitted once and judged again.
    fitted_fours, lattices = [], []
    for _, four in sorted(passed, key=lambda x: -x[0])[:_FINALISTS]:
        fitted = _refine(four, strokes.pixels, strokes.ways, bands=(0.15,))
        lattice = _lattice(*fitted, min_side=0.8 * min_spacing)
        if lattice is not None:
            fitted_fours.append(fitted)
            lattices.append(lattice)
    best: tuple[float, Four] | None = None
    if lattices:
        _, middle, closeness = _line_support(np.array(lattices), strokes)
        for k, fitted in enumerate(fitted_fours):
            if middle[k].min() >= _MIN_MIDDLE_SUPPORT and (best is None or closeness[k] > best[0]):
                best = (float(closeness[k]), fitted)
    return None if best is None else (best[1], best[0])


def _order(p: tuple, q: tuple) -> Four:
    """Two pairs of lines as (left, right, top, bottom)."""
    # The pair whose normals point more along x holds the vertical lines. All four lines are
    # weighed: near 45 degrees in perspective one line of a pair can lean past it alone.
    if _uprightness(q, p) > _uprightness(p, q):
        p, q = q, p
    mid = _crossing(p[0][:2], q[0][:2]) or (0.0, 0.0)

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


def _lattice(
    left: Line, right: Line, top: Line, bottom: Line, min_side: float = 1.0
) -> np.ndarray | None:
    """The (4, 4, 2) lattice of cell corners of four lines, or None if they make no grid."""
    inner = [_crossing(v, hz) for hz in (top, bottom) for v in (left, right)]
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
    return _extend(inner)


def _lattices(fours: list[Four], min_side: float) -> list[np.ndarray | None]:
    """`_lattice` of each of many quadruples of lines at once (numpy's cost per call, not per
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

    # Left 0, right 1, top 2, bottom 3: crossings a, b (top), c, d (bottom), as `_lattice`.
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
    return [_extend([a[k], b[k], cc[k], d[k]]) if ok[k] else None for k in range(len(fours))]


_RATIO_LOW = np.array([0.6, 0.6, 0.5], np.float32)
_RATIO_HIGH = np.array([1 / 0.6, 1 / 0.6, 2], np.float32)


def _extend(inner: list) -> np.ndarray:
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


def _line_frames(lattice: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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


def _line_support(
    lattices: np.ndarray, strokes: _Strokes
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each of a stack of lattices (C, 4, 4, 2): the share of each of its four lines along
    which ink is found (C, 4), the same along the middle cell only (C, 4), and how close to
    the lines the ink lies, 0-1 (C,), all over the lines' stretches in the frame. Only ink
    whose stroke runs the line's way counts: a line
    through a symbol crosses its strokes. (All candidates at once: numpy's cost per call,
    not per point, dominates.)"""
    ink = strokes.mask
    a, d, n, size = _line_frames(lattices)
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
    enough = (in_view >= _MIN_IN_VIEW) & (middle_in_view >= _MIN_MIDDLE_IN_VIEW)
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


@dataclass(frozen=True)
class _Strokes:
    """The ink of the work image, and which way its strokes run at each pixel."""

    mask: np.ndarray
    """uint8 (H, W) ink mask, 0/255."""
    pixels: np.ndarray
    """(N, 2) float x, y of the ink pixels, row by row."""
    ways: np.ndarray
    """(N,) int16: the direction of each ink pixel's stroke (`direction` at `pixels`)."""
    direction: np.ndarray
    """uint8 (H, W): at each ink pixel, the direction its stroke runs in whole degrees
    (0-179, 0 along x), or `_UNCLEAR` where the stroke is not clear-cut (a crossing, a
    blob). Every ink pixel is looked at: all of them vote for lines."""

    @classmethod
    def of(cls, small: np.ndarray, ink: np.ndarray) -> _Strokes:
        # The structure tensor: gradients run across a stroke, so its direction is their normal.
        f = small.astype(np.float32)
        gx = cv2.Sobel(f, cv2.CV_32F, 1, 0, ksize=3)
        gy = cv2.Sobel(f, cv2.CV_32F, 0, 1, ksize=3)
        jxx = cv2.boxFilter(gx * gx, -1, (5, 5))
        jyy = cv2.boxFilter(gy * gy, -1, (5, 5))
        jxy = cv2.boxFilter(gx * gy, -1, (5, 5))
        found = cv2.findNonZero(ink)  # as np.nonzero's order, several times faster
        xy = np.zeros((0, 2), np.intp) if found is None else found.reshape(-1, 2)
        x, y = xy[:, 0], xy[:, 1]
        xx, yy, xy_part = jxx[y, x], jyy[y, x], jxy[y, x]
        clear = np.hypot(xx - yy, 2 * xy_part) >= _MIN_CLEARNESS * np.maximum(xx + yy, 1e-3)
        degrees = np.degrees(0.5 * np.arctan2(-2 * xy_part, yy - xx))  # -90 to 90
        # Modulo 180, without numpy's slow float modulo: these are at most half a turn off.
        degrees[degrees < 0] += 180
        whole = np.round(degrees)
        whole[whole == 180] = 0
        direction = np.full(ink.shape, _UNCLEAR, np.uint8)
        ways = np.where(clear, whole, _UNCLEAR).astype(np.int16)
        direction[y, x] = ways
        return cls(ink, xy.astype(np.float64), ways, direction)

    def runs_along(self, x: np.ndarray, y: np.ndarray, way: np.ndarray) -> np.ndarray:
        """Whether the strokes at ink pixels (x, y) run within `_AGREE` degrees of `way`
        (degrees), or are too unclear to say."""
        seen = self.direction[y, x]
        off = np.abs(seen - way)  # 0-180 for directions 0-179 and `way` 0-180
        return (np.minimum(off, 180 - off) <= _AGREE) | (seen == _UNCLEAR)


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
    """(4, N): whether each stroke direction of `ways` (degrees, `_UNCLEAR` for unclear ones,
    which count) runs within `_AGREE` degrees of each of the lattice's four lines. A line
    fitted to ink near a crossing must not be pulled round by the other line's ink."""
    _, d, _, _ = _line_frames(lattice)
    line_way = np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 180
    off = np.abs(ways[None, :] - line_way[:, None])
    return (np.minimum(off, 180 - off) <= _AGREE) | (ways[None, :] == _UNCLEAR)


def _pixels_near(
    four: Four, pixels: np.ndarray, ways: np.ndarray, band: float
) -> tuple[np.ndarray, np.ndarray]:
    """The pixels within `band` cells of any of the four lines (see `_near_lines`), and the
    directions of their strokes."""
    lattice = _lattice(*four)
    if lattice is None:
        return pixels, ways
    keep = _near_lines(lattice, pixels, band).any(axis=0)
    return pixels[keep], ways[keep]


def _refine(
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
        lattice = _lattice(*four)
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


_LOCAL_REACH = 0.35  # cells along each line either side of a crossing fitted to find it
_CROSSING_ROUNDS = 3  # rounds of finding the crossings, each from the last one's lattice


def _local_crossings(
    four: Four, lattice: np.ndarray, pixels: np.ndarray, ways: np.ndarray
) -> np.ndarray:
    """The lattice rebuilt on where the lines really cross: a hand-drawn line bends, so each
    crossing is found from the two lines fitted within a third of a cell of it, first along
    the straight lines, then, for a few rounds, along the lines through the last crossings."""
    straight = lattice
    for _ in range(_CROSSING_ROUNDS):
        moved = _crossings_near(four, lattice, pixels, ways)
        if moved is None:
            break  # the local fits disagree with the lines: keep the last crossings
        lattice = moved
    return _bend_outer(lattice, pixels, ways, straight)


def _crossings_near(
    four: Four, lattice: np.ndarray, pixels: np.ndarray, ways: np.ndarray
) -> np.ndarray | None:
    """One round of `_local_crossings`: the lattice on the crossings of the lines fitted to
    the ink near each of its crossings, or None where one moves more than a quarter cell."""
    along, near, size = _along_lines(lattice, pixels)
    near &= _running_along(lattice, ways)
    around = (  # near each line's first crossing, and its second
        near & (np.abs(along) < _LOCAL_REACH),
        near & (np.abs(along - 1) < _LOCAL_REACH),
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
    return _extend(inner)


def _along_across(lattice: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Where each pixel of (N, 2) lies along each of the four lines, in cells from its first
    crossing (4, N); how far across each line it lies, in pixels (4, N); the mean cell size.
    (Line by line in rows: each line's pixels are then picked out of one contiguous row.)"""
    a, d, n, size = _line_frames(lattice)
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


IN_VIEW = 0.5
"""A cell is read when this share of its middle (the square from 0.2 to 0.8 of its sides,
where a symbol is drawn) lies in the frame; further out it is reported out of view. Half, not
more: the outer cells are extrapolated one middle cell along the lines, and may reach a
third of a cell further out than drawn, under perspective most of all."""
_MIDDLE_SAMPLES = np.linspace(0.2, 0.8, 7)


def _cells_in_view(lattice: np.ndarray, width: int, height: int) -> tuple[bool, ...]:
    """`Grid.in_view` of a lattice (4, 4, 2) in a frame this size."""
    u, v = np.meshgrid(_MIDDLE_SAMPLES, _MIDDLE_SAMPLES)
    seen = []
    for r in range(SIZE):
        for c in range(SIZE):
            q = lattice[r : r + 2, c : c + 2]  # the cell's corners, bilinear between them
            top = q[0, 0] + u[..., None] * (q[0, 1] - q[0, 0])
            bottom = q[1, 0] + u[..., None] * (q[1, 1] - q[1, 0])
            x, y = np.moveaxis(top + v[..., None] * (bottom - top), -1, 0)
            inside = (x >= 0) & (x <= width - 1) & (y >= 0) & (y <= height - 1)
            seen.append(bool(inside.mean() >= IN_VIEW))
    return tuple(seen)
