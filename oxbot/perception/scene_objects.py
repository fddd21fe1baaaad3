"""Things over a grid scene's sheet: hands and pens, each with its soft shadow.

They are drawn in the picture itself (they are not on the sheet's plane), sized by the grid's
cells: a hand is a palm, four fingers and a thumb on an arm reaching in from the picture's
edge, in one of many skin tones, shaded across; a pen a long bar with a tip and a glint. They
may cover the grid's lines but never one of its four crossings, which a finder must see.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from oxbot.perception.scene_ink import channels, darken, paint

HAND_WIDTH = (1.4, 3.0)
"""A palm's width in grid cells."""
PEN_LENGTH = (3.0, 8.0)
"""A pen's length in grid cells."""
_TRIES = 4


def _line(canvas: np.ndarray, a: np.ndarray, b: np.ndarray, width: float) -> None:
    """A thick antialiased segment with round ends."""
    pa, pb = (tuple(int(v) for v in np.round(p * 16)) for p in (a, b))
    cv2.line(canvas, pa, pb, 255, max(1, round(width)), cv2.LINE_AA, shift=4)


def _hand_shape(
    rng: np.random.Generator, shape: tuple[int, int], cell: float
) -> tuple[np.ndarray, np.ndarray]:
    """A hand's coverage (H, W) float32 and its direction (from wrist to fingers)."""
    h, w = shape
    canvas = np.zeros(shape, np.uint8)
    palm = float(np.clip(rng.uniform(*HAND_WIDTH) * cell, 0.12 * min(h, w), 0.7 * min(h, w)))
    edge = int(rng.integers(4))
    t = rng.uniform(0.1, 0.9)
    entry = np.array([[t * w, 0], [t * w, h], [0, t * h], [w, t * h]][edge], np.float64)
    inward = np.array([[0, 1], [0, -1], [1, 0], [-1, 0]][edge], np.float64)
    angle = math.atan2(inward[1], inward[0]) + rng.uniform(-0.7, 0.7)
    d = np.array([math.cos(angle), math.sin(angle)])
    n = np.array([-d[1], d[0]])
    centre = entry + d * palm * rng.uniform(0.3, 1.6)
    axes = (int(palm * 0.55), int(palm * 0.48))
    cv2.ellipse(canvas, tuple(int(v) for v in centre), axes, math.degrees(angle), 0, 360, 255, -1)
    _line(canvas, centre, centre - d * palm * 4, palm * 0.8)  # the arm, to the edge and beyond
    curl = rng.uniform(0.3, 1.0)  # fingers stretched out or curled under
    for k, across in enumerate((-0.33, -0.11, 0.11, 0.33)):
        length = palm * curl * (0.75, 0.9, 0.85, 0.65)[k] * rng.uniform(0.85, 1.15)
        base = centre + d * palm * 0.35 + n * palm * across
        spread = d + n * across * rng.uniform(0, 0.6)
        tip = base + spread / np.linalg.norm(spread) * length
        _line(canvas, base, tip, palm * 0.2)
    side = rng.choice((-1.0, 1.0))
    thumb = d * rng.uniform(0.2, 0.9) + n * side
    root = centre + n * side * palm * 0.3
    _line(canvas, root, root + thumb / np.linalg.norm(thumb) * palm * 0.6, palm * 0.24)
    return canvas.astype(np.float32) * (1 / 255), n


def _skin(rng: np.random.Generator) -> np.ndarray:
    """A skin tone, RGB in [0, 1], from deep brown to pale."""
    red = rng.uniform(0.3, 0.97)
    green = red * rng.uniform(0.62, 0.82)
    return np.array([red, green, green * rng.uniform(0.72, 0.92)], np.float32)


def _pen_shape(
    rng: np.random.Generator, shape: tuple[int, int], cell: float
) -> tuple[np.ndarray, np.ndarray]:
    """A pen's coverage (H, W) float32, and its glint's (a light stripe along it)."""
    h, w = shape
    body = np.zeros(shape, np.uint8)
    glint = np.zeros(shape, np.uint8)
    length = rng.uniform(*PEN_LENGTH) * cell
    thick = max(3.0, rng.uniform(0.12, 0.28) * cell)
    centre = rng.uniform((0, 0), (w, h))
    angle = rng.uniform(0, np.pi)
    d = np.array([math.cos(angle), math.sin(angle)])
    n = np.array([-d[1], d[0]])
    a, b = centre - d * length / 2, centre + d * length / 2
    _line(body, a, b, thick)
    tip = b + d * thick * rng.uniform(1.2, 2.5)
    cone = np.array([b + n * thick / 2, tip, b - n * thick / 2]) * 16
    cv2.fillPoly(body, [np.round(cone).astype(np.int32)], 255, cv2.LINE_AA, shift=4)
    _line(glint, a + n * thick * 0.2, b + n * thick * 0.2, max(1.0, thick * 0.2))
    return body.astype(np.float32) * (1 / 255), glint.astype(np.float32) * (1 / 255)


def _clear_of(alpha: np.ndarray, points: np.ndarray, radius: int) -> bool:
    """Whether `alpha` is (nearly) nothing within `radius` pixels of each image point."""
    for x, y in np.round(points).astype(int):
        patch = alpha[max(0, y - radius) : y + radius + 1, max(0, x - radius) : x + radius + 1]
        if patch.size and patch.max() > 0.05:
            return False
    return True


def _shadow(image: np.ndarray, alpha: np.ndarray, rng: np.random.Generator, reach: float) -> None:
    """Darken `image` by `alpha`'s soft shadow, cast `reach` pixels off in a random direction."""
    angle = rng.uniform(0, 2 * np.pi)
    dx, dy = np.array([math.cos(angle), math.sin(angle)]) * reach * rng.uniform(0.3, 1.0)
    h, w = alpha.shape
    shadow = cv2.warpAffine(alpha, np.float32([[1, 0, dx], [0, 1, dy]]), (w, h))
    shadow = cv2.GaussianBlur(shadow, (0, 0), max(1.0, reach * rng.uniform(0.3, 0.8)))
    darken(image, shadow * rng.uniform(0.15, 0.5))


def add_objects(
    rng: np.random.Generator,
    image: np.ndarray,
    cell: float,
    keep_clear: np.ndarray,
    hands: int,
    pens: int,
) -> np.ndarray:
    """Lay `hands` hands and `pens` pens over `image` (float32 RGB, in place), none over an
    image point of `keep_clear` (N, 2); `cell` is a grid cell's side in pixels. Returns what
    they cover (H, W), 0-1."""
    shape = image.shape[:2]
    covered = np.zeros(shape, np.float32)
    radius = max(2, round(cell * 0.08))
    for index in range(hands + pens):
        is_hand = index < hands
        for _ in range(_TRIES):
            if is_hand:
                alpha, across = _hand_shape(rng, shape, cell)
            else:
                alpha, glint = _pen_shape(rng, shape, cell)
            # Nearer the camera than the sheet: a little out of focus.
            alpha = cv2.GaussianBlur(alpha, (0, 0), rng.uniform(0.3, 1.5))
            if _clear_of(alpha, keep_clear, radius):
                break
        else:
            continue
        _shadow(image, alpha, rng, cell * (0.3 if is_hand else 0.15))
        if is_hand:
            yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float32)
            side = (xx * across[0] + yy * across[1]) / max(shape)
            shade = 0.95 + rng.uniform(-0.25, 0.25) * (side - side.mean())
            paint(image, alpha, channels(np.clip(shade, 0.6, 1.2), _skin(rng)))
        else:
            body = np.array([rng.random(), rng.random(), rng.random()], np.float32)
            paint(image, alpha, body * rng.uniform(0.2, 1.0))
            paint(image, glint * rng.uniform(0.2, 0.6), np.ones(3, np.float32))
        np.maximum(covered, alpha, out=covered)
    return covered
