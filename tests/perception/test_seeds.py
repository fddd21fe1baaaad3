import cv2
import numpy as np
import pytest

from oxbot.errors import DataError
from oxbot.perception.seeds import (
    load_labelled_folder,
    load_seeds,
    make_seeds,
    read_cell,
    shipped_seeds_dir,
)
from oxbot.perception.synth import LABELS


def write(path, image):
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), image)


def test_shipped_seeds_are_108_gray_40x40_pngs_dark_on_light():
    seeds = load_seeds()
    assert {label: len(seeds.images[label]) for label in LABELS} == dict.fromkeys(LABELS, 36)
    for label in LABELS:
        for path in seeds.files[label]:
            raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            assert raw.shape == (40, 40) and raw.dtype == np.uint8, path
            assert np.median(raw) > 120, path


def test_shipped_seeds_are_what_make_seeds_draws(tmp_path):
    make_seeds(tmp_path)
    shipped = load_seeds()
    remade = load_seeds(tmp_path)
    for label in LABELS:
        names = [p.name for p in remade.files[label]]
        assert names == [p.name for p in shipped.files[label]]
        for a, b in zip(remade.images[label], shipped.images[label], strict=True):
            assert np.array_equal(a, b)
    assert shipped.folder == shipped_seeds_dir()


def test_user_folder_of_any_size_and_colour_is_accepted(tmp_path):
    rng = np.random.default_rng(0)
    for i, label in enumerate(LABELS):
        gray = np.full((90, 70), 220, np.uint8)
        cv2.circle(gray, (35, 45), 20, 30, 3) if label == "circle" else None
        write(tmp_path / label / "a.png", gray)
        colour = rng.integers(150, 255, size=(25, 33, 3), dtype=np.uint8)
        write(tmp_path / label / f"b{i}.PNG", colour)
    seeds = load_seeds(tmp_path)
    assert len(seeds) == 6
    for label in LABELS:
        for image in seeds.images[label]:
            assert image.shape == (40, 40) and image.dtype == np.uint8
    assert seeds.images["circle"][0].min() < 100  # the drawn ring survived the resize


def test_empty_seed_folder_names_the_folder(tmp_path):
    for label in LABELS:
        (tmp_path / label).mkdir()
    with pytest.raises(DataError, match=f"{tmp_path}.*has no 'circle' images"):
        load_seeds(tmp_path)


def test_folder_missing_a_class_names_the_class(tmp_path):
    write(tmp_path / "circle" / "a.png", np.full((40, 40), 200, np.uint8))
    write(tmp_path / "nothing" / "a.png", np.full((40, 40), 200, np.uint8))
    with pytest.raises(DataError, match=r"no 'cross' images: .*cross is missing"):
        load_seeds(tmp_path)
    partial = load_labelled_folder(tmp_path, require_all=False)
    assert partial.arrays()[1] == ["circle", "nothing"]


def test_missing_folder_and_corrupt_or_missing_png_name_the_file(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        load_seeds(tmp_path / "nowhere")
    bad = tmp_path / "circle" / "broken.png"
    bad.parent.mkdir()
    bad.write_bytes(b"\x89PNG\r\n\x1a\n not really")
    with pytest.raises(DataError, match=r"broken\.png is not a readable PNG"):
        read_cell(bad)
    with pytest.raises(DataError, match=r"gone\.png does not exist"):
        read_cell(tmp_path / "gone.png")
    (tmp_path / "empty.png").write_bytes(b"")
    with pytest.raises(DataError, match=r"empty\.png is not a readable PNG"):
        read_cell(tmp_path / "empty.png")
