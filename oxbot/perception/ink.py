"""The grid finder's ink: pixels clearly darker than the paper around them, and which way
their strokes run.

Ink is what is clearly darker than the paper around it in any colour channel (a morphological
closing estimates the paper), so that a thin blue or green marker line, faint in gray, is dark
in the channel it absorbs, while desk edges, shadows and lighting gradients, not thin and
dark, are not ink. The frame is searched on a copy shrunk so that thin pen lines stay dark
(`shrink_keeping_strokes`). Each ink pixel's stroke direction (`Strokes`, from the image's
structure tensor) lets the later stages count only ink that runs a line's way.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class InkTuning:
    """The ink's and the strokes' tuned constants."""

    contrast: float = 0.12
    """Ink is at least this share of the paper's light darker than the paper around it, in
    some colour channel."""
    min_clearness: float = 0.3
    """Strokes less clear-cut than this (how much more the image changes across them than
    along them: crossings and blobs are not) count as running every way (`UNCLEAR`)."""
    agree: int = 25
    """Degrees: a stroke this near a line's direction runs its way."""


INK = InkTuning()

UNCLEAR = 255
"""The direction recorded for a stroke too unclear to say (not a degree, 0-179): such
strokes count as running every way."""


def ink_mask(image: np.ndarray, kernel: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """uint8 mask (0/255) of thin dark strokes, pixels well below the paper's closing in any
    colour channel; and float32 darkness, the largest share of the paper's light a pixel
    takes away in one channel (0 paper, 1 black), whose structure gives strokes' directions.
    Each channel against its own paper: a tinted sheet on a desk of another colour."""
    smooth = cv2.GaussianBlur(image, (3, 3), 0)
    paper = cv2.morphologyEx(smooth, cv2.MORPH_CLOSE, np.ones((kernel, kernel), np.uint8))
    darker = cv2.subtract(paper, smooth).astype(np.float32)
    lit = paper.astype(np.float32)
    ink = ((darker > INK.contrast * lit) & (darker > 12)).astype(np.uint8) * 255
    darkness = darker / np.maximum(lit, 8.0)
    if image.ndim == 3:  # OpenCV's maximum over the channels: numpy's is many times slower
        ink = cv2.max(cv2.max(ink[..., 0], ink[..., 1]), ink[..., 2])
        channels = cv2.split(darkness)
        darkness = cv2.max(cv2.max(channels[0], channels[1]), channels[2])
    return ink, darkness


def shrink_keeping_strokes(image: np.ndarray, k: int) -> np.ndarray:
    """`image` shrunk k times (k > 1 a whole number: OpenCV's fast area averaging) so that a
    pen line one pixel wide stays dark: each pixel first takes the darkest value around it (as
    wide as the pixels that merge), then areas are averaged."""
    darkest = cv2.erode(image, np.ones((k, k), np.uint8))
    return cv2.resize(darkest, None, fx=1 / k, fy=1 / k, interpolation=cv2.INTER_AREA)


@dataclass(frozen=True)
class Strokes:
    """The ink of the work image, and which way its strokes run at each pixel."""

    mask: np.ndarray
    """uint8 (H, W) ink mask, 0/255."""
    pixels: np.ndarray
    """(N, 2) float x, y of the ink pixels, row by row."""
    ways: np.ndarray
    """(N,) int16: the direction of each ink pixel's stroke (`direction` at `pixels`)."""
    direction: np.ndarray
    """uint8 (H, W): at each ink pixel, the direction its stroke runs in whole degrees
    (0-179, 0 along x), or `UNCLEAR` where the stroke is not clear-cut (a crossing, a
    blob). Every ink pixel is looked at: all of them vote for lines."""

    @classmethod
    def of(cls, small: np.ndarray, ink: np.ndarray) -> Strokes:
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
        clear = np.hypot(xx - yy, 2 * xy_part) >= INK.min_clearness * np.maximum(xx + yy, 1e-3)
        degrees = np.degrees(0.5 * np.arctan2(-2 * xy_part, yy - xx))  # -90 to 90
        # Modulo 180, without numpy's slow float modulo: these are at most half a turn off.
        degrees[degrees < 0] += 180
        whole = np.round(degrees)
        whole[whole == 180] = 0
        direction = np.full(ink.shape, UNCLEAR, np.uint8)
        ways = np.where(clear, whole, UNCLEAR).astype(np.int16)
        direction[y, x] = ways
        return cls(ink, xy.astype(np.float64), ways, direction)

    def runs_along(self, x: np.ndarray, y: np.ndarray, way: np.ndarray) -> np.ndarray:
        """Whether the strokes at ink pixels (x, y) run within `INK.agree` degrees of `way`
        (degrees), or are too unclear to say."""
        seen = self.direction[y, x]
        off = np.abs(seen - way)  # 0-180 for directions 0-179 and `way` 0-180
        return (np.minimum(off, 180 - off) <= INK.agree) | (seen == UNCLEAR)
