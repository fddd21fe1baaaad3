import numpy as np

from oxbot.perception.cells import CELL_SIZE, SHEET_CELL, cut_cells, remove_grid_lines
from oxbot.perception.grid import as_gray, find_grid
from oxbot.perception.rectify import rectify
from oxbot.testing.render import TUNING_STYLE, render_photo


def test_cells_hold_their_own_symbol_and_no_grid_ink():
    rng = np.random.default_rng(11)
    labels = ["nothing"] * 9
    labels[4] = "cross"
    labels[2] = "circle"
    photo = render_photo(rng, labels, TUNING_STYLE)
    gray = as_gray(photo.image)
    sheet = rectify(gray, find_grid(gray))
    assert sheet.shape == (3 * SHEET_CELL, 3 * SHEET_CELL) and sheet.dtype == np.uint8
    cells = cut_cells(remove_grid_lines(sheet))
    assert cells.shape == (9, CELL_SIZE, CELL_SIZE) and cells.dtype == np.uint8
    ink = (cells < 150).sum(axis=(1, 2))
    assert ink[4] > 40 and ink[2] > 40
    blank = [i for i in range(9) if labels[i] == "nothing"]
    assert ink[blank].max() <= 3, ink


def test_remove_grid_lines_paints_the_lines_over():
    rng = np.random.default_rng(12)
    photo = render_photo(rng, ["nothing"] * 9, TUNING_STYLE)
    gray = as_gray(photo.image)
    sheet = rectify(gray, find_grid(gray))
    cleaned = remove_grid_lines(sheet)
    band = np.zeros(sheet.shape, bool)
    for at in (SHEET_CELL, 2 * SHEET_CELL):
        band[:, at - 4 : at + 5] = True
        band[at - 4 : at + 5, :] = True
    assert (sheet[band] < 150).sum() > 200  # the lines were there
    assert (cleaned[band] < 150).sum() < 10  # and now they are gone
    np.testing.assert_array_equal(
        cleaned[~band & (sheet > 200)] >= sheet[~band & (sheet > 200)], True
    )
