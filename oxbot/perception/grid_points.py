"""The learned grid finder: the network's heatmaps turned into the grid's lattice.

`LearnedGridFinder.find(frame)` does what `grid.find_grid` does, by learning instead of line
grouping: the frame is shrunk to `INPUT_SIDE` on its long side and `GridPointNet` predicts
heatmaps of the grid's crossings, outer points and lines. The crossings' peaks are located to
a fraction of a heatmap pixel; among them the likeliest middle cell is chosen, its sides and the
lines past its corners checked against the line heatmap (a corner the net missed may be
completed from the other three), and ordered by where its corners lie (clockwise from the upper
left, the grid's turn within ±45 degrees). Each drawn line is extended past its crossings by the
middle cell's side, as the classical finder extends along its lines, and a line's end moves to
the outer heatmap's peak where the net is sure of one (a line drawn longer or bent).

The shipped weights (`data/models/grid_points.pt`) carry their checksum, the config and seed
they were trained from, and their figures; `oxbot train reader` makes them from nothing.
"""

from __future__ import annotations

import functools
import importlib.resources
import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import torch

from oxbot import artifacts
from oxbot.errors import NoGridFound
from oxbot.game.board import SIZE
from oxbot.perception.frame import as_image
from oxbot.perception.grid import Grid, cells_in_view
from oxbot.perception.grid_model import CROSSINGS, INPUT_SIDE, LINES, OUTER, STRIDE, GridPointNet

KIND, VERSION = "grid_points", 1
REMEDY = "train one with `oxbot train reader`, or reinstall oxbot for the shipped one"
MULTIPLE = 32
"""The network halves its picture 5 times: each side a multiple of this."""
PEAK_FLOOR = 0.05
"""A heatmap's local maximum weaker than this (sigmoid) is no peak."""


@dataclass(frozen=True)
class PeakTuning:
    """How heatmap peaks become points."""

    candidates: int = 8
    """The strongest peaks among which the middle cell's 4 corners are sought."""
    min_crossing: float = 0.2
    """The middle cell's 4 corners must be at least this sure on average."""
    min_line: float = 0.6
    """At least this share of the middle cell's sides must lie on drawn lines."""
    max_side_ratio: float = 2.5
    """A middle cell whose longest side is more than this times its shortest is a sliver."""
    min_outer: float = 0.6
    """An outer point's peak, at least this sure, moves the extended line's end to it."""
    outer_reach: float = 0.35
    """How far from the extended line's end an outer peak is looked for, in cells."""
    min_presence: float = 0.5
    """Below this "board present" probability the frame holds no grid."""
    min_side: float = 2.0
    """The inner cell's sides must be at least this many heatmap pixels long."""


PEAKS = PeakTuning()

# the inner crossings in cell units, in the order the peaks are sorted: clockwise from the
# upper left, as image coordinates (y down) turn
_INNER = np.array([[1, 1], [2, 1], [2, 2], [1, 2]], np.float32)
_INNER_ANGLES = np.radians([-135.0, -45.0, 45.0, 135.0])


def shipped_path() -> Path:
    """Where the grid-point model that ships with oxbot lives."""
    return Path(str(importlib.resources.files("oxbot") / "data" / "models" / "grid_points.pt"))


def picture_of(frame: np.ndarray) -> tuple[np.ndarray, float]:
    """The network's picture of `frame`: float32 (3, H, W) in [0, 1], the long side
    INPUT_SIDE, each side padded to a multiple of 32; and the frame pixels per picture pixel."""
    image = as_image(frame)
    if image.ndim == 2:
        image = cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    h, w = image.shape[:2]
    scale = max(h, w) / INPUT_SIDE
    size = (max(1, round(w / scale)), max(1, round(h / scale)))
    small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    padded = np.zeros((_up(size[1]), _up(size[0]), 3), np.uint8)
    padded[: size[1], : size[0]] = small
    return np.ascontiguousarray(padded.transpose(2, 0, 1), np.float32) / 255.0, scale


def _up(n: int) -> int:
    return -(-n // MULTIPLE) * MULTIPLE


def peaks(heat: np.ndarray, count: int) -> list[tuple[float, float, float]]:
    """The `count` strongest local maxima of a heatmap of probabilities (H, W), each as
    (x, y, value), x and y to a fraction of a pixel: the top of a parabola through the log of
    the peak and its two neighbours each way (exact for a Gaussian peak)."""
    dilated = cv2.dilate(heat, np.ones((3, 3), np.uint8))
    ys, xs = np.nonzero((heat >= dilated) & (heat > PEAK_FLOOR))
    order = np.argsort(-heat[ys, xs])[:count]
    logs = np.log(np.clip(heat, 1e-6, None))
    found = []
    for y, x in zip(ys[order], xs[order], strict=True):
        dx = _vertex(logs[y, x - 1 : x + 2]) if 0 < x < heat.shape[1] - 1 else 0.0
        dy = _vertex(logs[y - 1 : y + 2, x]) if 0 < y < heat.shape[0] - 1 else 0.0
        found.append((float(x + dx), float(y + dy), float(heat[y, x])))
    return found


def _vertex(three: np.ndarray) -> float:
    """Where a parabola through three values at -1, 0, 1 peaks, within half a step."""
    left, middle, right = (float(v) for v in three)
    curvature = left - 2 * middle + right
    if curvature >= 0:
        return 0.0
    return float(np.clip((left - right) / (2 * curvature), -0.5, 0.5))


def order_crossings(points: np.ndarray) -> np.ndarray:
    """The 4 crossings (4, 2) as the lattice's (1,1), (2,1), (2,2), (1,2): sorted clockwise
    round their centre, starting where the grid's turn is smallest (within ±45 degrees)."""
    centre = points.mean(axis=0)
    angles = np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0])
    clockwise = points[np.argsort(angles)]
    sorted_angles = np.sort(angles)

    def turn(shift: int) -> float:
        diff = np.roll(sorted_angles, -shift) - _INNER_ANGLES
        wrapped = (diff + math.pi) % (2 * math.pi) - math.pi
        return float(np.abs(np.angle(np.exp(1j * wrapped).mean())))

    best = min(range(4), key=turn)
    return np.roll(clockwise, -best, axis=0)


def lattice_from(
    crossings: np.ndarray, outer_heat: np.ndarray | None, tuning: PeakTuning = PEAKS
) -> np.ndarray:
    """The 4x4 lattice (heatmap pixels) from the ordered crossings: each drawn line extended
    by its middle cell's side past each crossing, the corners completing parallelograms (as
    the classical finder extends along the lines); an outer point is moved to the outer
    heatmap's peak near it, where the net is sure of one (a line drawn longer or bent)."""
    lattice = np.zeros((SIZE + 1, SIZE + 1, 2))
    lattice[1, 1], lattice[1, 2], lattice[2, 2], lattice[2, 1] = crossings
    inner = lattice.copy()
    for k in (1, 2):
        lattice[0, k] = 2 * inner[1, k] - inner[2, k]
        lattice[3, k] = 2 * inner[2, k] - inner[1, k]
        lattice[k, 0] = 2 * inner[k, 1] - inner[k, 2]
        lattice[k, 3] = 2 * inner[k, 2] - inner[k, 1]
    if outer_heat is not None:
        _move_to_peaks(lattice, outer_heat, crossings, tuning)
    for r, c, rr, cc in ((0, 0, 1, 1), (0, 3, 1, 2), (3, 0, 2, 1), (3, 3, 2, 2)):
        lattice[r, c] = lattice[r, cc] + lattice[rr, c] - lattice[rr, cc]
    return lattice


def _move_to_peaks(
    lattice: np.ndarray, outer_heat: np.ndarray, crossings: np.ndarray, tuning: PeakTuning
) -> None:
    """Each line's end moved to the outer heatmap's surest peak within reach, if sure enough."""
    cell = float(np.linalg.norm(crossings - np.roll(crossings, 1, axis=0), axis=1).mean())
    reach = max(1.0, tuning.outer_reach * cell)
    h, w = outer_heat.shape
    for r, c in ((0, 1), (0, 2), (3, 1), (3, 2), (1, 0), (2, 0), (1, 3), (2, 3)):
        x, y = lattice[r, c]
        x0, x1 = int(max(0, math.floor(x - reach))), int(min(w, math.ceil(x + reach) + 1))
        y0, y1 = int(max(0, math.floor(y - reach))), int(min(h, math.ceil(y + reach) + 1))
        if x0 >= x1 or y0 >= y1:
            continue  # out of the picture: the extended line's point it is
        found = peaks(outer_heat[y0:y1, x0:x1], 1)
        if found and found[0][2] >= tuning.min_outer:
            px, py, _ = found[0]
            if math.hypot(px + x0 - x, py + y0 - y) <= reach:
                lattice[r, c] = (px + x0, py + y0)


def best_crossings(
    found: np.ndarray, lines: np.ndarray, tuning: PeakTuning = PEAKS
) -> tuple[np.ndarray, float] | None:
    """The 4 of the crossing peaks `found` (K, 3) that make the likeliest middle cell, ordered,
    with how sure that is (0-1); None if no 4 make one. A middle cell is convex, no sliver,
    its corners sure enough on average, and its 4 sides drawn lines: the line heatmap `lines`
    must be high along them and past its corners (the net learns lines faster and surer than
    points). A corner the net missed may be completed from the other three (a parallelogram),
    counted as not sure at all: the lines must then vouch for it."""
    candidates = found[: tuning.candidates]
    quads = []
    for four in itertools.combinations(range(len(candidates)), 4):
        quads.append((candidates[list(four), :2], float(candidates[list(four), 2].mean())))
    for three in itertools.combinations(range(len(candidates)), 3):
        points = candidates[list(three), :2]
        sure = float(candidates[list(three), 2].sum() / 4)
        for corner in range(3):  # the corner opposite the missing one
            a, b = (points[k] for k in range(3) if k != corner)
            missing = a + b - points[corner]
            quads.append((np.vstack([points, missing]), sure))
    best, best_score = None, 0.0
    for points, sure in quads:
        if sure < tuning.min_crossing:
            continue
        quad = order_crossings(points)
        sides = np.linalg.norm(quad - np.roll(quad, 1, axis=0), axis=1)
        if sides.min() < tuning.min_side or sides.max() > tuning.max_side_ratio * sides.min():
            continue
        if not _convex(quad):
            continue
        drawn = (_along(lines, quad) + _beyond(lines, quad)) / 2
        score = sure * drawn
        if drawn >= tuning.min_line and score > best_score:
            best, best_score = quad, score
    return None if best is None else (best, best_score)


def _along(lines: np.ndarray, quad: np.ndarray, samples: int = 12) -> float:
    """The share of points along the quadrilateral's sides where the line heatmap says ink."""
    t = np.linspace(0.1, 0.9, samples)[:, None]
    points = np.concatenate(
        [a + t * (b - a) for a, b in zip(quad, np.roll(quad, -1, 0), strict=True)]
    )
    x = np.clip(np.round(points[:, 0]).astype(int), 0, lines.shape[1] - 1)
    y = np.clip(np.round(points[:, 1]).astype(int), 0, lines.shape[0] - 1)
    return float((lines[y, x] > 0.5).mean())


def _beyond(lines: np.ndarray, quad: np.ndarray, reach: float = 0.6, samples: int = 6) -> float:
    """The share of points on drawn lines where the 4 lines run on past the middle cell, by
    `reach` of its side (a #'s lines do; a cross's strokes, or a cell's own corners, do not);
    points outside the picture are not counted."""
    ends = []
    t = np.linspace(0.15, reach, samples)[:, None]
    for k in range(4):
        here, before, after = quad[k], quad[k - 1], quad[(k + 1) % 4]
        for other in (before, after):  # along each of the two sides meeting here, outwards
            ends.append(here + t * (here - other))
    points = np.concatenate(ends)
    h, w = lines.shape
    inside = (points[:, 0] >= 0) & (points[:, 0] <= w - 1) & (points[:, 1] >= 0)
    inside &= points[:, 1] <= h - 1
    if not inside.any():
        return 0.0
    x, y = np.round(points[inside]).astype(int).T
    return float((lines[y, x] > 0.5).mean())


@dataclass(frozen=True)
class GridPoints:
    """What the network saw in one frame, in frame pixels: for `oxbot see --debug`."""

    grid: Grid | None
    crossings: np.ndarray
    """(K, 3): the strongest crossing peaks found, x, y and how sure."""
    presence: float
    heatmaps: np.ndarray
    """(HEATMAPS, h, w) probabilities at the network's resolution."""


def heatmap_picture(points: GridPoints, frame: np.ndarray) -> np.ndarray:
    """The frame (uint8 RGB) as the network saw it, its heatmaps laid over it: crossings red,
    outer points green, grid lines blue; the crossing peaks ringed, with how sure each is."""
    picture, _ = picture_of(frame)
    base = (picture.transpose(1, 2, 0) * 255).astype(np.float32) * 0.5
    side = (picture.shape[2], picture.shape[1])
    heat = [cv2.resize(points.heatmaps[k], side, interpolation=cv2.INTER_LINEAR) for k in range(3)]
    for channel, k in ((0, CROSSINGS), (1, OUTER), (2, LINES)):
        base[:, :, channel] = np.maximum(base[:, :, channel], heat[k] * 255)
    shown = cv2.resize(np.clip(base, 0, 255).astype(np.uint8), None, fx=2, fy=2)
    scale = 2 * INPUT_SIDE / max(frame.shape[:2])  # frame pixels to the doubled picture's
    for x, y, sure in points.crossings:
        at = (round(x * scale), round(y * scale))
        cv2.circle(shown, at, 7, (255, 255, 0), 1, cv2.LINE_AA)
        cv2.putText(shown, f"{sure:.2f}", at, cv2.FONT_HERSHEY_SIMPLEX, 0.35, (255, 255, 0))
    cv2.putText(shown, f"board present {points.presence:.2f}", (4, 14), 0, 0.45, (255, 255, 255))
    return shown


class LearnedGridFinder:
    """Finds the grid with `GridPointNet`: `find(frame)` gives a `Grid`, as `find_grid` does."""

    def __init__(self, net: GridPointNet, tuning: PeakTuning = PEAKS, info: Any = None) -> None:
        self.net = net.eval()
        self.tuning = tuning
        self.info = info or {}

    @classmethod
    def load(cls, path: str | Path | None = None) -> LearnedGridFinder:
        """The finder of the model at `path` (default: the shipped one), checksum checked."""
        path = Path(path) if path is not None else shipped_path()
        what = "grid-point model"
        payload = artifacts.load(path, KIND, VERSION, what, REMEDY)
        with artifacts.checked(path, what, REMEDY):
            net = GridPointNet(width=int(payload["width"]))
            net.load_state_dict(payload["state_dict"])
        info = {k: v for k, v in payload.items() if k != "state_dict"}
        return cls(net, info=info)

    def look(self, frame: np.ndarray) -> GridPoints:
        """The network's view of `frame`: heatmaps, crossing peaks, and the grid if one is
        found (None if not)."""
        picture, scale = picture_of(frame)
        with torch.inference_mode():
            heat, presence = self.net(torch.from_numpy(picture)[None])
        heatmaps = torch.sigmoid(heat[0]).numpy()
        present = float(torch.sigmoid(presence[0]))
        found = peaks(heatmaps[CROSSINGS], self.tuning.candidates)
        found = np.array(found, np.float64).reshape(-1, 3)
        to_frame = scale * STRIDE
        shown = found.copy()
        shown[:, :2] = (shown[:, :2] + 0.5) * to_frame - 0.5
        grid = self._grid(found, heatmaps, present, frame.shape[:2], to_frame)
        return GridPoints(grid, shown, present, heatmaps)

    def _grid(
        self,
        found: np.ndarray,
        heatmaps: np.ndarray,
        present: float,
        shape: tuple[int, ...],
        to_frame: float,
    ) -> Grid | None:
        if present < self.tuning.min_presence:
            return None
        best = best_crossings(found, heatmaps[LINES], self.tuning)
        if best is None:
            return None
        crossings, support = best
        lattice = lattice_from(crossings, heatmaps[OUTER], self.tuning)
        lattice = (lattice + 0.5) * to_frame - 0.5  # heatmap pixel centres to frame pixels
        h, w = shape[:2]
        return Grid(lattice=lattice, support=support, in_view=cells_in_view(lattice, w, h))

    def find(self, frame: np.ndarray) -> Grid:
        """The 3x3 grid in `frame` (uint8 gray or RGB); NoGridFound when there is none."""
        grid = self.look(frame).grid
        if grid is None:
            raise NoGridFound(
                "no grid in view: the grid finder saw no 3x3 grid (a blank sheet, an empty "
                "desk, or a grid too small or too faint?); draw the 3x3 grid with a dark pen "
                "and keep all of it in the picture"
            )
        return grid


def _convex(quad: np.ndarray) -> bool:
    """Whether the quadrilateral (4, 2), in order, is convex (a grid's inner cell is)."""
    edges = np.roll(quad, -1, axis=0) - quad
    following = np.roll(edges, -1, axis=0)
    turns = edges[:, 0] * following[:, 1] - edges[:, 1] * following[:, 0]
    return bool(np.all(turns > 0) or np.all(turns < 0))


@functools.cache
def learned_finder(path: str | None = None) -> LearnedGridFinder:
    """The finder of the model file `path` (None: the shipped one), loaded once per process:
    the board reader and `see --debug`'s heatmaps share it."""
    return LearnedGridFinder.load(path if path is not None else shipped_path())


def shipped_finder() -> LearnedGridFinder:
    """The shipped finder, loaded once per process."""
    return learned_finder(None)
