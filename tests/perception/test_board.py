import dataclasses
import subprocess
import sys

import cv2
import numpy as np
import pytest

from oxbot.errors import InvalidInputError, NoGridFound
from oxbot.game.board import CELL_NAMES
from oxbot.perception.board import BoardReader, default_reader, ink_elongation, read_board
from oxbot.perception.classifier import load_classifier
from oxbot.testing.render import (
    HELD_OUT_STYLE,
    TUNING_STYLE,
    WIDE_TUNING_STYLE,
    random_scene,
    render_photo,
)


def test_read_board_is_public_next_to_load_classifier():
    import oxbot.perception as perception

    assert perception.read_board is read_board
    assert callable(perception.load_classifier)


HELD_OUT_FLOOR = 0.975
"""A regression guard just below what the reader with the shipped classifier was measured at on
these photos (98.5%, 197/200; SPEC §2's goal is 98%): two photos of slack for the last bits of
floating point in another build of OpenCV or torch."""


def test_all_9_cells_right_in_most_held_out_photos():
    """All 9 cells right in at least HELD_OUT_FLOOR of 200 photos of the style the reader was
    not tuned on (SPEC §2 goal: 98%)."""
    rng = np.random.default_rng(2024)
    right, wrong = 0, []
    for i in range(200):
        photo = render_photo(rng, style=HELD_OUT_STYLE)
        try:
            labels = tuple(read_board(photo.image))
        except NoGridFound:
            wrong.append((i, "no grid"))
            continue
        if labels == photo.labels:
            right += 1
        else:
            pairs = enumerate(zip(photo.labels, labels, strict=True))
            wrong.append((i, [(cell, true, seen) for cell, (true, seen) in pairs if true != seen]))
    share = right / 200
    assert share >= HELD_OUT_FLOOR, (f"all 9 cells right in {share:.1%}", wrong)


def test_read_board_takes_rgb_or_gray_and_gives_9_labels_row_major():
    labels = (
        "cross",
        "nothing",
        "nothing",
        "nothing",
        "circle",
        "nothing",
        "nothing",
        "nothing",
        "cross",
    )
    photo = render_photo(np.random.default_rng(3), labels, TUNING_STYLE)
    assert read_board(photo.image) == list(labels)
    gray = cv2.cvtColor(photo.image, cv2.COLOR_RGB2GRAY)
    assert read_board(gray) == list(labels)


class CountingClassifier:
    """The real classifier, counting the batches it is asked to classify."""

    def __init__(self) -> None:
        self.inner = load_classifier()
        self.batches: list[tuple[int, ...]] = []

    def predict(self, cells: np.ndarray) -> list[str]:
        self.batches.append(cells.shape)
        return self.inner.predict(cells)


def test_the_9_cells_go_to_the_classifier_in_one_batch():
    classifier = CountingClassifier()
    reader = BoardReader(classifier)
    photo = render_photo(np.random.default_rng(4), style=TUNING_STYLE)
    reading = reader.read(photo.image)
    assert classifier.batches == [(9, 40, 40)]
    assert reading.cells.shape == (9, 40, 40) and reading.cells.dtype == np.uint8
    assert default_reader() is default_reader()  # the shipped classifier is loaded once


def test_a_half_drawn_cross_reads_nothing_until_its_second_stroke():
    rng = np.random.default_rng(5)
    scene = random_scene(rng, TUNING_STYLE).with_symbol(4, "cross", rng)
    assert read_board(scene.photo(rng, drawn={4: 1.0}))[4] == "nothing"
    assert read_board(scene.photo(rng))[4] == "cross"


def test_ink_elongation_tells_a_stroke_from_a_symbol():
    cells = np.full((3, 40, 40), 245, np.uint8)
    cv2.line(cells[0], (8, 8), (31, 31), 40, 3)  # one stroke
    cv2.line(cells[1], (8, 8), (31, 31), 40, 3)  # a cross
    cv2.line(cells[1], (31, 8), (8, 31), 40, 3)
    cv2.circle(cells[2], (20, 20), 11, 40, 3)  # a circle
    stretch = ink_elongation(cells)
    assert stretch[0] > 20 and stretch[1] < 2 and stretch[2] < 2


@pytest.mark.parametrize(
    "frame,error,message",
    [
        (np.zeros((0, 640, 3), np.uint8), InvalidInputError, "empty"),
        (np.zeros((480, 640, 3), np.float64), InvalidInputError, "dtype float64"),
        (np.zeros((480, 640, 4), np.uint8), InvalidInputError, "alpha"),
        (np.zeros((16, 16, 3), np.uint8), InvalidInputError, "too small"),
        (np.full((480, 640, 3), 230, np.uint8), NoGridFound, "no grid in view"),
    ],
)
def test_bad_frames_raise_clear_oxbot_errors(frame, error, message):
    with pytest.raises(error, match=message):
        read_board(frame)


# --- `oxbot see` ---


def oxbot(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "oxbot.cli", *args], capture_output=True, text=True, timeout=120
    )


def test_see_prints_the_board_of_each_photo_and_writes_debug_images(tmp_path):
    labels = (
        "nothing",
        "cross",
        "nothing",
        "nothing",
        "circle",
        "nothing",
        "cross",
        "nothing",
        "nothing",
    )
    photo = render_photo(np.random.default_rng(6), labels, TUNING_STYLE)
    path = tmp_path / "sheet.jpg"
    cv2.imwrite(str(path), cv2.cvtColor(photo.image, cv2.COLOR_RGB2BGR))
    debug = tmp_path / "seen"
    result = oxbot("see", str(path), str(path), "--debug", str(debug))
    assert result.returncode == 0, result.stderr
    assert result.stdout.count(f"{path}: {' '.join(labels)}") == 2
    assert "   | X |  \n---+---+---\n   | O |  \n---+---+---\n X |   |  " in result.stdout
    written = sorted(p.name for p in debug.iterdir())
    assert len(written) == 12
    assert {"sheet_grid.png", "sheet_sheet.png", "sheet_cleaned.png"} <= set(written)
    assert f"sheet_cell4_{CELL_NAMES[4]}_circle.png" in written
    cell = cv2.imread(str(debug / "sheet_cell1_uppermiddle_cross.png"), cv2.IMREAD_GRAYSCALE)
    assert cell.shape == (40, 40)
    # each cell's reading with its confidence, in three rows; the same written on the grid image
    rows = [line.split() for line in result.stdout.splitlines() if line.count(".") == 3]
    assert len(rows) == 6 and rows[1][2:4] == ["circle", rows[1][3]]
    assert all(0.0 < float(c) <= 1.0 for row in rows for c in row[1::2])
    grid = cv2.imread(str(debug / "sheet_grid.png"))
    assert not np.array_equal(grid, cv2.imread(str(path)))  # drawn on


def test_see_debug_writes_a_refused_frame_with_the_reason(tmp_path):
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640, 3), 235, np.uint8))
    debug = tmp_path / "seen"
    result = oxbot("see", str(blank), "--debug", str(debug))
    assert result.returncode == 2 and "no grid in view" in result.stderr
    refused = cv2.imread(str(debug / "blank_refused.png"))
    assert refused.shape == (480, 640, 3)
    assert (refused[:40] != 235).any() and (refused[200:] == 235).all()  # the reason, on top


def test_see_reports_unreadable_photos_and_goes_on(tmp_path):
    good = tmp_path / "good.png"
    photo = render_photo(np.random.default_rng(7), style=TUNING_STYLE)
    cv2.imwrite(str(good), cv2.cvtColor(photo.image, cv2.COLOR_RGB2BGR))
    corrupt = tmp_path / "corrupt.png"
    corrupt.write_bytes(good.read_bytes()[:200])
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640, 3), 235, np.uint8))
    result = oxbot("see", str(corrupt), str(blank), str(good))
    assert result.returncode == 2
    assert "corrupt.png" in result.stderr and "not an image OpenCV can read" in result.stderr
    assert "blank.png" in result.stderr and "no grid in view" in result.stderr
    assert f"{good}: {' '.join(photo.labels)}" in result.stdout
    assert "Traceback" not in result.stderr


def test_all_9_cells_right_in_most_wide_tuning_photos():
    """A wider world (turned up to 40 degrees, strong perspective, squared, ruled and
    dotted paper, whiteboards, coloured markers, pens and hands around, grids at the frame's
    edge): all 9 cells right in nearly all of 40 development photos (39 when measured)."""
    rng = np.random.default_rng(15)
    wrong = []
    for i in range(40):
        photo = render_photo(rng, style=WIDE_TUNING_STYLE)
        try:
            labels = tuple(read_board(photo.image))
        except NoGridFound:
            wrong.append((i, "no grid"))
            continue
        if labels != photo.labels:
            wrong.append((i, photo.scene.paper_kind, labels))
    assert len(wrong) <= 2, wrong


def test_printed_squares_dots_and_rules_are_no_symbols():
    # The classifier learnt on plain paper: before the background was wiped (`wipe_background`)
    # 115 of these 288 empty cells read as a circle or a cross, after it 5 (all on one sheet
    # whose printed squares are dark and wide).
    reader = default_reader()
    misread = 0
    for kind in ("squared", "ruled", "dotted"):
        style = dataclasses.replace(WIDE_TUNING_STYLE, paper_kinds=(kind,), clutter=0)
        for seed in range(12):
            rng = np.random.default_rng(seed)
            scene = random_scene(rng, style).with_symbol(4, "cross", rng)
            labels = reader.read(scene.photo(rng)).labels
            misread += sum(label != "nothing" for i, label in enumerate(labels) if i != 4)
            assert labels[4] == "cross"
    assert misread <= 8


def photo_cut_at_the_left() -> np.ndarray:
    """A photo whose grid's left column lies beyond the frame's left edge (cells 80 px, the
    grid's left edge at -50 px), with a circle drawn there and four symbols in view."""
    width, height = TUNING_STYLE.size
    style = dataclasses.replace(TUNING_STYLE, perspective=0.0)
    center = ((-50 + 0.25 * height) / width, 0.5)
    rng = np.random.default_rng(3)
    scene = random_scene(rng, style, grid_fraction=(0.5, 0.5), center=center, rotation=0)
    for cell, label in ((3, "circle"), (4, "cross"), (5, "circle"), (8, "cross")):
        scene = scene.with_symbol(cell, label, rng)
    return scene.photo(rng)


def test_a_grid_cut_by_the_frame_edge_reads_the_cells_in_view():
    photo = photo_cut_at_the_left()
    reading = default_reader().read(photo)
    assert [r.label for r in reading.readings] == [
        *("unseen", "nothing", "nothing"),
        *("unseen", "cross", "circle"),
        *("unseen", "nothing", "cross"),
    ]
    with pytest.raises(NoGridFound, match="upperleft, middleleft, lowerleft out of view"):
        read_board(photo)


def test_see_says_which_cells_are_out_of_view(tmp_path):
    path = tmp_path / "cut.png"
    cv2.imwrite(str(path), cv2.cvtColor(photo_cut_at_the_left(), cv2.COLOR_RGB2BGR))
    result = oxbot("see", str(path))
    assert result.returncode == 0, result.stderr
    assert "out of view: upperleft, middleleft, lowerleft" in result.stdout
