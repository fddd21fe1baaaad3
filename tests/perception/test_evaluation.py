import cv2
import numpy as np
import pytest

from oxbot.perception import LABELS, load_classifier
from oxbot.perception.evaluation import (
    evaluate,
    evaluate_folder,
    evaluate_fonts,
    evaluate_generated,
)


@pytest.fixture(scope="module")
def shipped():
    return load_classifier()


def test_shipped_model_reaches_the_papers_accuracy_on_1000_generated_images(shipped):
    result = evaluate_generated(shipped)
    assert result.images == 1000
    assert result.accuracy >= 0.999, result.confusion


def test_shipped_model_reads_the_handwriting_fonts_it_never_saw(shipped):
    result = evaluate_fonts(shipped, n=1500)
    assert result.images == 1500
    assert result.accuracy >= 0.995, result.confusion


def test_generated_test_images_change_with_the_seed_and_still_pass(shipped):
    result = evaluate_generated(shipped, n=300, seed=12345)
    assert result.accuracy >= 0.99


class FixedScores:
    """Not a mock of the classifier: a stand-in whose answers are known, to check the sums."""

    def __init__(self, predicted):
        self.predicted = np.asarray(predicted)

    def decision_function(self, images):
        return np.eye(3)[self.predicted]


def test_confusion_matrix_precision_and_recall_are_counted_right():
    truth = ["circle", "circle", "cross", "nothing", "nothing", "nothing"]
    result = evaluate(FixedScores([0, 1, 1, 2, 2, 0]), np.zeros((6, 40, 40), np.uint8), truth)
    # four columns: a whole symbol or a blank read as "partial" is counted, and wrong
    assert result.confusion == [[1, 1, 0, 0], [0, 1, 0, 0], [1, 0, 2, 0], [0, 0, 0, 0]]
    assert result.accuracy == pytest.approx(4 / 6)
    assert result.precision == {"circle": 0.5, "cross": 0.5, "nothing": 1.0, "partial": 1.0}
    assert result.recall == {
        "circle": 0.5,
        "cross": 1.0,
        "nothing": pytest.approx(2 / 3),
        "partial": 1.0,
    }
    assert result.to_dict()["labels"] == [*LABELS, "partial"]


def test_a_labelled_folder_of_big_colour_pngs_is_measured(shipped, tmp_path):
    rng = np.random.default_rng(0)
    for label in ("circle", "cross"):
        for i in range(3):
            image = np.full((120, 120, 3), (235, 225, 215), np.uint8)
            c = int(rng.integers(50, 70))
            if label == "circle":
                cv2.ellipse(image, (c, 60), (30, 25), 0, 0, 360, (20, 20, 120), 6)
            else:
                cv2.line(image, (c - 30, 30), (c + 30, 90), (20, 20, 20), 6)
                cv2.line(image, (c + 30, 30), (c - 30, 90), (20, 20, 20), 6)
            (tmp_path / label).mkdir(exist_ok=True)
            cv2.imwrite(str(tmp_path / label / f"{i}.png"), image)
    result = evaluate_folder(shipped, tmp_path)
    assert result.images == 6 and result.name == str(tmp_path)
    assert result.accuracy == 1.0
    assert result.confusion[2] == [0, 0, 0, 0]  # no blanks in this folder
