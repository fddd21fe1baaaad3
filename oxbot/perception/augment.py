"""Training data generated from seed images (paper §2.1), reproducible from a seed.

The paper shifts each seed's drawing to random positions ("an image with a cross in the middle
can generate more images by shifting it left or right, up or down"). To reach handwriting the
project never saw, oxbot also varies what differs between people, pens and cameras: rotation,
size and proportions, stroke width, ink darkness, blur, noise, lighting, and the remnants of
grid lines that grid removal leaves at a cell's border.

    images, labels = generate(load_seeds(), 10_000, np.random.default_rng(0))
    # images: uint8 (10000, 40, 40); labels: int64 (10000,), indices into LABELS

Experimental (`[perception] partial_output`): with `partial=True` blank cells also come
on squared, dotted or ruled paper and with erased marks, and a fourth class, "partial" (index 3
of OUTPUTS), is ink that is not a whole symbol: a seed's circle with a sector cut away, or a
synthesised arc, stroke, plus or tick. Without it the images are those of the three public labels
the shipped model was trained on.
"""

from __future__ import annotations

import cv2
import numpy as np

from oxbot.errors import DataError
from oxbot.perception.seeds import LabelledImages
from oxbot.perception.synth import (
    LABELS,
    OUTPUTS,
    PARTIAL,
    Pen,
    add_clutter,
    add_ghost,
    add_grid_remnants,
    add_texture,
    darken,
    ink_mask,
    paper,
    partial_strokes,
)

TRAINING_PARTIALS = ("arc", "stroke", "plus", "tick")
"""The synthesised partial shapes trained on. Scribbles and corners are left out: the small
network then mistook more whole crosses (unequal, sketchy, cursive) for partial ink."""

_BORDER = 2  # pixels at a seed's border ignored as drawing: grid remnants live there


def extract_ink(image: np.ndarray) -> np.ndarray:
    """The fraction of light the ink takes away at each pixel, float32 in [0, 1].

    The paper under the ink is estimated by a grey-level closing, which erases dark strokes
    narrower than its kernel; what is darker than that estimate is ink.
    """
    gray = image.astype(np.float32)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (11, 11))
    background = cv2.morphologyEx(gray, cv2.MORPH_CLOSE, kernel, borderType=cv2.BORDER_REFLECT)
    background = cv2.GaussianBlur(background, (0, 0), 2.0)
    background = np.maximum(background, gray)
    ink = (background - gray) / np.maximum(background, 1.0)
    ink[ink < 0.04] = 0.0  # paper grain and sensor noise are not ink
    return ink.astype(np.float32)


class _Drawing:
    """A seed's ink, cropped to the drawing, ready to be placed anywhere."""

    def __init__(self, image: np.ndarray, label: str) -> None:
        ink = extract_ink(image)
        self.label = label
        if label == "nothing":
            self.ink, self.centre, self.extent = ink, None, 0.0
            return
        core = ink.copy()
        core[:_BORDER], core[-_BORDER:], core[:, :_BORDER], core[:, -_BORDER:] = 0, 0, 0, 0
        ys, xs = np.nonzero(core > 0.15)
        if xs.size == 0:
            ys, xs = np.nonzero(ink > 0.15)
        if xs.size == 0:
            raise DataError(f"a {label!r} seed has no visible drawing: no ink darker than paper")
        self.ink = core if core.max() > 0.15 else ink
        self.centre = ((xs.min() + xs.max()) / 2, (ys.min() + ys.max()) / 2)
        self.extent = float(max(xs.max() - xs.min(), ys.max() - ys.min()) + 1)


def _place_symbol(drawing: _Drawing, rng: np.random.Generator, size: int) -> np.ndarray:
    """The drawing's ink moved to a random place, size, angle and proportion in a new cell."""
    width = rng.uniform(0.35, 0.9) * size
    scale = width / max(drawing.extent, 4.0)
    # Ovals may be squashed and slanted far; a cross squashed as far stops looking like one.
    stretch = 0.4 if drawing.label == "circle" else 0.15
    aspect = np.exp(rng.uniform(-stretch, stretch))
    shear = rng.uniform(-stretch, stretch)  # slanted handwriting
    angle = np.deg2rad(rng.uniform(-20, 20))
    # Shifted anywhere the drawing stays in the cell: grid finding cuts cells at the lines.
    slack = max(size - width * 1.1, 0.0) / 2
    target = (size - 1) / 2 + rng.uniform(-slack, slack, size=2)
    c, s = np.cos(angle), np.sin(angle)
    linear = np.array([[c, -s], [s, c]]) @ np.array([[1.0, shear], [0.0, 1.0]])
    linear = linear @ np.diag([scale * aspect, scale / aspect])
    shift = target - linear @ np.asarray(drawing.centre)
    matrix = np.hstack([linear, shift[:, None]]).astype(np.float32)
    ink = cv2.warpAffine(drawing.ink, matrix, (size, size), flags=cv2.INTER_LINEAR)
    if rng.random() < 0.25:  # a broader pen
        ink = cv2.dilate(ink, np.ones((2, 2), np.uint8))
    return _inside(ink, size)


def _inside(ink: np.ndarray, size: int) -> np.ndarray:
    """The ink moved, if needed, to keep clear of the border band where grid remnants lie."""
    ys, xs = np.nonzero(ink > 0.05)
    if xs.size == 0:
        return ink
    low, high = _BORDER + 2, size - 1 - (_BORDER + 2)
    dx = max(0, low - xs.min()) - max(0, xs.max() - high)
    dy = max(0, low - ys.min()) - max(0, ys.max() - high)
    if dx == 0 and dy == 0:
        return ink
    moved = np.roll(ink, (int(dy), int(dx)), axis=(0, 1))
    # A drawing wider than the cell's inside wraps around: keep the warped one, clipped.
    return moved if np.ptp(xs) <= high - low and np.ptp(ys) <= high - low else ink


def _move_blank(drawing: _Drawing, rng: np.random.Generator, size: int) -> np.ndarray:
    """A blank seed's marks (smudges, remnants) flipped and turned."""
    ink = np.rot90(drawing.ink, int(rng.integers(4)))
    if rng.random() < 0.5:
        ink = ink[:, ::-1]
    ink = np.ascontiguousarray(ink)
    # Not shifted: the seed's grid remnants must stay at the border, where they belong.
    return ink if ink.shape == (size, size) else cv2.resize(ink, (size, size))


def _cut_to_arc(ink: np.ndarray, keep: float, rng: np.random.Generator) -> np.ndarray:
    """A circle's ink with all but `keep` of its turn (from a random angle) erased."""
    ys, xs = np.nonzero(ink > 0.15)
    if xs.size == 0:
        return ink
    cx, cy = (xs.min() + xs.max()) / 2, (ys.min() + ys.max()) / 2
    yy, xx = np.mgrid[0 : ink.shape[0], 0 : ink.shape[1]]
    angle = (np.arctan2(yy - cy, xx - cx) - rng.uniform(0, 2 * np.pi)) % (2 * np.pi)
    return np.where(angle < 2 * np.pi * keep, ink, 0.0).astype(np.float32)


def _partial(
    drawings: dict[str, list[_Drawing]], rng: np.random.Generator, size: int
) -> np.ndarray:
    """Ink that is not a whole symbol: a third of the time a seed's circle cut to an arc,
    else a synthesised arc, stroke, plus or tick (`TRAINING_PARTIALS`). A seed's cross cut
    in half is left out: it looks too much like a cross with one short stroke, a whole one."""
    if rng.random() < 1 / 3:
        items = drawings["circle"]
        ink = _place_symbol(items[rng.integers(len(items))], rng, size)
        # up to a half turn and a bit: open circles reach 0.8
        return _cut_to_arc(ink, rng.uniform(0.12, 0.55), rng)
    width = rng.uniform(0.35, 0.9) * size
    slack = max(size - width * 1.1, 0.0) / 2
    centre = (size - 1) / 2 + rng.uniform(-slack, slack, size=2)
    pen = Pen.random(rng, width)
    half = max(width / 2 - pen.width / 2, 1.0)
    kind = TRAINING_PARTIALS[int(rng.integers(len(TRAINING_PARTIALS)))]
    strokes = [s * half + centre for s in partial_strokes(rng, kind)]
    return _inside(ink_mask((size, size), strokes, pen, rng), size)


def _finish(
    image: np.ndarray, rng: np.random.Generator, label: str, partial: bool = False
) -> np.ndarray:
    """What the camera and the sheet add: remnants, clutter, blur, noise, lighting; with
    `partial` (the four-output data) also erased marks on blank cells."""
    if rng.random() < 0.6:
        image = add_grid_remnants(image, rng, probability=0.35)
    if label == "nothing" and rng.random() < 0.4:
        image = add_clutter(image, rng)
    if partial and label == "nothing" and rng.random() < 0.25:
        image = add_ghost(image, rng)
    out = image.astype(np.float32)
    if rng.random() < 0.4:
        out = cv2.GaussianBlur(out, (0, 0), rng.uniform(0.3, 1.1))
    if rng.random() < 0.3:  # exposure: a gamma curve
        out = 255.0 * (out / 255.0) ** rng.uniform(0.7, 1.4)
    out += rng.normal(0, rng.uniform(0, 6), size=out.shape)
    return np.clip(out, 0, 255).astype(np.uint8)


def generate(
    seeds: LabelledImages, n: int, rng: np.random.Generator, size: int = 40, partial: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """`n` new labelled cells from the seeds, classes balanced and shuffled.

    Returns uint8 (n, size, size) images and int64 (n,) label indices into `OUTPUTS`: the
    three of `LABELS`, and with `partial` also PARTIAL (3).
    """
    if n <= 0:
        raise DataError(f"asked to generate {n} images; ask for at least 1")
    drawings = {
        label: [_Drawing(image, label) for image in seeds.images[label]] for label in LABELS
    }
    for label, items in drawings.items():
        if not items:
            raise DataError(f"seed folder {seeds.folder} has no {label!r} images to generate from")
    classes = len(OUTPUTS) if partial else len(LABELS)
    labels = rng.permutation(np.arange(n) % classes).astype(np.int64)
    images = np.empty((n, size, size), np.uint8)
    for i, index in enumerate(labels):
        label = OUTPUTS[index]
        if label == PARTIAL:
            ink = _partial(drawings, rng, size)
        elif label == "nothing":
            items = drawings[label]
            ink = _move_blank(items[rng.integers(len(items))], rng, size)
        else:
            items = drawings[label]
            ink = _place_symbol(items[rng.integers(len(items))], rng, size)
            if partial and label == "circle" and rng.random() < 0.3:
                # An open circle is still one (oxbot's goal): taught beside the arcs of "partial",
                # so that a gap of a fifth of a turn does not make a circle partial.
                ink = _cut_to_arc(ink, rng.uniform(0.8, 0.97), rng)
        # Lighter or darker ink, but never so faint that a person could not see the drawing.
        factor = rng.uniform(0.55, 1.4)
        if label != "nothing":
            factor = max(factor, 0.45 / max(float(ink.max()), 1e-3))
        ink = np.clip(ink * factor, 0.0, 1.0)
        sheet = paper((size, size), rng)
        # Squared, dotted or ruled paper, under any label: the four-output data only, so that the
        # three-output images stay those the shipped model was trained and measured on.
        if partial and rng.random() < 0.3:
            sheet = add_texture(sheet, rng)
        images[i] = _finish(darken(sheet, ink), rng, label, partial)
    return images, labels
