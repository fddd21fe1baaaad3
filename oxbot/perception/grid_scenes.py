"""Randomised photos of hand-drawn 3x3 grids with their truth, to train a learned grid finder.

Domain randomisation (Tobin et al. 2017; Tremblay et al. 2018): every factor of a scene is
drawn independently and widely, so that a network trained on the scenes sees a real photo as
one more variation. `random_grid_scene(rng, size)` returns a `GridScene`: the picture, the 4x4
lattice of cell corners (as `oxbot.perception.grid.Grid.lattice`: the inner four exactly where
the drawn lines' centres cross, the outer ones one middle cell further along each drawn line,
measured on the sheet, the corners completing parallelograms), whether a grid is there, a mask
of the grid's visible ink and the paper's kind. The factors and their ranges:

- Paper (`scene_paper.py`), one of `PAPER_KINDS`: plain (white, cream, grey), squared,
  dotted, ruled with a red margin line (2.5-8 squares or dots per cell, thin uniform print in
  blue, grey, green, pink or dark), whiteboard (marker ink, glare), coloured card, or a
  printed tic-tac-toe board (the grid printed: straight, square, thin, uniform). The sheet
  fills the frame (35%, whiteboards 70%: `FILL_SHARE`) or lies on a desk (wood, mottled
  noise or a flat colour), turned a little against the grid (now and then any way), maybe
  over one or two other sheets (30%: `UNDER_SHARE`); a whiteboard may show its frame.
  Printed text lines on 25% of sheets (`TEXT_SHARE`), glare on 10% (`GLOSS_SHARE`).
- Grid ink (`scene_ink.py`): pen (black, blue, red, green, purple), pencil (light grey, thin,
  grainy), felt-tip, marker (thick, any colour), 0.6-9% of a cell wide, never paler than
  `scene_ink.MIN_INK_CONTRAST`. Lines (`scene_geometry.py`) tilted by up to 5 degrees each,
  bowed by up to 6% of a cell, wavy; the middle cell 0.75-1.3 times as wide as high; each
  end 0.55 of a cell short of to 0.35 past the outer cell edge; in 15% of grids a gap in one
  line where it crosses another.
- Symbols (`scene_marks.py`): 0-9 circles and crosses in the cells, alternating as in a game,
  45-85% of a cell wide (20% touch the lines), 12% of them partial shapes; in the grid's ink
  or another (half each: `SAME_INK_SHARE`); hatching or a scribble in 12% of grids. Off the
  grid, in half the scenes (`DISTRACTOR_SHARE`): 1-4 of handwritten words, a lone line, a
  small grid that is not 3x3 (a plus, one line crossed by two or three), a doodle.
- View (`scene_geometry.py`): the grid's side (the square root of its outer quadrilateral's
  area) `GRID_SIDE` of the frame's shorter side, log-uniform, smaller when it cannot fit;
  anywhere in the frame with its outer corners up to a third of a cell out of it, or (in
  10%: `ROW_OUT_SHARE`) a whole outer row of cells free to leave; its rows at a uniform
  angle in [-45, 45] degrees; a camera with a 50-75 degree field of view tilted up to 35
  degrees from the sheet's normal, about any axis (less when the columns would otherwise run
  nearer the horizontal than the rows).
- Light (`scene_camera.py`): a gradient of up to 60%, vignetting, soft hand- or head-shaped
  shadows, a colour cast (warm, cool or random), exposure x0.55-1.6 and gamma 0.75-1.35.
- Camera (`scene_camera.py`): gaussian blur (sigma 0.3-1.6 px, half the scenes), motion blur
  (3-9 px, 15%), noise (sigma up to 5%), grayscale (10%), JPEG at quality 20-95 (90%); in
  20% of scenes (`LOW_RES_SHARE`) all of it at 30-70% of the size, then scaled up.
- Clutter (`scene_objects.py`): a hand in about 30% of scenes (palm, fingers, thumb, arm;
  many skin tones), a pen in about 30% (a long bar), each with a soft shadow, a little out of
  focus; they may cover the grid's lines, never its four crossings.
- No grid (12%: `ABSENT_SHARE`): blank paper, paper with only symbols or doodles, the desk
  alone, or one or two of the grid's lines, or a big plus (`ABSENT_KINDS`).

The factors are drawn independently but for what goes together: whiteboards are written on
with markers, a printed board's grid is printed.

Everything is drawn at the picture's final size (pen strokes on a canvas twice as big, then
averaged down) with OpenCV's antialiased polylines: a median of about 11 ms a 256x256 scene
on one core (`bench/bench_grid_scenes.py`). A scene depends only on the random generator given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from oxbot.perception.scene_camera import blur_and_noise, light, to_file
from oxbot.perception.scene_geometry import (
    DrawnGrid,
    HandLine,
    camera_view,
    line_strokes,
    random_grid,
    view_box,
)
from oxbot.perception.scene_ink import (
    Coverage,
    Ink,
    channels,
    draw_plane_strokes,
    lay_ink,
    project,
    random_ink,
)
from oxbot.perception.scene_marks import cell_marks, distractors
from oxbot.perception.scene_objects import add_objects
from oxbot.perception.scene_paper import (
    PAPER_KINDS,
    PAPER_WEIGHTS,
    Sheet,
    desk,
    glare,
    lay_sheet,
    print_pattern,
    printed_text,
    sheet_around,
    sheet_under,
)

__all__ = ["ABSENT_KINDS", "PAPER_KINDS", "GridScene", "random_grid_scene", "save_preview"]

ABSENT_SHARE = 0.12
"""Share of scenes without a grid."""
ABSENT_KINDS = ("blank", "symbols", "desk", "lines")
"""What a scene without a grid shows: a blank sheet, symbols without lines, the desk alone,
or one or two of the grid's lines (or a big plus)."""
ABSENT_WEIGHTS = (0.25, 0.25, 0.15, 0.35)
GRID_SIDE = (0.15, 1.0)
"""The grid's side as a share of the frame's shorter side."""
MAX_ROTATION_DEG = 45.0
ROW_OUT_SHARE = 0.1
FILL_SHARE = 0.35
"""Share of sheets that fill the frame (a whiteboard: twice as often)."""
UNDER_SHARE = 0.3
TEXT_SHARE = 0.25
DISTRACTOR_SHARE = 0.5
SAME_INK_SHARE = 0.5
HAND_SHARE, PEN_SHARE = 0.25, 0.25
GLOSS_SHARE = 0.1
"""Share of paper sheets with glare (whiteboards always have it)."""
PRINT_REACH = 10.0
"""Paper print, text and doodles are drawn up to this many cells from the grid."""
LOW_RES_SHARE, LOW_RES_SCALE = 0.2, (0.3, 0.7)
LINE_MASK_COVERAGE = 0.3
"""A pixel belongs to the `lines` mask when the grid's ink covers this share of it."""
MIN_LINE_PIXELS = 0.9
"""The grid's lines are at least this wide in the picture, so that the mask has no holes."""


@dataclass(frozen=True)
class GridScene:
    """One randomised photo of a grid (or of no grid) and its truth."""

    image: np.ndarray
    """uint8 (H, W, 3) RGB."""
    lattice: np.ndarray
    """float32 (4, 4, 2): image pixels (x, y) of the cell corners, `lattice[r, c]` at cell
    units x=c, y=r, as `Grid.lattice`; NaN when `present` is False."""
    present: bool
    """Whether a whole 3x3 grid is drawn."""
    lines: np.ndarray
    """uint8 (H, W): 255 where the grid's lines' ink shows, else 0; all 0 without a grid."""
    kind: str
    """The paper's kind (`PAPER_KINDS`), or "desk" for the desk alone."""


def _grid_box(lattice: np.ndarray, margin: float) -> np.ndarray:
    points = lattice.reshape(-1, 2)
    return np.concatenate([points.min(axis=0) - margin, points.max(axis=0) + margin])


def _partial_lines(rng: np.random.Generator, grid: DrawnGrid) -> list[np.ndarray]:
    """One or two of the grid's lines, or a big plus through its middle: not a grid."""
    roll = rng.random()
    if roll < 0.25:
        plus = [
            HandLine(True, 1.5 + rng.normal(0, 0.1), rng.normal(0, 0.03), 0.0),
            HandLine(False, 1.5 + rng.normal(0, 0.1), rng.normal(0, 0.03), 0.0),
        ]
        return [s for line in plus for s in line_strokes(line, ((-0.1, 3.1),))]
    count = 1 if roll < 0.55 else 2
    chosen = rng.choice(4, size=count, replace=False)
    return [s for i in chosen for s in line_strokes(grid.lines[i], grid.stretches[i])]


def _lay_sheets(
    rng: np.random.Generator,
    image: np.ndarray,
    h: np.ndarray,
    kind: str,
    grid_box: np.ndarray,
) -> tuple[Sheet, np.ndarray]:
    """The sheets under the grid, laid on `image`: the top one and its coverage (H, W)."""
    fill = rng.random() < FILL_SHARE * (2 if kind == "whiteboard" else 1)
    sheet = sheet_around(rng, grid_box, kind, fill)
    if not fill and rng.random() < UNDER_SHARE:
        for _ in range(int(rng.integers(1, 3))):
            lay_sheet(image, h, sheet_under(rng, sheet), rng)
    if kind == "whiteboard" and not fill:  # the board's aluminium frame
        grey = np.full(3, rng.uniform(0.45, 0.8), np.float32)
        frame = Sheet(sheet.centre, sheet.half + rng.uniform(0.1, 0.3), sheet.angle, grey)
        lay_sheet(image, h, frame, rng)
    return sheet, lay_sheet(image, h, sheet, rng)


def _marks_inks(rng: np.random.Generator, grid_ink: Ink, kind: str) -> dict[str, Ink]:
    """The inks of the circles, crosses and other marks: the grid's, or each player's own."""
    fresh = "marker" if kind == "whiteboard" else None
    circle = grid_ink if rng.random() < SAME_INK_SHARE else random_ink(rng, fresh)
    if circle.kind == "print":
        circle = random_ink(rng, fresh)
    cross = circle if rng.random() < 0.6 else random_ink(rng, fresh)
    return {"circle": circle, "cross": cross, "partial": circle, "hatch": cross}


def _draw_marks(
    rng: np.random.Generator,
    image: np.ndarray,
    h: np.ndarray,
    marks: list[tuple[str, np.ndarray]],
    inks: dict[str, Ink],
) -> None:
    """Draw labelled plane strokes, each label in its ink (one coverage per ink)."""
    shape = image.shape[:2]
    by_ink: dict[int, tuple[Ink, list[np.ndarray]]] = {}
    for label, stroke in marks:
        ink = inks[label]
        by_ink.setdefault(id(ink), (ink, []))[1].append(stroke)
    for ink, strokes in by_ink.values():
        cover = Coverage(shape)
        draw_plane_strokes(cover, h, strokes, ink.width * rng.uniform(0.7, 1.1), rng)
        lay_ink(image, cover.result(), ink, rng)


def _paper_and_marks(
    rng: np.random.Generator,
    image: np.ndarray,
    h: np.ndarray,
    kind: str,
    grid: DrawnGrid,
    grid_ink: Ink,
    absent: str | None,
) -> None:
    """Lay the sheets, their print and every mark but the grid's lines on the desk `image`."""
    shape = image.shape[:2]
    size = (shape[1], shape[0])
    # What the camera sees of the plane, but no further than PRINT_REACH cells from the grid:
    # beyond that, under a strong tilt, print would cost much and show as a grey blur.
    near = _grid_box(grid.lattice, PRINT_REACH)
    view = view_box(h, size)
    view = (
        near
        if view is None
        else np.concatenate([np.maximum(view[:2], near[:2]), np.minimum(view[2:], near[2:])])
    )
    if kind != "desk":
        sheet, on_sheet = _lay_sheets(rng, image, h, kind, _grid_box(grid.lattice, 0.1))
        if kind in ("squared", "dotted", "ruled"):
            darkest = grid_ink.darkening()
            for coverage, ink in print_pattern(rng, h, sheet, kind, shape, view, darkest):
                lay_ink(image, coverage * on_sheet, ink, rng)
        if kind != "whiteboard" and rng.random() < TEXT_SHARE:
            text = printed_text(rng, h, sheet, view, _grid_box(grid.lattice, 0.3))
            cover = Coverage(shape)
            draw_plane_strokes(cover, h, text, rng.uniform(0.01, 0.035), rng)
            lay_ink(image, cover.result() * on_sheet, random_ink(rng, "print"), rng)
    inks = _marks_inks(rng, grid_ink, kind)
    marks: list[tuple[str, np.ndarray]] = []
    if absent != "desk" and rng.random() < DISTRACTOR_SHARE:
        region = view
        count = int(rng.integers(1, 5))
        strokes = distractors(rng, count, _grid_box(grid.lattice, 0.35), region)
        marks += [("hatch", s) for s in strokes]
    if absent in (None, "symbols", "lines"):
        marks += cell_marks(rng, grid.lattice)
    _draw_marks(rng, image, h, marks, inks)
    if absent == "lines":
        cover = Coverage(shape)
        draw_plane_strokes(cover, h, _partial_lines(rng, grid), grid_ink.width, rng)
        lay_ink(image, cover.result(), grid_ink, rng)


def _grid_lines(
    rng: np.random.Generator, image: np.ndarray, h: np.ndarray, grid: DrawnGrid, ink: Ink
) -> np.ndarray:
    """Draw the grid's four lines in `ink`; their coverage (H, W)."""
    cover = Coverage(image.shape[:2])
    for line, stretches in zip(grid.lines, grid.stretches, strict=True):
        strokes = line_strokes(line, stretches)
        width = ink.width * rng.uniform(0.85, 1.15)
        draw_plane_strokes(
            cover, h, strokes, width, rng, pressure=ink.kind != "print", min_pixels=MIN_LINE_PIXELS
        )
    coverage = cover.result()
    lay_ink(image, coverage, ink, rng)
    return coverage


def _sample_kinds(rng: np.random.Generator) -> tuple[str | None, str]:
    """What is absent (None: a grid is present) and the paper's kind."""
    absent = None
    if rng.random() < ABSENT_SHARE:
        absent = ABSENT_KINDS[int(rng.choice(len(ABSENT_KINDS), p=ABSENT_WEIGHTS))]
    if absent == "desk":
        return absent, "desk"
    return absent, PAPER_KINDS[int(rng.choice(len(PAPER_KINDS), p=PAPER_WEIGHTS))]


def random_grid_scene(rng: np.random.Generator, size: tuple[int, int] = (256, 256)) -> GridScene:
    """One randomised photo of a hand-drawn 3x3 grid (or, in 12%, of none), `size` (width,
    height), and its truth; the factors and their ranges are the module's docstring's."""
    width, height = size
    scale = rng.uniform(*LOW_RES_SCALE) if rng.random() < LOW_RES_SHARE else 1.0
    work = (max(24, round(width * scale)), max(24, round(height * scale)))
    shape = (work[1], work[0])
    absent, kind = _sample_kinds(rng)
    grid = random_grid(rng, printed=kind == "printed_board")
    side = min(work) * math.exp(rng.uniform(math.log(GRID_SIDE[0]), math.log(GRID_SIDE[1])))
    rotation = rng.uniform(-MAX_ROTATION_DEG, MAX_ROTATION_DEG)
    out_side = int(rng.integers(4)) if rng.random() < ROW_OUT_SHARE else None
    h = camera_view(rng, grid.lattice, work, side, rotation, out_side)
    q = project(h, grid.lattice.reshape(-1, 2))[0].reshape(4, 4, 2)
    cell = float(np.linalg.norm(q[2, 2] - q[1, 1]) / math.sqrt(2))

    image, _ = desk(rng, shape)
    ink_kind = {"whiteboard": "marker", "printed_board": "print"}.get(kind)
    grid_ink = random_ink(rng, ink_kind)
    _paper_and_marks(rng, image, h, kind, grid, grid_ink, absent)
    coverage = np.zeros(shape, np.float32)
    if absent is None:
        coverage = _grid_lines(rng, image, h, grid, grid_ink)
    if kind == "whiteboard" or (kind != "desk" and rng.random() < GLOSS_SHARE):
        image += channels(glare(rng, shape)) * (1 - image)
    hands = int(rng.random() < HAND_SHARE) + int(rng.random() < HAND_SHARE / 5)
    pens = int(rng.random() < PEN_SHARE) + int(rng.random() < PEN_SHARE / 5)
    crossings = q[1:3, 1:3].reshape(-1, 2) if absent is None else np.zeros((0, 2))
    covered = add_objects(rng, image, cell, crossings, hands, pens)
    light(rng, image)
    image = blur_and_noise(rng, image)

    visible = coverage * (covered < 0.5)
    if work != (width, height):
        image = cv2.resize(image, size, interpolation=cv2.INTER_LINEAR)
        visible = cv2.resize(visible, size, interpolation=cv2.INTER_LINEAR)
    lines = np.where(visible >= LINE_MASK_COVERAGE, 255, 0).astype(np.uint8)
    ratio = np.array([width / work[0], height / work[1]])
    lattice = ((q + 0.5) * ratio - 0.5).astype(np.float32)  # pixel centres at integers
    if absent is not None:
        lattice = np.full((4, 4, 2), np.nan, np.float32)
    return GridScene(to_file(rng, image), lattice, absent is None, lines, kind)


def save_preview(path: str | Path, seed: int, n: int = 16, size: int = 256) -> Path:
    """Write a PNG mosaic of `n` scenes from `seed` with their lattices' points drawn, so
    people can look: inner points red, outer ones green, the paper's kind (and "no grid")
    written in the corner. Returns the path."""
    rng = np.random.default_rng(seed)
    columns = math.ceil(math.sqrt(n))
    rows = math.ceil(n / columns)
    mosaic = np.full((rows * (size + 4), columns * (size + 4), 3), 255, np.uint8)
    for index in range(n):
        scene = random_grid_scene(rng, (size, size))
        tile = np.ascontiguousarray(scene.image[..., ::-1])  # OpenCV draws and writes BGR
        if scene.present:
            fixed = np.round(scene.lattice * 16).astype(np.int32)
            for r in range(4):
                for c in range(4):
                    colour = (0, 0, 255) if 0 < r < 3 and 0 < c < 3 else (0, 200, 0)
                    cv2.circle(tile, tuple(fixed[r, c]), 40, colour, -1, cv2.LINE_AA, shift=4)
        label = scene.kind + ("" if scene.present else " / no grid")
        cv2.putText(tile, label, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 3)
        cv2.putText(tile, label, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1)
        r, c = divmod(index, columns)
        y, x = r * (size + 4) + 2, c * (size + 4) + 2
        mosaic[y : y + size, x : x + size] = tile
    path = Path(path)
    cv2.imwrite(str(path), mosaic)
    return path
