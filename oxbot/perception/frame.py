"""A camera frame made fit to read: its checks (`as_image`, `as_gray`) and colour made gray.

The grid finder (`grid.py`) and the rectifier (`rectify.py`) take frames from any source;
each is checked here once, refused with the fix rather than silently guessed at.
`darkest_channel` makes colour gray so that ink of any colour is dark.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.errors import InvalidInputError


@dataclass(frozen=True)
class FrameTuning:
    """The frame's checks' limit."""

    min_side: int = 64
    """Frames smaller than this on either side cannot show a readable grid."""


FRAME = FrameTuning()


def as_gray(frame: object) -> np.ndarray:
    """A frame as a uint8 (H, W) grayscale image, or InvalidInputError saying what is wrong.

    Accepts uint8 (H, W) grayscale and (H, W, 3) RGB, as `read_board` promises, and nothing else:
    other layouts are refused with the fix rather than silently guessed at.
    """
    image = as_image(frame)
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY) if image.ndim == 3 else image


def as_image(frame: object) -> np.ndarray:
    """A frame checked as `as_gray` checks it, kept in colour: uint8 (H, W, 3) RGB or (H, W).

    The grid finder and the rectifier look at each colour channel: thin blue or green marker
    on a whiteboard is faint in gray, and clear in the channel it absorbs.
    """
    if not isinstance(frame, np.ndarray):
        raise InvalidInputError(
            f"a frame must be a numpy array; got {type(frame).__name__} "
            "(load a file with oxbot.perception.sources.load_image)"
        )
    if frame.size == 0:
        raise InvalidInputError(f"the frame is empty (shape {frame.shape}); give a photo")
    if frame.dtype != np.uint8:
        raise InvalidInputError(
            f"the frame has dtype {frame.dtype}; give uint8 pixels 0-255 "
            "(e.g. (frame * 255).astype(np.uint8) for floats in [0, 1])"
        )
    if not (frame.ndim == 2 or (frame.ndim == 3 and frame.shape[2] == 3)):
        hint = " (drop the alpha channel: frame[..., :3])" if frame.shape[-1] == 4 else ""
        raise InvalidInputError(
            f"the frame has shape {frame.shape}; give (H, W, 3) RGB or (H, W) grayscale{hint}"
        )
    h, w = frame.shape[:2]
    if min(h, w) < FRAME.min_side:
        raise InvalidInputError(
            f"the frame is {w}x{h} pixels, too small to show a 3x3 grid; give a photo at least "
            f"{FRAME.min_side}x{FRAME.min_side} (a webcam's 640x480 is fine)"
        )
    return np.ascontiguousarray(frame)


def darkest_channel(image: np.ndarray, paper_region: np.ndarray | None = None) -> np.ndarray:
    """An RGB image as gray in which ink of any colour is dark: each channel scaled so that the
    paper (the brightest tenth of `paper_region`, by default the whole image) is equally light
    in all three, then the darkest channel kept. A blue or green marker, faint in plain gray,
    is dark in the channel it absorbs; the paper's own tint (cream, a bluish whiteboard) is
    divided out first so that it does not darken."""
    region = image if paper_region is None else paper_region
    h, w = region.shape[:2]
    step = max(1, round(math.sqrt(h * w / 4000)))  # a few thousand pixels
    sample = region[::step, ::step].reshape(-1, 3)
    paper = np.percentile(sample, 90, axis=0) if len(sample) else np.full(3, 255.0)
    gains = 255.0 / np.maximum(paper, 16.0)
    gains /= gains.max()  # the brightest channel kept as it is: nothing saturates
    r, g, b = (cv2.convertScaleAbs(image[..., k], alpha=float(gains[k])) for k in range(3))
    return cv2.min(cv2.min(r, g), b)
