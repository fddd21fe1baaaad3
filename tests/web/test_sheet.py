"""The page's sheet, drawn in Python, reads as drawn: the same pipeline a camera feeds."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

from oxbot.perception import read_board
from oxbot.testing.sheet import SIDE, Sheet, cell_box


def test_page_sheet_reads_as_drawn():
    rng = np.random.default_rng(0)
    for seed in range(8):
        sheet, labels = Sheet(seed), ["nothing"] * 9
        for k, cell in enumerate(rng.permutation(9)[:5]):
            symbol = "cross" if k % 2 == 0 else "circle"
            sheet.draw(int(cell), symbol)
            labels[cell] = symbol
            assert read_board(sheet.image) == labels


def test_half_a_cross_is_not_yet_a_symbol():
    sheet = Sheet(3).draw("middle", "cross", strokes=1)
    assert read_board(sheet.image) == ["nothing"] * 9


def test_sheet_png_is_the_canvas_size_and_cells_tile_the_grid():
    image = np.asarray(Image.open(io.BytesIO(Sheet(1).png())))
    assert image.shape == (SIDE, SIDE, 3)
    left, top, right, bottom = cell_box("upperleft")
    assert top == left
    assert cell_box("uppermiddle")[0] == right and cell_box("middleleft")[1] == bottom
    assert cell_box("lowerright")[2] == SIDE - left
