import json
import subprocess
import sys

import numpy as np

from oxbot.perception.seeds import load_seeds


def oxbot(*args: str) -> subprocess.CompletedProcess:
    """The installed console command, as a user runs it."""
    return subprocess.run(
        [sys.executable, "-m", "oxbot.cli", *args], capture_output=True, text=True, timeout=120
    )


def one_line(text: str) -> str:
    """The terminal wraps long messages; compare them as one line."""
    return " ".join(text.split())


def test_make_seeds_writes_108_pngs_like_the_shipped_ones(tmp_path):
    result = oxbot("perceive", "make-seeds", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert "wrote 108 seed images" in result.stdout
    made, shipped = load_seeds(tmp_path), load_seeds()
    assert all(
        np.array_equal(a, b)
        for label in made.images
        for a, b in zip(made.images[label], shipped.images[label], strict=True)
    )


def test_train_then_evaluate_a_model_on_a_labelled_folder(tmp_path):
    model = tmp_path / "m" / "perceiver.pt"
    trained = oxbot(
        "--set",
        "perception.test_images=150",
        "train",
        "perceiver",
        "--images",
        "300",
        "--out",
        str(model),
        "--no-curve",
        "--quiet",
    )
    assert trained.returncode == 0, trained.stderr
    assert "trained on 300 images" in trained.stdout
    assert model.exists() and model.with_suffix(".metrics.json").exists()
    assert model.with_suffix(".curve.png").exists()

    fonts = tmp_path / "fonts"
    assert oxbot("perceive", "make-font-set", str(fonts), "--images", "30").returncode == 0
    evaluated = oxbot(
        "evaluate",
        "perceiver",
        "--json",
        "--model",
        str(model),
        "--images",
        "150",
        "--no-fonts",
        str(fonts),
    )
    assert evaluated.returncode == 0, evaluated.stderr
    results = json.loads(evaluated.stdout)
    assert [r["name"] for r in results] == ["generated", str(fonts)]
    assert [r["images"] for r in results] == [150, 30]
    assert all(0 <= r["accuracy"] <= 1 and len(r["confusion"]) == 4 for r in results)


def test_bad_seed_folder_and_model_give_one_clear_line(tmp_path):
    (tmp_path / "circle").mkdir()
    result = oxbot("train", "perceiver", "--seeds", str(tmp_path), "--images", "30")
    assert result.returncode == 2
    assert "has no 'circle' images" in one_line(result.stderr)
    assert "Traceback" not in result.stderr
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a model")
    result = oxbot("evaluate", "perceiver", "--model", str(bad))
    assert result.returncode == 2
    assert "bad.pt is truncated or not a model file" in one_line(result.stderr)
    assert "Traceback" not in result.stderr
