"""The conditions are counterbalanced by a balanced Latin square (Williams design)."""

from __future__ import annotations

import itertools
from collections import Counter

import pytest

from oxbot.errors import ConfigError
from oxbot.study.conditions import Design, balanced_latin_square, conditions, label


@pytest.mark.parametrize("n", range(1, 9))
def test_each_condition_comes_at_each_position_equally_often(n):
    rows = balanced_latin_square(n)
    assert len(rows) == (n if n % 2 == 0 else 2 * n)
    for row in rows:
        assert sorted(row) == list(range(n))
    for position in range(n):
        counts = Counter(row[position] for row in rows)
        assert set(counts.values()) == {len(rows) // n}


@pytest.mark.parametrize("n", range(2, 9))
def test_each_condition_follows_each_other_equally_often(n):
    rows = balanced_latin_square(n)
    pairs = Counter((a, b) for row in rows for a, b in itertools.pairwise(row))
    assert len(pairs) == n * (n - 1)  # every ordered pair of different conditions
    assert set(pairs.values()) == {1 if n % 2 == 0 else 2}


def test_the_full_design_crosses_the_three_factors():
    found = conditions()
    assert len(found) == 8
    assert len({label(c) for c in found}) == 8
    assert conditions(["manager"]) == [
        {"manager": "dqn", "starter": "robot", "input": "typing"},
        {"manager": "rules", "starter": "robot", "input": "typing"},
    ]


def test_participants_take_the_rows_in_turn():
    design = Design(vary=("manager", "input"), games=2, blocks=2)
    orders = [[label(c) for c in design.order(k)] for k in range(8)]
    assert orders[0] != orders[1]
    assert orders[:4] == orders[4:]  # 4 conditions: a square of 4 rows, then again
    firsts = Counter(o[0] for o in orders[:4])
    assert len(firsts) == 4  # over a whole square, each condition starts once
    assert all(len(o) == 2 for o in orders)


def test_a_design_refuses_impossible_settings():
    with pytest.raises(ConfigError, match="factor"):
        Design(vary=("colour",))
    with pytest.raises(ConfigError, match="--games"):
        Design(games=0)
    with pytest.raises(ConfigError, match="--blocks"):
        Design(vary=("manager",), blocks=3)
