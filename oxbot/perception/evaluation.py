"""Measuring the perceiver: accuracy, per-label precision and recall, the confusion matrix.

The paper's protocol is 1,000 test images freshly generated from the seeds (§3.3); oxbot adds
any labelled folder (`circle/`, `cross/`, `nothing/` of PNGs) and the handwriting-font set of
`oxbot.perception.fonts`, drawn by a hand the project never trained on.

    clf = load_classifier()
    evaluate_generated(clf).accuracy
    evaluate_folder(clf, "my_cells/").to_dict()
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from oxbot.perception.augment import generate
from oxbot.perception.classifier import SymbolClassifier, label_indices
from oxbot.perception.seeds import LabelledImages, load_labelled_folder, load_seeds
from oxbot.perception.synth import OUTPUTS

TRAIN_STREAM = 1
"""Training images come from `np.random.default_rng([seed, TRAIN_STREAM])`."""
TEST_STREAM = 2
"""Test images come from `np.random.default_rng([seed, TEST_STREAM])`: never the training ones."""
FONT_STREAM = 3
"""The font set comes from `np.random.default_rng([seed, FONT_STREAM])`."""
CALIBRATION_STREAM = 4
"""The held-out images the softmax temperature is fitted on (never training or test ones)."""


@dataclass(frozen=True)
class Evaluation:
    """How well the classifier labels one set of cells."""

    name: str
    """What was measured: "generated", "fonts" or a folder's path."""
    images: int
    """How many cells."""
    accuracy: float
    """Fraction of cells labelled right."""
    precision: dict[str, float]
    """Per label: of the cells given this label, the fraction that had it."""
    recall: dict[str, float]
    """Per label: of the cells that had this label, the fraction given it."""
    confusion: list[list[int]]
    """Counts; rows the true label, columns the predicted one, both in OUTPUTS order (a
    "partial" reading of a whole symbol or a blank counts as wrong)."""

    def to_dict(self) -> dict[str, Any]:
        return {"labels": list(OUTPUTS), **asdict(self)}

    def summary(self) -> str:
        """One line for the terminal."""
        per_label = "  ".join(
            f"{label} P {self.precision[label]:.2%} R {self.recall[label]:.2%}" for label in OUTPUTS
        )
        return f"{self.name}: {self.images} cells, accuracy {self.accuracy:.2%}  {per_label}"


def evaluate(
    classifier: SymbolClassifier,
    images: np.ndarray,
    labels: Any,
    name: str = "cells",
) -> Evaluation:
    """Measure `classifier` on labelled cells (labels as strings or indices)."""
    truth = label_indices(labels)
    predicted = classifier.decision_function(images).argmax(axis=1)
    k = len(OUTPUTS)
    confusion = np.zeros((k, k), np.int64)
    np.add.at(confusion, (truth, predicted), 1)
    given, had = confusion.sum(axis=0), confusion.sum(axis=1)
    diagonal = np.diag(confusion)
    # A label never predicted (or never present) has nothing wrong to report: 1.0, not NaN.
    precision = np.where(given > 0, diagonal / np.maximum(given, 1), 1.0)
    recall = np.where(had > 0, diagonal / np.maximum(had, 1), 1.0)
    return Evaluation(
        name=name,
        images=len(truth),
        accuracy=float(diagonal.sum() / max(len(truth), 1)),
        precision={label: float(p) for label, p in zip(OUTPUTS, precision, strict=True)},
        recall={label: float(r) for label, r in zip(OUTPUTS, recall, strict=True)},
        confusion=confusion.tolist(),
    )


def generated_test_set(
    seeds: LabelledImages, n: int = 1000, seed: int = 0, size: int = 40, partial: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Fresh test cells generated from the seeds, from a stream training never draws from;
    the three public labels, and with `partial` the fourth output too."""
    return generate(seeds, n, np.random.default_rng([seed, TEST_STREAM]), size, partial)


def evaluate_generated(
    classifier: SymbolClassifier,
    seeds: LabelledImages | None = None,
    n: int | None = None,
    seed: int | None = None,
) -> Evaluation:
    """The paper's protocol: accuracy on `n` (1,000) test images generated from the seeds."""
    config = classifier.config
    seeds = seeds if seeds is not None else load_seeds(size=config.image_size)
    images, labels = generated_test_set(
        seeds,
        n if n is not None else config.test_images,
        config.seed if seed is None else seed,
        config.image_size,
    )
    return evaluate(classifier, images, labels, "generated")


def evaluate_folder(classifier: SymbolClassifier, folder: str | Path) -> Evaluation:
    """Accuracy on a labelled folder of PNGs of any size; labels with no images are skipped."""
    cells = load_labelled_folder(folder, classifier.image_size, require_all=False)
    images, labels = cells.arrays()
    return evaluate(classifier, images, labels, str(folder))


def evaluate_fonts(classifier: SymbolClassifier, n: int = 1500, seed: int = 0) -> Evaluation:
    """Accuracy on `n` cells rendered from handwriting fonts, the other hand (never trained on)."""
    from oxbot.perception.fonts import font_cells

    images, labels = font_cells(
        n, np.random.default_rng([seed, FONT_STREAM]), classifier.image_size
    )
    return evaluate(classifier, images, labels, "fonts")
