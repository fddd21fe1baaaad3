"""Reading the board: a photo of the game sheet in, the 9 cells' labels out (a public interface).

Paper §3.1 "Game Move Recognition": RGB → grayscale → remove the grid → split into 9 images →
classify each as circle, cross or nothing. Here the grid is found first (`grid.py`), the sheet
seen from above (`rectify.py`), the grid lines painted over and the 9 cells cut (`cells.py`),
and the cells go to the classifier in one batch:

    from oxbot.perception import read_board, read_cells
    read_board(frame)   # uint8 (H, W, 3) RGB or (H, W) gray -> ["nothing", "cross", ...]
    read_cells(frame)   # -> [CellReading("nothing", 0.99, 0.0), CellReading("partial", ...)]

`read_board` keeps the three public labels; `read_cells` (and `BoardReader.read`'s
`BoardReading.readings`) say also "partial" for ink that is not a whole symbol (one stroke, or
what `wholeness.py` finds is no whole circle or cross), with the classifier's calibrated
confidence and the cell's ink.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from oxbot.config import PerceptionConfig
from oxbot.errors import NoGridFound
from oxbot.game.board import CELL_NAMES, SIZE
from oxbot.perception.cells import (
    SHEET_CELL,
    cut_cells_and_painted,
    lift_shading,
    remove_grid_lines,
    wipe_background,
)
from oxbot.perception.classifier import CellReading, ink_share
from oxbot.perception.frame import as_image
from oxbot.perception.grid import Grid, find_grid
from oxbot.perception.rectify import rectify
from oxbot.perception.seeds import write_png
from oxbot.perception.wholeness import veto_partial

OUT_OF_VIEW = "unseen"
"""oxbot: a cell's reading when its middle is outside the frame (a grid cut by the frame's
edge): nothing can be said of it. `BoardReading.labels` has "nothing" there, as for a cell
under a hand: the move tracker ignores a symbol that is not seen."""

SHEET_RING = SHEET_CELL // 2
"""oxbot: width, in sheet pixels, of the ring around the grid that the sheet is rectified with,
so that a symbol sticking out of an outer cell is cut whole."""

SINGLE_STROKE = 15.0
"""oxbot: ink whose spread along its main axis is this many times its spread across it is one
stroke — half a cross, a stray line — not yet a symbol. In 150 tuning renders of each, whole
circles stay below 6 and whole crosses below 12.5 (99% below 5); a cross's first stroke alone
is above 18."""


class Classifier(Protocol):
    """What the board reader needs of a classifier: the public `predict`."""

    def predict(self, cells: np.ndarray) -> list[str]: ...


class CellReader(Classifier, Protocol):
    """A classifier that also gives `CellReading`s (`SymbolClassifier.read`)."""

    def read(self, cells: np.ndarray) -> list[CellReading]: ...


@dataclass(frozen=True)
class BoardReading:
    """One frame's reading, with what the reader saw on the way, for debugging."""

    labels: tuple[str, ...]
    """The 9 labels, row-major from the upper left."""
    grid: Grid
    """Where the grid was found in the frame."""
    sheet: np.ndarray
    """The rectified sheet with a ring of half a cell around the grid, uint8 (176, 176), before
    the grid lines were painted over."""
    cleaned: np.ndarray
    """The rectified sheet with the grid lines painted over."""
    cells: np.ndarray
    """The 9 cells the classifier saw, uint8 (9, 40, 40)."""
    readings: tuple[CellReading, ...] = ()
    """Each cell's reading among OUTPUTS (partial included) with its confidence and ink."""


GridFinder = Callable[[np.ndarray], Grid]
"""Finds the grid in a frame, or raises NoGridFound: `grid.find_grid` (classical) or
`grid_points.LearnedGridFinder.find` (learned)."""


def cut_board(
    frame: np.ndarray, find: GridFinder = find_grid
) -> tuple[np.ndarray, Grid, np.ndarray, np.ndarray, np.ndarray]:
    """The 9 cells of the sheet in `frame`, uint8 (9, 40, 40), with the grid (found by `find`),
    the sheets and where in each cell a grid line was painted over (bool (9, 40, 40)).

    Raises InvalidInputError for a frame that is not a photo, NoGridFound when no grid is seen.
    """
    image = as_image(frame)
    grid = find(image)
    border = SHEET_RING
    sheet = rectify(image, grid, border=border)
    cleaned = remove_grid_lines(sheet, border=border)
    painted = cleaned != sheet
    cleaned = lift_shading(cleaned)
    cut, painted = cut_cells_and_painted(cleaned, painted, border=border)
    cells = deepen_faint_ink(wipe_background(cut))
    return cells, grid, sheet, cleaned, painted


FAINT_INK = 170
"""oxbot: a cell whose darkest ink is lighter than this (pencil, a pale pen) has it darkened."""
INK_DARKNESS = 60
"""oxbot: how dark faint ink is made, like the pens the classifier was trained on."""
FAINT_PAPER = 205
"""oxbot: below this (paper near 245) a pixel may be faint ink."""


def deepen_faint_ink(cells: np.ndarray) -> np.ndarray:
    """Cells (N, 40, 40) whose ink is faint, with its contrast to the paper stretched so that
    the darkest ink reaches INK_DARKNESS; cells of plain paper are kept."""
    out = cells.copy()
    c = cells.astype(np.float32)
    # The darkest 2x2 patch, not the darkest pixel: a pixel of noise is no ink.
    patches = (c[:, :-1, :-1] + c[:, 1:, :-1] + c[:, :-1, 1:] + c[:, 1:, 1:]) / 4
    darkest = patches.min(axis=(1, 2))
    # A faint symbol is a stroke of some length; specks, noise and bits of line are not.
    inked = (cells < FAINT_PAPER).sum(axis=(1, 2))
    for i in np.nonzero((darkest > FAINT_INK) & (darkest < FAINT_PAPER) & (inked >= 40))[0]:
        gain = (245 - INK_DARKNESS) / (245 - darkest[i])
        out[i] = np.clip(245 - (245 - c[i]) * gain, 0, 255).astype(np.uint8)
    return out


class BoardReader:
    """Reads boards with one classifier: `read(frame)` gives a `BoardReading`.

    With `config.wholeness` a circle or cross whose ink is not whole (an open arc,
    a stroke, a tick, a plus sign unless `config.plus_is_cross`; `wholeness.py`) reads "partial".
    """

    def __init__(
        self, classifier: Classifier | None = None, config: PerceptionConfig | None = None
    ) -> None:
        if classifier is None:
            from oxbot.perception.classifier import load_classifier

            classifier = load_classifier()
        self.classifier = classifier
        self.config = config if config is not None else PerceptionConfig()
        self.find_grid = grid_finder(self.config.grid_finder, self.config.grid_model_path or None)
        self.rejector = None
        if self.config.rejector:
            from oxbot.perception.rejector import load_rejector

            self.rejector = load_rejector(self.config.rejector_path or None)

    def read(self, frame: np.ndarray) -> BoardReading:
        """Find the grid in `frame`, cut the 9 cells and classify them in one batch.

        A cell whose ink is a single stroke, or with `config.wholeness` not a whole symbol
        (`wholeness.py`), reads "partial" (so "nothing" in `labels`), whatever
        the classifier says: the first stroke of a cross must not become a move while the
        person is still drawing (a rule kept from before the network learnt "partial"; its
        confidence is the rule's, 1).
        """
        cells, grid, sheet, cleaned, painted = cut_board(frame, self.find_grid)
        readings = self.classify(cells, painted)
        for i in grid.cells_out_of_view():
            readings[i] = CellReading(OUT_OF_VIEW, 1.0, 0.0)
        labels = tuple("nothing" if r.label == OUT_OF_VIEW else r.spec_label for r in readings)
        return BoardReading(labels, grid, sheet, cleaned, cells, tuple(readings))

    def classify(self, cells: np.ndarray, painted: np.ndarray | None = None) -> list[CellReading]:
        """The readings of cut cells (N, 40, 40) as `read` gives them (the network, the
        single-stroke rule, the wholeness check); `painted`: where a grid line was painted over
        in each cell (`cut_board`), if known."""
        if hasattr(self.classifier, "read"):
            readings = list(self.classifier.read(cells))
        else:  # a three-label classifier: its labels, fully trusted
            ink = ink_share(cells)
            readings = [
                CellReading(label, 1.0, float(ink[i]))
                for i, label in enumerate(self.classifier.predict(cells))
            ]
        stretched = ink_elongation(cells) > SINGLE_STROKE
        readings = [
            CellReading("partial", 1.0, r.ink) if stretched[i] and r.label != "nothing" else r
            for i, r in enumerate(readings)
        ]
        if self.config.wholeness:
            readings = veto_partial(
                cells, readings, self.config.max_circle_gap, self.config.plus_is_cross, painted
            )
        if self.rejector is not None:
            readings = self.rejector.veto(cells, readings, painted)
        return readings


def grid_finder(name: str, model: str | None = None) -> GridFinder:
    """The grid finder `PerceptionConfig.grid_finder` names; the learned one from the model file
    `model` (None: the shipped one)."""
    if name == "learned":
        from oxbot.perception.grid_points import learned_finder

        return learned_finder(model).find
    return find_grid


def ink_elongation(cells: np.ndarray) -> np.ndarray:
    """For each cell of (N, 40, 40), how stretched its ink is: the ratio of the ink's spread
    along its main axis to its spread across it (1 for a circle or an X, large for a line)."""
    inner = cells[:, 2:-2, 2:-2].astype(np.float32)  # the border may hold grid remnants
    weight = np.clip(235.0 - inner, 0.0, None)
    weight[weight < 40.0] = 0.0  # paper grain and faint smudges are not ink
    total = weight.sum(axis=(1, 2))
    ys, xs = _pixel_grid(inner.shape[1], inner.shape[2])
    safe = np.maximum(total, 1e-6)
    mx = (weight * xs).sum(axis=(1, 2)) / safe
    my = (weight * ys).sum(axis=(1, 2)) / safe
    dx, dy = xs[None] - mx[:, None, None], ys[None] - my[:, None, None]
    weight_dx = weight * dx
    cxx = (weight_dx * dx).sum(axis=(1, 2)) / safe
    cyy = (weight * dy * dy).sum(axis=(1, 2)) / safe
    cxy = (weight_dx * dy).sum(axis=(1, 2)) / safe
    half_trace, det = (cxx + cyy) / 2, cxx * cyy - cxy * cxy
    root = np.sqrt(np.maximum(half_trace**2 - det, 0.0))
    major, minor = half_trace + root, half_trace - root
    return np.where(total > 0, major / np.maximum(minor, 1e-3), 0.0)


@functools.cache
def _pixel_grid(height: int, width: int) -> np.ndarray:
    """float32 (2, height, width): each pixel's y and x (the same for every frame)."""
    grid = np.mgrid[0:height, 0:width].astype(np.float32)
    grid.flags.writeable = False
    return grid


@functools.cache
def default_reader(config: PerceptionConfig | None = None) -> BoardReader:
    """The board reader with the shipped classifier, loaded once (per `[perception]` config:
    its wholeness settings)."""
    return BoardReader(config=config)


def read_board(frame: np.ndarray) -> list[str]:
    """The 9 labels of the game sheet photographed in `frame`, row-major from the upper left.

    `frame` is uint8 (H, W, 3) RGB or (H, W) grayscale. Raises `oxbot.errors.NoGridFound` if
    no 3x3 grid is in view or a cell of it is out of view (the message names the cells; a
    grid cut by the frame's edge is read as long as every cell's middle is in view), and
    `InvalidInputError` for an array that is not a photo.
    """
    reading = default_reader().read(frame)
    refuse_cells_out_of_view(reading.grid)
    return list(reading.labels)


def refuse_cells_out_of_view(grid: Grid) -> None:
    """NoGridFound naming the grid's cells that are out of view, if there are any."""
    out = grid.cells_out_of_view()
    if out:
        names = ", ".join(CELL_NAMES[i] for i in out)
        raise NoGridFound(
            f"the grid runs off the edge of the picture: {names} out of view; move the camera "
            "or the sheet so that all nine cells are in view"
        )


def read_cells(frame: np.ndarray) -> list[CellReading]:
    """The 9 cells' readings of the sheet in `frame`: label among circle, cross, nothing and
    partial (or `OUT_OF_VIEW` for a cell outside the frame), calibrated confidence, ink
    share. Raises as `read_board`, except for cells out of view."""
    return list(default_reader().read(frame).readings)


def save_debug(
    reading: BoardReading, frame: np.ndarray, folder: str | Path, stem: str
) -> list[Path]:
    """Write what the reader saw as PNGs in `folder`; return the paths.

    `<stem>_grid.png` the photo with the found grid drawn on it, `<stem>_sheet.png` the
    rectified sheet, `<stem>_cleaned.png` the same with the grid lines painted over, and
    `<stem>_cell<i>_<name>_<label>.png` the nine 40x40 cells the classifier saw.
    """
    folder = Path(folder)
    overlay = frame.copy() if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2RGB)
    lattice = reading.grid.lattice
    thickness = max(1, round(reading.grid.cell_size() / 40))
    for k in range(SIZE + 1):  # the lattice's rows and columns; the inner ones are the drawn lines
        color = (255, 0, 0) if 0 < k < SIZE else (0, 200, 0)
        for line in (lattice[k, :], lattice[:, k]):
            pts = np.round(line * 16).astype(np.int32).reshape(-1, 1, 2)
            cv2.polylines(overlay, [pts], False, color, thickness, cv2.LINE_AA, shift=4)
    for point in lattice.reshape(-1, 2):  # the points found (or extended to)
        at = tuple(np.round(point * 16).astype(np.int32))
        cv2.circle(overlay, at, 3 * thickness * 16, (255, 140, 0), thickness, cv2.LINE_AA, 4)
    for i, cell_reading in enumerate(reading.readings):
        r, c = divmod(i, SIZE)
        corners = lattice[r : r + 2, c : c + 2].reshape(-1, 2)
        _label(overlay, f"{cell_reading.label} {cell_reading.confidence:.2f}", corners)
    images = {
        f"{stem}_grid.png": cv2.cvtColor(overlay, cv2.COLOR_RGB2BGR),
        f"{stem}_sheet.png": reading.sheet,
        f"{stem}_cleaned.png": reading.cleaned,
    }
    for i, (cell, label) in enumerate(zip(reading.cells, reading.labels, strict=True)):
        images[f"{stem}_cell{i}_{CELL_NAMES[i]}_{label}.png"] = cell
    written = []
    for name, image in images.items():
        write_png(folder / name, image)
        written.append(folder / name)
    return written


def save_refusal(frame: np.ndarray, reason: str, folder: str | Path, stem: str) -> Path:
    """Write `<stem>_refused.png` in `folder`: the frame the reader refused, with why across
    its top, so that a folder of debug images shows the refused frames beside the read ones."""
    overlay = frame.copy() if frame.ndim == 3 else cv2.cvtColor(frame, cv2.COLOR_GRAY2RGB)
    height, width = overlay.shape[:2]
    scale = max(0.4, width / 1400)
    lines, line = [], ""
    for word in reason.split():  # wrap to the frame's width
        wider = f"{line} {word}".strip()
        (w, _), _ = cv2.getTextSize(wider, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        if w > width - 20 and line:
            lines.append(line)
            wider = word
        line = wider
    lines.append(line)
    step = int(30 * scale) + 6
    cv2.rectangle(overlay, (0, 0), (width, min(height, step * len(lines) + 8)), (255, 255, 255), -1)
    for k, text in enumerate(lines):
        position = (10, step * (k + 1))
        cv2.putText(overlay, text, position, cv2.FONT_HERSHEY_SIMPLEX, scale, (200, 0, 0), 1)
    path = Path(folder) / f"{stem}_refused.png"
    write_png(path, cv2.cvtColor(overlay, cv2.COLOR_RGB2BGR))
    return path


def _label(image: np.ndarray, text: str, corners: np.ndarray) -> None:
    """`text` in the upper left of the cell with these corners, sized to the cell."""
    cell = float(np.ptp(corners[:, 0]))
    scale = max(0.3, cell / 260)
    (w, h), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    # Inside the frame, also for a cell the frame's edge cuts off.
    height, width = image.shape[:2]
    x, y = (int(v) + 3 for v in corners.min(axis=0))
    x, y = min(max(x, 0), max(width - w - 2, 0)), min(max(y, 0), max(height - h - base - 2, 0))
    cv2.rectangle(image, (x, y), (x + w + 2, y + h + base + 2), (255, 255, 255), -1)
    cv2.putText(image, text, (x + 1, y + h + 1), cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 200), 1)
