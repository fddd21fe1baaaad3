import numpy as np
import pytest
import torch
from torch import nn

from oxbot import artifacts
from oxbot.config import PerceptionConfig
from oxbot.errors import InvalidInputError, ModelFileError
from oxbot.perception import LABELS, OUTPUTS, SymbolClassifier, load_classifier
from oxbot.perception.augment import generate
from oxbot.perception.classifier import SymbolNet, shipped_model_path
from oxbot.perception.seeds import load_seeds
from oxbot.perception.synth import draw_cell, draw_partial, paper


@pytest.fixture(scope="module")
def shipped():
    return load_classifier()


@pytest.fixture(scope="module")
def cells():
    rng = np.random.default_rng(11)
    labels = [LABELS[i % 3] for i in range(30)]
    return np.stack([draw_cell(label, rng) for label in labels]), labels


def test_network_is_the_papers_architecture():
    net = SymbolNet()
    conv1, relu1, pool1, conv2, relu2, pool2 = net.features
    assert (conv1.in_channels, conv1.out_channels, conv1.kernel_size, conv1.padding) == (
        1,
        8,
        (5, 5),
        (2, 2),
    )
    assert (conv2.out_channels, conv2.kernel_size, conv2.padding) == (16, (5, 5), (2, 2))
    assert isinstance(relu1, nn.ReLU) and isinstance(relu2, nn.ReLU)
    assert (pool1.kernel_size, pool1.stride, pool2.kernel_size, pool2.stride) == (2, 2, 3, 3)
    assert (net.svm.in_features, net.svm.out_features) == (16 * 6 * 6, 3)
    assert net(torch.zeros(2, 1, 40, 40)).shape == (2, 3)
    # the experimental four-output variant: "partial" after the paper's three labels, kept there
    assert SymbolNet(outputs=4)(torch.zeros(2, 1, 40, 40)).shape == (2, 4)
    assert OUTPUTS[:3] == LABELS == ("circle", "cross", "nothing") and OUTPUTS[3] == "partial"


def test_inference_scores_are_the_trained_networks(shipped):
    # `scores` pools by strided maxima instead of MaxPool2d, for speed; the scores must not move.
    x = torch.from_numpy(np.random.default_rng(3).normal(size=(9, 1, 40, 40)).astype(np.float32))
    with torch.inference_mode():
        torch.testing.assert_close(shipped.net.scores(x), shipped.net(x), rtol=0, atol=1e-6)


def test_shipped_model_labels_a_batch_of_cells(shipped, cells):
    images, labels = cells
    predicted = shipped.predict(images)
    assert isinstance(predicted, list) and len(predicted) == len(images)
    assert set(predicted) <= set(LABELS)
    assert predicted == labels


def test_predict_resizes_and_converts_colour(shipped, cells):
    images, labels = cells
    big = np.stack([np.kron(image, np.ones((3, 3), np.uint8)) for image in images[:9]])
    assert shipped.predict(big) == labels[:9]
    rgb = np.repeat(images[:9, :, :, None], 3, axis=3)
    assert shipped.predict(rgb) == labels[:9]
    assert shipped.predict(images[:9].astype(np.float32)) == labels[:9]


@pytest.mark.parametrize(
    "bad,message",
    [
        (np.zeros((0, 40, 40), np.uint8), r"shape \(0, 40, 40\): the batch is empty"),
        (np.zeros((40, 40), np.uint8), r"shape \(40, 40\); expected a batch"),
        (np.zeros((2, 40, 40), bool), "dtype bool; expected uint8"),
        (np.array([["a"] * 40] * 40)[None], "dtype <U1; expected uint8"),
        (np.full((3, 40, 40), np.nan, np.float32), r"NaN or infinite values \(cells \[0, 1, 2\]\)"),
        (np.full((1, 40, 40), 300.0), "values from 300.0 to 300.0"),
        (np.zeros((1, 40, 40, 2), np.uint8), r"shape \(1, 40, 40, 2\)"),
    ],
)
def test_bad_batches_get_a_clear_message(shipped, bad, message):
    with pytest.raises(InvalidInputError, match=message):
        shipped.predict(bad)


def test_fit_on_600_images_beats_chance_strongly():
    seeds = load_seeds()
    x, y = generate(seeds, 600, np.random.default_rng(0))
    test_x, test_y = generate(seeds, 300, np.random.default_rng(1))
    clf = SymbolClassifier(PerceptionConfig(epochs=6), seed=0).fit(x, y)
    assert clf.score(test_x, test_y) > 0.85  # chance is 1/3


def test_fit_checks_labels_against_images():
    images = np.full((4, 40, 40), 200, np.uint8)
    with pytest.raises(InvalidInputError, match="4 images but 3 labels"):
        SymbolClassifier().fit(images, ["circle", "cross", "nothing"])
    with pytest.raises(InvalidInputError, match=r"unknown labels \['square'\]"):
        SymbolClassifier().fit(images, ["circle", "cross", "nothing", "square"])


def test_save_and_load_round_trip_with_metadata(shipped, cells, tmp_path):
    path = shipped.save(tmp_path / "copy.pt", note="round trip")
    again = load_classifier(path)
    np.testing.assert_array_equal(
        again.decision_function(cells[0]), shipped.decision_function(cells[0])
    )
    assert again.metadata["note"] == "round trip"
    assert again.config == shipped.config and again.seed == shipped.seed
    assert [p.name for p in tmp_path.iterdir()] == ["copy.pt"]  # no temporary file left


def test_truncated_model_file_is_refused(tmp_path):
    data = shipped_model_path().read_bytes()
    cut = tmp_path / "cut.pt"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ModelFileError, match=r"cut\.pt is truncated"):
        load_classifier(cut)


def test_model_of_another_architecture_is_refused(tmp_path):
    other = tmp_path / "other.pt"
    torch.save(nn.Linear(57, 18).state_dict(), other)
    with pytest.raises(ModelFileError, match="not a model file"):
        load_classifier(other)
    payload = artifacts.load(shipped_model_path(), "perceiver", 2, "model", "", lambda p: True)
    payload["architecture"]["conv2_filters"] = 32
    artifacts.save(other, "perceiver", 2, payload)
    with pytest.raises(ModelFileError, match="does not match the perceiver's architecture"):
        load_classifier(other)


def test_missing_model_file_says_how_to_make_one(tmp_path):
    with pytest.raises(ModelFileError, match="oxbot train perceiver"):
        load_classifier(tmp_path / "none.pt")


def test_failed_save_keeps_the_old_file_whole(shipped, tmp_path):
    path = shipped.save(tmp_path / "model.pt")
    before = path.read_bytes()
    with pytest.raises(Exception):  # noqa: B017 - a lambda cannot be pickled
        shipped.save(path, callback=lambda: None)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["model.pt"]


def test_predict_leaves_torch_threads_as_they_were(shipped, cells):
    before = torch.get_num_threads()
    shipped.predict(cells[0][:9])
    shipped.predict(np.concatenate([cells[0]] * 4))  # a big batch keeps the caller's threads
    assert torch.get_num_threads() == before


def test_the_shipped_model_has_three_outputs_and_never_reads_partial(shipped):
    rng = np.random.default_rng(5)
    arcs = np.stack([draw_partial(paper((40, 40), rng), rng, (19.5, 19.5), 28) for _ in range(9)])
    assert shipped.outputs == LABELS
    assert shipped.decision_function(arcs).shape == (9, 3)
    readings = shipped.read(arcs)
    assert all(r.label in LABELS for r in readings), readings
    assert [r.spec_label for r in readings] == shipped.predict(arcs)


def _four_output_model(seed=3):
    """An untrained classifier with the experimental partial output, made to win it always."""
    clf = SymbolClassifier(PerceptionConfig(partial_output=True), seed=seed)
    with torch.no_grad():
        clf.net.svm.bias[3] += 5.0
    return clf


def test_a_four_output_model_reads_partial_and_predict_says_nothing(cells, tmp_path):
    clf = _four_output_model()
    assert clf.outputs == OUTPUTS
    assert all(r.label == "partial" for r in clf.read(cells[0]))
    assert clf.predict(cells[0]) == ["nothing"] * len(cells[0])  # a partial cell is no move
    again = load_classifier(clf.save(tmp_path / "four.pt"))
    assert again.outputs == OUTPUTS and again.config.partial_output
    np.testing.assert_array_equal(
        again.decision_function(cells[0]), clf.decision_function(cells[0])
    )


def test_a_three_output_model_cannot_learn_or_lower_partial(cells):
    clf = SymbolClassifier()
    with pytest.raises(InvalidInputError, match="no output for"):
        clf.fit(cells[0][:4], ["circle", "cross", "nothing", "partial"])
    with pytest.raises(InvalidInputError, match="no partial output"):
        clf.lower_partial(*cells, share=0.0)


def test_read_confidences_are_calibrated_probabilities(shipped, cells):
    images, labels = cells
    readings = shipped.read(images)
    assert [r.spec_label for r in readings] == labels
    assert all(0.25 <= r.confidence <= 1.0 for r in readings)
    assert 0.05 <= shipped.temperature <= 5.0  # fitted on held-out images, not left at 1
    assert shipped.temperature != 1.0
    p = shipped.probabilities(images)
    np.testing.assert_allclose(p.sum(axis=1), 1.0, rtol=1e-9)
    # ink: little on a blank (specks, remnants), more on a symbol
    ink = {
        name: np.median([r.ink for r, label in zip(readings, labels, strict=True) if label == name])
        for name in LABELS
    }
    assert ink["nothing"] < 0.5 * min(ink["circle"], ink["cross"]), ink


def test_the_shipped_temperature_is_fitted_on_the_calibration_stream(shipped):
    from oxbot.perception.training import calibrate

    fresh = load_classifier()
    fresh.metadata.pop("temperature")
    assert calibrate(fresh, load_seeds()) == {"temperature": shipped.temperature}


def test_fit_temperature_minimises_the_held_out_loss():
    clf = SymbolClassifier()
    images = np.full((8, 40, 40), 230, np.uint8)
    t = clf.fit_temperature(images, ["nothing"] * 8)
    assert clf.metadata["temperature"] == t and clf.temperature == t


def test_model_files_say_how_many_outputs_they_have(tmp_path):
    payload = artifacts.load(shipped_model_path(), "perceiver", 2, "model", "", lambda p: True)
    assert payload["outputs"] == list(LABELS)
    odd = tmp_path / "odd.pt"
    del payload["outputs"]  # as saved before files named their outputs (three)
    artifacts.save(odd, "perceiver", 2, payload)
    assert load_classifier(odd).outputs == LABELS
    payload["outputs"] = [*LABELS, "smudge"]
    artifacts.save(odd, "perceiver", 2, payload)
    with pytest.raises(ModelFileError, match="has outputs"):
        load_classifier(odd)


def test_lower_partial_keeps_whole_symbols_whole(cells):
    images, labels = cells
    clf = _four_output_model()
    assert all(r.label == "partial" for r in clf.read(images))
    offset = clf.lower_partial(images, labels, share=0.0)
    assert offset > 0 and clf.metadata["partial_offset"] == offset
    whole = [r for r, label in zip(clf.read(images), labels, strict=True) if label != "nothing"]
    assert all(r.label != "partial" for r in whole)
