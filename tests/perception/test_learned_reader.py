"""The board reader with the shipped learned grid finder (`perception.grid_finder=learned`)."""

from __future__ import annotations

import subprocess
import sys

import cv2
import numpy as np
import pytest

from oxbot.config import PerceptionConfig
from oxbot.errors import NoGridFound
from oxbot.perception.board import BoardReader
from oxbot.perception.grid_points import LearnedGridFinder, shipped_path
from oxbot.testing.render import TUNING_VARIANTS, random_scene, render_photo

from .test_board import photo_cut_at_the_left


@pytest.fixture(scope="module")
def reader() -> BoardReader:
    return BoardReader(config=PerceptionConfig(grid_finder="learned"))


def test_the_shipped_model_says_how_it_was_made():
    info = LearnedGridFinder.load(shipped_path()).info
    assert info["seed"] == 0 and info["config"]["scenes"] == 8000
    assert info["metrics"]["validation"]["found"] > 0.8 * info["metrics"]["validation"]["grids"]


def test_most_photos_of_a_worse_camera_are_read_whole(reader):
    # measured 190 of 200 at seed 7000 (bench/bench_readers.py); 36 of these 40 is the floor
    rng = np.random.default_rng(7000)
    wrong = []
    for i in range(40):
        photo = render_photo(rng, style=TUNING_VARIANTS["tuning-camera"])
        try:
            labels = reader.read(photo.image).labels
        except NoGridFound:
            wrong.append((i, "refused"))
            continue
        if labels != photo.labels:
            wrong.append((i, labels))
    assert len(wrong) <= 4, wrong


def test_a_blank_sheet_is_refused_and_an_empty_grid_reads_empty(reader):
    rng = np.random.default_rng(4)
    style = TUNING_VARIANTS["tuning-hand"]
    blank = random_scene(rng, style, with_grid=False).photo(rng)
    with pytest.raises(NoGridFound, match="no grid in view"):
        reader.read(blank)
    empty = random_scene(rng, style).photo(rng)
    assert reader.read(empty).labels == ("nothing",) * 9


def test_a_grid_cut_by_the_frame_edge_reads_the_cells_in_view(reader):
    labels = [r.label for r in reader.read(photo_cut_at_the_left()).readings]
    assert labels == [
        *("unseen", "nothing", "nothing"),
        *("unseen", "cross", "circle"),
        *("unseen", "nothing", "cross"),
    ]


def test_see_with_the_learned_reader_writes_what_its_network_saw(tmp_path):
    photo = render_photo(np.random.default_rng(6), style=TUNING_VARIANTS["tuning-hand"])
    path = tmp_path / "sheet.png"
    cv2.imwrite(str(path), cv2.cvtColor(photo.image, cv2.COLOR_RGB2BGR))
    debug = tmp_path / "seen"
    args = ["see", str(path), "--reader", "learned", "--debug", str(debug)]
    result = subprocess.run(
        [sys.executable, "-m", "oxbot.cli", *args], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert f"{path}: {' '.join(photo.labels)}" in result.stdout
    heatmaps = cv2.imread(str(debug / "sheet_heatmaps.png"))
    assert heatmaps.shape[1] == 2 * 256 and heatmaps[:, :, 0].max() > 200  # the lines, blue
    wrong = subprocess.run(
        [sys.executable, "-m", "oxbot.cli", "see", str(path), "--reader", "hough"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert wrong.returncode == 2 and "choose one of classical, learned" in wrong.stderr


def test_a_grid_model_of_ones_own_reads_boards_and_a_missing_one_says_what_to_do(tmp_path):
    photo = render_photo(np.random.default_rng(6), style=TUNING_VARIANTS["tuning-hand"])
    path = tmp_path / "sheet.png"
    cv2.imwrite(str(path), cv2.cvtColor(photo.image, cv2.COLOR_RGB2BGR))
    own = tmp_path / "mine.pt"
    own.write_bytes(shipped_path().read_bytes())

    def see(model) -> subprocess.CompletedProcess:
        args = ["--set", "perception.grid_finder=learned"]
        args += ["--set", f"perception.grid_model_path={model}", "see", str(path)]
        return subprocess.run(
            [sys.executable, "-m", "oxbot.cli", *args], capture_output=True, text=True, timeout=120
        )

    assert f"{path}: {' '.join(photo.labels)}" in see(own).stdout
    missing = see(tmp_path / "nowhere.pt")
    assert missing.returncode != 0 and "nowhere.pt" in missing.stderr
    assert "oxbot train reader" in missing.stderr and "Traceback" not in missing.stderr
    no_lattices = subprocess.run(
        [sys.executable, "-m", "oxbot.cli", "train", "reader", "--finetune", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert no_lattices.returncode == 2 and "lattices.json" in no_lattices.stderr
