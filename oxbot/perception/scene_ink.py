"""Ink and paint for the grid scenes: plane shapes seen through the camera, drawn antialiased.

A scene's sheet is a plane with its own coordinates (the grid's cell units); a homography maps
it to the image. Strokes are sampled densely on the plane and mapped point by point, so that a
hand-drawn curve stays a curve under perspective; points the camera cannot see (behind it, or so
near its own plane that they would land far outside the picture) are left out. Coverage is drawn
on a canvas twice the image's size with OpenCV's antialiased polylines and averaged down, so
that pen widths come in half pixels. Inks are filters (`Ink.colour` is how much of each channel
the ink lets through), so a blue pen on yellow card looks as it would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

NEAREST_DEPTH = 0.1
"""Plane points nearer the camera than this share of the grid's own distance are not drawn:
they would land thousands of pixels out of the picture, or behind the camera."""
SUPERSAMPLE = 2
"""Coverage is drawn this many times larger, then averaged down."""
MIN_INK_CONTRAST = 0.22
"""Least share of white paper's brightness any ink takes away, so that no stroke is invisible."""
_SHIFT = 4  # fractional bits of OpenCV's fixed-point coordinates
_LUMA = np.array([0.299, 0.587, 0.114], np.float32)

INK_KINDS = ("pen", "pencil", "felt", "marker")
INK_WEIGHTS = (0.4, 0.2, 0.15, 0.25)
# Widths as a share of a cell's side: a 0.5 mm ballpoint to a 4 mm marker on 3-6 cm cells.
_WIDTHS = {
    "pen": (0.008, 0.022),
    "pencil": (0.006, 0.018),
    "felt": (0.02, 0.04),
    "marker": (0.04, 0.09),
    "print": (0.006, 0.016),
}
# Pen colours as transmittance (what the ink lets through): black, blue, dark blue, red, green,
# purple.
_PEN_COLOURS = np.array(
    [
        [0.08, 0.08, 0.1],
        [0.15, 0.25, 0.75],
        [0.1, 0.12, 0.4],
        [0.8, 0.12, 0.12],
        [0.12, 0.5, 0.2],
        [0.4, 0.15, 0.55],
    ],
    np.float32,
)


@dataclass(frozen=True)
class Ink:
    """How one pen's strokes look: colour, strength, width, grain and how steady the hand."""

    kind: str
    """"pen", "pencil", "felt", "marker" or "print"."""
    colour: tuple[float, float, float]
    """Share of each channel's light (RGB) the ink lets through: 0 black, 1 clear."""
    alpha: float
    """How fully the ink covers where it is laid, 0-1 (pencil and worn felt-tips leave gaps)."""
    width: float
    """Stroke width as a share of the grid's cell side."""
    grain: float
    """Share of a stroke's pixels the pencil skips, showing paper; 0 for ink."""

    def darkening(self) -> float:
        """The share of white paper's brightness the ink takes away, on average along a stroke
        (a pencil's grain lets some through)."""
        grainy = 1 - 0.55 * self.grain  # `lay_ink` leaves 45% where the grain skips
        return float(self.alpha * grainy * (1 - _LUMA @ np.array(self.colour, np.float32)))


def random_ink(rng: np.random.Generator, kind: str | None = None) -> Ink:
    """A pen, pencil (light grey, thin, grainy), felt-tip or marker (thick, any colour)."""
    if kind is None:
        kind = INK_KINDS[int(rng.choice(len(INK_KINDS), p=INK_WEIGHTS))]
    grain = 0.0
    if kind == "pencil":
        colour = np.full(3, rng.uniform(0.3, 0.6), np.float32) + rng.uniform(-0.03, 0.03, 3)
        alpha, grain = rng.uniform(0.5, 0.9), rng.uniform(0.1, 0.45)
    elif kind == "print":
        colour = np.full(3, rng.uniform(0.0, 0.45), np.float32)
        alpha = rng.uniform(0.75, 1.0)
    elif kind == "marker" and rng.random() < 0.5:  # any colour at all
        colour = rng.uniform(0.0, 1.0, 3).astype(np.float32) * rng.uniform(0.3, 1.0)
        alpha = rng.uniform(0.8, 1.0)
    else:
        colour = _PEN_COLOURS[int(rng.integers(len(_PEN_COLOURS)))] + rng.uniform(-0.07, 0.07, 3)
        alpha = rng.uniform(0.6, 0.95) if kind == "pen" else rng.uniform(0.8, 1.0)
        if kind == "felt" and rng.random() < 0.3:
            grain = rng.uniform(0.05, 0.2)  # a drying felt-tip
    colour = np.clip(colour, 0.0, 1.0).astype(np.float32)
    need = 1 - MIN_INK_CONTRAST / alpha  # the brightest the colour may be
    bright = float(_LUMA @ colour)
    if bright > need:
        colour *= max(need, 0.0) / bright
    width = rng.uniform(*_WIDTHS[kind])
    return Ink(kind, tuple(float(v) for v in colour), float(alpha), float(width), float(grain))


def project(h: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plane points (N, 2) in the image (N, 2), and which of them the camera sees."""
    p = np.asarray(points, np.float64)
    hom = p @ h[:, :2].T + h[:, 2]
    depth = hom[:, 2]
    seen = depth > NEAREST_DEPTH
    return hom[:, :2] / np.where(seen, depth, 1.0)[:, None], seen


def image_runs(h: np.ndarray, points: np.ndarray) -> list[np.ndarray]:
    """A plane polyline in the image: its pieces the camera sees, each (K >= 2, 2)."""
    image, seen = project(h, points)
    if seen.all():
        return [image]
    edges = np.flatnonzero(np.diff(np.concatenate([[0], seen.astype(np.int8), [0]])))
    return [image[a:b] for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= 2]


def clip_polygon(h: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """The part of a plane polygon the camera sees (Sutherland-Hodgman against the near limit)."""
    depth = polygon @ h[2, :2] + h[2, 2] - NEAREST_DEPTH * 1.01
    out = []
    for i in range(len(polygon)):
        p, q, dp, dq = polygon[i - 1], polygon[i], depth[i - 1], depth[i]
        if (dp > 0) != (dq > 0):
            out.append(p + (q - p) * (dp / (dp - dq)))
        if dq > 0:
            out.append(q)
    return np.array(out, np.float64).reshape(-1, 2)


def to_fixed(points: np.ndarray) -> np.ndarray:
    """Image points as int32 fixed-point coordinates of the `SUPERSAMPLE` times bigger canvas."""
    # Pixel i of the image holds big pixels S*i .. S*i+S-1: its centre is S*x + (S-1)/2.
    big = (points * SUPERSAMPLE + (SUPERSAMPLE - 1) / 2) * (1 << _SHIFT)
    return np.round(big).astype(np.int32)


class Coverage:
    """How much of each pixel one layer of ink covers, drawn at `SUPERSAMPLE` times the size."""

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        self.big = np.zeros((shape[0] * SUPERSAMPLE, shape[1] * SUPERSAMPLE), np.uint8)

    def stroke(self, runs: list[np.ndarray], width: float) -> None:
        """Draw image polylines `width` pixels wide (rounded to 1 / SUPERSAMPLE of a pixel)."""
        if runs:
            self.polylines([to_fixed(r) for r in runs], max(1, round(width * SUPERSAMPLE)))

    def polylines(self, fixed: list[np.ndarray], thickness: int) -> None:
        """Draw polylines already in the big canvas' fixed point (`to_fixed`), `thickness`
        big pixels wide."""
        cv2.polylines(self.big, fixed, False, 255, thickness, cv2.LINE_AA, shift=_SHIFT)

    def dots(self, points: np.ndarray, radius: float) -> None:
        """Round dots of `radius` pixels at image points (N, 2) (one dilation for them all)."""
        centres = np.round(points * SUPERSAMPLE + (SUPERSAMPLE - 1) / 2).astype(np.int64)
        h, w = self.big.shape
        inside = (centres >= 0).all(axis=1) & (centres[:, 0] < w) & (centres[:, 1] < h)
        if not inside.any():
            return
        spots = np.zeros_like(self.big)
        spots[centres[inside, 1], centres[inside, 0]] = 255
        r = max(0, round(radius * SUPERSAMPLE - 0.5))
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        np.maximum(self.big, cv2.dilate(spots, disc), out=self.big)

    def fill(self, polygon: np.ndarray) -> None:
        """Fill an image polygon (K, 2)."""
        fixed = np.round((polygon * SUPERSAMPLE + (SUPERSAMPLE - 1) / 2) * (1 << _SHIFT))
        cv2.fillPoly(self.big, [fixed.astype(np.int32)], 255, cv2.LINE_AA, shift=_SHIFT)

    def result(self) -> np.ndarray:
        """float32 (H, W) in [0, 1]."""
        h, w = self.shape
        small = cv2.resize(self.big, (w, h), interpolation=cv2.INTER_AREA)
        return small.astype(np.float32) * (1 / 255)


def draw_plane_strokes(
    cover: Coverage,
    h: np.ndarray,
    strokes: list[np.ndarray],
    width: float,
    rng: np.random.Generator,
    pressure: bool = False,
    min_pixels: float = 0.5,
) -> None:
    """Draw plane polylines `width` plane units wide (at least `min_pixels` in the picture,
    and wider where the plane is nearer the camera); with `pressure`, each in pieces of
    varying width, as a pen pressed harder and softer.

    All points are mapped at once and the strokes drawn in one call per width: a scene has
    hundreds of small strokes, and numpy's and OpenCV's cost per call would dominate.
    """
    if pressure:
        strokes = [
            stroke[max(0, piece[0] - 1) : piece[-1] + 1]
            for stroke in strokes
            for piece in np.array_split(np.arange(len(stroke)), max(1, len(stroke) // 24))
        ]
    strokes = [s for s in strokes if len(s) >= 2]
    if not strokes:
        return
    points = np.concatenate(strokes)
    image, seen = project(h, points)
    starts = np.cumsum([0] + [len(s) for s in strokes])
    # Pixels per plane unit: the square root of the homography's area ratio, |det H| / w^3.
    depth = points[(starts[:-1] + starts[1:]) // 2] @ h[2, :2] + h[2, 2]
    ratio = math.sqrt(abs(np.linalg.det(h))) / np.maximum(depth, NEAREST_DEPTH) ** 1.5
    pixels = np.maximum(width * ratio, min_pixels)
    if pressure:
        pixels *= rng.uniform(0.8, 1.15, len(pixels))
    thickness = np.maximum(1, np.round(pixels * SUPERSAMPLE)).astype(int)
    fixed = to_fixed(image)
    groups: dict[int, list[np.ndarray]] = {}
    for k in range(len(strokes)):
        a, b = starts[k], starts[k + 1]
        group = groups.setdefault(int(thickness[k]), [])
        if seen[a:b].all():
            group.append(fixed[a:b])
        else:
            edges = np.flatnonzero(np.diff(np.concatenate([[0], seen[a:b].astype(np.int8), [0]])))
            group += [
                fixed[a + i : a + j]
                for i, j in zip(edges[::2], edges[1::2], strict=True)
                if j - i >= 2
            ]
    for size, fixed_runs in groups.items():
        if fixed_runs:
            cover.polylines(fixed_runs, size)


def _extent(alpha: np.ndarray) -> tuple[slice, slice] | None:
    """The rows and columns holding all of `alpha`'s non-zero pixels, or None if none."""
    rows = np.flatnonzero(alpha.max(axis=1) > 0)
    if rows.size == 0:
        return None
    cols = np.flatnonzero(alpha[rows[0] : rows[-1] + 1].max(axis=0) > 0)
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def channels(plane: np.ndarray, rgb: np.ndarray | tuple | None = None) -> np.ndarray:
    """A float32 (H, W) plane as (H, W, 3), each channel scaled by `rgb` (default 1).

    Multiplying an RGB image by a (H, W, 1) array makes numpy loop three values at a time,
    several times slower than by an array of the image's own shape."""
    if rgb is None:
        return cv2.merge([plane, plane, plane])
    return cv2.merge([plane * np.float32(v) for v in rgb])


def lay_ink(
    image: np.ndarray, coverage: np.ndarray, ink: Ink, rng: np.random.Generator
) -> np.ndarray:
    """`image` (float32 RGB in [0, 1]) with `ink` laid where `coverage` says, in place."""
    extent = _extent(coverage)
    if extent is None:
        return image
    amount = coverage[extent] * np.float32(ink.alpha)
    if ink.grain > 0:
        skipped = rng.random(amount.shape, dtype=np.float32) < ink.grain
        amount[skipped] *= 0.45
    image[extent] *= 1.0 - channels(amount, 1.0 - np.asarray(ink.colour, np.float32))
    return image


def darken(image: np.ndarray, amount: np.ndarray) -> np.ndarray:
    """`image` with the share `amount` (H, W) of its light taken away, in place."""
    extent = _extent(amount)
    if extent is not None:
        image[extent] *= channels(1.0 - amount[extent])
    return image


def paint(image: np.ndarray, alpha: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """`image` with `colour` (RGB, or an image) laid opaquely where `alpha` (H, W) says, in
    place."""
    extent = _extent(alpha)
    if extent is None:
        return image
    part = image[extent]
    if np.ndim(colour) == 3:
        change = part - colour[extent]
    else:
        change = cv2.subtract(part, (*(float(v) for v in colour), 0.0))
    change *= channels(alpha[extent])
    part -= change
    return image
