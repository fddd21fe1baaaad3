import cv2
import numpy as np
import pytest

from oxbot.errors import DataError
from oxbot.perception.augment import extract_ink, generate
from oxbot.perception.seeds import LabelledImages, load_seeds
from oxbot.perception.synth import LABELS


@pytest.fixture(scope="module")
def seeds():
    return load_seeds()


def test_generation_is_reproducible_from_a_seed(seeds):
    a, la = generate(seeds, 60, np.random.default_rng(3))
    b, lb = generate(seeds, 60, np.random.default_rng(3))
    c, _ = generate(seeds, 60, np.random.default_rng(4))
    assert np.array_equal(a, b) and np.array_equal(la, lb)
    assert not np.array_equal(a, c)


def test_generated_images_are_balanced_cells(seeds):
    images, labels = generate(seeds, 300, np.random.default_rng(0))
    assert images.shape == (300, 40, 40) and images.dtype == np.uint8
    assert labels.dtype == np.int64
    assert np.bincount(labels, minlength=3).tolist() == [100, 100, 100]
    assert np.median(images) > 120  # still dark ink on light paper


def test_drawings_are_shifted_to_many_positions(seeds):
    one = LabelledImages(
        {
            "circle": seeds.images["circle"][:1],
            "cross": seeds.images["cross"][:1],
            "nothing": seeds.images["nothing"][:1],
        },
        {label: [] for label in LABELS},
        seeds.folder,
    )
    images, labels = generate(one, 300, np.random.default_rng(1))
    centres = []
    for image in images[labels == LABELS.index("cross")]:
        ink = extract_ink(image)
        ink[:3], ink[-3:], ink[:, :3], ink[:, -3:] = 0, 0, 0, 0  # ignore grid remnants
        ys, xs = np.nonzero(ink > 0.3)
        centres.append((xs.mean(), ys.mean()))
    centres = np.array(centres)
    assert centres[:, 0].std() > 2.5 and centres[:, 1].std() > 2.5
    assert np.ptp(centres[:, 0]) > 10


def test_extract_ink_finds_strokes_not_paper():
    image = np.full((40, 40), 200, np.uint8)
    image[:, 20:] = 150  # a shadow is not ink
    cv2.line(image, (5, 10), (35, 30), 40, 2)
    ink = extract_ink(image)
    assert ink[10:31, 5:36].max() > 0.6
    assert ink[30:, :10].max() == 0 and ink[:8, 25:].max() == 0


def test_a_seed_with_no_drawing_is_reported(seeds):
    blank = np.full((40, 40), 210, np.uint8)
    broken = LabelledImages(
        {"circle": [blank], "cross": seeds.images["cross"], "nothing": seeds.images["nothing"]},
        {label: [] for label in LABELS},
        seeds.folder,
    )
    with pytest.raises(DataError, match="'circle' seed has no visible drawing"):
        generate(broken, 10, np.random.default_rng(0))


def test_partial_adds_a_fourth_balanced_class(seeds):
    images, labels = generate(seeds, 400, np.random.default_rng(0), partial=True)
    counts = np.bincount(labels, minlength=4)
    assert counts.sum() == 400 and counts[3] > 0 and labels.max() == 3
    assert np.median(images[labels == 3]) > 120  # ink on light paper, like the rest
