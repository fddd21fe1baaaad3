import dataclasses

import numpy as np
import pytest

from oxbot.testing.render import (
    HELD_OUT_STYLE,
    STYLES,
    TUNING_STYLE,
    TUNING_VARIANTS,
    random_labels,
    random_scene,
    render_photo,
)


@pytest.mark.parametrize("style", [TUNING_STYLE, HELD_OUT_STYLE], ids=lambda s: s.name)
def test_photos_are_rgb_frames_of_the_style_size(style):
    photo = render_photo(np.random.default_rng(0), style=style)
    width, height = style.size
    assert photo.image.shape == (height, width, 3) and photo.image.dtype == np.uint8
    assert photo.labels == photo.scene.labels and len(photo.labels) == 9


def test_the_same_seed_gives_the_same_photo_and_another_seed_another():
    a = render_photo(np.random.default_rng(42))
    b = render_photo(np.random.default_rng(42))
    c = render_photo(np.random.default_rng(43))
    np.testing.assert_array_equal(a.image, b.image)
    assert a.labels == b.labels
    assert np.abs(a.image.astype(int) - c.image.astype(int)).mean() > 5


def test_labels_are_drawn_where_asked():
    labels = (
        "cross",
        "nothing",
        "circle",
        "nothing",
        "cross",
        "nothing",
        "nothing",
        "nothing",
        "circle",
    )
    photo = render_photo(np.random.default_rng(1), labels)
    assert photo.labels == labels
    assert sorted(photo.scene.symbols) == [0, 2, 4, 8]
    assert photo.scene.symbols[0].label == "cross" and len(photo.scene.symbols[0].strokes) >= 2
    with pytest.raises(ValueError, match="9 of"):
        render_photo(np.random.default_rng(1), ("cross",) * 8)


def test_the_whole_grid_stays_in_view():
    for seed in range(40):
        scene = random_scene(
            np.random.default_rng(seed), STYLES["held-out" if seed % 2 else "tuning"]
        )
        corners = scene.homography @ np.array([[0, 3, 3, 0], [0, 0, 3, 3], [1, 1, 1, 1]], float)
        corners = corners[:2] / corners[2]
        width, height = scene.style.size
        assert corners.min() >= 0 and (corners[0] < width).all() and (corners[1] < height).all()


def test_a_symbol_is_drawn_stroke_by_stroke():
    rng = np.random.default_rng(2)
    scene = random_scene(rng).with_symbol(4, "cross", rng)
    quiet = np.random.default_rng(0)
    # Ink in the middle cell grows with every stroke, and the scene's frames otherwise agree.
    frames = [scene.photo(np.random.default_rng(0), drawn={4: p}) for p in (0, 0.5, 1, 1.5, 2)]
    center = scene.homography @ np.array([1.5, 1.5, 1.0])
    x, y = (center[:2] / center[2]).astype(int)
    r = int(scene.cell_size_px() * 0.4)
    ink = [
        int((255 - f[y - r : y + r, x - r : x + r].min(axis=2)).astype(int).sum()) for f in frames
    ]
    assert ink == sorted(ink) and ink[-1] > ink[2] > ink[0]
    np.testing.assert_array_equal(frames[-1], scene.photo(quiet))


def test_the_held_out_style_is_kept_apart_from_the_tuning_style():
    assert TUNING_STYLE.hand.symbols == "synth"  # the seed synthesiser's strokes
    assert HELD_OUT_STYLE.hand.symbols == "sketch"  # an independent hand
    assert set(TUNING_STYLE.pen_colors).isdisjoint(HELD_OUT_STYLE.pen_colors)
    assert set(TUNING_STYLE.desk_colors).isdisjoint(HELD_OUT_STYLE.desk_colors)
    assert TUNING_STYLE.size != HELD_OUT_STYLE.size
    assert set(STYLES) == {"tuning", "held-out", "wide-tuning", "wide-held-out"}
    for variant in TUNING_VARIANTS.values():  # harder tuning styles share nothing held-out
        assert variant.hand.symbols == "synth"
        assert set(variant.pen_colors).isdisjoint(HELD_OUT_STYLE.pen_colors)
        assert variant.desk_colors == TUNING_STYLE.desk_colors
        assert variant.size == TUNING_STYLE.size


def test_the_wide_held_out_style_is_kept_apart_from_the_wide_tuning_style():
    tuning, held_out = STYLES["wide-tuning"], STYLES["wide-held-out"]
    assert (tuning.hand.symbols, held_out.hand.symbols) == ("synth", "sketch")
    assert set(tuning.pen_colors).isdisjoint(held_out.pen_colors)
    assert set(tuning.desk_colors).isdisjoint(held_out.desk_colors)
    assert set(tuning.paper_colors).isdisjoint(held_out.paper_colors)
    assert set(tuning.pattern_colors).isdisjoint(held_out.pattern_colors)
    assert tuning.size != held_out.size


def test_the_wide_styles_render_printed_paper_whiteboards_and_clutter():
    rng = np.random.default_rng(0)
    scenes = [random_scene(rng, STYLES["wide-tuning"]) for _ in range(30)]
    kinds = {scene.paper_kind for scene in scenes}
    assert kinds == {"plain", "squared", "ruled", "dotted", "whiteboard"}
    assert any(scene.clutter for scene in scenes)
    plain = random_scene(np.random.default_rng(1), STYLES["wide-tuning"])
    squared = dataclasses.replace(plain, paper_kind="squared")
    # The printed squares darken the paper around the grid; the rest is the same photo.
    assert (
        squared.photo(np.random.default_rng(2)).mean()
        < plain.photo(np.random.default_rng(2)).mean()
    )


def test_random_labels_cover_all_three_labels():
    labels = [label for seed in range(50) for label in random_labels(np.random.default_rng(seed))]
    counts = {label: labels.count(label) for label in ("circle", "cross", "nothing")}
    assert counts["nothing"] > counts["circle"] > 50 and counts["cross"] > 50
