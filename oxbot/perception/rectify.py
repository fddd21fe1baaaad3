"""Rectifying a found grid: the sheet seen from straight above, its light evened out.

Each cell's quadrilateral in the frame (from `Grid`'s lattice of cell corners, `grid.py`) is
warped to a square of `SHEET_CELL` pixels, with a ring around the grid so that a symbol that
sticks out of an outer cell stays whole; the paper's uneven light is then divided out, so that
`cells.py` can tell ink from paper with one threshold.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from oxbot.game.board import SIZE
from oxbot.perception.cells import SHEET_CELL
from oxbot.perception.frame import darkest_channel
from oxbot.perception.grid import Grid


def rectify(image: np.ndarray, grid: Grid, cell: int = SHEET_CELL, border: int = 0) -> np.ndarray:
    """The grid seen from straight above: uint8 (SIZE*cell + 2*border,) * 2, paper evened out.

    `image` is the frame, gray (H, W) or RGB (H, W, 3); colour is made gray by `ink_gray`.

    Each cell's quadrilateral is warped to a `cell` x `cell` square on its own; neighbouring
    cells share their edges, so the sheet is continuous across the grid lines. `border` > 0
    adds a ring that wide around the outer cells, continuing the lattice outwards (by
    `border / cell` of the outer cells' sides), so that a symbol that sticks out of an outer
    cell is on the sheet whole.
    """
    gray = ink_gray(image, grid) if image.ndim == 3 else image
    lattice = grid.lattice
    frame_cell = grid.cell_size()
    shrink = frame_cell > 1.6 * cell  # shrink first: a perspective warp does not average pixels
    if shrink:
        f = 1.25 * cell / frame_cell
        lattice = lattice * f
    edges = [k * cell for k in range(SIZE + 1)]
    if border > 0:
        lattice = _ring(lattice, border / cell)
        edges = [0] + [border + e for e in edges] + [SIZE * cell + 2 * border]
    if shrink:
        gray = _shrink_up_to(gray, f, lattice.reshape(-1, 2).max(axis=0))
    side = edges[-1]
    sheet = np.empty((side, side), np.uint8)
    n = len(edges) - 1
    corners = lattice.astype(np.float32)
    # Each cell's corners clockwise from its upper left, (n, n, 4, 2).
    quads = np.stack([corners[:-1, :-1], corners[:-1, 1:], corners[1:, 1:], corners[1:, :-1]], 2)
    for r in range(n):
        for c in range(n):
            x0, x1, y0, y1 = edges[c], edges[c + 1], edges[r], edges[r + 1]
            w, h = x1 - x0, y1 - y0
            rect = np.array([[0, 0], [w, 0], [w, h], [0, h]], np.float32)
            to_frame = cv2.getPerspectiveTransform(rect, quads[r, c])
            sheet[y0:y1, x0:x1] = cv2.warpPerspective(
                gray,
                to_frame,
                (w, h),
                flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                borderMode=cv2.BORDER_REPLICATE,
            )
    return even_out_light(sheet, cell)


def ink_gray(image: np.ndarray, grid: Grid) -> np.ndarray:
    """An RGB frame as gray in which ink of any colour is dark (`darkest_channel`), the paper's
    tint measured around the grid."""
    h, w = image.shape[:2]
    (x0, y0), (x1, y1) = grid.corners().min(axis=0), grid.corners().max(axis=0)
    x0, x1 = int(np.clip(x0, 0, w - 1)), int(np.clip(x1, 1, w))
    y0, y1 = int(np.clip(y0, 0, h - 1)), int(np.clip(y1, 1, h))
    return darkest_channel(image, image[y0:y1, x0:x1])


def _shrink_up_to(gray: np.ndarray, f: float, reach: np.ndarray) -> np.ndarray:
    """`gray` shrunk by `f` with INTER_AREA as far right and down as the point `reach` (x, y
    in the shrunk image) needs: the same pixels there as shrinking the whole frame, sooner.

    An INTER_AREA pixel averages the frame's pixels under it, found counting from the frame's
    top left; cutting the frame off to the right and below changes only the shrunk pixels
    whose areas the cut shortens, two pixels past those a warp up to `reach` reads (it reads
    one pixel past its last point). Shrinking is one of the reader's costliest steps, and
    the sheet often leaves a good part of the frame to its right or below it.
    """
    h, w = gray.shape
    right = min(w, math.ceil((float(reach[0]) + 4) / f) + 2)
    bottom = min(h, math.ceil((float(reach[1]) + 4) / f) + 2)
    return cv2.resize(gray[:bottom, :right], None, fx=f, fy=f, interpolation=cv2.INTER_AREA)


def _ring(q: np.ndarray, share: float) -> np.ndarray:
    """An (n, n, 2) lattice grown to (n + 2, n + 2, 2): a ring `share` of a cell further out."""
    n = len(q)
    out = np.empty((n + 2, n + 2, 2))
    out[1:-1, 1:-1] = q
    out[0, 1:-1] = q[0] + share * (q[0] - q[1])
    out[-1, 1:-1] = q[-1] + share * (q[-1] - q[-2])
    out[:, 0] = out[:, 1] + share * (out[:, 1] - out[:, 2])
    out[:, -1] = out[:, -2] + share * (out[:, -2] - out[:, -3])
    return out


def even_out_light(sheet: np.ndarray, cell: int = SHEET_CELL) -> np.ndarray:
    """Divide out the paper's uneven light (changing over a third of a cell of `cell` pixels or
    more): paper near 245, ink keeps its contrast."""
    kernel = max(5, (cell // 3) | 1)
    paper = cv2.morphologyEx(sheet, cv2.MORPH_CLOSE, np.ones((kernel, kernel), np.uint8))
    for _ in range(3):  # three box blurs: a Gaussian of sigma kernel/2, at a twentieth the time
        paper = cv2.blur(paper, (kernel, kernel))
    out = sheet.astype(np.float32) * (245.0 / np.maximum(paper.astype(np.float32), 8.0))
    return np.clip(out, 0, 255).astype(np.uint8)
