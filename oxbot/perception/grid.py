"""Finding the hand-drawn 3x3 grid in a photo: where its 4x4 lattice of cell corners lies.

Paper §3.1 "Game Move Recognition": grayscale → remove the grid → split into 9 images. The
paper's arm camera saw a fixed grid from a fixed pose; here the grid may be anywhere in view,
turned up to 45° (oxbot's goal asks only ±15°) and in perspective, so it is found first, in
stages, each in its own module:

1. *Ink* (`ink.py`): pixels clearly darker than the paper around them in any colour channel,
   on a copy of the frame at most `FINDER.work_side` pixels wide, shrunk so that thin pen
   lines stay dark; and which way each pixel's stroke runs.
2. *Lines* (`lines.py`): the Hough transform proposes straight lines in six bands of
   direction, each band voted for only by ink whose stroke runs its way, so that circles and
   crosses cannot crowd out the grid's lines; the grid is a pair of near-parallel lines and a
   pair crossing it near a right angle, whichever way they are turned, whose ink runs along
   all four, across the whole grid (`lattice.py` checks each candidate's lattice against the
   ink). Hand-drawn lines wobble, overshoot or stop short; the check asks for ink along most
   of each line, and along most of its stretch beside the middle cell.
3. *Fit* (`refit.py`): each of the four lines is refitted to the ink near it that runs its
   way, and each crossing to such ink within a third of a cell of it, three times over, each
   time looking along the lines through the last crossings (a hand-drawn line bends). The
   four crossings and one more cell along each line give a 4x4 lattice of cell corners
   (`Grid`), in *cell units* (inner lines at 1 and 2, cells filling [0, 3]²). Of the pairs,
   the one nearer the frame's vertical holds the columns.

This module owns the search (`find_grid`, the stages read top to bottom) and its result
(`Grid`); the frame's check (`as_image`, `as_gray`) is `frame.py`'s, imported here as well.
`NoGridFound` is raised rather than a guess when no such four lines exist (a blank sheet, an
empty desk). A grid cut by the frame's edge is found as long as its four lines are;
`Grid.in_view` says which cells are too far out of the frame to read. What follows the search
is `rectify.py` (the grid seen from straight above) and `cells.py` (the grid lines painted
over, nine 40x40 cells cut).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from oxbot.errors import NoGridFound
from oxbot.game.board import SIZE
from oxbot.perception.frame import as_gray, as_image
from oxbot.perception.ink import Strokes, ink_mask, shrink_keeping_strokes
from oxbot.perception.lattice import lattice_of
from oxbot.perception.lines import any_crossing, best_grid, hough_lines
from oxbot.perception.refit import local_crossings, pixels_near, refine

__all__ = [
    "FINDER",
    "FinderTuning",
    "Grid",
    "NoGridFound",
    "as_gray",
    "as_image",
    "cells_in_view",
    "find_grid",
]


@dataclass(frozen=True)
class FinderTuning:
    """The search's sizes and the found grid's reading limit."""

    work_side: int = 320
    """Longest side, in pixels, of the copy of the frame the grid is searched in at most (the
    frame is shrunk a whole number of times: 800 pixels to 267, 1280 to 320)."""
    min_grid_share: float = 0.15
    """The grid's side must be at least this share of the frame's shorter side."""
    in_view: float = 0.5
    """A cell is read when this share of its middle (the square from 0.2 to 0.8 of its sides,
    where a symbol is drawn) lies in the frame; further out it is reported out of view. Half,
    not more: the outer cells are extrapolated one middle cell along the lines, and may reach
    a third of a cell further out than drawn, under perspective most of all."""


FINDER = FinderTuning()


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
    """For each cell, row-major: whether its middle is in the frame (`FINDER.in_view`), so that
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


def find_grid(frame: np.ndarray) -> Grid:
    """The hand-drawn 3x3 grid in a frame (uint8 gray or RGB); NoGridFound when there is none.

    The grid may run off the frame: `Grid.in_view` says which cells are seen well enough to
    read. A grid with a cell out of view is still found, so that the reader can say which.
    """
    h, w = frame.shape[:2]
    shrink = math.ceil(max(h, w) / FINDER.work_side)
    scale = 1 / shrink
    small = frame if shrink == 1 else shrink_keeping_strokes(frame, shrink)
    ink, darkness = ink_mask(small)
    # The paper's closing brightens the frame's edge, where the desk then looks like ink.
    ink[:2, :] = ink[-2:, :] = ink[:, :2] = ink[:, -2:] = 0
    short = min(ink.shape)
    min_spacing = FINDER.min_grid_share * short / SIZE
    strokes = Strokes.of(darkness, ink)
    lines = hough_lines(strokes, votes=max(12, int(0.6 * SIZE * min_spacing)))
    if len(lines) < 4 or not any_crossing(lines):
        raise NoGridFound(
            "no grid in view: found no long pen lines crossing (a blank sheet or an empty "
            "desk?); draw the 3x3 grid with a dark pen and keep all of it in the picture"
        )
    center = np.array(ink.shape[::-1], np.float64) / 2
    best = best_grid(lines, strokes, min_spacing, short / 2, center)
    if best is None:
        raise NoGridFound(
            "no 3x3 grid in view: I see lines, but not the four lines of a whole grid; keep "
            "all of the grid in the picture"
        )
    four, support = best
    # The fits below look only at ink near the four lines, a small part of all the ink.
    pixels, ways = pixels_near(four, strokes.pixels, strokes.ways, band=0.3)
    refined = refine(four, pixels, ways)
    lattice = lattice_of(*refined)
    if lattice is None:
        lattice = lattice_of(*four)
    else:
        lattice = local_crossings(refined, lattice, pixels, ways)
    assert lattice is not None
    lattice = lattice / scale
    return Grid(lattice=lattice, support=support, in_view=cells_in_view(lattice, w, h))


# The points of a cell's middle (0.2 to 0.8 of its sides) that `FINDER.in_view` counts.
_MIDDLE_SAMPLES = np.linspace(0.2, 0.8, 7)


def cells_in_view(lattice: np.ndarray, width: int, height: int) -> tuple[bool, ...]:
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
            seen.append(bool(inside.mean() >= FINDER.in_view))
    return tuple(seen)
