"""Light and camera for the grid scenes: what happens to a scene between the sheet and the file.

Light (`light`): a gradient across the picture, soft shadows shaped like a hand or a head,
vignetting, a colour cast and over or under exposure, all one field of light made small and
scaled up. Camera (`blur_and_noise`, `to_file`): gaussian and motion blur, sensor noise (in
brightness, and less in colour), sometimes grayscale, and JPEG at quality 20-95.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from oxbot.perception.scene_ink import channels

GRADIENT = 0.6
"""The light across the picture varies by up to this share from one side to the other."""
VIGNETTE = 0.5
"""The corners get up to this share less light than the middle."""
SHADOW_SHARE = 0.35
"""Share of scenes with a soft shadow (a hand's or a head's) across them."""
SHADOW_DEPTH = (0.15, 0.55)
"""How much light a soft shadow takes away."""
EXPOSURE = (0.55, 1.6)
"""Gain of the whole picture: under to over exposed (bright paper then clips)."""
GAMMA = (0.75, 1.35)
BLUR_SHARE, BLUR_SIGMA = 0.5, (0.3, 1.6)
MOTION_SHARE, MOTION_LENGTH = 0.15, (3, 9)
NOISE_SIGMA = (0.0, 0.05)
"""Sensor noise's standard deviation, a share of full brightness."""
GRAY_SHARE = 0.1
JPEG_SHARE, JPEG_QUALITY = 0.9, (20, 95)
_FIELD = 32  # the light field's side before it is scaled up: light varies slowly


def _shadow_blob(rng: np.random.Generator, field: np.ndarray) -> None:
    """Add a hand's (palm and fingers) or a head's (a big oval) shadow to `field`, blurred."""
    n = field.shape[0]
    blob = np.zeros_like(field)
    centre = rng.uniform(0, n, 2)
    angle = rng.uniform(0, 2 * np.pi)
    if rng.random() < 0.5:  # a head: one big soft oval
        axes = (int(rng.uniform(0.2, 0.5) * n), int(rng.uniform(0.25, 0.6) * n))
        cv2.ellipse(blob, tuple(int(v) for v in centre), axes, math.degrees(angle), 0, 360, 1, -1)
    else:
        palm = rng.uniform(0.12, 0.3) * n
        cv2.circle(blob, tuple(int(v) for v in centre), int(palm), 1, -1)
        d = np.array([math.cos(angle), math.sin(angle)])
        for spread in np.linspace(-0.5, 0.5, 4):
            way = d + spread * np.array([-d[1], d[0]])
            tip = centre + way * palm * rng.uniform(1.6, 2.4)
            a, b = tuple(int(v) for v in centre), tuple(int(v) for v in tip)
            cv2.line(blob, a, b, 1, max(1, int(palm * 0.35)))
        cv2.line(
            blob, tuple(int(v) for v in centre), tuple(int(v) for v in centre - d * n), 1, int(palm)
        )
    blob = cv2.GaussianBlur(blob, (0, 0), rng.uniform(1.0, 4.0))
    field *= 1 - rng.uniform(*SHADOW_DEPTH) * blob


def light(rng: np.random.Generator, image: np.ndarray) -> np.ndarray:
    """`image` (float32 RGB in [0, 1], in place) under uneven, tinted, mis-exposed light."""
    h, w = image.shape[:2]
    yy, xx = (np.mgrid[0:_FIELD, 0:_FIELD].astype(np.float32) + 0.5) / _FIELD - 0.5
    angle = rng.uniform(0, 2 * np.pi)
    field = 1 + rng.uniform(0, GRADIENT) * (math.cos(angle) * xx + math.sin(angle) * yy)
    if rng.random() < 0.5:
        field *= 1 - rng.uniform(0, VIGNETTE) * (xx**2 + yy**2) * 2
    if rng.random() < SHADOW_SHARE:
        for _ in range(int(rng.integers(1, 3))):
            _shadow_blob(rng, field)
    field = cv2.resize(field, (w, h), interpolation=cv2.INTER_LINEAR)
    cast = np.exp(rng.normal(0, 0.07, 3)).astype(np.float32)
    if rng.random() < 0.3:  # tungsten (warm) or shade (cool) light
        cast *= np.array([1.12, 1.0, 0.8] if rng.random() < 0.6 else [0.9, 1.0, 1.12], np.float32)
    gain = math.exp(rng.uniform(math.log(EXPOSURE[0]), math.log(EXPOSURE[1])))
    image *= channels(field, cast * gain / cast.mean())
    np.clip(image, 0, 1, out=image)
    gamma = rng.uniform(*GAMMA)
    if abs(gamma - 1) > 0.02:
        cv2.pow(image, gamma, dst=image)
    return image


def blur_and_noise(rng: np.random.Generator, image: np.ndarray) -> np.ndarray:
    """`image` (float32 RGB in [0, 1]) blurred, maybe smeared by motion, and noisy."""
    if rng.random() < BLUR_SHARE:
        image = cv2.GaussianBlur(image, (0, 0), rng.uniform(*BLUR_SIGMA))
    if rng.random() < MOTION_SHARE:
        length = int(rng.integers(*MOTION_LENGTH))
        kernel = np.zeros((length, length), np.float32)
        angle = rng.uniform(0, np.pi)
        half = (length - 1) / 2
        a = (half - half * math.cos(angle), half - half * math.sin(angle))
        b = (half + half * math.cos(angle), half + half * math.sin(angle))
        cv2.line(kernel, tuple(round(v) for v in a), tuple(round(v) for v in b), 1.0, 1)
        image = cv2.filter2D(image, -1, kernel / kernel.sum())
    sigma = rng.uniform(*NOISE_SIGMA)
    if sigma > 0.002:
        h, w = image.shape[:2]
        grain = rng.standard_normal((h, w), dtype=np.float32) * sigma
        image += channels(grain)
        if rng.random() < 0.5:  # colour noise, coarser and weaker
            small = rng.standard_normal((h // 2 + 1, w // 2 + 1, 3), dtype=np.float32)
            image += cv2.resize(small, (w, h)) * (sigma * 0.4)
    return image


def to_file(rng: np.random.Generator, image: np.ndarray) -> np.ndarray:
    """`image` (float32 RGB) as a camera's file: uint8 RGB, maybe gray, maybe JPEG-compressed."""
    out = np.clip(image * 255 + 0.5, 0, 255).astype(np.uint8)
    if rng.random() < GRAY_SHARE:
        gray = cv2.cvtColor(out, cv2.COLOR_RGB2GRAY)
        out = cv2.cvtColor(gray, cv2.COLOR_GRAY2RGB)
    if rng.random() < JPEG_SHARE:
        quality = int(rng.integers(JPEG_QUALITY[0], JPEG_QUALITY[1] + 1))
        ok, data = cv2.imencode(".jpg", out[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, quality])
        if ok:
            out = np.ascontiguousarray(cv2.imdecode(data, cv2.IMREAD_COLOR)[..., ::-1])
    return out
