"""From the rectified sheet to nine 40x40 cells: the grid lines painted over, the cells cut.

On the sheet from `rectify.py`, the four grid lines are traced and painted over with paper where
they are drawn (`remove_grid_lines`), and each cell is cut at 40x40 as a square around its own
ink (the connected pieces whose centres lie in it), so that a symbol is whole and neighbouring
ink stays out; a cell without ink is cut at its place (`cut_cells_around_ink`, `cut_cells`).
This module also owns the cell's size and the sheet's cell side (`CELL_SIZE`, `SHEET_CELL`),
which `rectify.py` warps to.
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from oxbot.game.board import N_CELLS, SIZE

CELL_SIZE = 40
"""Paper §2.1: cells are 40x40 grayscale images."""
CELL_MARGIN = 0.05
"""Share of a cell's side cropped away along each grid line, to keep its ink out."""
SHEET_CELL = round(CELL_SIZE / (1 - 2 * CELL_MARGIN))
"""Side of one cell, in pixels, on the rectified sheet (a 40x40 crop plus the margins)."""


def remove_grid_lines(sheet: np.ndarray, cell: int = SHEET_CELL, border: int = 0) -> np.ndarray:
    """The rectified sheet with the grid lines traced and painted over with paper."""
    out = sheet.copy()
    band = max(3, round(0.18 * cell))
    dark = 255 - sheet.astype(np.int16)
    for at in _inner_lines(cell, border):
        lo, hi = at - band, at + band + 1
        _erase_line(out, dark[:, lo:hi], lo, vertical=True)
        _erase_line(out, dark[lo:hi, :].T, lo, vertical=False)
    return out


SHADE_KERNEL = SHEET_CELL // 4
"""Side, in sheet pixels, of the paper around a pixel that `lift_shading` divides it by: wider
than any pen's stroke on the sheet (a thick marker is 5-6), narrower than a wrinkle's shadow."""

SHADOW_FLOOR = 160
"""Paper darker than this around a pixel (paper is near 245 once the light is evened out) is no
shadow on the sheet but a desk, the sheet's edge or a hand: lifted, only its outline would be
left, as thin as a stroke."""


def lift_shading(sheet: np.ndarray, cell: int = SHEET_CELL) -> np.ndarray:
    """The sheet with shading narrower than a cell lifted out: each pixel divided by the
    lightest paper around it (a closing a quarter of a cell wide), where that makes it lighter.

    `rectify.even_out_light` divides out light that changes over a cell or more; a wrinkled
    sheet's shadows and a fold's change within a cell, and were left as soft gray patches that
    the classifier read as crosses and circles. A pen's stroke is narrower than the closing, so
    the paper beside it keeps it dark; a patch of shadow wider than it is the paper there.
    Nothing gets darker, and where the paper around is darker than `SHADOW_FLOOR` nothing
    changes.
    """
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (SHADE_KERNEL * cell // SHEET_CELL,) * 2)
    paper = cv2.morphologyEx(sheet, cv2.MORPH_CLOSE, kernel).astype(np.float32)
    paper[paper < SHADOW_FLOOR] = 245.0  # no shadow on paper: left as it is
    lifted = sheet.astype(np.float32) * (245.0 / np.maximum(paper, 8.0))
    return np.maximum(sheet, np.clip(lifted, 0, 255).astype(np.uint8))


def _inner_lines(cell: int, border: int) -> range:
    """Where the drawn grid lines run on the sheet, in pixels (the same across and down)."""
    return range(border + cell, border + SIZE * cell, cell)


def _erase_line(out: np.ndarray, strip: np.ndarray, offset: int, vertical: bool) -> None:
    """Trace a near-vertical line through `strip` (rows along the line) and paint it over.

    The line is followed as a smooth curve fitted to the rows where it is dark, dropping rows
    whose darkness lies off the curve: beyond the ends of a line that stops short, a symbol
    near the cell's edge must not be taken for the line and painted over.
    """
    weight = np.clip(strip - 40, 0, None).astype(np.float32)
    total = weight.sum(axis=1)
    known = total > 0
    if known.sum() < strip.shape[0] // 3:
        return
    pos = np.arange(strip.shape[1], dtype=np.float32)
    rows = np.arange(strip.shape[0], dtype=np.float32)
    center = (weight * pos).sum(axis=1) / np.maximum(total, 1e-6)
    keep = known.copy()
    for _ in range(3):  # a smooth curve through the rows that agree with it
        if keep.sum() < 6:
            return
        curve = _parabola(rows[keep], center[keep], rows)
        keep = known & (np.abs(center - curve) < 2.5)
    # The line's half-width: its typical inked extent, plus a pixel of anti-aliasing.
    inked = strip > 60
    widths = inked[keep].sum(axis=1)
    if len(widths) == 0:
        return  # no row lies on the curve: nothing to paint over
    half = float(np.median(widths)) / 2 + 1.5
    # Paint over only where the line is drawn: runs of rows whose ink is one narrow stroke on
    # the curve (a symbol beside or across the line interrupts a run only briefly). Beyond a
    # line that stops short, a symbol in its way stays whole.
    first = np.argmax(inked, axis=1)
    last = strip.shape[1] - 1 - np.argmax(inked[:, ::-1], axis=1)
    good = keep & inked.any(axis=1) & (last - first + 1 <= 2 * half + 2)
    drawn = _drawn_rows(good, min_run=8, max_gap=6)
    cover = (np.abs(pos[None, :] - curve[:, None]) <= half) & (strip > 25) & drawn[:, None]
    region = (
        out[:, offset : offset + strip.shape[1]]
        if vertical
        else out[offset : offset + strip.shape[1], :].T
    )
    region[cover] = np.maximum(region[cover], 245)


def _parabola(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The least-squares parabola through points (x, y), evaluated at `at` (as np.polyfit with
    np.polyval, at half the time: this runs for every line of every frame)."""
    x = x.astype(np.float64)
    a = np.empty((len(x), 3))
    a[:, 0], a[:, 1], a[:, 2] = x * x, x, 1.0
    c = np.linalg.solve(a.T @ a, a.T @ y)
    return (c[0] * at + c[1]) * at + c[2]


def _drawn_rows(good: np.ndarray, min_run: int, max_gap: int, grow: int = 2) -> np.ndarray:
    """The rows between the line's ends: from the first to the last run of at least `min_run`
    good rows, taking in shorter runs of 3 or more beyond them while less than `max_gap`
    rows apart, grown by `grow` rows at both ends."""
    padded = np.concatenate([[False], good, [False]]).astype(np.int8)
    change = padded[1:] - padded[:-1]
    # Plain ints from here on: a handful of runs, walked in Python.
    starts, ends = np.flatnonzero(change == 1).tolist(), np.flatnonzero(change == -1).tolist()
    runs = [(a, b) for a, b in zip(starts, ends, strict=True) if b - a >= 3]
    long = [k for k, (a, b) in enumerate(runs) if b - a >= min_run]
    out = np.zeros(good.shape, bool)
    if not long:
        return out
    lo, hi = long[0], long[-1]
    while lo > 0 and runs[lo][0] - runs[lo - 1][1] < max_gap:
        lo -= 1
    while hi < len(runs) - 1 and runs[hi + 1][0] - runs[hi][1] < max_gap:
        hi += 1
    out[max(runs[lo][0] - grow, 0) : runs[hi][1] + grow] = True
    return out


def cut_cells(sheet: np.ndarray, cell: int = SHEET_CELL) -> np.ndarray:
    """The nine cells of a rectified sheet, row-major, as uint8 (9, 40, 40)."""
    margin = (cell - CELL_SIZE) / 2
    cells = np.empty((N_CELLS, CELL_SIZE, CELL_SIZE), np.uint8)
    for i in range(N_CELLS):
        row, col = divmod(i, SIZE)
        top, left = round(row * cell + margin), round(col * cell + margin)
        crop = sheet[top : top + CELL_SIZE, left : left + CELL_SIZE]
        if crop.shape != (CELL_SIZE, CELL_SIZE):
            crop = cv2.resize(crop, (CELL_SIZE, CELL_SIZE), interpolation=cv2.INTER_AREA)
        cells[i] = crop
    return cells


INK_LEVEL = 170
"""oxbot: on the evened-out sheet (paper near 245), pixels darker than this are ink."""
PALE_INK = 190
"""oxbot: pixels darker than this that touch ink are ink too (`ink_with_pale_stretches`)."""
SYMBOL_SHARE = 0.72
"""oxbot: a cell cut around its ink is this much wider than the ink (the classifier was trained
on symbols 35-90% as wide as the cell, placed anywhere in it, but whole)."""

MIN_SYMBOL = 0.35
"""oxbot: ink narrower than this share of a cell is no symbol (people draw them at least 0.4
of the cell wide); such a cell is cut at its place."""
LINE_REACH = 0.12
"""oxbot: ink within this share of a cell of where a grid line runs may be left of the line."""
LINE_PIECE_SHARE = 0.7
"""oxbot: a piece of ink this much of which lies that near the grid lines is left of them."""


def cut_cells_around_ink(sheet: np.ndarray, cell: int = SHEET_CELL, border: int = 0) -> np.ndarray:
    """The nine cells of a grid-free sheet, each cut as a square around its own ink
    (`cut_cells_and_painted` without the painted-over lines)."""
    return cut_cells_and_painted(sheet, None, cell, border)[0]


def cut_cells_and_painted(
    sheet: np.ndarray, painted: np.ndarray | None, cell: int = SHEET_CELL, border: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """The nine cells of a grid-free sheet, each cut as a square around its own ink, and where
    in each the grid lines were painted over (bool (9, 40, 40), from `painted`, a bool mask of
    the sheet; all False without it).

    A cell of the game holds at most one symbol, so the ink is split into connected pieces,
    each piece belongs to the cell its centre lies in, and a cell with ink is cut as a square
    around all of its pieces, with the other cells' ink painted over: the symbol is whole and
    alone even when it sticks out of its cell (the outer cells, which no line bounds outside,
    are guessed from the middle one). Pieces of grid line that line removal left (long, thin,
    along a cell's side) are nobody's. A cell without ink is cut at its place, as `cut_cells`.
    `sheet`: uint8 (SIZE*cell + 2*border,) * 2, from `rectify` and `remove_grid_lines`.
    """
    inside = slice(border, border + SIZE * cell)  # the grid, without the ring around it
    cells = cut_cells(sheet[inside, inside], cell)
    painted_u8 = np.zeros(sheet.shape, np.uint8) if painted is None else painted.astype(np.uint8)
    painted_cells = cut_cells(painted_u8[inside, inside] * 255, cell) > 50
    ink = ink_with_pale_stretches(sheet)
    joined = cv2.dilate(ink, np.ones((3, 3), np.uint8))
    count, labels, stats, centres = cv2.connectedComponentsWithStats(joined, connectivity=8)
    near_lines = np.zeros(sheet.shape, bool)
    reach = round(LINE_REACH * cell)
    for at in _inner_lines(cell, border):
        near_lines[:, at - reach : at + reach + 1] = True
        near_lines[at - reach : at + reach + 1, :] = True
    owner: dict[int, list[int]] = {}
    side_max = sheet.shape[0]
    # Plain ints and floats: most pieces are specks, dismissed faster than numpy scalars allow.
    for k, ((x, y, w, h, area), centre) in enumerate(
        zip(stats.tolist(), centres.tolist(), strict=True)
    ):
        if k == 0:
            continue  # the background
        if area < 12 or max(w, h) > 1.15 * cell or _is_line_piece(labels, k, stats[k], cell):
            continue
        on_lines = np.count_nonzero(
            near_lines[y : y + h, x : x + w] & (labels[y : y + h, x : x + w] == k)
        )
        if on_lines > LINE_PIECE_SHARE * area:
            continue  # what is left of a grid line
        if x == 0 or y == 0 or x + w == side_max or y + h == side_max:
            continue  # the desk, a shadow, the paper's edge or what is beyond the ring
        col = math.floor((centre[0] - border) / cell)
        row = math.floor((centre[1] - border) / cell)
        if not (0 <= row < SIZE and 0 <= col < SIZE):
            # The ring around the grid belongs to the outer cells next to it: a symbol
            # drawn out there, but no specks or bits of line.
            if max(w, h) < 0.3 * cell:
                continue
            col, row = min(max(col, 0), SIZE - 1), min(max(row, 0), SIZE - 1)
        owner.setdefault(row * SIZE + col, []).append(k)
    for i, pieces in owner.items():
        box = stats[pieces]
        x0, y0 = box[:, 0].min(), box[:, 1].min()
        x1 = (box[:, 0] + box[:, 2]).max()
        y1 = (box[:, 1] + box[:, 3]).max()
        extent = max(x1 - x0, y1 - y0)
        if extent < MIN_SYMBOL * cell:
            continue  # a speck or a bit of line: cut the cell at its place
        side = round(min(max(extent / SYMBOL_SHARE, 0.6 * cell), 1.6 * cell))
        left = round((x0 + x1 - side) / 2)
        top = round((y0 + y1 - side) / 2)
        crop = np.full((side, side), 245, np.uint8)
        sx0, sy0 = max(left, 0), max(top, 0)
        sx1, sy1 = min(left + side, side_max), min(top + side, side_max)
        if sx1 <= sx0 or sy1 <= sy0:
            continue
        part = sheet[sy0:sy1, sx0:sx1].copy()
        lab = labels[sy0:sy1, sx0:sx1]
        ours = np.zeros(count, bool)  # by label: a lookup, several times faster than np.isin
        ours[pieces] = True
        others = (lab > 0) & ~ours[lab]
        part[others] = 245
        crop[sy0 - top : sy1 - top, sx0 - left : sx1 - left] = part
        cells[i] = cv2.resize(crop, (CELL_SIZE, CELL_SIZE), interpolation=cv2.INTER_AREA)
        if painted is not None:
            lines = np.zeros((side, side), np.uint8)
            lines[sy0 - top : sy1 - top, sx0 - left : sx1 - left] = painted_u8[sy0:sy1, sx0:sx1]
            shrunk = cv2.resize(lines * 255, (CELL_SIZE, CELL_SIZE), interpolation=cv2.INTER_AREA)
            painted_cells[i] = shrunk > 50
    return cells, painted_cells


def ink_with_pale_stretches(sheet: np.ndarray) -> np.ndarray:
    """uint8 0/1 mask of the sheet's ink: pixels darker than INK_LEVEL, and the pale ones
    (darker than PALE_INK) joined to them, as Canny's hysteresis joins weak edges to strong.
    A thin pen's stroke fades towards its ends: without its pale stretches a cross is cut
    short round its dark middle, and a "Y" or a "T" reaches the classifier."""
    ink = sheet < INK_LEVEL
    count, pale = cv2.connectedComponents((sheet < PALE_INK).view(np.uint8), connectivity=8)
    joined = np.zeros(count, bool)  # by label: a lookup, as in cut_cells_and_painted
    joined[pale[ink]] = True
    joined[0] = False
    return joined[pale].view(np.uint8)


def _is_line_piece(labels: np.ndarray, k: int, stat: np.ndarray, cell: int) -> bool:
    """Whether connected piece `k` is a remnant of a grid line: long, thin and running within
    25 degrees of a cell's side (a symbol's single stroke runs aslant)."""
    x, y, w, h, _ = stat
    if max(w, h) < 0.25 * cell:
        return False
    m = cv2.moments((labels[y : y + h, x : x + w] == k).astype(np.uint8), binaryImage=True)
    mu20, mu02, mu11 = m["mu20"], m["mu02"], m["mu11"]
    half, det = (mu20 + mu02) / 2, mu20 * mu02 - mu11 * mu11
    root = math.sqrt(max(half * half - det, 0.0))
    major, minor = half + root, max(half - root, 1e-6)
    if major / minor < 12:
        return False
    angle = abs(math.degrees(0.5 * math.atan2(2 * mu11, mu20 - mu02)))  # 0 along x
    return min(angle, abs(90 - angle)) < 25


STRONG_INK = 150
"""oxbot: on the evened-out sheet, pen ink is darker than this; printed squares, rules and dots
(light lines under the drawing), paper grain and shadows are not."""
FAINT_LEVEL = 215
"""oxbot: in a cell without pen ink, pixels darker than this may be a faint (pencil) symbol."""


def wipe_background(cells: np.ndarray) -> np.ndarray:
    """Cells (N, 40, 40) with what is not the drawing painted over with paper (245).

    Squared, ruled and dotted paper print light lines and dots under the drawing, which the
    classifier, trained on plain paper, takes for symbols. What stays: pen ink
    (`STRONG_INK`) and what lies within two pixels of it, and the pieces of fainter ink that
    together are as wide and high as a small symbol, where printed lines (running from one side of
    the cell to the other), meshes (filling it) and dots (a few pixels) never count. Faint ink
    along a straight line across the cell goes first (`lines_across`): a printed rule touching
    the symbol would otherwise join it into one piece, kept whole.
    """
    out = cells.copy()
    near = np.ones((5, 5), np.uint8)
    side = cells.shape[1]
    for i, cell in enumerate(cells):
        # The classifier takes even a faint mesh of printed squares (20 grey levels) for a
        # circle: all that is not kept goes, down to the paper's grain.
        level = min(FAINT_LEVEL, int(np.median(cell)) - 20)  # below the cell's own paper
        faint = (cell < level).astype(np.uint8)
        strong = cell < STRONG_INK
        # A printed rule through a symbol joins it into one piece that no longer runs across
        # the cell alone: its faint pixels go first, wherever it runs straight across.
        faint[lines_across(faint > 0) & ~strong] = 0
        _, labels, stats, _ = cv2.connectedComponentsWithStats(faint, connectivity=8)
        x, y, w, h, area = stats.T
        wide, high = (x == 0) & (x + w == side), (y == 0) & (y + h == side)
        printed = (  # a printed line runs across the cell, a printed mesh fills it
            (wide & (h < side / 4)) | (high & (w < side / 4)) | (wide & high & (area > side**2 / 5))
        )
        pieces = ~printed & (area >= 10)  # dots are smaller
        pieces[0] = False
        if pieces.any():
            x0, y0 = x[pieces].min(), y[pieces].min()
            x1, y1 = (x + w)[pieces].max(), (y + h)[pieces].max()
            if min(x1 - x0, y1 - y0) < side / 4:  # together too small for a symbol
                pieces[:] = False
        keep = pieces[labels]
        if np.count_nonzero(strong) >= 8:  # pen ink stays, even where it crosses a mesh
            keep |= cv2.dilate(strong.view(np.uint8), near) > 0
        out[i][~keep] = 245
    return out


PRINTED_SPAN = 0.85
"""oxbot: ink along a straight line this share of the cell long, from one side to the other,
is printed (a rule, a square's side) or left of a grid line: a symbol, cut round its ink, is
at most SYMBOL_SHARE of the cell wide."""
PRINTED_SLANT = 3
"""oxbot: pixels such a line may shift sideways on its way across a 40-pixel cell (about 4
degrees from the cell's sides; 7 pixels found no more lines on the composed dev boards)."""


def lines_across(mask: np.ndarray) -> np.ndarray:
    """The pixels of `mask` (bool (side, side)) on straight lines that run across the cell
    within PRINTED_SLANT pixels of its sides and are inked along PRINTED_SPAN of it."""
    side = mask.shape[0]
    rows, columns, inside = _straight_paths(side, PRINTED_SLANT)
    out = np.zeros_like(mask)
    for seen, found in ((mask, out), (mask.T, out.T)):  # upright lines, then level ones
        on = seen[rows, columns] & inside
        full = on.sum(axis=1) >= PRINTED_SPAN * side
        if full.any():
            hit = on & full[:, None]
            found[rows[hit], columns[hit]] = True
    return out


@functools.cache
def _straight_paths(side: int, slant: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every straight path from the top of a side x side cell to its bottom that shifts at
    most `slant` pixels: the (paths, side) rows and columns of its pixels (columns clipped to
    the cell) and whether each lies in it."""
    down = np.arange(side)
    paths = [
        start + np.rint(shift * down / (side - 1)).astype(int)
        for shift in range(-slant, slant + 1)
        for start in range(-slant, side + slant)
    ]
    columns = np.array(paths)
    inside = (columns >= 0) & (columns < side)
    rows = np.broadcast_to(down, columns.shape)
    return rows, np.clip(columns, 0, side - 1), inside
