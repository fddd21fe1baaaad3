"""The questionnaires are scored as their authors define, checked against hand-worked answers."""

from __future__ import annotations

import pytest

from oxbot.errors import InvalidInputError
from oxbot.study.instruments import (
    INTELLIGENCE,
    LIKEABILITY,
    PRE,
    SUS,
    check_answer,
    mean_scale,
    score,
    sus_score,
)


def sus(*values: int) -> dict[str, int]:
    return {f"sus{i}": v for i, v in enumerate(values, start=1)}


def test_sus_scores_a_hand_worked_example():
    # odd items 4,4,5,4,5 -> 3+3+4+3+4 = 17; even items 2,1,2,2,1 -> 3+4+3+3+4 = 17; 34 x 2.5
    assert sus_score(sus(4, 2, 4, 1, 5, 2, 4, 2, 5, 1)) == 85.0


@pytest.mark.parametrize(
    ("values", "expected"),
    [
        ((5, 1, 5, 1, 5, 1, 5, 1, 5, 1), 100.0),  # agrees with every good, no bad statement
        ((1, 5, 1, 5, 1, 5, 1, 5, 1, 5), 0.0),
        ((3,) * 10, 50.0),
        ((5,) * 10, 50.0),  # agreeing with everything cancels out
        ((2, 3, 3, 4, 1, 2, 5, 3, 4, 2), 52.5),  # (1+2+0+4+3) + (2+1+3+2+3) = 21 x 2.5
    ],
)
def test_sus_reverses_the_even_items(values, expected):
    assert sus_score(sus(*values)) == expected


def test_sus_is_none_until_all_ten_are_answered():
    answers = sus(4, 2, 4, 1, 5, 2, 4, 2, 5)
    assert sus_score(answers) is None


def test_godspeed_scales_are_the_mean_of_their_items():
    likes = dict(zip([i.key for i in LIKEABILITY.items], [4, 5, 3, 4, 4], strict=True))
    assert mean_scale(LIKEABILITY, likes) == 4.0
    smart = {i.key: str(v) for i, v in zip(INTELLIGENCE.items, [2, 3, 3, 2, 4], strict=True)}
    assert score("intelligence", smart) == pytest.approx(2.8)
    del smart["intel5"]
    assert score("intelligence", smart) is None


def test_score_reads_the_text_the_page_sends():
    assert score("sus", {k: str(v) for k, v in sus(4, 2, 4, 1, 5, 2, 4, 2, 5, 1).items()}) == 85
    assert score("pre", {"age_band": "25-34"}) is None


def test_the_instruments_have_their_authors_item_counts():
    assert len(SUS.items) == 10
    assert len(LIKEABILITY.items) == len(INTELLIGENCE.items) == 5
    assert LIKEABILITY.items[0].low == "Dislike"
    assert INTELLIGENCE.items[-1].high == "Sensible"
    assert [i.key for i in PRE.items] == ["age_band", "robot_experience", "game_experience"]


@pytest.mark.parametrize(
    ("instrument", "item", "value"),
    [
        ("sus", "sus1", "6"),
        ("sus", "sus11", "3"),
        ("godspeed", "like1", "3"),
        ("pre", "age_band", "17"),
    ],
)
def test_check_answer_refuses_what_an_item_cannot_take(instrument, item, value):
    with pytest.raises(InvalidInputError):
        check_answer(instrument, item, value)


def test_check_answer_takes_a_valid_answer():
    check_answer("likeability", "like3", "5")
    check_answer("pre", "robot_experience", "never")
