"""Whether a cell's ink is a whole symbol: a loop for a circle, crossing strokes for a cross.

The paper's three-output network has no word for ink that is not a whole symbol: it reads an
arc, a semicircle, a tick or a plus as a circle or a cross, often surely, and two four-output
networks failed to learn the difference without losing whole symbols (docs/perception.md). This
check looks at the ink's shape instead, and turns a circle or cross reading into "partial" when
the shape is surely not whole. It judges only what it can measure; ink it cannot judge keeps
the network's reading.

Each cell read as a circle or a cross is cut again around its ink (as the board reader cuts
its cells: a small symbol thins to too few pixels to tell its arms), and its ink thinned to a
skeleton whose spurs are cut off. Then:

- A circle is a loop. Ink that encloses paper is one; an open curve (a skeleton with two ends)
  is one when the gap it leaves, seen from the middle of the ellipse fitted to it, is at most
  `max_gap` degrees of the turn (`PerceptionConfig.max_circle_gap`, 95: loops of 0.8 of a turn
  and more are circles; the open "O"s of some handwriting come close). An arc, a semicircle, a
  C, most three quarters of a circle, a stroke, a tick or a plus sign read as a circle are not.
- A cross is two strokes crossing. Ink whose skeleton has at most two ends and encloses nothing
  is one stroke, bent or straight: a single stroke, a tick, an L, a C. Four or more ends whose
  directions from the ink's middle run within `PLUS_ANGLE` of the cell's sides are a plus sign,
  which is a cross only with `plus_is_cross` (some people draw their crosses that way).
- Flecks are neither: ink in `SCATTERED_PIECES` or more pieces, none a third of it (a fibrous
  paper's flecks, a texture's specks), whatever the network reads.
- Not judged: ends that run out of the cell or under a grid line painted over (`painted`),
  and an open curve whose ellipse runs on there across its gap (a circle drawn over a grid
  line, its far side in the next cell); three ends (a T, a V whose corner thins to a spur, a
  cross with one short arm), scribbles (holes and many ends). But a stroke read as a cross
  with one end in plain view is one stroke, whatever its other end runs into; and a plus sign
  or one straight stroke is never a circle, nor a cross (but a plus with `plus_is_cross`),
  whether or not it runs out of sight.

    from oxbot.perception.wholeness import veto_partial
    readings = veto_partial(cells, clf.read(cells), plus_is_cross=False)
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence

import cv2
import numpy as np

from oxbot.perception.cells import SYMBOL_SHARE
from oxbot.perception.classifier import CellReading, to_input
from oxbot.perception.synth import PARTIAL

INK_LEVEL = 0.3
"""oxbot: after a light blur, a pixel at least this share of the way from the cell's paper to
its darkest ink (`to_input`'s scale) is ink, for the shape checks."""
CORE_LEVEL = 0.6
"""oxbot: the darkest ink, at least this share of the way to the darkest pixel: a thick pen's
small "0" fills its own slit at `INK_LEVEL` but leaves it open here."""
MIN_PIECE = 6
"""oxbot: pieces of ink smaller than this many pixels are specks, not part of the symbol."""
REMNANT = 7
"""oxbot: thin pieces of ink within this many pixels of one side of the cell, along it, are
what is left of a grid line."""
SPUR = 0.05
"""oxbot: a skeleton's branches shorter than this share of the symbol's size are spurs (the
corners of a thick stroke), cut off before its ends are counted."""
THICK = 0.25
"""oxbot: ink whose mean width is this share of its size or more thins to a stub, whatever it
is drawn as: not judged."""
FLAT = 0.2
"""oxbot: an open curve bulging less than this share of the way between its ends from the line
through them goes round nothing: a stroke, not a circle."""
MIN_HOLE = 0.04
"""oxbot: a hole of this share of the ink's box, once gaps of a pixel are closed, makes a loop
(a hole of a few pixels does in ink as it is: a thick pen's slit of an oval)."""
PLUS_ANGLE = 12.0
"""oxbot: four or more stroke ends whose directions from the ink's middle run on average within
this many degrees of the cell's sides make a plus sign. The generated test set's crosses,
turned up to 34 degrees from the diagonals, stay at 10 or more (1 of 333 below 12)."""
SCATTERED_PIECES = 5
"""oxbot: ink in at least this many pieces (specks dropped), none of them `SCATTERED_SHARE` of
it, is scattered: a paper's fibres and flecks, not a symbol drawn in one or two strokes."""
SCATTERED_SHARE = 0.35
"""oxbot: see `SCATTERED_PIECES`. A symbol drawn in one or two strokes keeps a piece this large
where a grid line painted over breaks it (tests/perception/test_wholeness.py)."""
MAX_CIRCLE_GAP = 95.0
"""oxbot: the default of `PerceptionConfig.max_circle_gap` (degrees; see there)."""


@dataclasses.dataclass(frozen=True)
class Shape:
    """What the shape checks measured of one cell's ink."""

    ends: int
    """The skeleton's ends, once spurs are cut off (a circle 0, a stroke 2, an X 4)."""
    hole: bool
    """The ink encloses paper."""
    turn_gap: float
    """For an open curve (two ends, no hole): degrees of the turn it leaves open, seen from the
    middle of its ellipse (360 when none fits); 0 otherwise."""
    plus_offset: float
    """With four or more ends: the mean angle (degrees) between their directions from the
    ink's middle and the nearest side of the cell (45 for an upright X, 0 for a plus); 90
    otherwise."""
    hidden: bool
    """The ink runs out of the cell, or under a grid line painted over: what it is there cannot
    be told."""
    arms: int
    """For thick ink, whose skeleton may shrink to a stub: how many arms leave its middle (the
    runs of ink on circles round it); 0 for thin ink."""
    end_in_view: bool
    """An end of the skeleton lies in plain view, away from the cell's edge and painted lines."""
    gap_hidden: bool
    """For an open curve: the rest of the ellipse fitted to it, across its gap, lies mostly
    under a painted-over grid line or beyond the cell's edge, as `zoom` marks them (a circle
    drawn over a grid line)."""
    straight: bool
    """Two ends and a skeleton bulging less than FLAT of the way between them: a stroke."""
    scattered: bool = False
    """The ink lies in many small pieces (`SCATTERED_PIECES`): flecks, no symbol."""

    def whole(
        self, label: str, max_gap: float = MAX_CIRCLE_GAP, plus_is_cross: bool = False
    ) -> bool:
        """Whether this ink is a whole `label` ("circle" or "cross"; anything else is)."""
        if self.scattered and label in ("circle", "cross"):
            return False
        if label == "circle":
            if self.hole:
                return True
            # A stroke or a plus is no circle, whatever runs out of sight.
            if self.straight or self.plus_offset < PLUS_ANGLE:
                return False
            if self.hidden or self.gap_hidden:
                return True
            return self.ends != 2 or self.turn_gap <= max_gap
        if label == "cross":
            if self.plus_offset < PLUS_ANGLE:
                return plus_is_cross
            if self.straight:
                return False
            # A stroke with an end in plain view is one stroke, whatever its other end meets.
            hidden = self.hidden and not (self.ends <= 2 and self.end_in_view)
            return hidden or self.hole or self.ends > 2 or self.arms >= 4
        return True


def ink_masks(cells: np.ndarray, level: float = INK_LEVEL) -> np.ndarray:
    """The ink of uint8 (N, 40, 40) cells as bool (N, 40, 40), without specks and grid-line
    remnants; ink is at least `level` of the way from the paper to the darkest ink."""
    soft = np.stack([cv2.GaussianBlur(c, (3, 3), 0) for c in cells])
    x = to_input(soft).numpy()[:, 0]
    # Relative to the darkest ink inside the cell: a dark grid-line remnant at its border
    # must not make a faint symbol vanish.
    inner = x[:, REMNANT:-REMNANT, REMNANT:-REMNANT].max(axis=(1, 2), keepdims=True)
    masks = x > np.maximum(level * inner, 0.12)
    side = masks.shape[1]
    for mask in masks:
        count, labels, stats, _ = cv2.connectedComponentsWithStats(
            mask.view(np.uint8), connectivity=8
        )
        if count > 1:
            x0, y0, w, h, area = stats.T
            along = ((y0 + h <= REMNANT) | (y0 >= side - REMNANT)) & (h <= 4) & (w > h)
            down = ((x0 + w <= REMNANT) | (x0 >= side - REMNANT)) & (w <= 4) & (h > w)
            drop = (area < MIN_PIECE) | along | down
            drop[0] = False
            if drop.any():
                mask[drop[labels]] = False
    return masks


def shape_of(
    mask: np.ndarray, painted: np.ndarray | None = None, core: np.ndarray | None = None
) -> Shape:
    """Measure the shape of one cell's ink (bool (H, W)); `painted` (bool (H, W)): where a grid
    line was painted over, hiding what ink was there; `core`: the ink's darkest part (at
    `CORE_LEVEL`), where a thick pen's narrow loop still shows its hole."""
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return Shape(0, False, 0.0, 90.0, True, 0, False, False, False)
    width, height = int(xs.max() - xs.min() + 1), int(ys.max() - ys.min() + 1)
    size = max(width, height)
    ink = mask.view(np.uint8)
    closed = cv2.morphologyEx(ink, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
    hole = _largest_hole(closed) >= MIN_HOLE * width * height or _largest_hole(ink) >= 3
    if core is not None and not hole:
        hole = _largest_hole(core.view(np.uint8)) >= MIN_HOLE * width * height
    skeleton = thin(closed > 0)
    stroke = mask.sum() / max(skeleton.sum(), 1)  # the strokes' mean width
    spur = max(1, round(SPUR * size))
    ends = np.argwhere(_end_points(prune(skeleton, spur)))
    far = mask.shape[0] - 2 - spur
    unseen = np.array([min(y, x) <= 1 + spur or max(y, x) >= far for y, x in ends], bool)
    near = np.zeros(mask.shape, bool)
    if painted is not None and painted.any():
        near = cv2.dilate(painted.view(np.uint8), np.ones((2 * spur + 5,) * 2, np.uint8)) > 0
        if len(ends):
            unseen |= near[ends[:, 0], ends[:, 1]]
    hidden, end_in_view = bool(unseen.any()), bool((~unseen).any())
    arms = _arms(mask, (ys.mean(), xs.mean()), size) if stroke >= THICK * size else 0
    open_curve = len(ends) == 2 and not hole
    straight = open_curve and _straight(np.argwhere(skeleton), ends)
    turn_gap, gap_hidden = 0.0, False
    if open_curve:  # a straight stroke goes round nothing: 360
        turn_gap, gap_hidden = (360.0, False) if straight else _turn_gap(skeleton, ends, near)
    plus_offset = 90.0
    if len(ends) >= 4:
        angles = np.degrees(np.arctan2(*(ends - [ys.mean(), xs.mean()]).T)) % 90.0
        plus_offset = float(np.minimum(angles, 90.0 - angles).mean())
    count, _, stats, _ = cv2.connectedComponentsWithStats(ink, connectivity=8)
    areas = stats[1:, cv2.CC_STAT_AREA]
    scattered = count - 1 >= SCATTERED_PIECES and areas.max() < SCATTERED_SHARE * areas.sum()
    return Shape(
        len(ends),
        hole,
        turn_gap,
        plus_offset,
        hidden,
        arms,
        end_in_view,
        gap_hidden,
        straight,
        bool(scattered),
    )


def _arms(mask: np.ndarray, centre: tuple[float, float], size: int) -> int:
    """The most runs of ink met going round circles of 0.3 and 0.4 of `size` about `centre`
    (y, x): four for an X, two for a stroke or a V."""
    most = 0
    for share in (0.3, 0.4):
        radius = share * size
        n = max(24, int(4 * math.pi * radius))
        t = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
        y = np.clip(np.rint(centre[0] + radius * np.sin(t)).astype(int), 0, mask.shape[0] - 1)
        x = np.clip(np.rint(centre[1] + radius * np.cos(t)).astype(int), 0, mask.shape[1] - 1)
        on = mask[y, x].astype(np.int8)
        most = max(most, int(((on - np.roll(on, 1)) == 1).sum()))
    return most


def _largest_hole(ink: np.ndarray) -> float:
    """Area (pixels) of the largest region of paper that the ink (uint8 0/1) encloses."""
    contours, hierarchy = cv2.findContours(np.pad(ink, 1), cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
    if hierarchy is None:
        return 0.0
    holes = [cv2.contourArea(c) for c, h in zip(contours, hierarchy[0], strict=True) if h[3] >= 0]
    return max(holes, default=0.0)


def _straight(points: np.ndarray, ends: np.ndarray) -> bool:
    """Whether a skeleton's pixels (K, 2) (row, column) bulge less than FLAT of the way between
    its two ends (row, column) from the line through them."""
    (y0, x0), (y1, x1) = ends.astype(np.float32)
    chord = math.hypot(x1 - x0, y1 - y0)
    if chord == 0:
        return False
    ys, xs = points[:, 0].astype(np.float32), points[:, 1].astype(np.float32)
    bulge = np.abs((xs - x0) * (y1 - y0) - (ys - y0) * (x1 - x0)) / chord
    return bool(bulge.max() < FLAT * chord)


def _turn_gap(skeleton: np.ndarray, ends: np.ndarray, unseen: np.ndarray) -> tuple[float, bool]:
    """How much of a turn (degrees) an open curve (not `_straight`) with these two ends leaves
    out, seen from the middle of the ellipse fitted to it; 360 when it goes round nothing (too
    few pixels, or no ellipse fits). And whether the ellipse across that gap lies mostly on
    `unseen` pixels (bool (H, W))."""
    points = np.argwhere(skeleton)[:, ::-1].astype(np.float32)
    if len(points) < 8:
        return 360.0, False
    (cx, cy), (w, h), angle = cv2.fitEllipse(points)
    if not (min(w, h) > 1 and max(w, h) < 4 * skeleton.shape[0]):
        return 360.0, False
    t = math.radians(angle)
    dx, dy = points[:, 0] - cx, points[:, 1] - cy
    u = (dx * math.cos(t) + dy * math.sin(t)) / (w / 2)
    v = (dy * math.cos(t) - dx * math.sin(t)) / (h / 2)
    around = np.sort(np.degrees(np.arctan2(v, u)) % 360.0)
    steps = np.diff(np.concatenate([around, [around[0] + 360.0]]))
    k = int(steps.argmax())
    phi = np.radians(around[k] + steps[k] * np.linspace(0.1, 0.9, 9))
    a, b = np.cos(phi) * w / 2, np.sin(phi) * h / 2
    x = np.rint(cx + a * math.cos(t) - b * math.sin(t)).astype(int)
    y = np.rint(cy + a * math.sin(t) + b * math.cos(t)).astype(int)
    side = skeleton.shape[0]
    # Beyond the frame is not counted: there the ellipse is far bigger than the ink (an arc).
    inside = (x >= 0) & (x < side) & (y >= 0) & (y < side)
    return float(steps[k]), bool(unseen[y[inside], x[inside]].sum() >= 0.5 * len(phi))


def _neighbours(p: np.ndarray) -> list[np.ndarray]:
    """The 8 neighbours of each inner pixel of the padded image `p`, clockwise from north."""
    return [
        p[:-2, 1:-1],
        p[:-2, 2:],
        p[1:-1, 2:],
        p[2:, 2:],
        p[2:, 1:-1],
        p[2:, :-2],
        p[1:-1, :-2],
        p[:-2, :-2],
    ]


def _end_points(skeleton: np.ndarray) -> np.ndarray:
    """Skeleton pixels where it ends: their neighbours lie in one run round them, or none."""
    ring = _neighbours(np.pad(skeleton.view(np.uint8), 1))
    transitions = sum((ring[k] == 0) & (ring[(k + 1) % 8] == 1) for k in range(8))
    return skeleton & (transitions <= 1)


def prune(skeleton: np.ndarray, steps: int) -> np.ndarray:
    """The skeleton with its ends eaten back `steps` pixels: spurs shorter than that go."""
    out = skeleton.copy()
    for _ in range(steps):
        ends = _end_points(out)
        if not ends.any():
            break
        out &= ~ends
    return out


@functools.cache
def _thinning_tables() -> tuple[np.ndarray, np.ndarray]:
    """For each of the 256 neighbourhoods (bit k: neighbour k clockwise from north), whether
    the thinning removes the pixel in its first and in its second sub-iteration."""
    first, second = np.zeros(256, bool), np.zeros(256, bool)
    for code in range(256):
        n = [(code >> k) & 1 for k in range(8)]
        transitions = sum(n[k] == 0 and n[(k + 1) % 8] == 1 for k in range(8))
        if not (3 <= sum(n) <= 6 and transitions == 1):
            continue
        north, east, south, west = n[0], n[2], n[4], n[6]
        first[code] = north * east * south == 0 and east * south * west == 0
        second[code] = north * east * west == 0 and north * south * west == 0
    return first, second


def thin(mask: np.ndarray) -> np.ndarray:
    """The skeleton of a bool mask: Zhang and Suen's thinning (1984), removing only pixels with
    three to six neighbours (Lü and Wang, 1986): with two, a diagonal stroke two pixels wide is
    eaten from its ends, and a straight line thins to a dot."""
    tables = _thinning_tables()
    p = np.pad(mask.view(np.uint8), 1).copy()
    while True:
        changed = False
        for table in tables:
            code = sum(n << k for k, n in enumerate(_neighbours(p)))
            remove = table[code] & (p[1:-1, 1:-1] == 1)
            if remove.any():
                p[1:-1, 1:-1][remove] = 0
                changed = True
        if not changed:
            return p[1:-1, 1:-1].astype(bool)


def whole(
    cells: np.ndarray,
    labels: Sequence[str],
    max_gap: float = MAX_CIRCLE_GAP,
    plus_is_cross: bool = False,
    painted: np.ndarray | None = None,
) -> np.ndarray:
    """For uint8 (N, 40, 40) cells and their labels, whether each one's ink is whole for its
    label (always for labels other than circle and cross), bool (N,). `painted` (bool (N, 40,
    40)): where grid lines were painted over in each cell (`board.cut_board`)."""
    out = np.ones(len(labels), bool)
    todo = [i for i, label in enumerate(labels) if label in ("circle", "cross")]
    if todo:
        cells = np.asarray(cells)[todo]
        lines = np.zeros(cells.shape, bool) if painted is None else np.asarray(painted)[todo]
        cells, lines = zoom(cells, ink_masks(cells), lines)
        cores = ink_masks(cells, CORE_LEVEL)
        for i, mask, core, painted_here in zip(todo, ink_masks(cells), cores, lines, strict=True):
            out[i] = shape_of(mask, painted_here, core).whole(labels[i], max_gap, plus_is_cross)
    return out


def zoom(
    cells: np.ndarray, masks: np.ndarray, painted: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Cells (and where lines were painted over in them, or the cell ends) cut again as squares
    around their ink (`masks`), the ink SYMBOL_SHARE of the side as the board reader cuts its
    cells, brought back to the cells' size: a small symbol thins to too few pixels to tell its
    arms."""
    size = cells.shape[1]
    out, lines = cells.copy(), painted.copy()
    for i, mask in enumerate(masks):
        ys, xs = np.nonzero(mask)
        if xs.size == 0:
            continue
        extent = max(xs.max() - xs.min(), ys.max() - ys.min()) + 1
        side = max(round(extent / SYMBOL_SHARE), 8)
        if side >= size:
            continue  # big enough already
        left = (int(xs.min() + xs.max()) + 1 - side) // 2
        top = (int(ys.min() + ys.max()) + 1 - side) // 2
        paper = float(np.percentile(cells[i], 90))
        pad = side
        big = cv2.copyMakeBorder(cells[i], pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=paper)
        crop = big[top + pad : top + pad + side, left + pad : left + pad + side]
        out[i] = cv2.resize(crop, (size, size), interpolation=cv2.INTER_LINEAR)
        # beyond the cell's edge is unseen, as under a painted-over line
        line = np.pad(painted[i].view(np.uint8), pad, constant_values=1)[
            top + pad : top + pad + side, left + pad : left + pad + side
        ]
        lines[i] = cv2.resize(line, (size, size), interpolation=cv2.INTER_NEAREST) > 0
    return out, lines


def veto_partial(
    cells: np.ndarray,
    readings: Sequence[CellReading],
    max_gap: float = MAX_CIRCLE_GAP,
    plus_is_cross: bool = False,
    painted: np.ndarray | None = None,
) -> list[CellReading]:
    """`readings` of `cells`, each circle or cross whose ink is not whole read "partial" with
    the network's confidence and the same ink (`painted` as `whole`)."""
    ok = whole(cells, [r.label for r in readings], max_gap, plus_is_cross, painted)
    return [
        r if ok[i] else CellReading(PARTIAL, r.confidence, r.ink) for i, r in enumerate(readings)
    ]
