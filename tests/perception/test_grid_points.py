"""The learned grid finder's geometry: heatmap peaks to an ordered lattice."""

from __future__ import annotations

import hashlib
import json
import math

import cv2
import numpy as np
import pytest
import torch

from oxbot.config import GridModelConfig
from oxbot.errors import ModelFileError
from oxbot.perception.grid_model import INPUT_SIDE, STRIDE
from oxbot.perception.grid_points import (
    LearnedGridFinder,
    best_crossings,
    lattice_from,
    order_crossings,
    peaks,
    picture_of,
)
from oxbot.perception.grid_training import (
    finetune_reader,
    load_photos,
    point_targets,
    train_reader,
)


def grid_lattice(rotation: float, centre=(120.0, 100.0), cell=40.0, tilt=0.0) -> np.ndarray:
    """A 4x4 lattice in picture pixels: a grid turned by `rotation` degrees, seen with some
    perspective (`tilt`: how much further apart the lower rows are)."""
    a = math.radians(rotation)
    turn = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    units = np.array([[c, r] for r in range(4) for c in range(4)], np.float64) - 1.5
    units[:, 0] *= 1 + tilt * units[:, 1] / 1.5
    return (units * cell @ turn.T + centre).reshape(4, 4, 2)


@pytest.mark.parametrize("rotation", [-44.0, -30.0, -5.0, 0.0, 12.0, 33.0, 44.0])
def test_the_crossings_are_ordered_by_where_they_lie_whatever_order_they_come_in(rotation):
    truth = grid_lattice(rotation)
    inner = np.array([truth[1, 1], truth[1, 2], truth[2, 2], truth[2, 1]])
    rng = np.random.default_rng(int(rotation) + 50)
    for _ in range(5):
        shuffled = inner[rng.permutation(4)]
        assert np.allclose(order_crossings(shuffled), inner)


def test_a_grid_turned_past_45_degrees_is_read_as_turned_the_other_way():
    # a # looks the same turned by a quarter: 60 degrees one way is 30 the other
    inner60 = grid_lattice(60.0)[1:3, 1:3].reshape(4, 2)[[0, 1, 3, 2]]
    inner_30 = grid_lattice(-30.0)[1:3, 1:3].reshape(4, 2)[[0, 1, 3, 2]]
    assert np.allclose(order_crossings(inner60), inner_30, atol=1e-6)


@pytest.mark.parametrize("rotation,tilt", [(0.0, 0.0), (25.0, 0.15), (-40.0, -0.2)])
def test_peaks_of_the_target_heatmaps_give_back_the_crossings_to_half_a_pixel(rotation, tilt):
    truth = grid_lattice(rotation, tilt=tilt)
    crossing_heat, outer_heat = point_targets(truth[None].astype(np.float32), sigma=1.5)[0]
    found = np.array(peaks(crossing_heat, 4))
    assert found[:, 2].min() > 0.7
    lattice = lattice_from(order_crossings(found[:, :2]), outer_heat)
    in_picture = (lattice + 0.5) * STRIDE - 0.5
    assert np.abs(in_picture[1:3, 1:3] - truth[1:3, 1:3]).max() < 0.5  # picture pixels
    if tilt == 0.0:  # no perspective: extending along the lines is exact everywhere
        assert np.abs(in_picture - truth).max() < 0.5


def test_the_lines_are_extended_past_the_crossings_by_the_middle_cell():
    truth = grid_lattice(20.0)
    crossings = (truth[[1, 1, 2, 2], [1, 2, 2, 1]] + 0.5) / STRIDE - 0.5
    lattice = (lattice_from(crossings, None) + 0.5) * STRIDE - 0.5
    assert np.abs(lattice - truth).max() < 1e-6


def test_a_line_drawn_longer_ends_at_its_own_peak():
    truth = grid_lattice(10.0)
    uneven = truth.copy()
    uneven[0, 1] += (5.0, -6.0)  # the left line runs on, bent: not where extending puts it
    _, outer_heat = point_targets(uneven[None].astype(np.float32), sigma=1.5)[0]
    crossing_heat, _ = point_targets(truth[None].astype(np.float32), sigma=1.5)[0]
    crossings = order_crossings(np.array(peaks(crossing_heat, 4))[:, :2])
    lattice = (lattice_from(crossings, outer_heat) + 0.5) * STRIDE - 0.5
    assert np.abs(lattice[0, 1] - uneven[0, 1]).max() < 0.5
    # without the outer heatmap, the extended line's point: the drawn end is missed
    plain = (lattice_from(crossings, None) + 0.5) * STRIDE - 0.5
    assert np.abs(plain[0, 1] - uneven[0, 1]).max() > 3


def test_a_frame_becomes_the_networks_picture_with_its_long_side_at_input_size():
    frame = np.full((720, 1280, 3), 200, np.uint8)
    picture, scale = picture_of(frame)
    assert picture.shape == (3, 160, INPUT_SIDE)  # 144 rows padded to a multiple of 32
    assert scale == pytest.approx(1280 / INPUT_SIDE)
    assert picture[:, :144].min() == pytest.approx(200 / 255, abs=0.01)
    assert picture[:, 144:].max() == 0.0
    gray = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)
    assert picture_of(gray)[0].shape == picture.shape


def test_a_tiny_training_run_writes_a_checked_model_its_metrics_and_curve(tmp_path):
    config = GridModelConfig(
        width=4, scenes=16, validation_scenes=8, epochs=1, batch_size=8, threads=1
    )
    result = train_reader(config, tmp_path / "grid.pt", show_progress=False)
    assert result.curve_path.stat().st_size > 0
    metrics = json.loads(result.metrics_path.read_text())
    assert metrics["config"]["seed"] == 0 and len(metrics["curve"]) == 1
    assert metrics["validation"]["grids"] + metrics["validation"]["without_grid"] == 8
    finder = LearnedGridFinder.load(result.model_path)
    assert finder.info["config"]["width"] == 4
    look = finder.look(np.full((120, 160, 3), 230, np.uint8))
    assert look.heatmaps.shape == (3, 192 // STRIDE, INPUT_SIDE // STRIDE)
    # a flipped byte in the weights is refused before anything is loaded
    data = bytearray(result.model_path.read_bytes())
    data[-100] ^= 0xFF
    damaged = tmp_path / "damaged.pt"
    damaged.write_bytes(bytes(data))
    with pytest.raises(ModelFileError, match=r"damaged\.pt is corrupt"):
        LearnedGridFinder.load(damaged)


def photos_with_lattices(folder, count: int, size=(480, 360)) -> list[np.ndarray]:
    """`count` photos of grids (large renders standing in for real photos) written as a
    fine-tuning folder: images/ and lattices.json. Their lattices, in photo pixels."""
    from oxbot.perception.grid_scenes import random_grid_scene

    (folder / "images").mkdir(parents=True)
    rng = np.random.default_rng(11)
    lattices, truths = {}, []
    while len(truths) < count:
        scene = random_grid_scene(rng, size)
        if not scene.present:
            continue
        name = f"photo_{len(truths)}.png"
        cv2.imwrite(str(folder / "images" / name), scene.image[:, :, ::-1])
        lattices[name] = scene.lattice.tolist()
        truths.append(scene.lattice)
    (folder / "lattices.json").write_text(json.dumps(lattices))
    return truths


def test_photos_are_seen_as_the_network_sees_a_frame_with_their_lattices_scaled(tmp_path):
    truths = photos_with_lattices(tmp_path / "photos", 3, size=(512, 384))
    photos = load_photos([tmp_path / "photos"])
    assert photos.pictures.shape == (3, INPUT_SIDE, INPUT_SIDE, 3)
    assert photos.sizes.tolist() == [[256, 192]] * 3
    # half the size, about the pixel centres: (x + 0.5) / 2 - 0.5
    assert np.allclose(photos.lattices[0], (truths[0] + 0.5) / 2 - 0.5, atol=1e-4)
    assert photos.present.all() and not photos.lines_known.any()
    assert photos.pictures[:, 192:].max() == 0  # padded below, as renders are


def test_fine_tuning_goes_on_from_a_model_and_records_where_from(tmp_path):
    config = GridModelConfig(
        width=4,
        scenes=16,
        validation_scenes=8,
        epochs=1,
        batch_size=8,
        threads=1,
        finetune_epochs=2,
        finetune_renders=8,
    )
    begun = train_reader(config, tmp_path / "grid.pt", show_progress=False)
    photos_with_lattices(tmp_path / "photos", 20)
    result = finetune_reader(
        config, begun.model_path, [tmp_path / "photos"], tmp_path / "tuned.pt", False
    )
    metrics = json.loads(result.metrics_path.read_text())
    assert metrics["photos"] == {
        "folders": [str(tmp_path / "photos")],
        "trained_on": 18,
        "kept_apart": 2,
    }
    assert len(metrics["curve"]) == 2 and metrics["curve"][-1]["photos_grids"] == 2
    assert metrics["before"]["photos"]["grids"] == 2
    finder = LearnedGridFinder.load(result.model_path)
    digest = hashlib.sha256(begun.model_path.read_bytes()).hexdigest()
    assert finder.info["finetuned_from"]["sha256"] == digest
    before = LearnedGridFinder.load(begun.model_path).net.state_dict()
    after = finder.net.state_dict()
    assert any(not torch.equal(before[k], after[k]) for k in before)


def test_fine_tuning_on_a_folder_without_lattices_says_what_it_needs(tmp_path):
    (tmp_path / "images").mkdir()
    with pytest.raises(FileNotFoundError, match=r"has no lattices\.json.*compose_boards"):
        load_photos([tmp_path])


def test_a_crossing_the_net_missed_is_completed_when_the_lines_vouch_for_it():
    truth = grid_lattice(15.0, centre=(128.0, 128.0), cell=60.0)
    heat = (truth + 0.5) / STRIDE - 0.5
    lines = np.zeros((64, 64), np.float32)
    for k in (1, 2):  # the four drawn lines, end to end
        for a, b in ((heat[0, k], heat[3, k]), (heat[k, 0], heat[k, 3])):
            cv2.line(lines, tuple(np.round(a).astype(int)), tuple(np.round(b).astype(int)), 1.0)
    three = np.array([[*heat[1, 1], 0.9], [*heat[1, 2], 0.8], [*heat[2, 1], 0.85]])
    crossings, sure = best_crossings(three, lines)
    assert np.abs(crossings[2] - heat[2, 2]).max() < 0.5 and 0 < sure < 0.7
    # without the lines there is nothing to vouch for a fourth corner
    assert best_crossings(three, np.zeros_like(lines)) is None
