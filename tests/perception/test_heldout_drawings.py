"""The held-out drawing generator (oxbot.testing.heldout_drawings) itself: what it promises a
bench of the cell reader. The reader is not run here."""

import json
from collections import Counter

import numpy as np
import pytest

from oxbot.game.board import CELL_NAMES
from oxbot.testing.heldout_drawings import (
    KINDS,
    MARGIN,
    NOT_MOVES,
    QUICKDRAW_FOLDER,
    SYMBOLS,
    heldout_drawing,
    heldout_set,
    quickdraw_categories,
    quickdraw_drawings,
)


def drawings(kind, n, seed=0):
    rng = np.random.default_rng(seed)
    return [heldout_drawing(kind, rng) for _ in range(n)]


def test_the_symbols_are_circle_and_cross_and_nothing_else_is_a_move():
    assert SYMBOLS == ("circle", "cross")
    assert not set(SYMBOLS) & set(NOT_MOVES)
    assert KINDS == SYMBOLS + NOT_MOVES
    assert len(set(KINDS)) == len(KINDS)
    for kind in ("scribble", "zigzag", "letter_a", "star", "spiral", "triangle", "square"):
        assert kind in NOT_MOVES
    # a ring is a fair circle: the letter O and the digits 0, 6, 8, 9 are left out
    for ring in ("letter_o", "digit_0", "digit_6", "digit_8", "digit_9"):
        assert ring not in KINDS


def test_a_drawing_is_the_same_for_the_same_generator_state():
    for kind in KINDS:
        first, second = drawings(kind, 2, seed=5), drawings(kind, 2, seed=5)
        for a, b in zip(first, second, strict=True):
            assert len(a) == len(b)
            for sa, sb in zip(a, b, strict=True):
                np.testing.assert_array_equal(sa, sb)


def test_every_kind_draws_strokes_inside_the_cell_clear_of_its_edge():
    for kind in KINDS:
        for strokes in drawings(kind, 15, seed=1):
            assert len(strokes) >= 1, kind
            for stroke in strokes:
                assert stroke.ndim == 2 and stroke.shape[1] == 2 and len(stroke) >= 2, kind
                assert np.isfinite(stroke).all(), kind
                assert stroke.min() >= MARGIN - 1e-9 and stroke.max() <= 1 - MARGIN + 1e-9, kind


def test_drawings_span_a_person_s_range_of_sizes():
    for kind in KINDS:
        if kind in ("dot", "tick"):
            continue
        sides = []
        for strokes in drawings(kind, 20, seed=2):
            every = np.concatenate(strokes)
            sides.append((every.max(axis=0) - every.min(axis=0)).max())
        assert min(sides) >= 0.3 and max(sides) <= 1 - 2 * MARGIN + 1e-9, kind
        assert max(sides) - min(sides) > 0.15, kind  # not all one size


def test_a_dot_is_small():
    for strokes in drawings("dot", 20):
        every = np.concatenate(strokes)
        assert (every.max(axis=0) - every.min(axis=0)).max() < 0.1


def test_a_circle_is_one_closed_stroke_about_as_wide_as_tall():
    for (stroke,) in drawings("circle", 40, seed=3):
        every = stroke
        width, height = every.max(axis=0) - every.min(axis=0)
        assert 0.75 <= width / height <= 1.3
        # closed: the pen's end comes back onto the ring's start (a gap of a few pixels at most)
        head = stroke[: len(stroke) // 4]
        gap = np.linalg.norm(head - stroke[-1], axis=1).min()
        assert gap < 0.04 * max(width, height) + 0.01


def segments_cross(a, b):
    """Whether polylines a and b cross (any pair of their segments intersects)."""
    p, r = a[:-1, None, :], (a[1:] - a[:-1])[:, None, :]
    q, s = b[None, :-1, :], (b[1:] - b[:-1])[None, :, :]
    denominator = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]) / denominator
        u = (qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]) / denominator
    return bool(((t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)).any())


def test_a_cross_is_two_strokes_that_cross_at_a_slant():
    for strokes in drawings("cross", 40, seed=4):
        assert len(strokes) == 2
        assert segments_cross(*strokes)
        lengths = []
        for stroke in strokes:
            d = stroke[-1] - stroke[0]
            angle = np.degrees(np.arctan2(abs(d[1]), abs(d[0])))
            assert 15 <= angle <= 75  # 30-60 degrees, give or take the slant and stretch
            lengths.append(np.linalg.norm(d))
        assert 0.6 <= lengths[0] / lengths[1] <= 1.6


def test_an_unknown_kind_is_refused_naming_the_kinds():
    with pytest.raises(ValueError, match="circle, cross, scribble"):
        heldout_drawing("letter_o", np.random.default_rng(0))


def test_a_held_out_set_has_n_of_every_kind_in_every_cell_in_turn():
    drawn = heldout_set(30, seed=9)
    assert Counter(kind for kind, _, _ in drawn) == {kind: 30 for kind in KINDS}
    for kind in KINDS:
        cells = [cell for k, cell, _ in drawn if k == kind]
        assert cells == [CELL_NAMES[i % 9] for i in range(30)]


def test_a_held_out_set_is_reproducible_for_its_seed_and_differs_between_seeds():
    first, again, other = heldout_set(2, seed=11), heldout_set(2, seed=11), heldout_set(2, seed=12)
    for (k1, c1, s1), (k2, c2, s2) in zip(first, again, strict=True):
        assert (k1, c1) == (k2, c2)
        assert all(np.array_equal(a, b) for a, b in zip(s1, s2, strict=True))
    assert any(
        not np.array_equal(s1[0], s3[0])
        for (_, _, s1), (_, _, s3) in zip(first, other, strict=True)
    )


def record(word, strokes, recognized=True, raw=False):
    drawing = [[list(xs), list(ys)] + ([list(range(len(xs)))] if raw else []) for xs, ys in strokes]
    return json.dumps(
        {
            "word": word,
            "countrycode": "GB",
            "recognized": recognized,
            "key_id": "1",
            "drawing": drawing,
        }
    )


def test_quickdraw_drawings_fit_the_unit_square_and_keep_only_recognised_ones(tmp_path):
    lines = [
        record("square", [([10, 110, 110, 10, 10], [20, 20, 70, 70, 20])], raw=True),
        record("square", [([0, 5], [0, 5])], recognized=False),
        record("square", [([300, 300], [0, 255]), ([250], [40])]),  # a one-point tap
    ]
    (tmp_path / "square.ndjson").write_text("\n".join(lines) + "\n")
    drawn = quickdraw_drawings("square", folder=tmp_path, margin=0.1)
    assert quickdraw_categories(tmp_path) == ("square",)
    assert len(drawn) == 2
    (box,) = drawn[0]
    assert box.shape == (5, 2)
    np.testing.assert_allclose(box.min(axis=0), [0.1, 0.3])  # wide: centred top to bottom
    np.testing.assert_allclose(box.max(axis=0), [0.9, 0.7])
    line, tap = drawn[1]
    assert line.shape == (2, 2) and tap.shape == (2, 2)
    assert np.concatenate(drawn[1]).min() >= 0.1 - 1e-9


def test_a_missing_quickdraw_file_names_where_to_restore_it(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"SOURCES\.md"):
        quickdraw_drawings("circle", folder=tmp_path)


@pytest.mark.skipif(
    not QUICKDRAW_FOLDER.joinpath("circle.ndjson").exists(),
    reason="the Quick, Draw! files are not in git (bench/data/quickdraw/SOURCES.md)",
)
def test_the_restored_quickdraw_files_load_as_drawings_in_the_unit_square():
    for category in quickdraw_categories():
        drawn = quickdraw_drawings(category)
        assert len(drawn) >= 15, category
        for strokes in drawn:
            for stroke in strokes:
                assert stroke.ndim == 2 and stroke.shape[1] == 2 and len(stroke) >= 2
                assert stroke.min() >= 0.15 - 1e-9 and stroke.max() <= 0.85 + 1e-9
