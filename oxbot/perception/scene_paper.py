"""What the grid is drawn on in a grid scene: the desk, the sheets and the sheet's own print.

Desks are wood (grain along a random direction), mottled noise or a flat colour, made at half
the picture's size and scaled up (they are out of focus and cheap that way). Sheets lie on the
sheet's plane: rectangles seen through the camera, each casting a soft shadow on what lies
under it. The print on a sheet (squared, dotted or ruled with a margin line, printed text) is
drawn on the plane too, so that it shares the grid's perspective, but thin and uniform in the
picture, as a printer's lines are. Whiteboards get glare, coloured card any hue.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.perception.scene_ink import (
    Coverage,
    Ink,
    channels,
    clip_polygon,
    darken,
    image_runs,
    paint,
    project,
)

PAPER_KINDS = ("plain", "squared", "dotted", "ruled", "whiteboard", "card", "printed_board")
"""The sheets a grid is drawn on; "printed_board" carries a printed tic-tac-toe grid."""
PAPER_WEIGHTS = (0.22, 0.15, 0.09, 0.15, 0.13, 0.11, 0.15)
DESK_KINDS = ("wood", "noise", "flat")
PRINT_COLOURS = np.array(
    [[0.55, 0.7, 0.95], [0.6, 0.6, 0.6], [0.6, 0.85, 0.65], [0.95, 0.6, 0.7], [0.3, 0.3, 0.3]],
    np.float32,
)
"""Squared, dotted and ruled paper's print, as transmittance: blue, grey, green, pink, dark."""
PRINT_DARKENING = (0.06, 0.3)
"""Share of the paper's light the print of squared, dotted and ruled paper takes away."""
_LUMA = np.array([0.299, 0.587, 0.114], np.float32)
PRINT_PER_CELL = (2.5, 8.0)
"""Squares (or dots, or rules, half as many) of a sheet's print per grid cell."""


def _hsv(h: float, s: float, v: float) -> np.ndarray:
    """An RGB colour in [0, 1] from hue (0-1), saturation and value."""
    pixel = np.array([[[h * 180, s * 255, v * 255]]], np.float32)
    return cv2.cvtColor(pixel.astype(np.uint8), cv2.COLOR_HSV2RGB)[0, 0] / np.float32(255)


def _smooth(rng: np.random.Generator, shape: tuple[int, int], cells: int) -> np.ndarray:
    """Smooth noise in about [-1, 1]: a coarse random grid scaled up."""
    coarse = rng.uniform(-1, 1, size=(cells, cells)).astype(np.float32)
    return cv2.resize(coarse, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)


def desk(rng: np.random.Generator, shape: tuple[int, int]) -> tuple[np.ndarray, str]:
    """A desk filling the picture: float32 RGB (H, W, 3) in [0, 1], and its kind."""
    h, w = shape
    small = (max(8, h // 2), max(8, w // 2))
    kind = DESK_KINDS[int(rng.integers(len(DESK_KINDS)))]
    if kind == "wood":
        base = _hsv(rng.uniform(0.03, 0.11), rng.uniform(0.3, 0.75), rng.uniform(0.25, 0.85))
        yy, xx = np.mgrid[0 : small[0], 0 : small[1]].astype(np.float32)
        angle = rng.uniform(0, np.pi)
        along = math.cos(angle) * xx + math.sin(angle) * yy
        warp = _smooth(rng, small, int(rng.integers(3, 7))) * rng.uniform(2, 10)
        grain = np.sin(along / rng.uniform(1.0, 4.0) + warp) * 0.5 + 0.5
        tone = 1 - rng.uniform(0.1, 0.35) * grain**2
        texture = tone[..., None] * base
    elif kind == "noise":
        a = _hsv(rng.random(), rng.uniform(0, 0.6), rng.uniform(0.1, 0.9))
        b = _hsv(rng.random(), rng.uniform(0, 0.6), rng.uniform(0.1, 0.9))
        mix = _smooth(rng, small, int(rng.integers(3, 12))) * 0.5 + 0.5
        mix += rng.uniform(-0.3, 0.3, size=small).astype(np.float32) * rng.uniform(0, 1)
        mix = np.clip(mix, 0, 1)[..., None]
        texture = a * (1 - mix) + b * mix
    else:
        colour = _hsv(rng.random(), rng.uniform(0, 0.8), rng.uniform(0.1, 0.95))
        texture = np.broadcast_to(colour, (*small, 3)) * (
            1 + 0.05 * _smooth(rng, small, 3)[..., None]
        )
    image = cv2.resize(np.ascontiguousarray(texture, np.float32), (w, h))
    return image, kind


@dataclass(frozen=True)
class Sheet:
    """A rectangle on the plane: its centre, half sides, turn (radians) and colour."""

    centre: np.ndarray
    half: np.ndarray
    angle: float
    colour: np.ndarray

    def corners(self) -> np.ndarray:
        """(4, 2) plane corners, clockwise."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        box = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * self.half
        return box @ np.array([[c, s], [-s, c]]) + self.centre

    def to_plane(self, local: np.ndarray) -> np.ndarray:
        """Points in the sheet's own frame (centred, along its sides) on the plane."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        return local @ np.array([[c, s], [-s, c]]) + self.centre

    def to_local(self, plane: np.ndarray) -> np.ndarray:
        """Plane points in the sheet's own frame."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        return (plane - self.centre) @ np.array([[c, -s], [s, c]])


def paper_colour(rng: np.random.Generator, kind: str) -> np.ndarray:
    """White, cream or grey paper; a whiteboard's cool white; coloured card."""
    if kind == "card":
        return _hsv(rng.random(), rng.uniform(0.2, 0.8), rng.uniform(0.55, 1.0))
    if kind == "whiteboard":
        return np.clip(rng.uniform(0.9, 1.0) + np.array([-0.02, 0.0, 0.02]), 0, 1).astype(
            np.float32
        )
    tint = rng.uniform(-0.04, 0.04, 3) + np.array([0.01, 0.0, -0.03]) * rng.random()
    return np.clip(rng.uniform(0.82, 1.0) + tint, 0, 1).astype(np.float32)


def sheet_around(rng: np.random.Generator, grid_box: np.ndarray, kind: str, fill: bool) -> Sheet:
    """A sheet the grid (plane box x0, y0, x1, y1) lies on: A4-like, 4-11 cells wide, turned a
    little against the grid, or (`fill`) far bigger than anything in view."""
    colour = paper_colour(rng, kind)
    centre = (grid_box[:2] + grid_box[2:]) / 2
    if fill:
        return Sheet(centre, np.array([200.0, 200.0]), rng.uniform(-0.3, 0.3), colour)
    angle = rng.normal(0, 0.12) if rng.random() < 0.9 else rng.uniform(-np.pi, np.pi)
    width = rng.uniform(4.0, 11.0)
    ratio = math.sqrt(2) if rng.random() < 0.6 else rng.uniform(0.7, 1.5)
    half = np.array([width, width * ratio]) / 2
    if rng.random() < 0.5:
        half = half[::-1]
    sheet = Sheet(centre, half, angle, colour)
    # Shift the sheet so that the grid lies on it, 0.15 of a cell in from its edges at least.
    grid = sheet.to_local(
        np.array([grid_box[[0, 1]], grid_box[[2, 1]], grid_box[[2, 3]], grid_box[[0, 3]]])
    )
    room = np.maximum(half - 0.15 - (grid.max(axis=0) - grid.min(axis=0)) / 2, 0.0)
    middle = (grid.max(axis=0) + grid.min(axis=0)) / 2
    local = middle + rng.uniform(-room, room)
    return Sheet(sheet.to_plane(local[None])[0], half, angle, colour)


def sheet_under(rng: np.random.Generator, top: Sheet) -> Sheet:
    """Another sheet partly under `top`, shifted and turned."""
    shift = rng.uniform(-1, 1, 2) * top.half * 1.2
    return Sheet(
        top.centre + shift,
        top.half * rng.uniform(0.7, 1.2, 2),
        top.angle + rng.uniform(-0.6, 0.6),
        paper_colour(rng, "card" if rng.random() < 0.3 else "plain"),
    )


def lay_sheet(
    image: np.ndarray, h: np.ndarray, sheet: Sheet, rng: np.random.Generator
) -> np.ndarray:
    """Paint `sheet` seen through `h` over `image`, with its soft shadow; its coverage (H, W)."""
    shape = image.shape[:2]
    polygon = clip_polygon(h, sheet.corners())
    cover = Coverage(shape)
    if len(polygon) >= 3:
        cover.fill(project(h, polygon)[0])
    alpha = cover.result()
    if alpha.max() == 0:
        return alpha
    blur = rng.uniform(1.0, 4.0)
    dx, dy = rng.uniform(-3, 3, 2)
    shadow = cv2.GaussianBlur(alpha, (0, 0), blur)
    shadow = cv2.warpAffine(shadow, np.float32([[1, 0, dx], [0, 1, dy]]), shape[::-1])
    darken(image, shadow * rng.uniform(0.1, 0.4))
    # Each sheet faces the light a little differently, and is not quite flat.
    shade = 1 + rng.uniform(-0.04, 0.04) + _smooth(rng, shape, 4) * rng.uniform(0, 0.05)
    paint(image, alpha, channels(shade, sheet.colour))
    return alpha


def _local_box(h: np.ndarray, sheet: Sheet, view: np.ndarray | None) -> np.ndarray:
    """The part of the sheet worth printing: its own frame's box, cut to what is in view."""
    box = np.array([-sheet.half[0], -sheet.half[1], sheet.half[0], sheet.half[1]])
    if view is None:
        return np.clip(box, -12, 12)
    seen = sheet.to_local(
        np.array([view[[0, 1]], view[[2, 1]], view[[2, 3]], view[[0, 3]]], np.float64)
    )
    return np.array(
        [
            max(box[0], seen[:, 0].min()),
            max(box[1], seen[:, 1].min()),
            min(box[2], seen[:, 0].max()),
            min(box[3], seen[:, 1].max()),
        ]
    )


def print_pattern(
    rng: np.random.Generator,
    h: np.ndarray,
    sheet: Sheet,
    kind: str,
    shape: tuple[int, int],
    view: np.ndarray | None,
    grid_darkening: float,
) -> list[tuple[np.ndarray, Ink]]:
    """The sheet's squares, dots or rules (with a red margin line): coverages (H, W), inks.

    The print takes away 6-30% of the paper's light, and less than the grid's ink does
    (`grid_darkening`), so that the drawn grid is never fainter than the paper's own lines.
    """
    box = _local_box(h, sheet, view)
    if box[0] >= box[2] or box[1] >= box[3]:
        return []
    colour = PRINT_COLOURS[int(rng.integers(len(PRINT_COLOURS)))]
    darkening = min(rng.uniform(*PRINT_DARKENING), max(0.06, 0.8 * grid_darkening))
    ink = Ink("print", tuple(colour), min(1.0, darkening / float(1 - _LUMA @ colour)), 0, 0)
    step = (2 if kind == "ruled" else 1) / rng.uniform(*PRINT_PER_CELL)
    phase = rng.uniform(0, step, 2)
    xs = np.arange(math.floor(box[0] / step), math.ceil(box[2] / step) + 1) * step + phase[0]
    ys = np.arange(math.floor(box[1] / step), math.ceil(box[3] / step) + 1) * step + phase[1]
    width = rng.uniform(0.5, 1.2)  # pixels: a printer's line, whatever the distance
    cover = Coverage(shape)
    if kind == "dotted":
        gx, gy = np.meshgrid(xs, ys)
        dots, seen = project(h, sheet.to_plane(np.stack([gx.ravel(), gy.ravel()], axis=1)))
        cover.dots(dots[seen], rng.uniform(0.5, 1.5))
        return [(cover.result(), ink)]
    t = np.linspace(0, 1, 12)
    across = [np.stack([box[0] + t * (box[2] - box[0]), np.full(12, y)], 1) for y in ys]
    if kind == "squared":
        across += [np.stack([np.full(12, x), box[1] + t * (box[3] - box[1])], 1) for x in xs]
    _draw_local(cover, h, sheet, across, width)
    layers = [(cover.result(), ink)]
    if kind == "ruled":  # the red margin line, near the left edge
        x = -sheet.half[0] + rng.uniform(0.08, 0.2) * 2 * sheet.half[0]
        margin = np.stack([np.full(12, x), box[1] + t * (box[3] - box[1])], 1)
        red = Coverage(shape)
        _draw_local(red, h, sheet, [margin], width * rng.uniform(1, 1.8))
        pink = np.array([rng.uniform(0.85, 1.0), rng.uniform(0.2, 0.55), rng.uniform(0.25, 0.6)])
        alpha = min(rng.uniform(0.5, 0.9), max(0.06, 0.8 * grid_darkening) / (1 - _LUMA @ pink))
        layers.append((red.result(), Ink("print", tuple(pink), float(alpha), 0, 0)))
    return layers


def _draw_local(
    cover: Coverage, h: np.ndarray, sheet: Sheet, lines: list[np.ndarray], width: float
) -> None:
    """Draw lines given in the sheet's frame, `width` pixels wide."""
    runs = [run for line in lines for run in image_runs(h, sheet.to_plane(line))]
    cover.stroke(runs, width)


def printed_text(
    rng: np.random.Generator,
    h: np.ndarray,
    sheet: Sheet,
    view: np.ndarray | None,
    avoid: np.ndarray,
) -> list[np.ndarray]:
    """Plane strokes of a block of printed text on the part of the sheet in view: rows of
    words, each a zigzag of letters, left out where they would touch the box `avoid` (x0, y0,
    x1, y1 on the plane)."""
    box = _local_box(h, sheet, view)
    size = rng.uniform(0.08, 0.25)  # letter height, in cells
    pitch = size * 1.8
    if box[2] - box[0] < 1 or box[3] - box[1] < pitch:
        return []
    rows = int(rng.integers(1, 9))
    left = rng.uniform(box[0], box[0] + 0.4 * (box[2] - box[0]))
    right = rng.uniform(left + 0.5 * (box[2] - left), box[2])
    top = rng.uniform(box[1], max(box[1], box[3] - rows * pitch))
    strokes = []
    for r in range(rows):
        base = top + (r + 1) * pitch
        xs = np.arange(left, right, size * 0.3)
        # Letters up and down, a few ascenders; words end where a space is drawn.
        tops = np.where(rng.random(xs.size) < 0.2, size, size * 0.6)
        ys = np.where(np.arange(xs.size) % 2 == 0, base, base - tops)
        cuts = np.flatnonzero(rng.random(xs.size) < 0.15)
        for word_x, word_y in zip(np.split(xs, cuts), np.split(ys, cuts), strict=True):
            if word_x.size >= 3:
                strokes.append(np.stack([word_x[1:], word_y[1:]], axis=1))
    placed = [sheet.to_plane(s) for s in strokes]
    return [s for s in placed if not _hits(s, avoid)]


def _hits(points: np.ndarray, box: np.ndarray) -> bool:
    inside = (points >= box[:2]) & (points <= box[2:])
    return bool(inside.all(axis=1).any())


def glare(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A glossy surface's glare: (H, W) share of white light added, one or two soft blobs."""
    h, w = shape
    small = np.zeros((max(8, h // 4), max(8, w // 4)), np.float32)
    sh, sw = small.shape
    for _ in range(int(rng.integers(1, 3))):
        centre = (int(rng.uniform(0, sw)), int(rng.uniform(0, sh)))
        axes = (int(rng.uniform(0.05, 0.3) * sw) + 1, int(rng.uniform(0.05, 0.2) * sh) + 1)
        cv2.ellipse(small, centre, axes, rng.uniform(0, 180), 0, 360, rng.uniform(0.4, 1.0), -1)
    small = cv2.GaussianBlur(small, (0, 0), max(1.0, rng.uniform(0.02, 0.08) * sw))
    return cv2.resize(small, (w, h)) * rng.uniform(0.4, 0.95)
