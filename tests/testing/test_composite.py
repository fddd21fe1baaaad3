"""The composer of the independent test's board photos, on sources made here: it writes what
bench_real_boards.py reads, its two parts share no drawing and no paper photo, a seed gives the
same photos, and what it labels is what the board reader sees on a clean, easy sheet."""

import contextlib
import csv
import json

import cv2
import numpy as np
import pytest

from oxbot.testing.composite import (
    CELLS,
    COLUMNS,
    LATTICES,
    HandwritingSource,
    PaperSource,
    compose,
    compose_board,
    compose_game,
    random_position,
    symbol_cells,
    write_set,
)


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    """Made-up drawings, and four made-up sheets: plain and squared, one of each per part."""
    root = tmp_path_factory.mktemp("composite")
    rng = np.random.default_rng(0)
    circles, crosses = [], []
    for _ in range(8):
        t = np.linspace(0, 2 * np.pi, 40)
        circles.append([np.stack([np.cos(t) * 50, np.sin(t) * 45], 1).tolist()])
        a, b = rng.uniform(-5, 5, 2)
        crosses.append([[[0, 0], [100, 100 + a]], [[100, b], [0, 100]]])
    hands = root / "hands"
    hands.mkdir()
    (hands / "circle.json").write_text(json.dumps(circles))
    (hands / "cross.json").write_text(json.dumps(crosses))
    papers = root / "papers"
    papers.mkdir()
    rows = ["file,kind,split,x0,y0,x1,y1,what"]
    for kind in ("plain", "squared"):
        for j, part in enumerate(("dev", "test")):
            sheet = np.full((600, 800, 3), 235 - 5 * j, np.uint8)
            if kind == "squared":
                sheet[::20] = sheet[:, ::20] = (215, 220, 235)
            cv2.imwrite(str(papers / f"{kind}_{j}.png"), sheet)
            rows.append(f"{kind}_{j}.png,{kind},{part},0,0,800,600,made here")
    regions = root / "regions.csv"
    regions.write_text("\n".join(rows) + "\n")
    return HandwritingSource.load(hands), papers, regions


def test_missing_sources_say_how_to_restore_them(sources, tmp_path):
    _, _, regions = sources
    with pytest.raises(FileNotFoundError, match=r"SOURCES\.md"):
        HandwritingSource.load(tmp_path)
    with pytest.raises(FileNotFoundError, match=r"SOURCES\.md"):
        PaperSource.load(tmp_path, regions)


def test_the_parts_share_no_drawing_and_no_paper(sources):
    hands, papers, regions = sources
    dev, test = hands.split("dev"), hands.split("test")
    assert len(dev.drawings["circle"]) + len(test.drawings["circle"]) == 8
    assert dev.drawings["circle"] and test.drawings["circle"]
    assert not set(dev.writers["circle"]) & set(test.writers["circle"])
    names = {
        part: {n for v in PaperSource.load(papers, regions, part).photos.values() for n, _ in v}
        for part in ("dev", "test")
    }
    assert names["dev"] == {"plain_0.png", "squared_0.png"}
    assert names["test"] == {"plain_1.png", "squared_1.png"}


def test_positions_are_positions_of_a_game():
    rng = np.random.default_rng(1)
    for _ in range(200):
        labels = random_position(rng)
        crosses, circles = labels.count("cross"), labels.count("circle")
        assert crosses - circles in (0, 1)


def test_write_set_writes_what_the_bench_reads_and_a_seed_repeats(sources, tmp_path):
    hands, folder, regions = sources
    papers = PaperSource.load(folder, regions, "test")
    first = write_set(tmp_path / "a", hands, papers, 3, seed=4, split="test")
    again = write_set(tmp_path / "b", hands, papers, 3, seed=4, split="test")
    with first.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert tuple(rows[0]) == COLUMNS and len(rows) == 3
    assert all(r[c] in ("circle", "cross", "nothing") for r in rows for c in CELLS)
    for row in rows:
        a = (tmp_path / "a" / "images" / row["file"]).read_bytes()
        assert a == (tmp_path / "b" / "images" / row["file"]).read_bytes()
    assert again.read_text() == first.read_text()
    lattices = json.loads((tmp_path / "a" / LATTICES).read_text())
    assert sorted(lattices) == sorted(r["file"] for r in rows)
    assert np.asarray(lattices[rows[0]["file"]]).shape == (4, 4, 2)
    write_set(tmp_path / "a", hands, papers, 2, seed=4, split="dev")  # a part beside the other
    with first.open(newline="") as handle:
        splits = [r["split"] for r in csv.DictReader(handle)]
    assert splits.count("test") == 3 and splits.count("dev") == 2
    both = json.loads((tmp_path / "a" / LATTICES).read_text())
    assert len(both) == 5 and {k: both[k] for k in lattices} == lattices
    from oxbot.perception import grid_training  # the file that fine-tuning reads

    assert grid_training.LATTICES == LATTICES


def test_the_lattice_lies_where_the_grid_was_drawn(sources):
    # The inner four points on the drawn lines' crossings, and each symbol inside the cell
    # the lattice gives its label: a lattice off the lines, or turned against the labels,
    # fails one or the other.
    hands, folder, regions = sources
    papers = PaperSource.load(folder, regions)
    rng = np.random.default_rng(8)
    boards = [compose_board(rng, hands, papers) for _ in range(10)]
    for board in boards:
        if "pencil" in board.notes["ink"]:  # faint, and grainy: not in question here
            continue
        gray = board.photo.min(axis=2).astype(np.float32)
        grid = np.zeros(gray.shape, np.uint8)
        cv2.fillConvexPoly(grid, np.round(board.lattice[[0, 0, 3, 3], [0, 3, 3, 0]]).astype(int), 1)
        paper = np.median(gray[grid > 0])  # mostly paper, whatever the desk
        for x, y in board.lattice[1:3, 1:3].reshape(-1, 2):
            patch = gray[round(y) - 1 : round(y) + 2, round(x) - 1 : round(x) + 2]
            assert patch.min() < paper - 40, (board.notes, x, y)
        for cell, label in enumerate(board.labels):
            r, c = divmod(cell, 3)
            corners = board.lattice[[r, r, r + 1, r + 1], [c, c + 1, c + 1, c]]
            middle = corners.mean(axis=0)
            # the middle half of the cell: a cross's strokes cross it, an empty cell's is paper
            inner = np.round(middle + 0.5 * (corners - middle)).astype(np.int32)
            mask = np.zeros(gray.shape, np.uint8)
            cv2.fillConvexPoly(mask, inner, 1)
            darkest = gray[mask > 0].min()
            if label == "cross":
                assert darkest < paper - 40, (board.notes, cell)
            elif label == "nothing":
                assert darkest > paper - 40, (board.notes, cell)


def test_the_labels_are_what_the_reader_sees_on_easy_photos(sources):
    # Not a measurement (bench_composite.py is): if the composer put symbols in other cells
    # than it labels, or the rows the wrong way round, most of these would fail.
    from oxbot.perception.board import read_board

    hands, folder, regions = sources
    papers = PaperSource.load(folder, regions)
    rng = np.random.default_rng(3)
    read = right = 0
    for _ in range(12):
        photo, labels, notes = compose(rng, hands, papers)
        if "pencil" in notes["ink"]:  # faint: read or not, not in question here
            continue
        with contextlib.suppress(Exception):  # a refusal is not in question either
            got = read_board(photo)
            read += 1
            right += got == labels
    assert read >= 5 and right >= read - 1


def test_a_game_is_one_sheet_whose_symbols_come_one_at_a_time(sources):
    hands, folder, regions = sources
    papers = PaperSource.load(folder, regions, "dev")
    x, o, e = "cross", "circle", "nothing"
    labels = [x, o, e, e, x, e, o, e, x]
    order = [4, 0, 8, 6, 1]
    stages, notes = compose_game(np.random.default_rng(5), hands, papers, labels, order, 2)
    assert len(stages) == len(order) + 1 and all(len(s) == 2 for s in stages)
    assert set(notes) >= {"paper", "ink", "notes"}
    first = stages[0][0].astype(np.int16)
    # A camera held still: two frames of one stage differ by sensor noise only, and each new
    # symbol adds ink in its own cell, nowhere else.
    assert np.abs(stages[0][1] - first).mean() < 8
    changed = [np.abs(stages[k][0].astype(np.int16) - stages[k - 1][0]) for k in (1, 2)]
    for diff in changed:
        assert (diff > 60).sum() > 50
    darker = [np.argwhere(d > 60).mean(axis=0) for d in changed]
    assert np.linalg.norm(darker[0] - darker[1]) > 20  # the middle, then the upper left


def test_symbol_cells_are_what_the_classifier_reads(sources):
    hands, folder, regions = sources
    papers = PaperSource.load(folder, regions)
    cells, labels, writers = symbol_cells(hands, papers, np.random.default_rng(0))
    assert cells.shape == (16, 40, 40) and cells.dtype == np.uint8
    assert labels.count("circle") == labels.count("cross") == 8 and len(writers) == 16
    from oxbot.perception import load_classifier

    read = [r.label for r in load_classifier().read(cells)]
    assert sum(r == label for r, label in zip(read, labels, strict=True)) >= 14
