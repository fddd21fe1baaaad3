import math

import numpy as np
import pytest

from oxbot.perception.grid_scenes import (
    ABSENT_SHARE,
    PAPER_KINDS,
    _sample_kinds,
    random_grid_scene,
    save_preview,
)
from oxbot.perception.scene_geometry import (
    OUT_OF_FRAME,
    camera_view,
    plane_lattice,
    random_grid,
    row_direction,
)
from oxbot.perception.scene_ink import project


@pytest.fixture(scope="module")
def scenes():
    """60 scenes of one generator, 256x256: the tests below read them, none makes its own."""
    rng = np.random.default_rng(2024)
    return [random_grid_scene(rng) for _ in range(60)]


def test_scene_has_the_promised_shapes_and_types():
    rng = np.random.default_rng(1)
    for _ in range(8):
        scene = random_grid_scene(rng, (200, 120))  # width, height
        assert scene.image.shape == (120, 200, 3) and scene.image.dtype == np.uint8
        assert scene.lattice.shape == (4, 4, 2) and scene.lattice.dtype == np.float32
        assert scene.lines.shape == (120, 200) and scene.lines.dtype == np.uint8
        assert set(np.unique(scene.lines)) <= {0, 255}
        assert isinstance(scene.present, bool)
        assert scene.kind in (*PAPER_KINDS, "desk")


def test_same_generator_state_gives_the_same_scene():
    a = random_grid_scene(np.random.default_rng(7))
    b = random_grid_scene(np.random.default_rng(7))
    c = random_grid_scene(np.random.default_rng(8))
    assert np.array_equal(a.image, b.image) and np.array_equal(a.lines, b.lines)
    assert np.array_equal(a.lattice, b.lattice, equal_nan=True)
    assert a.kind == b.kind and a.present == b.present
    assert not np.array_equal(a.image, c.image)


def test_inner_lattice_points_lie_on_the_grid_lines_ink(scenes):
    checked = 0
    for scene in scenes:
        if not scene.present:
            continue
        assert scene.lines.any()
        for x, y in np.round(scene.lattice[1:3, 1:3].reshape(-1, 2)).astype(int):
            assert 0 <= x < 256 and 0 <= y < 256  # the crossings are always in the frame
            near = scene.lines[max(0, y - 1) : y + 2, max(0, x - 1) : x + 2]
            assert near.max() == 255, f"no grid ink within a pixel of ({x}, {y})"
            checked += 1
    assert checked >= 150


def test_lattice_points_off_the_crossings_are_not_on_line_ink_everywhere(scenes):
    # The mask is the lines' ink, not the whole grid: the middle cell's centre holds none.
    for scene in (s for s in scenes if s.present):
        x, y = np.round(scene.lattice[1:3, 1:3].reshape(-1, 2).mean(axis=0)).astype(int)
        assert scene.lines[y, x] == 0


def test_scenes_without_a_grid_have_an_empty_mask_and_no_lattice():
    rng = np.random.default_rng(6)
    found = 0
    for _ in range(300):
        scene = random_grid_scene(rng, (96, 96))
        if not scene.present:
            found += 1
            assert not scene.lines.any()
            assert np.isnan(scene.lattice).all()
            if found == 5:
                break
    assert found == 5


def test_about_an_eighth_of_scenes_show_no_grid():
    rng = np.random.default_rng(4)
    kinds = [_sample_kinds(rng) for _ in range(4000)]
    share = sum(absent is not None for absent, _ in kinds) / len(kinds)
    assert share == pytest.approx(ABSENT_SHARE, abs=0.015)
    assert {paper for _, paper in kinds} == {*PAPER_KINDS, "desk"}


def test_rows_turn_at_most_45_degrees_both_ways(scenes):
    angles = []
    for scene in (s for s in scenes if s.present):
        v = row_direction(scene.lattice)
        angles.append(math.degrees(math.atan2(v[1], v[0])))
        columns = (scene.lattice[3] - scene.lattice[0]).mean(axis=0)
        # The columns run nearer the vertical than the rows do, and downwards.
        assert abs(columns[1]) / np.linalg.norm(columns) > abs(v[1]) / np.linalg.norm(v)
        assert columns[1] > 0
    assert max(np.abs(angles)) <= 45.5
    assert min(angles) < -25 and max(angles) > 25


def test_grid_side_stays_between_15_and_100_percent_of_the_frame(scenes):
    for scene in (s for s in scenes if s.present):
        q = scene.lattice
        corners = np.array([q[0, 0], q[0, 3], q[3, 3], q[3, 0]], np.float64)
        x, y = corners[:, 0], corners[:, 1]
        area = 0.5 * abs(x @ np.roll(y, -1) - y @ np.roll(x, -1))
        assert 0.15 * 0.97 <= math.sqrt(area) / 256 <= 1.03


def test_camera_keeps_outer_corners_within_a_third_of_a_cell_of_the_frame():
    rng = np.random.default_rng(6)
    for _ in range(100):
        grid = random_grid(rng)
        side = rng.uniform(0.15, 1.0) * 200
        h = camera_view(rng, grid.lattice, (300, 200), side, rng.uniform(-45, 45))
        q = project(h, grid.lattice.reshape(-1, 2))[0].reshape(4, 4, 2)
        (ax, ay), (bx, by) = q[2, 1] - q[1, 1], q[1, 2] - q[1, 1]
        cell = math.sqrt(abs(ax * by - ay * bx))
        outside = np.maximum(np.maximum(-q, q - (299, 199)), 0).max()
        assert outside <= OUT_OF_FRAME * cell * 1.6  # local cells differ under perspective
        assert ((q[1:3, 1:3] >= 0) & (q[1:3, 1:3] <= (299, 199))).all()


def test_plane_lattice_sits_on_the_drawn_lines():
    rng = np.random.default_rng(9)
    for _ in range(20):
        grid = random_grid(rng)
        left, right, top, bottom = grid.lines
        q = grid.lattice
        for j, row in ((1, top), (2, bottom)):
            for k, column in ((1, left), (2, right)):
                x, y = q[j, k]
                assert column.across(y) == pytest.approx(x, abs=1e-9)
                assert row.across(x) == pytest.approx(y, abs=1e-9)
        # The outer points lie on the lines, one middle cell further along them.
        assert left.across(q[0, 1, 1]) == pytest.approx(q[0, 1, 0])
        assert q[1, 1, 1] - q[0, 1, 1] == pytest.approx(q[2, 1, 1] - q[1, 1, 1])
        assert bottom.across(q[2, 3, 0]) == pytest.approx(q[2, 3, 1])


def test_straight_lines_give_a_regular_lattice():
    grid = random_grid(np.random.default_rng(0), printed=True)
    expected = np.stack(np.meshgrid(np.arange(4.0), np.arange(4.0)), axis=-1)
    assert np.allclose(plane_lattice(grid.lines), expected)


def test_preview_is_a_png_mosaic(tmp_path):
    path = save_preview(tmp_path / "preview.png", seed=0, n=4, size=64)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
