"""What to tell a person whose camera cannot show the robot the board, and what to do.

The grid finder (`grid.py`) says only that it found no grid, or that the grid runs off the
picture. A person holding a phone over a sheet needs to know why: the room is too dark, the
picture is blurred, a hand is in the way, the sheet is partly out of the picture or the camera
is too close. `diagnose` looks at a frame the reader refused, cheaply (a few milliseconds on a
320-pixel copy), and names the likeliest cause with what to do about it; when none of these
fits, the finder's own words stand.

    guidance = diagnose(frame, str(no_grid_found), last_grid=corners)
    guidance.kind   # "too_dark", "blurred", "hand", "off_edge", "too_close" or "no_grid"
    guidance.text   # "It is too dark for me to see the sheet: turn on a light ..."

The thresholds were set on `oxbot.testing.webcam`'s rendered frames (a readable sheet, and the
same sheet dark, blurred, under a hand, shifted out of the picture), with margins both ways.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.perception.frame import as_gray

GuidanceKind = str
"""One of KINDS."""
KINDS = ("too_dark", "blurred", "hand", "off_edge", "too_close", "no_grid")

WORK_SIDE = 320
"""Longest side of the copy of the frame that is looked at."""
DARK_LEVEL = 45.0
"""oxbot: a frame whose mean brightness (0-255) is below this is too dark; a readable sheet
under a desk lamp is about 180, and the reader still found the grid at 25 (webcam renders)."""
MIN_SHARPNESS = 0.17
"""oxbot: a frame whose steepest edges in its middle (the 99th percentile of the gradient,
over the spread of brightness) are below this is blurred; sharp renders give 0.27-0.51 at
any scale, renders blurred by 1.2% of their width 0.09-0.10."""
MIN_CONTRAST = 40.0
"""oxbot: below this spread of brightness (95th minus 5th percentile) a frame shows nothing
(a blank desk): neither blurred nor sharp."""
HAND_SHARE = 0.2
"""oxbot: share of the last grid's area covered by skin colour that makes a hand."""
PAPER_SHARE = 0.12
"""oxbot: least share of the frame that must look like paper for the sheet to be in view."""
EDGE_SHARE = 0.25
"""oxbot: share of a frame's side along which the paper must touch it to be cut off there."""

SIDES = ("top", "right", "bottom", "left")
_MOVE = {"top": "up", "right": "to the right", "bottom": "down", "left": "to the left"}


@dataclass(frozen=True)
class Guidance:
    """Why the robot cannot see the board, for code (`kind`) and in words (`text`)."""

    kind: GuidanceKind
    text: str


def diagnose(frame: np.ndarray, refusal: str = "", last_grid: np.ndarray | None = None) -> Guidance:
    """The likeliest reason the board cannot be read in `frame`, and what to do.

    `refusal` is the grid finder's reason (kept when nothing else fits); `last_grid` the
    grid's outer corners where it was last seen, (4, 2) as shares of the frame's width and
    height, for telling a hand over it from a desk around it.
    """
    gray = _small(as_gray(frame))
    if float(gray.mean()) < DARK_LEVEL:
        return Guidance(
            "too_dark",
            "It is too dark for me to see the sheet: turn on a light or move somewhere brighter.",
        )
    if sharpness(gray) < MIN_SHARPNESS:
        return Guidance(
            "blurred",
            "The picture is blurred: hold the camera still, a little higher, and let it focus.",
        )
    paper = _paper(frame, gray.shape)
    inked = float((gray < 0.6 * np.median(gray)).mean()) > 0.005
    if paper.mean() >= PAPER_SHARE and inked:
        cut = [side for side, edge in zip(SIDES, _edges(paper), strict=True) if edge]
        if len(cut) == 4:
            return Guidance(
                "too_close",
                "The camera is too close: hold it higher so that the whole sheet is in view.",
            )
        if cut:
            where = " and ".join(cut)
            move = " and ".join(_MOVE[side] for side in cut)
            return Guidance(
                "off_edge",
                f"The sheet runs off the {where} of the picture: move the camera {move} so "
                "that the whole grid is in view.",
            )
    # after the edges: where the sheet has moved away, a wooden desk can look like skin
    covered = (
        paper.mean() >= PAPER_SHARE
        and last_grid is not None
        and frame.ndim == 3
        and _skin_over(frame, gray.shape, last_grid) >= HAND_SHARE
    )
    if covered:
        return Guidance(
            "hand",
            "A hand is in the way: take it off the grid once you have drawn, so that I "
            "can see the sheet.",
        )
    return Guidance("no_grid", refusal or "I cannot see the grid: hold the camera over it.")


def sharpness(gray: np.ndarray) -> float:
    """How steep the steepest edges in the middle of `gray` are, relative to its spread of
    brightness (inf for a frame with too little contrast to tell)."""
    h, w = gray.shape
    middle = gray[int(0.15 * h) : int(0.85 * h), int(0.15 * w) : int(0.85 * w)]
    spread = float(np.percentile(middle, 95) - np.percentile(middle, 5))
    if spread < MIN_CONTRAST:
        return float("inf")
    smooth = cv2.GaussianBlur(middle.astype(np.float32), (0, 0), 1.0)  # sensor noise is no edge
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1)
    return float(np.percentile(np.hypot(gx, gy) / 8, 99)) / spread


def _small(gray: np.ndarray) -> np.ndarray:
    h, w = gray.shape
    scale = min(1.0, WORK_SIDE / max(h, w))
    if scale < 1.0:
        gray = cv2.resize(gray, (round(w * scale), round(h * scale)), interpolation=cv2.INTER_AREA)
    return gray


def _paper(frame: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Bool (h, w) of the pixels that look like paper: bright and nearly grey."""
    small = cv2.resize(frame, shape[::-1], interpolation=cv2.INTER_AREA)
    if small.ndim == 2:
        return small > max(150.0, float(np.percentile(small, 90)) * 0.8)
    value = small.max(axis=2).astype(np.float32)
    chroma = value - small.min(axis=2)
    bright = value > max(140.0, float(np.percentile(value, 90)) * 0.8)
    return bright & (chroma < 0.18 * value)


def _edges(mask: np.ndarray) -> list[bool]:
    """Whether `mask` touches each side of the frame (top, right, bottom, left) along at
    least EDGE_SHARE of it."""
    return [
        float(line.mean()) >= EDGE_SHARE for line in (mask[0], mask[:, -1], mask[-1], mask[:, 0])
    ]


def _skin_over(frame: np.ndarray, shape: tuple[int, int], corners: np.ndarray) -> float:
    """The share of the quadrilateral `corners` (shares of the frame's size) in skin colour."""
    small = cv2.resize(frame, shape[::-1], interpolation=cv2.INTER_AREA)
    ycrcb = cv2.cvtColor(small, cv2.COLOR_RGB2YCrCb)
    y, cr, cb = (ycrcb[..., k].astype(np.int16) for k in range(3))
    # the usual YCrCb skin box, for lit skin of every tone
    skin = (y > 60) & (cr >= 135) & (cr <= 175) & (cb >= 80) & (cb <= 125)
    area = np.zeros(shape, np.uint8)
    points = np.asarray(corners, np.float64) * np.array([shape[1], shape[0]])
    cv2.fillConvexPoly(area, np.round(points).astype(np.int32), 1)
    inside = area.astype(bool)
    return float(skin[inside].mean()) if inside.any() else 0.0


__all__ = ["KINDS", "Guidance", "diagnose"]
