"""Issue 15's acceptance sets on a fixed seed, small: half-drawn and wrong shapes, and blank
cells of used paper, drawn by `oxbot.testing.odd_cells` (not the training synthesiser).
bench/bench_cells.py measures the same on 1,400 of each."""

from collections import Counter

import numpy as np
import pytest

from oxbot.perception import load_classifier
from oxbot.testing.odd_cells import EMPTY_KINDS, PARTIAL_KINDS, empty_cell, odd_cells, partial_cell

N = 210


@pytest.fixture(scope="module")
def shipped():
    return load_classifier()


@pytest.fixture(scope="module")
def partial_set():
    return odd_cells(N, np.random.default_rng([15, 1]), PARTIAL_KINDS, partial_cell)


@pytest.fixture(scope="module")
def empty_set():
    return odd_cells(N, np.random.default_rng([15, 2]), EMPTY_KINDS, empty_cell)


def test_the_generators_are_reproducible_and_dark_on_light():
    a, kinds = odd_cells(14, np.random.default_rng(1), PARTIAL_KINDS, partial_cell)
    b, _ = odd_cells(14, np.random.default_rng(1), PARTIAL_KINDS, partial_cell)
    assert np.array_equal(a, b) and kinds == list(PARTIAL_KINDS) * 2
    assert a.shape == (14, 40, 40) and a.dtype == np.uint8
    assert all(np.median(c) - c.min() > 40 for c in a)  # visible ink on paper
    e, _ = odd_cells(12, np.random.default_rng(1), EMPTY_KINDS, empty_cell)
    assert all(np.median(c) > 120 for c in e)
    with pytest.raises(ValueError, match="unknown"):
        partial_cell("square", np.random.default_rng(0))


# Issue 15's targets (half-drawn and wrong shapes never a symbol; blanks of used paper nothing)
# are not met by the shipped perceiver, which has the paper's three outputs: bench/bench_cells.py
# (1,400 of each, seed 15) measures them: all 1,400 partial shapes read as a symbol, 1,207 of them
# at confidence >= 0.9; 957 = 68.4% of blanks read as nothing. The experimental 4-output
# perceiver (`[perception] partial_output`) got 565 of 1,400 and 98.4% but fell short of SPEC §1.


def test_dotted_paper_remnants_and_smudges_read_as_nothing(shipped, empty_set):
    # What the shipped model does reach: all 105 of these kinds here (and 700 of 700 in
    # bench/bench_cells.py); squared and ruled paper and erased ghosts are the misses above.
    cells, kinds = empty_set
    labels = shipped.predict(cells)
    wrong = Counter(
        k
        for k, label in zip(kinds, labels, strict=True)
        if k in ("dotted", "remnants", "smudge") and label != "nothing"
    )
    assert sum(wrong.values()) <= 1, wrong
