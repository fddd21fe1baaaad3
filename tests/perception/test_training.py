import json

import cv2
import pytest

from oxbot.config import PerceptionConfig
from oxbot.errors import DataError
from oxbot.perception import load_classifier
from oxbot.perception.training import train_perceiver


def test_training_writes_model_metrics_and_learning_curve(tmp_path):
    config = PerceptionConfig(test_images=300, epochs=6)
    result = train_perceiver(config, images=600, out=tmp_path / "p.pt", show_progress=False)
    assert result.model_path == tmp_path / "p.pt"
    metrics = json.loads((tmp_path / "p.metrics.json").read_text())
    assert metrics["train_images"] == 600
    assert [p["images"] for p in metrics["learning_curve"]] == [100, 300, 600]
    assert metrics["test"]["images"] == 300
    assert metrics["test"]["accuracy"] > 0.85  # chance is 1/3
    assert metrics["learning_curve"][-1]["accuracy"] == metrics["test"]["accuracy"]
    assert 0 <= metrics["fonts"]["accuracy"] <= 1
    assert metrics["config"]["epochs"] == 6
    curve = cv2.imread(str(tmp_path / "p.curve.png"))
    assert curve is not None and curve.shape[0] > 200
    loaded = load_classifier(tmp_path / "p.pt")
    assert loaded.metadata["trained_images"] == 600
    assert loaded.metadata["test_accuracy"] == metrics["test"]["accuracy"]


def test_training_is_reproducible_from_the_config_seed():
    config = PerceptionConfig(test_images=90, epochs=2)
    a = train_perceiver(config, images=90, curve=False, show_progress=False)
    b = train_perceiver(config, images=90, curve=False, show_progress=False)
    for pa, pb in zip(a.classifier.net.parameters(), b.classifier.net.parameters(), strict=True):
        assert (pa == pb).all()


def test_training_from_a_seed_folder_missing_a_class_fails_clearly(tmp_path):
    (tmp_path / "circle").mkdir()
    with pytest.raises(DataError, match="has no 'circle' images"):
        train_perceiver(images=30, seeds_dir=tmp_path, show_progress=False)
