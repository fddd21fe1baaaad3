import numpy as np
import pytest

from oxbot.errors import InvalidInputError
from oxbot.perception.synth import (
    LABELS,
    PARTIAL_KINDS,
    Pen,
    add_ghost,
    add_grid_remnants,
    add_texture,
    draw_cell,
    draw_symbol,
    paper,
    partial_strokes,
    symbol_strokes,
)


@pytest.mark.parametrize("label", LABELS)
def test_cells_are_dark_ink_on_light_paper(label):
    rng = np.random.default_rng(0)
    for _ in range(20):
        cell = draw_cell(label, rng)
        assert cell.shape == (40, 40) and cell.dtype == np.uint8
        assert np.median(cell) > 120  # mostly paper, and paper is light
        if label != "nothing":
            assert np.median(cell) - cell.min() > 25  # a visible, darker drawing


def test_same_seed_draws_the_same_cell():
    a = draw_cell("cross", np.random.default_rng(7))
    b = draw_cell("cross", np.random.default_rng(7))
    c = draw_cell("cross", np.random.default_rng(8))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize("label,count", [("circle", 1), ("cross", 2), ("nothing", 0)])
def test_strokes_fill_the_unit_box(label, count):
    rng = np.random.default_rng(1)
    for _ in range(50):
        strokes = symbol_strokes(label, rng)
        assert len(strokes) >= count and (count > 0 or not strokes)
        if strokes:
            points = np.vstack(strokes)
            assert points.shape[1] == 2
            assert np.abs(points).max() == pytest.approx(1.0, abs=1e-6)


def test_circles_vary_between_open_and_overlapping_loops():
    rng = np.random.default_rng(2)
    gaps = []
    for _ in range(200):
        (loop,) = symbol_strokes("circle", rng)
        gaps.append(np.linalg.norm(loop[0] - loop[-1]))
    assert min(gaps) < 0.1 and max(gaps) > 0.4  # some closed, some clearly open


def test_draw_symbol_inks_only_around_its_centre_on_any_canvas():
    canvas = np.full((120, 200), 230, np.uint8)
    pen = Pen(width=3.0, darkness=0.9)
    draw_symbol(canvas, "circle", np.random.default_rng(3), centre=(150, 60), size=40, pen=pen)
    ys, xs = np.nonzero(canvas < 150)
    assert xs.size > 50
    assert 125 <= xs.min() <= xs.max() <= 175
    assert 35 <= ys.min() <= ys.max() <= 85


def test_pencil_is_lighter_than_marker():
    rng = np.random.default_rng(4)
    darkest = {}
    for name, pen in {"pencil": Pen(2.0, 0.35, 0.3), "marker": Pen(4.0, 0.95)}.items():
        canvas = np.full((40, 40), 230, np.uint8)
        draw_symbol(canvas, "cross", rng, size=28, pen=pen)
        darkest[name] = int(canvas.min())
    assert darkest["marker"] < darkest["pencil"] - 60


def test_grid_remnants_stay_at_the_border():
    rng = np.random.default_rng(5)
    for _ in range(30):
        sheet = paper((40, 40), np.random.default_rng(0))
        marked = add_grid_remnants(sheet.copy(), rng, probability=1.0)
        changed = np.abs(marked.astype(int) - sheet.astype(int)) > 20
        assert changed.any()
        assert not changed[10:30, 10:30].any()


def test_bad_label_and_canvas_are_refused():
    with pytest.raises(InvalidInputError, match="unknown label 'square'"):
        draw_cell("square", np.random.default_rng(0))
    with pytest.raises(InvalidInputError, match="uint8 grayscale canvas"):
        draw_symbol(np.zeros((40, 40, 3), np.uint8), "cross", np.random.default_rng(0))


@pytest.mark.parametrize("kind", PARTIAL_KINDS)
def test_partial_strokes_fill_the_unit_box(kind):
    rng = np.random.default_rng(2)
    for _ in range(20):
        points = np.vstack(partial_strokes(rng, kind))
        assert np.abs(points).max() <= 1.0 + 1e-6
        assert points.shape[1] == 2


def test_textured_and_ghosted_paper_stays_faint():
    rng = np.random.default_rng(3)
    for _ in range(30):
        sheet = paper((40, 40), rng)
        for marked in (add_texture(sheet, rng), add_ghost(sheet, rng)):
            assert marked.dtype == np.uint8 and marked.shape == (40, 40)
            # never darker than the faintest pen (darkness 0.3) takes away
            assert (marked.astype(float) >= sheet.astype(float) * 0.69 - 1).all()
    with pytest.raises(InvalidInputError, match="unknown partial kind"):
        partial_strokes(rng, "square")
