import contextlib
import dataclasses
import math

import cv2
import numpy as np
import pytest

from oxbot.errors import InvalidInputError, NoGridFound
from oxbot.perception.grid import as_gray, find_grid
from oxbot.perception.lines import _order
from oxbot.testing.render import (
    TUNING_STYLE,
    TUNING_VARIANTS,
    SheetScene,
    random_scene,
    render_photo,
)


def polyline_crossing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where two polylines cross (the first crossing found), or where they come closest."""
    p, r = a[:-1, None, :], (a[1:] - a[:-1])[:, None, :]
    q, s = b[None, :-1, :], (b[1:] - b[:-1])[None, :, :]
    cross = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    cross = np.where(np.abs(cross) < 1e-12, 1e-12, cross)
    qp = q - p
    t = (qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]) / cross
    u = (qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]) / cross
    inside = (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    if inside.any():
        i, j = np.argwhere(inside)[0]
        return a[i] + t[i, j] * (a[i + 1] - a[i])
    # A line stops short of the other: extend both straight, as a person sees the crossing.
    (pa, da), (pb, db) = (a.mean(axis=0), a[-1] - a[0]), (b.mean(axis=0), b[-1] - b[0])
    t = np.linalg.solve(np.stack([da, -db], axis=1), pb - pa)[0]
    return pa + t * da


def drawn_crossings(scene: SheetScene) -> np.ndarray:
    """Photo pixels where the scene's drawn lines cross: upper left, upper right, lower right,
    lower left (the grid's lattice[1:3, 1:3])."""
    lines = scene.grid_lines
    points = [polyline_crossing(lines[v], lines[h]) for v, h in ((0, 2), (1, 2), (1, 3), (0, 3))]
    pts = np.array(points, np.float64).reshape(-1, 1, 2)
    return cv2.perspectiveTransform(pts, scene.homography).reshape(-1, 2)


def crossing_error(scene: SheetScene, gray: np.ndarray) -> float:
    """How far the found crossings are from the drawn ones, in cells."""
    lattice = find_grid(gray).lattice
    found = np.array([lattice[1, 1], lattice[1, 2], lattice[2, 2], lattice[2, 1]])
    error = np.linalg.norm(found - drawn_crossings(scene), axis=1).max()
    return float(error / scene.cell_size_px())


def test_finds_the_grid_anywhere_in_view():
    errors = []
    for seed in range(30):
        photo = render_photo(np.random.default_rng(seed), style=TUNING_STYLE)
        errors.append(crossing_error(photo.scene, as_gray(photo.image)))
    assert np.median(errors) < 0.04
    assert max(errors) < 0.15


@pytest.mark.parametrize("variant", ["tuning-hand", "tuning-camera"])
def test_finds_where_bent_lines_really_cross(variant):
    # Tilted, bowed lines under strong perspective: the crossings are found from the ink near
    # each of them, not where the lines' straight fits meet (median 0.04 cells, 13% of them
    # 0.1 cells or more off on tuning-camera, before they were).
    errors = []
    for seed in range(40):
        photo = render_photo(np.random.default_rng(seed), style=TUNING_VARIANTS[variant])
        with contextlib.suppress(NoGridFound):
            errors.append(crossing_error(photo.scene, as_gray(photo.image)))
    assert len(errors) >= 35
    assert np.median(errors) < 0.035
    assert np.mean(np.array(errors) >= 0.1) <= 0.1


def test_symbols_do_not_crowd_the_grid_lines_out():
    # Big, scattered symbols under a poor camera: with every ink pixel voting for every line,
    # circles' arcs and crosses' strokes outvoted bowed grid lines and the grid was not
    # found in 7 of these 100 photos; voted for only by strokes running their way, in 1.
    rng = np.random.default_rng(11)
    missed = 0
    for _ in range(100):
        photo = render_photo(rng, style=TUNING_VARIANTS["tuning-camera"])
        try:
            find_grid(as_gray(photo.image))
        except NoGridFound:
            missed += 1
    assert missed <= 3


@pytest.mark.parametrize("degrees", [-15, -8, 0, 8, 15])
def test_finds_the_grid_rotated_up_to_15_degrees(degrees):
    rng = np.random.default_rng(100 + degrees)
    scene = random_scene(rng, TUNING_STYLE, rotation=degrees).with_symbol(4, "cross", rng)
    assert crossing_error(scene, as_gray(scene.photo(rng))) < 0.1


def test_finds_grid_lines_that_stop_short_of_a_crossing():
    hand = dataclasses.replace(TUNING_STYLE.hand, grid_gap_chance=0.3)
    style = dataclasses.replace(TUNING_STYLE, hand=hand)
    gapped = 0
    for seed in range(12):
        rng = np.random.default_rng(seed)
        scene = random_scene(rng, style)
        # A line with a gap starts or ends between the two lines it should cross.
        ends = [(s[:, 1] if i < 2 else s[:, 0])[[0, -1]] for i, s in enumerate(scene.grid_lines)]
        gapped += sum(bool(((e > 0.9) & (e < 2.1)).any()) for e in ends)
        assert crossing_error(scene, as_gray(scene.photo(rng))) < 0.15
    assert gapped >= 3


@pytest.mark.parametrize(
    "what,kwargs",
    [
        ("blank sheet", {"with_grid": False}),
        ("empty desk", {"with_grid": False, "with_paper": False}),
        ("grid cut off at the left", {"center": (0.02, 0.5)}),
        ("grid cut off at the bottom", {"center": (0.5, 0.97)}),
    ],
)
def test_no_grid_in_view_raises_instead_of_guessing(what, kwargs):
    for seed in range(3):
        rng = np.random.default_rng(seed)
        scene = random_scene(rng, TUNING_STYLE, **kwargs).with_symbol(4, "circle", rng)
        with pytest.raises(NoGridFound, match="grid"):
            find_grid(as_gray(scene.photo(rng)))


def test_a_desk_with_no_paper_and_stray_strokes_has_no_grid():
    rng = np.random.default_rng(3)
    scene = random_scene(rng, TUNING_STYLE, with_grid=False)
    for cell in (0, 2, 4, 6, 8):
        scene = scene.with_symbol(cell, "cross" if cell % 4 else "circle", rng)
    with pytest.raises(NoGridFound):
        find_grid(as_gray(scene.photo(rng)))


def test_lines_that_make_no_grid_are_told_in_plain_words():
    sheet = np.full((480, 640), 235, np.uint8)
    for start, end in (((320, 60), (320, 420)), ((250, 60), (250, 420)), ((140, 240), (500, 240))):
        cv2.line(sheet, start, end, 30, 4)  # three of a grid's four lines
    with pytest.raises(NoGridFound) as refused:
        find_grid(sheet)
    words = str(refused.value)  # shown over the camera's video, to anyone
    assert "the four lines of a whole grid" in words and "pairs" not in words


@pytest.mark.parametrize(
    "frame,message",
    [
        (np.zeros((0, 0, 3), np.uint8), "empty"),
        (np.zeros((480, 640, 3), np.float32), "dtype float32"),
        (np.zeros((480, 640, 4), np.uint8), "alpha"),
        (np.zeros((480, 640, 2), np.uint8), r"shape \(480, 640, 2\)"),
        (np.zeros((3, 480, 640), np.uint8), r"shape \(3, 480, 640\)"),
        (np.zeros((20, 30, 3), np.uint8), "too small"),
        ([[0, 1], [2, 3]], "numpy array"),
    ],
)
def test_bad_frames_are_refused_with_the_fix(frame, message):
    with pytest.raises(InvalidInputError, match=message):
        as_gray(frame)


def test_gray_and_rgb_frames_agree():
    photo = render_photo(np.random.default_rng(5), style=TUNING_STYLE)
    gray = cv2.cvtColor(photo.image, cv2.COLOR_RGB2GRAY)
    np.testing.assert_array_equal(as_gray(photo.image), as_gray(gray))


def test_the_frame_edge_is_no_grid_line():
    # Tuning photo 40 of seed 2024: the desk at the frame's left edge once looked like a
    # long pen line, and the grid found with it ran off the picture.
    rng = np.random.default_rng(2024)
    for _ in range(40):
        render_photo(rng, style=TUNING_STYLE)
    photo = render_photo(rng, style=TUNING_STYLE)
    assert crossing_error(photo.scene, as_gray(photo.image)) < 0.1


def test_a_line_through_a_symbol_is_not_a_grid_line():
    # Tuning-hand photo 76 of seed 7000: the left line stops short of the top line, and a
    # Hough line through the cross above it and the circle beside it once won.
    rng = np.random.default_rng(7000)
    style = TUNING_VARIANTS["tuning-hand"]
    for _ in range(76):
        render_photo(rng, style=style)
    photo = render_photo(rng, style=style)
    assert crossing_error(photo.scene, as_gray(photo.image)) < 0.1


def same_crossings_any_order(scene: SheetScene, frame: np.ndarray) -> float:
    """How far the found crossings are from the drawn ones, in cells, whichever found
    crossing is taken for the upper left: at 45 degrees which way is up is a toss-up."""
    lattice = find_grid(frame).lattice
    found = np.array([lattice[1, 1], lattice[1, 2], lattice[2, 2], lattice[2, 1]])
    drawn = drawn_crossings(scene)
    errors = [np.linalg.norm(np.roll(found, k, 0) - drawn, axis=1).max() for k in range(4)]
    errors += [np.linalg.norm(np.roll(found[::-1], k, 0) - drawn, axis=1).max() for k in range(4)]
    return float(min(errors) / scene.cell_size_px())


@pytest.mark.parametrize("degrees", [-40, -30, 22, 30, 40])
def test_finds_the_grid_turned_well_past_15_degrees(degrees):
    # the goal is up to 45 degrees. Before, only lines within 27 degrees of the frame's axes
    # were looked for, and three of these five grids were not found at all.
    rng = np.random.default_rng(200 + degrees)
    scene = random_scene(rng, TUNING_STYLE, rotation=degrees).with_symbol(4, "cross", rng)
    assert crossing_error(scene, scene.photo(rng)) < 0.1


def test_finds_a_grid_turned_45_degrees_either_way_up():
    for seed in range(4):
        rng = np.random.default_rng(seed)
        scene = random_scene(rng, TUNING_STYLE, rotation=45).with_symbol(0, "circle", rng)
        assert same_crossings_any_order(scene, scene.photo(rng)) < 0.1


def test_finds_the_grid_under_strong_perspective():
    style = dataclasses.replace(TUNING_STYLE, perspective=0.15, max_rotation=30.0)
    errors = []
    for seed in range(12):
        photo = render_photo(np.random.default_rng(seed), style=style)
        errors.append(crossing_error(photo.scene, photo.image))
    assert np.median(errors) < 0.05
    assert max(errors) < 0.15


def test_finds_thin_coloured_marker_lines_that_gray_hides():
    # A light blue marker on a grey-white board: in gray its lines are barely darker than the
    # board; in the red channel they are dark (the real whiteboard photos of
    # bench/data/real_boards/).
    style = dataclasses.replace(
        TUNING_STYLE,
        pen_colors=((90, 150, 230),),
        pen_width=(0.015, 0.02),
        paper_kinds=("whiteboard",),
    )
    for seed in range(5):
        photo = render_photo(np.random.default_rng(seed), style=style)
        assert crossing_error(photo.scene, photo.image) < 0.1


def grid_with_left_edge_at(pixels: float, rng: np.random.Generator) -> SheetScene:
    """A tuning scene, upright, cells 80 px wide, whose grid's left edge lies `pixels` from
    the frame's left edge (negative: beyond it)."""
    width, height = TUNING_STYLE.size
    style = dataclasses.replace(TUNING_STYLE, perspective=0.0)
    side = 0.5 * height
    center = ((pixels + side / 2) / width, 0.5)
    return random_scene(rng, style, grid_fraction=(0.5, 0.5), center=center, rotation=0)


def test_a_grid_touching_the_frame_edge_is_found_whole():
    # The grid's outer edge a tenth of a cell beyond the frame: every cell's middle in view.
    for seed in range(3):
        rng = np.random.default_rng(seed)
        scene = grid_with_left_edge_at(-8, rng).with_symbol(3, "cross", rng)
        grid = find_grid(scene.photo(rng))
        assert all(grid.in_view)
        assert crossing_error(scene, scene.photo(rng)) < 0.1


def test_a_grid_cut_by_the_frame_edge_says_which_cells_are_out_of_view():
    # The left column's middle is beyond the frame: those cells are out of view, the others
    # are found where they are drawn.
    for seed in range(3):
        rng = np.random.default_rng(seed)
        scene = grid_with_left_edge_at(-50, rng)
        photo = scene.photo(rng)
        grid = find_grid(photo)
        assert grid.cells_out_of_view() == [0, 3, 6]
        assert crossing_error(scene, photo) < 0.1


def test_which_pair_holds_the_columns_does_not_hang_on_one_line():
    # Near 45 degrees in perspective the two lines of a pair lean differently: left and right
    # at 47 and 35 degrees from the frame's vertical, top and bottom at 47 and 35 from its
    # horizontal. On average the first pair is nearer the vertical, whichever of its lines is
    # listed first (the rule looked at one line of each pair and swapped rows and columns).
    def line(degrees: float) -> tuple[float, float, float]:
        return (100.0, math.radians(degrees), 1.0)  # (rho, theta of the normal, votes)

    columns = {line(47)[:2], line(35)[:2]}
    for p in ((line(47), line(35)), (line(35), line(47))):
        for q in ((line(137), line(125)), (line(125), line(137))):
            for pairs in ((p, q), (q, p)):
                left, right, _, _ = _order(*pairs)
                assert {left, right} == columns
