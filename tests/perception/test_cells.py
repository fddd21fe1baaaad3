import itertools

import cv2
import numpy as np

from oxbot.perception.board import default_reader
from oxbot.perception.cells import (
    CELL_SIZE,
    SHEET_CELL,
    cut_cells,
    cut_cells_and_painted,
    remove_grid_lines,
    wipe_background,
)
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


def test_a_stroke_fading_at_its_ends_is_cut_whole():
    # A thin pen leaves its strokes dark in the middle and pale towards the ends (dev_0185 of
    # the composed boards): the cell must be cut round the pale ends too, or the classifier
    # sees a cross cut short, a "Y" or a "T", and takes it for a circle.
    border = SHEET_CELL // 2
    sheet = np.full((3 * SHEET_CELL + 2 * border,) * 2, 245, np.uint8)
    x0 = y0 = border + 6  # the upper left cell, a cross 32 pixels wide
    for (ax, ay), (bx, by) in (((x0, y0), (x0 + 32, y0 + 32)), ((x0 + 32, y0), (x0, y0 + 32))):
        cv2.line(sheet, (ax, ay), (bx, by), 185, 2)  # pale all along
        a = (round(ax + 0.2 * (bx - ax)), round(ay + 0.2 * (by - ay)))
        b = (round(ax + 0.8 * (bx - ax)), round(ay + 0.8 * (by - ay)))
        cv2.line(sheet, a, b, 90, 2)  # dark in the middle 60%
    cells, _ = cut_cells_and_painted(sheet, None, border=border)
    ys, xs = np.nonzero(cells[0] < 215)
    # the whole cross, pale ends included, lies inside the cut with paper all round it
    assert min(xs.min(), ys.min()) >= 2 and max(xs.max(), ys.max()) <= CELL_SIZE - 3
    assert min(xs.max() - xs.min(), ys.max() - ys.min()) >= 0.55 * CELL_SIZE


def test_a_printed_rule_through_a_symbol_is_wiped_and_the_symbol_kept():
    # A ruled line crossing a circle joins it into one piece of faint ink that no longer runs
    # across the cell on its own; left in, it made circles crosses and crosses circles
    # (composed dev boards on ruled paper).
    cell = np.full((CELL_SIZE, CELL_SIZE), 245, np.uint8)
    cv2.line(cell, (12, 0), (14, CELL_SIZE - 1), 200, 2)  # a printed rule, slightly aslant
    cv2.circle(cell, (22, 20), 10, 90, 2)  # the pen's circle, touching it
    wiped = wipe_background(cell[None])[0]
    rule_alone = np.zeros(cell.shape, bool)
    rule_alone[:6, 10:17] = rule_alone[-6:, 10:17] = True  # above and below the circle
    assert (cell[rule_alone] < 215).sum() > 10  # the rule was there
    assert (wiped[rule_alone] < 215).sum() == 0  # and is gone
    circle = cell < 150
    np.testing.assert_array_equal(wiped[circle], cell[circle])  # the pen's ink is untouched


def test_a_wrinkles_shadow_in_an_empty_cell_is_paper_not_a_symbol():
    # A wrinkled sheet's shadows change within a cell, where `even_out_light` leaves them: soft
    # gray patches that the classifier read as circles and crosses at 1.0 (composed dev boards
    # on phone photos of wrinkled paper). Lifted out, the cell is paper; the symbols stay.
    reader = default_reader()
    for seed, (across, along) in itertools.product((1, 2, 3), ((0.2, 0.4), (0.3, 0.3))):
        rng = np.random.default_rng(seed)
        labels = ["nothing"] * 9
        labels[0], labels[8] = "cross", "circle"
        photo = render_photo(rng, labels, TUNING_STYLE).image
        grid = find_grid(photo)
        cx, cy = grid.lattice[1:3, 1:3].reshape(-1, 2).mean(axis=0)  # the middle cell's centre
        size = grid.cell_size()
        yy, xx = np.mgrid[0 : photo.shape[0], 0 : photo.shape[1]].astype(np.float32)
        u = ((xx - cx) * 0.8 + (yy - cy) * 0.6) / (across * size)  # a shadow aslant
        v = ((yy - cy) * 0.8 - (xx - cx) * 0.6) / (along * size)
        shade = 1 - 0.45 * np.exp(-(u**2 + v**2) / 2)
        reading = reader.read((photo * shade[..., None]).astype(np.uint8))
        assert reading.readings[4].label == "nothing", (seed, across, reading.readings[4])
        assert (reading.labels[0], reading.labels[8]) == ("cross", "circle")
