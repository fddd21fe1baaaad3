"""Where things lie in a grid scene: the hand-drawn grid on its sheet, its cell corners, the camera.

The sheet is a plane measured in the grid's cell units, the nominal grid filling [0, 3]^2. A
hand-drawn line (`HandLine`) is a function across its direction of the distance along it: an
offset, a tilt, a bow and a few waves. The lattice of cell corners (`plane_lattice`) follows
the lines exactly: its inner four points are where the lines' centres cross; its outer points
lie on each line one middle cell further along it (the cell measured along the line, on the
sheet); its corners complete parallelograms. The camera (`camera_view`) is a homography from
the plane to the image: a pinhole camera tilted out of the sheet's plane, then the picture
turned, scaled and shifted so that the grid lies at the asked angle, size and place.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from oxbot.perception.scene_ink import NEAREST_DEPTH, project

LINE_TILT_DEG = 5.0
"""Each drawn line is tilted by up to this from its nominal direction."""
MAX_BOW = 0.06
"""A line bows by up to this share of a cell at its middle (a stroke drawn from the wrist)."""
MAX_WAVE = 0.012
"""Each of a line's slow waves is up to this share of a cell high."""
CELL_ASPECT = (0.75, 1.3)
"""The middle cell's width over its height."""
LINE_ENDS = (-0.55, 0.35)
"""How far past the outer cell edge a line ends, in cells: negative stops short."""
GAP_SHARE = 0.15
"""Share of grids whose pen left a small gap in one line where it crosses another."""
FOV_DEG = (50.0, 75.0)
"""The camera's horizontal field of view."""
MAX_TILT_DEG = 35.0
"""The camera's axis is up to this far from the sheet's normal."""
OUT_OF_FRAME = 1 / 3
"""An outer cell corner may lie up to this share of a cell out of the picture."""


@dataclass(frozen=True)
class HandLine:
    """One drawn line: across = offset + tilt, bow and waves as functions of the distance along."""

    vertical: bool
    """True: x is a function of y (a column line); False: y a function of x."""
    offset: float
    slope: float
    bow: float
    waves: tuple[tuple[float, float, float], ...] = ()
    """(height, cycles per cell, phase) of each slow wave."""

    def across(self, t: np.ndarray | float) -> np.ndarray:
        """The line's position across its direction at distance `t` along it (cell units)."""
        t = np.asarray(t, np.float64)
        u = (t - 1.5) / 1.5
        v = self.offset + self.slope * (t - 1.5) + self.bow * (1 - u * u)
        for height, cycles, phase in self.waves:
            v = v + height * np.sin(2 * np.pi * cycles * t + phase)
        return v

    def points(self, t: np.ndarray) -> np.ndarray:
        """(N, 2) plane points at distances `t` along the line."""
        t = np.asarray(t, np.float64)
        v = self.across(t)
        return np.stack([v, t] if self.vertical else [t, v], axis=-1)


@dataclass(frozen=True)
class DrawnGrid:
    """A grid as drawn on the sheet: four lines, the stretches the pen inked, the lattice."""

    lines: tuple[HandLine, HandLine, HandLine, HandLine]
    """Left and right (vertical), then top and bottom."""
    stretches: tuple[tuple[tuple[float, float], ...], ...]
    """For each line, the pieces (start, end) along it that carry ink (two where it has a gap)."""
    lattice: np.ndarray
    """float64 (4, 4, 2) plane points of the cell corners."""


def random_line(rng: np.random.Generator, vertical: bool, offset: float, steady: bool) -> HandLine:
    """A line near `offset`, tilted, bowed and wavy as a hand draws it (straight if `steady`)."""
    if steady:
        return HandLine(vertical, offset, 0.0, 0.0)
    slope = math.tan(math.radians(rng.uniform(-LINE_TILT_DEG, LINE_TILT_DEG)))
    bow = rng.uniform(-MAX_BOW, MAX_BOW) * rng.random()
    cycles = rng.uniform(0.3, 2.5, size=int(rng.integers(1, 4)))
    # A hand wanders slowly more than it shakes: the faster the wave, the lower.
    waves = tuple(
        (rng.uniform(0, MAX_WAVE) / max(1.0, c), c, rng.uniform(0, 2 * np.pi)) for c in cycles
    )
    tremor = (rng.uniform(0, 0.003), rng.uniform(4, 8), rng.uniform(0, 2 * np.pi))
    return HandLine(vertical, offset, slope, bow, (*waves, tremor))


def plane_lattice(lines: tuple[HandLine, HandLine, HandLine, HandLine]) -> np.ndarray:
    """The (4, 4, 2) cell corners of four lines (left, right, top, bottom) on the plane.

    The crossings: each line moves less than half a cell across per cell along (tilt, bow
    and waves are small), so alternating between a row line and a column line converges
    fast, all four crossings at once.
    """
    left, right, top, bottom = lines
    x = np.array([[left.offset, right.offset]] * 2)  # [row line, column line]
    y = np.array([[top.offset] * 2, [bottom.offset] * 2])
    for _ in range(8):
        y = np.stack([top.across(x[0]), bottom.across(x[1])])
        x = np.stack([left.across(y[:, 0]), right.across(y[:, 1])], axis=1)
    q = np.zeros((4, 4, 2))
    q[1:3, 1:3] = np.stack([x, y], axis=-1)
    for k, column in ((1, left), (2, right)):  # along each column line, by y
        y1, y2 = q[1, k, 1], q[2, k, 1]
        q[0, k], q[3, k] = column.points(np.array([2 * y1 - y2, 2 * y2 - y1]))
    for j, row in ((1, top), (2, bottom)):  # along each row line, by x
        x1, x2 = q[j, 1, 0], q[j, 2, 0]
        q[j, 0], q[j, 3] = row.points(np.array([2 * x1 - x2, 2 * x2 - x1]))
    for j, jn in ((0, 1), (3, 2)):
        for k, kn in ((0, 1), (3, 2)):
            q[j, k] = q[j, kn] + q[jn, k] - q[jn, kn]
    return q


def random_grid(rng: np.random.Generator, printed: bool = False) -> DrawnGrid:
    """A hand-drawn grid (or a printed one: straight, square, ending at the outer cell edges)."""
    aspect = 1.0 if printed else rng.uniform(*CELL_ASPECT)
    width, height = math.sqrt(aspect), 1 / math.sqrt(aspect)
    lines = (
        random_line(rng, True, 1.5 - width / 2, printed),
        random_line(rng, True, 1.5 + width / 2, printed),
        random_line(rng, False, 1.5 - height / 2, printed),
        random_line(rng, False, 1.5 + height / 2, printed),
    )
    lattice = plane_lattice(lines)
    gap = None
    if not printed and rng.random() < GAP_SHARE:
        gap = (int(rng.integers(4)), int(rng.integers(2)), rng.uniform(0.04, 0.12))
    stretches = []
    for index in range(4):
        # Where the line crosses the other two, as distances along it.
        along = lattice[1:3, 1 + index % 2, 1] if index < 2 else lattice[1 + index % 2, 1:3, 0]
        cell = along[1] - along[0]
        ends = (0.0, 0.0) if printed else rng.uniform(*LINE_ENDS, size=2)
        start, end = along[0] - cell * (1 + ends[0]), along[1] + cell * (1 + ends[1])
        if gap is not None and gap[0] == index:
            middle, half = along[gap[1]], gap[2] * cell
            stretches.append(((start, middle - half), (middle + half, end)))
        else:
            stretches.append(((start, end),))
    return DrawnGrid(lines, tuple(stretches), lattice)


def line_strokes(line: HandLine, stretches: tuple[tuple[float, float], ...]) -> list[np.ndarray]:
    """The plane polylines of a line's inked stretches, a point every 1/50 of a cell."""
    return [line.points(np.linspace(a, b, max(2, int(abs(b - a) * 50) + 1))) for a, b in stretches]


def _camera(focal: float, tilt: float, axis: float, unit: float) -> np.ndarray:
    """Plane (centred, cell units) to image (relative to the principal point) of a pinhole
    camera at distance 1 whose axis is `tilt` radians from the plane's normal about `axis`."""
    k = np.array([math.cos(axis), math.sin(axis), 0.0])
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    turn = np.eye(3) + math.sin(tilt) * cross + (1 - math.cos(tilt)) * cross @ cross
    plane_to_camera = np.column_stack([turn[:, 0] * unit, turn[:, 1] * unit, [0, 0, 1]])
    return np.diag([focal, focal, 1.0]) @ plane_to_camera


def _similarity(scale: float, angle: float, shift: np.ndarray | None = None) -> np.ndarray:
    c, s = scale * math.cos(angle), scale * math.sin(angle)
    tx, ty = (0.0, 0.0) if shift is None else shift
    return np.array([[c, -s, tx], [s, c, ty], [0, 0, 1.0]])


def _quad_area(q: np.ndarray) -> float:
    corners = np.array([q[0, 0], q[0, 3], q[3, 3], q[3, 0]])
    x, y = corners[:, 0], corners[:, 1]
    return 0.5 * abs(float(x @ np.roll(y, -1) - y @ np.roll(x, -1)))


def _folded_angle(v: np.ndarray) -> float:
    """A direction's angle from the horizontal, 0-90 degrees, either way."""
    return math.degrees(math.atan2(abs(v[1]), abs(v[0])))


def row_direction(lattice: np.ndarray) -> np.ndarray:
    """The mean direction of a (4, 4, 2) lattice's rows, from column 0 to column 3."""
    return (lattice[:, 3] - lattice[:, 0]).mean(axis=0)


def _placement(
    rng: np.random.Generator,
    q: np.ndarray,
    size: tuple[int, int],
    out_side: int | None,
    reach: float,
) -> np.ndarray | None:
    """A shift putting the image lattice `q` in the frame: its outer corners at most `reach`
    of a cell out, or the whole outer row `out_side` (0 top, 1 bottom, 2 left, 3 right) free
    to leave; None when no shift does."""
    rows = np.linalg.norm(np.diff(q, axis=0), axis=2)  # (3, 4)
    cols = np.linalg.norm(np.diff(q, axis=1), axis=2)  # (4, 3)
    cell = np.full((4, 4), np.inf)
    cell[:3] = np.minimum(cell[:3], rows)
    cell[1:] = np.minimum(cell[1:], rows)
    cell[:, :3] = np.minimum(cell[:, :3], cols)
    cell[:, 1:] = np.minimum(cell[:, 1:], cols)
    allow = cell * reach
    allow[1:3, 1:3] = -1.0  # the crossings stay in the picture
    if out_side is not None:
        outer = [np.s_[0, :], np.s_[3, :], np.s_[:, 0], np.s_[:, 3]][out_side]
        inner = [np.s_[1, 1:3], np.s_[2, 1:3], np.s_[1:3, 1], np.s_[1:3, 2]][out_side]
        allow[outer] = np.inf
        allow[inner] = -0.1 * cell[inner]
    limit = np.array(size, np.float64) - 1
    p, a = q.reshape(-1, 2), allow.reshape(-1, 1)
    low, high = (-a - p).max(axis=0), (limit + a - p).min(axis=0)
    if (low > high).any():
        return None
    shift = rng.uniform(low, high)
    if out_side is not None:  # push the outer row out of the picture
        outward = q[outer].mean(axis=0) - q[inner].mean(axis=0)
        axis = int(np.argmax(np.abs(outward)))
        slack = rng.uniform(0, 0.25) * (high[axis] - low[axis])
        shift[axis] = low[axis] + slack if outward[axis] < 0 else high[axis] - slack
    return shift


def camera_view(
    rng: np.random.Generator,
    lattice: np.ndarray,
    size: tuple[int, int],
    side: float,
    rotation: float,
    out_side: int | None = None,
) -> np.ndarray:
    """The plane-to-image homography (3x3) of a camera that sees `lattice` (plane, (4, 4, 2)).

    The grid's side (the square root of its outer quadrilateral's area) is `side` pixels, or
    less when that does not fit; its rows run at `rotation` degrees (their mean direction);
    it lies anywhere in the `size` (width, height) picture, its outer corners up to a random
    share of `OUT_OF_FRAME` of a cell out of it, or with the whole outer row `out_side` free
    to leave (`_placement`). The camera is tilted by up to `MAX_TILT_DEG`, less when a strong
    tilt would make the columns run nearer the horizontal than the rows. The third row of the
    homography is the depth: 1 at the grid's centre.
    """
    centre = lattice.reshape(-1, 2).mean(axis=0)
    to_centre = np.array([[1, 0, -centre[0]], [0, 1, -centre[1]], [0, 0, 1.0]])
    for attempt in range(12):
        # A strong tilt, or a skewed grid near 45 degrees, may turn the columns nearer the
        # horizontal than the rows; then try another tilt, then none, then a smaller turn.
        tilt = math.radians(rng.uniform(0, MAX_TILT_DEG)) if attempt < 6 else 0.0
        angle = math.radians(rotation) * (1 - 0.1 * max(0, attempt - 6))
        focal = size[0] / 2 / math.tan(math.radians(rng.uniform(*FOV_DEG)) / 2)
        seen = _camera(focal, tilt, rng.uniform(0, 2 * np.pi), side / 3 / focal) @ to_centre
        q, _ = project(seen, lattice.reshape(-1, 2))
        q = q.reshape(4, 4, 2)
        row = row_direction(q)
        turn = angle - math.atan2(row[1], row[0])
        h = _similarity(side / math.sqrt(_quad_area(q)), turn) @ seen
        q = project(h, lattice.reshape(-1, 2))[0].reshape(4, 4, 2)
        columns = (q[3] - q[0]).mean(axis=0)
        if _folded_angle(columns) <= _folded_angle(row_direction(q)) + 1.0:
            continue
        reach = OUT_OF_FRAME * rng.random()  # from wholly in the frame to a third of a cell out
        for _ in range(20):
            shift = _placement(rng, q, size, out_side, reach)
            if shift is not None:
                return _similarity(1.0, 0.0, shift) @ h
            h = _similarity(0.9, 0.0) @ h  # too big to fit at this angle: smaller
            q = q * 0.9
    raise AssertionError(
        "an untilted grid turned by less than 20 degrees always fits"
    )  # pragma: no cover


def view_box(h: np.ndarray, size: tuple[int, int], margin: float = 0.1) -> np.ndarray | None:
    """The plane's (x0, y0, x1, y1) box that holds all the camera sees of it (and `margin` of the
    picture's size around it), or None when the picture holds the plane's horizon."""
    w, hh = size
    x0, y0, x1, y1 = -margin * w, -margin * hh, w * (1 + margin), hh * (1 + margin)
    corners = np.array([[x0, y0, 1], [x1, y0, 1], [x1, y1, 1], [x0, y1, 1]], np.float64)
    plane = corners @ np.linalg.inv(h).T
    xy = plane[:, :2] / plane[:, 2:]
    if (xy @ h[2, :2] + h[2, 2] <= NEAREST_DEPTH).any():
        return None
    return np.array([*xy.min(axis=0), *xy.max(axis=0)])
