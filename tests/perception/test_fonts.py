import numpy as np
import pytest

from oxbot.errors import DataError
from oxbot.perception import fonts
from oxbot.perception.seeds import load_labelled_folder
from oxbot.perception.synth import LABELS


def test_the_four_handwriting_font_packages_are_found():
    families = {path.parent.name for path in fonts.font_files()}
    assert families == {"fifthhorseman", "breip", "femkeklaver", "rufscript"}


def test_font_cells_are_labelled_dark_on_light_and_reproducible():
    images, labels = fonts.font_cells(30, np.random.default_rng(0))
    again, _ = fonts.font_cells(30, np.random.default_rng(0))
    assert images.shape == (30, 40, 40) and images.dtype == np.uint8
    assert labels == [LABELS[i % 3] for i in range(30)]
    assert np.array_equal(images, again)
    for image, label in zip(images, labels, strict=True):
        contrast = np.median(image) - image.min()
        assert contrast > 40 if label != "nothing" else contrast < 40


def test_font_set_is_written_as_a_labelled_folder(tmp_path):
    fonts.write_font_set(tmp_path, 12)
    folder = load_labelled_folder(tmp_path)
    assert {label: len(folder.images[label]) for label in LABELS} == dict.fromkeys(LABELS, 4)


def test_missing_fonts_name_the_packages(monkeypatch, tmp_path):
    monkeypatch.setattr(fonts, "FONT_DIRS", (tmp_path,))
    fonts.font_files.cache_clear()
    try:
        with pytest.raises(DataError, match="fonts-dkg-handwriting"):
            fonts.font_files()
    finally:
        fonts.font_files.cache_clear()


def test_every_font_draws_both_symbols_except_three_capital_xs_that_are_not_two_strokes():
    assert len(fonts.glyphs("circle")) == 2 * len(fonts.font_files())
    assert len(fonts.glyphs("cross")) == 2 * len(fonts.font_files()) - 3
    kept = {(f.name, c) for f, c in fonts.glyphs("cross")}
    assert not kept & fonts.LEFT_OUT
    assert ("Rufscript010.ttf", "x") in kept and ("dkg.ttf", "X") in kept
