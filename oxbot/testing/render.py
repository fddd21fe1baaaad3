"""Synthetic "photos of the game sheet" for the project's own tests and benchmarks.

A scene is paper lying on a desk, seen by a camera: a hand-drawn 3x3 grid (four wobbly lines
that overshoot or stop short), circles and crosses drawn stroke by stroke, rotation, mild
perspective, uneven lighting, sensor noise, blur and JPEG compression. Geometry lives in *cell
units*: the grid's inner lines are x = 1, x = 2, y = 1, y = 2 and the cells fill [0, 3]². Like
the grid finder, it draws a 3x3 grid only: two lines each way (`_grid_line`, `_cell_bounds`).

Two styles are kept apart on purpose. `TUNING_STYLE` is the one the board reader was developed
and tuned on; `HELD_OUT_STYLE` (other pens, desk, paper, hand, lighting and camera) is used only
to measure it, so that the acceptance figure says how the reader copes with photos it was not
tuned on.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from oxbot.game.board import LABELS, N_CELLS, SIZE

Range = tuple[float, float]
Color = tuple[int, int, int]


@dataclass(frozen=True)
class HandStyle:
    """How a person draws: sizes, placement, wobble and habits, all in cell units."""

    symbols: str = "synth"
    """Whose strokes: "synth" the seed synthesiser's (`oxbot.perception.synth`), "sketch"
    this module's own, independent model of a hand."""
    symbol_size: Range = (0.45, 0.75)
    """Width of a symbol as a share of the cell it is drawn in (as drawn, between its lines)."""
    symbol_offset: float = 0.12
    """Largest shift of a symbol's centre from the cell's centre, as a share of the cell;
    symbols stay inside their cell, as people keep them."""
    wobble: float = 0.04
    """Amplitude of the slow tremor of a stroke, as a share of the symbol's size."""
    circle_sweep: Range = (0.88, 1.12)
    """How far round a circle goes, in turns: below 1 leaves it open, above 1 overlaps."""
    circle_aspect: Range = (0.8, 1.2)
    """Height over width of a circle."""
    cross_angle_jitter: float = 12.0
    """Largest deviation of a cross's strokes from the diagonals, in degrees."""
    grid_wobble: float = 0.03
    """Amplitude of the tremor of a grid line, as a share of a cell."""
    grid_tilt: float = 3.0
    """Largest tilt of a grid line against its ideal direction, in degrees."""
    grid_spacing_jitter: float = 0.08
    """Largest shift of a grid line from its ideal position, as a share of a cell."""
    grid_overshoot: Range = (-0.2, 0.35)
    """How far a grid line runs past the outer edge of the grid (negative: it stops short)."""
    grid_gap_chance: float = 0.05
    """Chance that one end of a grid line stops just short of the line it should cross."""


@dataclass(frozen=True)
class RenderStyle:
    """Everything random about a photo: paper, desk, pens, hand, camera and lighting."""

    name: str
    size: tuple[int, int] = (640, 480)
    """Width and height of the photo in pixels (a common webcam size)."""
    grid_fraction: Range = (0.4, 0.8)
    """Side of the 3x3 grid as a share of the photo's shorter side."""
    max_rotation: float = 15.0
    """oxbot's goal: the grid may be rotated up to ±15 degrees."""
    perspective: float = 0.06
    """Largest shift of a grid corner, as a share of the grid's side (mild perspective)."""
    desk_colors: tuple[Color, ...] = ((150, 110, 70), (120, 85, 55), (170, 140, 100))
    """Base colours of the desk (RGB)."""
    desk_grain: float = 0.12
    """Contrast of the desk's wood grain."""
    paper_colors: tuple[Color, ...] = ((236, 234, 228), (245, 245, 240), (230, 228, 215))
    """Colours of the paper (RGB)."""
    pen_colors: tuple[Color, ...] = ((25, 25, 30), (20, 30, 90), (40, 40, 40))
    """Colours of the pens (RGB)."""
    pen_width: Range = (0.025, 0.05)
    """Width of a pen stroke as a share of a cell."""
    hand: HandStyle = field(default_factory=HandStyle)
    """How the person draws."""
    light_gradient: Range = (0.0, 0.35)
    """Darkening from one side of the photo to the other."""
    brightness: Range = (0.75, 1.05)
    """Overall exposure."""
    shadow_chance: float = 0.0
    """Chance of a soft shadow (a hand or a head) falling across the sheet."""
    noise_sigma: Range = (1.0, 5.0)
    """Sensor noise, grey levels."""
    blur_sigma: Range = (0.0, 1.0)
    """Camera blur, pixels."""
    jpeg_quality: Range = (60, 95)
    """JPEG quality of the camera's compression."""
    paper_kinds: tuple[str, ...] = ("plain",)
    """Kinds of sheet, one picked per scene: "plain", "squared" (graph paper), "ruled",
    "dotted" (a printed pattern under the drawing) or "whiteboard" (grey-white, with glare)."""
    pattern_colors: tuple[Color, ...] = ((160, 185, 215), (175, 175, 180), (150, 200, 190))
    """Colours of the printed squares, rules and dots (RGB)."""
    edge_chance: float = 0.0
    """Chance that the grid's outer edge on one side runs up to the frame's edge or slightly
    past it (by up to `edge_overrun` of a cell): every cell's middle stays in view."""
    edge_overrun: float = 0.12
    """How far past the frame's edge the grid may run, as a share of a cell."""
    clutter: int = 0
    """Most objects lying around the sheet, outside the grid: pens (long thin dark bars) and
    hands (skin-coloured blobs)."""


TUNING_STYLE = RenderStyle(name="tuning")
"""The style the board reader was developed and tuned on."""

HELD_OUT_STYLE = RenderStyle(
    name="held-out",
    size=(800, 600),
    grid_fraction=(0.35, 0.75),
    perspective=0.07,
    desk_colors=((90, 95, 100), (60, 70, 60), (185, 180, 170)),
    desk_grain=0.05,
    paper_colors=((250, 250, 252), (240, 238, 225), (225, 230, 235)),
    pen_colors=((10, 10, 10), (30, 60, 160), (120, 30, 30), (60, 60, 70)),
    pen_width=(0.02, 0.06),
    hand=HandStyle(
        symbols="sketch",
        symbol_size=(0.4, 0.8),
        symbol_offset=0.14,
        wobble=0.06,
        circle_sweep=(0.85, 1.2),
        circle_aspect=(0.75, 1.25),
        cross_angle_jitter=15.0,
        grid_wobble=0.04,
        grid_tilt=4.0,
        grid_spacing_jitter=0.1,
        grid_overshoot=(-0.25, 0.45),
        grid_gap_chance=0.08,
    ),
    light_gradient=(0.05, 0.45),
    brightness=(0.6, 1.1),
    shadow_chance=0.35,
    noise_sigma=(2.0, 7.0),
    blur_sigma=(0.3, 1.4),
    jpeg_quality=(45, 85),
)
"""A style kept apart from tuning: used only to measure the board reader."""

_WIDE_TUNING_HAND = dataclasses.replace(
    TUNING_STYLE.hand, grid_tilt=4.0, grid_wobble=0.04, grid_overshoot=(-0.2, 0.45)
)
WIDE_TUNING_STYLE = dataclasses.replace(
    TUNING_STYLE,
    name="wide-tuning",
    size=(960, 540),
    grid_fraction=(0.3, 0.95),
    max_rotation=40.0,
    perspective=0.12,
    pen_colors=(
        *TUNING_STYLE.pen_colors,
        (20, 60, 170),  # blue marker
        (20, 120, 60),  # green marker
        (170, 30, 30),  # red pen
        (95, 95, 100),  # pencil
    ),
    pen_width=(0.015, 0.07),
    hand=_WIDE_TUNING_HAND,
    shadow_chance=0.4,
    noise_sigma=(1.0, 7.0),
    blur_sigma=(0.0, 1.5),
    jpeg_quality=(40, 95),
    paper_kinds=("plain", "squared", "ruled", "dotted", "whiteboard"),
    edge_chance=0.3,
    clutter=3,
)
"""The wider world for development: turned up to 40 degrees, stronger perspective,
squared, ruled, dotted paper and whiteboards, coloured markers and pencil, grids running up to
the frame's edge, pens and hands lying around."""

WIDE_HELD_OUT_STYLE = dataclasses.replace(
    HELD_OUT_STYLE,
    name="wide-held-out",
    size=(1280, 720),
    grid_fraction=(0.25, 0.95),
    max_rotation=40.0,
    perspective=0.13,
    pen_colors=(
        *HELD_OUT_STYLE.pen_colors,
        (30, 90, 200),  # light blue marker
        (10, 110, 110),  # teal marker
        (110, 40, 140),  # purple pen
        (110, 110, 115),  # pencil
    ),
    pattern_colors=((140, 170, 220), (190, 190, 190), (200, 160, 160)),
    paper_kinds=("plain", "squared", "ruled", "dotted", "whiteboard"),
    edge_chance=0.3,
    edge_overrun=0.15,
    clutter=4,
)
"""A wide style kept apart from tuning, like `HELD_OUT_STYLE`: used only to measure."""

STYLES = {
    style.name: style
    for style in (TUNING_STYLE, HELD_OUT_STYLE, WIDE_TUNING_STYLE, WIDE_HELD_OUT_STYLE)
}

_HARDER_HAND = dataclasses.replace(
    TUNING_STYLE.hand,
    symbol_size=(0.45, 0.9),
    symbol_offset=0.2,
    grid_wobble=0.05,
    grid_tilt=5.0,
    grid_spacing_jitter=0.12,
    grid_overshoot=(-0.3, 0.5),
    grid_gap_chance=0.1,
)
TUNING_VARIANTS = {
    style.name: style
    for style in (
        # The tuning hand drawing bigger, more scattered symbols that touch the lines, and
        # wobblier, more tilted lines that stop short more often.
        dataclasses.replace(TUNING_STYLE, name="tuning-hand", hand=_HARDER_HAND),
        # The same hand under a worse camera: stronger perspective, shadows, noise, blur, JPEG.
        dataclasses.replace(
            TUNING_STYLE,
            name="tuning-camera",
            hand=_HARDER_HAND,
            perspective=0.09,
            pen_colors=(*TUNING_STYLE.pen_colors, (90, 40, 20), (20, 80, 40)),
            pen_width=(0.015, 0.065),
            shadow_chance=0.5,
            noise_sigma=(1.0, 9.0),
            blur_sigma=(0.0, 1.8),
            jpeg_quality=(35, 95),
            light_gradient=(0.0, 0.5),
            brightness=(0.5, 1.1),
        ),
        # The same hand with thin, faint pencil.
        dataclasses.replace(
            TUNING_STYLE,
            name="tuning-pencil",
            hand=_HARDER_HAND,
            pen_colors=((95, 95, 100), (120, 118, 115), (80, 82, 90)),
            pen_width=(0.012, 0.035),
        ),
    )
}
"""Harder variants of the tuning style, for developing the board reader (never held-out)."""


_GRID_CORNERS = np.array([[0, 0], [SIZE, 0], [SIZE, SIZE], [0, SIZE]])
"""The grid's outer corners in cell units, clockwise from the upper left."""

Stroke = np.ndarray
"""A pen stroke: float (N, 2) points in cell units, in drawing order."""


@dataclass(frozen=True)
class Symbol:
    """A symbol drawn in one cell: its label, strokes (cell units) and pen."""

    label: str
    strokes: tuple[Stroke, ...]
    color: Color
    width: float
    """Pen width as a share of a cell."""


@dataclass(frozen=True)
class SheetScene:
    """One sheet on one desk under one camera; `photo` takes pictures of it.

    The scene is fixed (geometry, paper, desk, pens, lighting); every photo adds its own noise,
    so that a sequence of photos of one scene behaves like frames of a video.
    """

    style: RenderStyle
    homography: np.ndarray
    """3x3 map from cell units to photo pixels."""
    grid_lines: tuple[Stroke, ...]
    line_positions: tuple[float, float, float, float]
    """Where the drawn lines cross the grid's middle: x of both vertical lines, y of both
    horizontal ones, in cell units (ideally 1, 2, 1, 2)."""
    grid_color: Color
    grid_width: float
    paper_corners: np.ndarray
    """(4, 2) corners of the paper in cell units."""
    desk: np.ndarray
    """(H, W, 3) float32 desk image, 0-255."""
    paper_color: Color
    light: np.ndarray
    """(H, W) float32 multiplicative lighting."""
    noise_sigma: float
    blur_sigma: float
    jpeg_quality: int
    symbols: Mapping[int, Symbol] = field(default_factory=dict)
    paper_kind: str = "plain"
    """One of `RenderStyle.paper_kinds`."""
    pattern: tuple[float, float, float, Color] = (0.25, 0.0, 0.0, (170, 170, 170))
    """The printed pattern's pitch (cell units), turn against the grid (degrees), phase (a
    share of the pitch) and colour."""
    clutter: tuple[tuple[np.ndarray, Color], ...] = ()
    """Objects lying around: (outline (N, 2) in cell units, colour)."""

    @property
    def labels(self) -> tuple[str, ...]:
        """The label of each cell, row-major from the upper left."""
        return tuple(
            self.symbols[i].label if i in self.symbols else "nothing" for i in range(N_CELLS)
        )

    def cell_size_px(self) -> float:
        """The mean side of a cell in photo pixels."""
        corners = _apply(self.homography, _GRID_CORNERS.astype(float))
        sides = np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1)
        return float(sides.mean() / SIZE)

    def with_symbol(self, cell: int, label: str, rng: np.random.Generator) -> SheetScene:
        """This scene with `label` ("circle" or "cross") drawn in `cell` by the scene's hand."""
        if label == "nothing":
            symbols = {k: v for k, v in self.symbols.items() if k != cell}
        else:
            bounds = _cell_bounds(cell, self.grid_lines, self.line_positions)
            symbols = {**self.symbols, cell: _draw_symbol(bounds, label, self.style, rng)}
        return dataclasses.replace(self, symbols=symbols)

    def photo(
        self, rng: np.random.Generator, drawn: Mapping[int, float] | None = None
    ) -> np.ndarray:
        """A uint8 (H, W, 3) RGB photo of the scene.

        `drawn[cell]` says how many of that cell's strokes the person has drawn so far: 1.5
        is the first stroke and half of the second; cells not in `drawn` are complete.
        """
        drawn = drawn or {}
        width, height = self.style.size
        cell_px = self.cell_size_px()
        image = self.desk.copy()
        paper = _apply(self.homography, self.paper_corners)
        paper_mask = np.zeros((height, width), np.uint8)
        cv2.fillConvexPoly(paper_mask, _fixed(paper), 255, cv2.LINE_AA, shift=4)
        alpha = paper_mask.astype(np.float32) * (1 / 255.0)
        paper_layer = np.empty_like(image)
        paper_layer[:] = np.float32(self.paper_color)
        image = cv2.blendLinear(paper_layer, image, alpha, 1 - alpha)
        if self.paper_kind in ("squared", "ruled", "dotted"):
            image = self._print_pattern(image, alpha, cell_px)
        # All ink in one layer: anti-aliased coverage, and each pen's colour underneath it.
        coverage = np.zeros((height, width), np.uint8)
        colors = np.zeros((height, width, 3), np.uint8)
        inks = [(list(self.grid_lines), self.grid_color, self.grid_width)]
        for cell, symbol in sorted(self.symbols.items()):
            inks.append(
                (_partial(symbol.strokes, drawn.get(cell, 99.0)), symbol.color, symbol.width)
            )
        for strokes, color, pen in inks:
            pts = [_fixed(_apply(self.homography, s)) for s in strokes if len(s) >= 2]
            if not pts:
                continue
            thickness = max(1, round(pen * cell_px))
            cv2.polylines(colors, pts, False, color, thickness + 2, cv2.LINE_8, shift=4)
            cv2.polylines(coverage, pts, False, 255, thickness, cv2.LINE_AA, shift=4)
        a = coverage.astype(np.float32) * (0.92 / 255.0)
        image = cv2.blendLinear(colors.astype(np.float32), image, a, 1 - a)
        for outline, color in self.clutter:  # on top of the sheet, but never over the grid
            cv2.fillPoly(image, [_fixed(_apply(self.homography, outline))], color, cv2.LINE_AA, 4)
        image = cv2.multiply(image, cv2.merge([self.light] * 3))
        if self.blur_sigma > 0.05:
            image = cv2.GaussianBlur(image, (0, 0), self.blur_sigma)
        noise = rng.standard_normal(image.shape, dtype=np.float32)
        image = cv2.scaleAdd(noise, self.noise_sigma, image)
        photo = np.clip(image, 0, 255).astype(np.uint8)
        ok, jpeg = cv2.imencode(
            ".jpg", photo[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality]
        )
        assert ok
        return cv2.imdecode(jpeg, cv2.IMREAD_COLOR)[..., ::-1].copy()

    def _print_pattern(self, image: np.ndarray, paper: np.ndarray, cell_px: float) -> np.ndarray:
        """The paper's printed squares, rules or dots, under the drawing."""
        pitch, turn, phase, color = self.pattern
        height, width = paper.shape
        ticks = (np.arange(-30, 60) + phase) * pitch
        ticks = ticks[(ticks > -4) & (ticks < SIZE + 4)]
        a = math.radians(turn)
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        center = np.array([SIZE / 2, SIZE / 2])
        coverage = np.zeros((height, width), np.uint8)
        span = np.linspace(-4, SIZE + 4, 24)
        if self.paper_kind == "dotted":
            gx, gy = np.meshgrid(ticks, ticks)
            dots = (np.stack([gx.ravel(), gy.ravel()], 1) - center) @ rot.T + center
            radius = max(1, round(0.025 * cell_px))
            for x, y in _apply(self.homography, dots):
                if 0 <= x < width and 0 <= y < height:
                    cv2.circle(coverage, (int(x), int(y)), radius, 255, -1, cv2.LINE_AA)
        else:
            lines = [np.stack([span, np.full_like(span, t)], 1) for t in ticks]
            if self.paper_kind == "squared":
                lines += [np.stack([np.full_like(span, t), span], 1) for t in ticks]
            pts = [_fixed(_apply(self.homography, (ln - center) @ rot.T + center)) for ln in lines]
            cv2.polylines(coverage, pts, False, 255, 1, cv2.LINE_AA, shift=4)
        a_cov = coverage.astype(np.float32) * (0.6 / 255.0) * paper
        layer = np.empty_like(image)
        layer[:] = np.float32(color)
        return cv2.blendLinear(layer, image, a_cov, 1 - a_cov)


@dataclass(frozen=True)
class RenderedPhoto:
    """A photo with its truth: the labels of the 9 cells and where the grid is."""

    image: np.ndarray
    """uint8 (H, W, 3) RGB."""
    labels: tuple[str, ...]
    scene: SheetScene


def random_labels(rng: np.random.Generator) -> tuple[str, ...]:
    """Nine labels drawn independently, "nothing" as often as both symbols together."""
    return tuple(rng.choice(LABELS, size=N_CELLS, p=(0.25, 0.25, 0.5)).tolist())


def render_photo(
    rng: np.random.Generator,
    labels: Sequence[str] | None = None,
    style: RenderStyle = TUNING_STYLE,
) -> RenderedPhoto:
    """A random photo of a sheet whose cells hold `labels` (random when None)."""
    labels = tuple(labels) if labels is not None else random_labels(rng)
    if len(labels) != N_CELLS or any(label not in LABELS for label in labels):
        raise ValueError(f"labels must be {N_CELLS} of {LABELS}; got {labels!r}")
    scene = random_scene(rng, style)
    for cell, label in enumerate(labels):
        if label != "nothing":
            scene = scene.with_symbol(cell, label, rng)
    return RenderedPhoto(scene.photo(rng), labels, scene)


def random_scene(
    rng: np.random.Generator,
    style: RenderStyle = TUNING_STYLE,
    *,
    with_grid: bool = True,
    with_paper: bool = True,
    grid_fraction: Range | None = None,
    center: tuple[float, float] | None = None,
    rotation: float | None = None,
) -> SheetScene:
    """A sheet with a grid (and no symbols yet) lying on a desk in front of the camera.

    `center` places the grid's centre at that share of the photo's width and height (default:
    anywhere the whole grid fits), `rotation` turns it by that many degrees (default: random
    within the style's range); `with_grid=False` gives a blank sheet and `with_paper=False`
    an empty desk.
    """
    width, height = style.size
    hand = style.hand
    side = float(rng.uniform(*(grid_fraction or style.grid_fraction))) * min(width, height)
    if rotation is None:
        rotation = rng.uniform(-style.max_rotation, style.max_rotation)
    src = _GRID_CORNERS.astype(np.float32)
    corners = _placed_corners(rng, style, side, rotation, center)
    homography = cv2.getPerspectiveTransform(src, corners.astype(np.float32))

    grid_lines: tuple[Stroke, ...] = ()
    positions = (1.0, 2.0, 1.0, 2.0)
    if with_grid:
        drawn = [_grid_line(k, vertical, hand, rng) for vertical in (True, False) for k in (1, 2)]
        grid_lines = tuple(stroke for stroke, _ in drawn)
        positions = (drawn[0][1], drawn[1][1], drawn[2][1], drawn[3][1])
    paper_corners = _paper_corners(rng) if with_paper else np.zeros((4, 2))
    # In the order the older styles always drew them, so that they render the same photos;
    # the wider world draws its own after them.
    grid_color = _pick(rng, style.pen_colors)
    grid_width = float(rng.uniform(*style.pen_width))
    desk = _desk(rng, style)
    paper_color = _jitter_color(rng, _pick(rng, style.paper_colors), 6)
    light = _lighting(rng, style)
    noise_sigma = float(rng.uniform(*style.noise_sigma))
    blur_sigma = float(rng.uniform(*style.blur_sigma))
    jpeg_quality = int(rng.uniform(*style.jpeg_quality))
    kind = style.paper_kinds[0] if with_paper else "plain"
    if with_paper and len(style.paper_kinds) > 1:
        kind = _pick(rng, style.paper_kinds)
    if kind == "whiteboard":
        paper_color = _jitter_color(rng, (222, 226, 228), 10)
        light = _glare(rng, light)
    pattern = SheetScene.pattern
    if kind in ("squared", "ruled", "dotted"):
        pattern = (
            float(rng.uniform(0.18, 0.4)),
            float(rng.uniform(-6, 6)),
            float(rng.uniform()),
            _pick(rng, style.pattern_colors),
        )
    return SheetScene(
        style=style,
        homography=homography,
        grid_lines=grid_lines,
        line_positions=positions,
        grid_color=grid_color,
        grid_width=grid_width,
        paper_corners=paper_corners,
        desk=desk,
        paper_color=paper_color,
        light=light,
        noise_sigma=noise_sigma,
        blur_sigma=blur_sigma,
        jpeg_quality=jpeg_quality,
        paper_kind=kind,
        pattern=pattern,
        clutter=_clutter(rng, style.clutter) if style.clutter else (),
    )


def _placed_corners(
    rng: np.random.Generator,
    style: RenderStyle,
    side: float,
    rotation: float,
    center: tuple[float, float] | None,
) -> np.ndarray:
    """Where the grid's four outer corners lie in the photo (pixels): a square of `side`
    turned by `rotation` degrees, in the style's perspective, at `center` (shares of the
    photo's width and height) or anywhere the whole grid fits."""
    width, height = style.size
    angle = math.radians(rotation)
    src = _GRID_CORNERS.astype(np.float32)
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    square = (src - SIZE / 2) / SIZE * side
    corners = square @ rot.T
    corners += rng.uniform(-1, 1, corners.shape) * style.perspective * side
    # Keep the whole grid and a margin for symbols that spill over in view (shrinking the grid
    # if it would not fit).
    margin = 0.15 * side
    fit = min(1.0, *((np.array([width, height]) - 2 * margin) / np.ptp(corners, axis=0)))
    corners *= fit
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    if center is None:
        cx = rng.uniform(margin - lo[0], max(margin - lo[0], width - margin - hi[0]))
        cy = rng.uniform(margin - lo[1], max(margin - lo[1], height - margin - hi[1]))
    else:
        cx, cy = center[0] * width, center[1] * height
    # (Random draws for the wider world only where a style asks for it, so that the
    # older styles render the very photos they always did.)
    if center is None and style.edge_chance > 0 and rng.uniform() < style.edge_chance:
        # The grid's outer edge on one side at the frame's edge or just past it.
        over = rng.uniform(0, style.edge_overrun) * side / SIZE
        side_k = int(rng.integers(4))
        if side_k == 0:
            cx = -lo[0] - over
        elif side_k == 1:
            cx = width - 1 - hi[0] + over
        elif side_k == 2:
            cy = -lo[1] - over
        else:
            cy = height - 1 - hi[1] + over
    return corners + np.array([cx, cy])


def _paper_corners(rng: np.random.Generator) -> np.ndarray:
    """The sheet, in cell units: larger than the grid, sometimes running out of the photo."""
    grow = rng.uniform(0.5, 1.6, 4)
    return np.array(
        [
            [-grow[0], -grow[1]],
            [SIZE + grow[2], -grow[1]],
            [SIZE + grow[2], SIZE + grow[3]],
            [-grow[0], SIZE + grow[3]],
        ]
    )


# --- strokes ---


def _tremor(n: int, amplitude: float, rng: np.random.Generator) -> np.ndarray:
    """A slow random wobble of n samples: a few sinusoids with random phases."""
    t = np.linspace(0, 1, n)
    out = np.zeros(n)
    for freq in (1, 2, 3.5):
        out += rng.normal(0, amplitude / freq) * np.sin(2 * np.pi * (freq * t + rng.uniform()))
    return out


def _grid_line(
    k: int, vertical: bool, hand: HandStyle, rng: np.random.Generator
) -> tuple[Stroke, float]:
    """Grid line number k (1 or 2): a wobbly stroke across the grid, and where it crosses the
    grid's middle."""
    start = -float(rng.uniform(*hand.grid_overshoot))
    end = SIZE + float(rng.uniform(*hand.grid_overshoot))
    if rng.uniform() < hand.grid_gap_chance:  # stops just short of an outer crossing line
        if rng.uniform() < 0.5:
            start = 1 + float(rng.uniform(0.02, 0.06))
        else:
            end = 2 - float(rng.uniform(0.02, 0.06))
    n = 40
    along = np.linspace(start, end, n)
    tilt = math.tan(math.radians(rng.uniform(-hand.grid_tilt, hand.grid_tilt)))
    offset = k + rng.uniform(-1, 1) * hand.grid_spacing_jitter
    across = offset + (along - SIZE / 2) * tilt + _tremor(n, hand.grid_wobble, rng)
    across += rng.normal(0, 0.15 * hand.grid_wobble, n)
    points = np.stack([across, along], axis=1) if vertical else np.stack([along, across], axis=1)
    stroke = points if rng.uniform() < 0.5 else points[::-1].copy()
    return stroke, float(offset)


def _cell_bounds(
    cell: int, lines: Sequence[Stroke], positions: tuple[float, float, float, float]
) -> tuple[float, float, float, float]:
    """Left, top, right, bottom of a cell as the person sees it, in cell units: where the
    drawn (tilted, wobbly) lines pass the cell's middle; the outer cells as wide as the middle
    one."""
    row, col = divmod(cell, SIZE)
    cx, cy = col + 0.5, row + 0.5

    def across(k: int, at: float) -> float:
        if not lines:
            return positions[k]
        stroke = lines[k]
        along, other = (stroke[:, 1], stroke[:, 0]) if k < 2 else (stroke[:, 0], stroke[:, 1])
        order = np.argsort(along)
        return float(np.interp(at, along[order], other[order]))

    v1, v2, h1, h2 = across(0, cy), across(1, cy), across(2, cx), across(3, cx)
    xs = (v1 - (v2 - v1), v1, v2, v2 + (v2 - v1))
    ys = (h1 - (h2 - h1), h1, h2, h2 + (h2 - h1))
    return xs[col], ys[row], xs[col + 1], ys[row + 1]


def _draw_symbol(
    bounds: tuple[float, float, float, float],
    label: str,
    style: RenderStyle,
    rng: np.random.Generator,
) -> Symbol:
    """A symbol inside the cell `bounds`, at a random size and place, in a random pen."""
    hand = style.hand
    left, top, right, bottom = bounds
    side = min(right - left, bottom - top)
    size = float(rng.uniform(*hand.symbol_size)) * side
    room = max(0.0, (side - size) / 2 - 0.04 * side)
    shift = np.clip(rng.uniform(-1, 1, 2) * hand.symbol_offset * side, -room, room)
    center = np.array([(left + right) / 2, (top + bottom) / 2]) + shift
    if label not in ("circle", "cross"):
        raise ValueError(f"cannot draw {label!r}; draw 'circle' or 'cross'")
    if hand.symbols == "synth":
        from oxbot.perception.synth import symbol_strokes

        strokes = tuple(s * (size / 2) for s in symbol_strokes(label, rng))
    elif label == "circle":
        strokes = (_circle(size, hand, rng),)
    else:
        strokes = _cross(size, hand, rng)
    return Symbol(
        label=label,
        strokes=tuple(s + center for s in strokes),
        color=_pick(rng, style.pen_colors),
        width=float(rng.uniform(*style.pen_width)),
    )


def _circle(size: float, hand: HandStyle, rng: np.random.Generator) -> Stroke:
    n = 60
    sweep = 2 * np.pi * rng.uniform(*hand.circle_sweep)
    direction = 1 if rng.uniform() < 0.3 else -1  # most people draw circles anticlockwise
    phi = rng.uniform(0, 2 * np.pi) + direction * np.linspace(0, sweep, n)
    radius = size / 2 * (1 + _tremor(n, hand.wobble, rng) + np.linspace(0, rng.normal(0, 0.08), n))
    aspect = rng.uniform(*hand.circle_aspect)
    tilt = rng.uniform(0, np.pi)
    x, y = radius * np.cos(phi), radius * np.sin(phi) * aspect
    c, s = math.cos(tilt), math.sin(tilt)
    return np.stack([c * x - s * y, s * x + c * y], axis=1)


def _cross(size: float, hand: HandStyle, rng: np.random.Generator) -> tuple[Stroke, Stroke]:
    strokes = []
    for base in (45.0, -45.0):
        angle = math.radians(base + rng.uniform(-hand.cross_angle_jitter, hand.cross_angle_jitter))
        half = size / 2 * math.sqrt(2) * rng.uniform(0.85, 1.1)
        n = 20
        t = np.linspace(-half, half, n) + rng.uniform(-0.05, 0.05) * size
        bow = _tremor(n, hand.wobble * size, rng)
        x = t * math.cos(angle) - bow * math.sin(angle)
        y = t * math.sin(angle) + bow * math.cos(angle)
        stroke = np.stack([x, y], axis=1)
        strokes.append(stroke if rng.uniform() < 0.7 else stroke[::-1].copy())
    return strokes[0], strokes[1]


def _partial(strokes: Sequence[Stroke], progress: float) -> list[Stroke]:
    """The strokes as the pen has drawn them so far: `progress` 1.5 is the first stroke and
    the first half (by length) of the second."""
    done = int(max(0.0, progress))
    out = list(strokes[:done])
    if done < len(strokes) and progress > done:
        stroke = strokes[done]
        cum = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(stroke, axis=0), axis=1))])
        keep = int(np.searchsorted(cum, (progress - done) * cum[-1]))
        if keep >= 1:
            out.append(stroke[: keep + 1])
    return out


# --- paper, desk and camera ---


def _desk(rng: np.random.Generator, style: RenderStyle) -> np.ndarray:
    width, height = style.size
    base = np.float32(_jitter_color(rng, _pick(rng, style.desk_colors), 12))
    # Wood grain: stretched low-resolution noise along a random direction.
    w4, h4 = width // 4, height // 4
    small = rng.normal(0, 1, (12, 80)).astype(np.float32)
    grain = cv2.resize(small, (w4 * 2, h4 * 2), interpolation=cv2.INTER_CUBIC)
    rot = cv2.getRotationMatrix2D((w4, h4), rng.uniform(0, 180), 1.0)
    grain = cv2.warpAffine(grain, rot, (w4 * 2, h4 * 2), borderMode=cv2.BORDER_REFLECT)
    grain = grain[h4 // 2 : h4 // 2 + h4, w4 // 2 : w4 // 2 + w4]
    blotch = cv2.resize(rng.normal(0, 1, (4, 5)).astype(np.float32), (w4, h4))
    shade = cv2.resize(1 + style.desk_grain * (0.6 * grain + 0.4 * blotch), (width, height))
    return np.clip(base[None, None, :] * shade[..., None], 0, 255).astype(np.float32)


def _lighting(rng: np.random.Generator, style: RenderStyle) -> np.ndarray:
    width, height = style.size
    w4, h4 = width // 4, height // 4
    yy, xx = np.mgrid[0:h4, 0:w4].astype(np.float32) * 4
    angle = rng.uniform(0, 2 * np.pi)
    ramp = (xx / width - 0.5) * math.cos(angle) + (yy / height - 0.5) * math.sin(angle)
    light = 1 - rng.uniform(*style.light_gradient) * (ramp + 0.5)
    light *= rng.uniform(*style.brightness)
    if rng.uniform() < style.shadow_chance:
        cx, cy = rng.uniform(0, width), rng.uniform(0, height)
        r = rng.uniform(0.15, 0.4) * min(width, height)
        dist = np.sqrt((xx - cx) ** 2 + (yy - cy) ** 2)
        light *= 1 - rng.uniform(0.2, 0.4) * np.clip(1.5 - dist / r, 0, 1)
    return cv2.resize(light.astype(np.float32), (width, height), interpolation=cv2.INTER_LINEAR)


def _glare(rng: np.random.Generator, light: np.ndarray) -> np.ndarray:
    """A whiteboard's glare: a soft bright patch on the lighting."""
    height, width = light.shape
    yy, xx = np.mgrid[0:height:4, 0:width:4].astype(np.float32)
    cx, cy = rng.uniform(0, width), rng.uniform(0, height)
    r = rng.uniform(0.1, 0.3) * min(width, height)
    patch = 1 + rng.uniform(0.1, 0.3) * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * r * r))
    return light * cv2.resize(patch, (width, height), interpolation=cv2.INTER_LINEAR)


_SKINS = ((225, 185, 160), (190, 140, 110), (140, 95, 70), (240, 205, 185))
_PENS = ((20, 20, 25), (25, 50, 150), (160, 30, 30), (230, 200, 40), (40, 40, 40))


def _clutter(rng: np.random.Generator, most: int) -> tuple[tuple[np.ndarray, Color], ...]:
    """Up to `most` pens and hands lying around the grid, outside it (cell units)."""
    out = []
    for _ in range(int(rng.integers(0, most + 1))):
        for _ in range(10):  # a few tries to find a place clear of the grid
            center = rng.uniform(-3, SIZE + 3, 2)
            turn = rng.uniform(0, math.pi)
            if rng.uniform() < 0.6:  # a pen: a long thin bar
                length, width = rng.uniform(1.5, 3.5), rng.uniform(0.06, 0.15)
                box = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * [length / 2, width / 2]
                color = _pick(rng, _PENS)
            else:  # a hand: a rounded blob
                t = np.linspace(0, 2 * math.pi, 32, endpoint=False)
                rx, ry = rng.uniform(0.8, 1.4), rng.uniform(0.5, 0.9)
                box = np.stack([rx * np.cos(t), ry * np.sin(t)], 1)
                color = _jitter_color(rng, _pick(rng, _SKINS), 12)
            rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
            outline = box @ rot.T + center
            dense = np.concatenate([outline, (outline + np.roll(outline, 1, 0)) / 2, [center]])
            clear = (dense < -0.4) | (dense > SIZE + 0.4)
            if clear.any(axis=1).all():
                out.append((outline, color))
                break
    return tuple(out)


def _apply(homography: np.ndarray, points: np.ndarray) -> np.ndarray:
    pts = np.asarray(points, np.float64).reshape(-1, 1, 2)
    return cv2.perspectiveTransform(pts, homography).reshape(-1, 2)


def _fixed(points: np.ndarray) -> np.ndarray:
    """Points as OpenCV's fixed-point coordinates with 4 fractional bits (shift=4)."""
    return np.round(points * 16).astype(np.int32).reshape(-1, 1, 2)


def _pick(rng: np.random.Generator, colors: Sequence[Color]) -> Color:
    return colors[int(rng.integers(len(colors)))]


def _jitter_color(rng: np.random.Generator, color: Color, amount: float) -> Color:
    jittered = np.clip(np.array(color) + rng.uniform(-amount, amount, 3), 0, 255)
    return (int(jittered[0]), int(jittered[1]), int(jittered[2]))
