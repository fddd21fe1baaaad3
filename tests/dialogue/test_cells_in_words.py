"""Cells named in words: the phrasings that name one, the ones that must not, the recogniser's
mishearings undone, and how sure an N-best list makes a move."""

import pytest

from oxbot.dialogue.cells_in_words import (
    MIN_AGREEMENT,
    REPAIRED_CERTAINTY,
    CellWords,
    move_in_words,
    read_cell,
)
from oxbot.dialogue.domain import GAME_MOVE_TEMPLATE, load_domain
from oxbot.game.board import CELL_NAMES

NAMED = {
    "top left": "upperleft",
    "Top left.": "upperleft",
    "left top": "upperleft",
    "upperleft": "upperleft",
    "the top left corner": "upperleft",
    "the left hand corner at the top": "upperleft",
    "the middle one": "middle",
    "the middle": "middle",
    "centre": "middle",
    "center": "middle",
    "the centre square please": "middle",
    "middle middle": "middle",
    "right in the middle": "middle",
    "right, the middle one": "middle",
    "go in the middle": "middle",
    "the upper middle": "uppermiddle",
    "top middle": "uppermiddle",
    "in the middle of the top row": "uppermiddle",
    "middle left": "middleleft",
    "left middle": "middleleft",
    "centre right": "middleright",
    "top right please": "upperright",
    "bottom right corner": "lowerright",
    "lower right": "lowerright",
    "I'll take the bottom left": "lowerleft",
    "I'd like the bottom middle": "lowermiddle",
    "okay, I'll go top left then": "upperleft",
    "row two column three": "middleright",
    "row 2, column 3": "middleright",
    "column three row two": "middleright",
    "the second row, third column": "middleright",
    "the left column of the top row": "upperleft",
    "row three column one": "lowerleft",
    "number five": "middle",
    "cell 9": "lowerright",
    "number one": "upperleft",
    "five": "middle",
    "5": "middle",
    "I'll take 7": "lowerleft",
    "top left, top left": "upperleft",
}
"""Phrasings and the cell each names."""

NOT_A_CELL = [
    "I'm left handed",  # a column alone
    "what's left",
    "no",
    "yes",
    "right",
    "okay",
    "top",
    "the corner",
    "bottom corner",
    "middle row",  # a row alone
    "row two",
    "one",  # "this one" as often as the first cell
    "I pick this one",
    "that one",
    "one more",
    "one two three",
    "number ten",
    "row four column one",
    "top bottom",
    "left right",
    "the middle or the top left",  # two cells
    "top left, no, bottom right",
    "I want to stop",
    "road two",  # a mishearing undone only with a column named
    "",
]
"""Phrasings that name no cell, or more than one."""

LOOSE = {
    "middle of nowhere": "middle",
    "not the middle": "middle",
    "I'll go in the middle this time": "middle",
    "no, top left": "upperleft",
}
"""A cell among other words: never a move, but the robot may ask which cell was meant."""


@pytest.mark.parametrize("text,cell", NAMED.items())
def test_a_cell_named_in_words_is_read(text, cell):
    assert read_cell(text) == CellWords(CELL_NAMES.index(cell))


@pytest.mark.parametrize("text", NOT_A_CELL)
def test_words_that_name_no_cell_or_several_are_not_read(text):
    assert read_cell(text) is None


@pytest.mark.parametrize("text,cell", LOOSE.items())
def test_a_cell_among_other_words_is_read_loosely_and_never_surely(text, cell):
    reading = read_cell(text)
    assert reading is not None and reading.loose and reading.cell == CELL_NAMES.index(cell)
    assert reading.certainty == 0.0 and move_in_words([(text, 1.0)]) is None


@pytest.mark.parametrize(
    "text", ["road to column three", "row to column three", "roll two column three"]
)
def test_a_recognisers_mishearing_of_a_row_is_undone_and_counts_as_less_sure(text):
    reading = read_cell(text)
    assert reading == CellWords(CELL_NAMES.index("middleright"), repaired=True)
    assert move_in_words([(text, 1.0)]).score == REPAIRED_CERTAINTY


def test_the_domains_own_move_phrasings_name_their_cells():
    """The phrasings added for the recogniser to hear moves all read as a cell."""
    said = load_domain().phrasings[GAME_MOVE_TEMPLATE]
    named = [text for text in said if read_cell(text) is not None]
    assert len(named) >= 20 and all(not read_cell(text).loose for text in named)
    # the words of a drawing ("I pick this one") name none
    assert read_cell("i pick this one") is None and read_cell("over to you") is None


def test_a_move_heard_is_as_sure_as_the_best_hypothesis_and_the_n_best_agree():
    alone = move_in_words([("top left", 0.9)])
    assert alone.cell == 0 and alone.score == pytest.approx(0.9) and alone.words == "top left"
    agreeing = move_in_words([("top left", 0.8), ("the top left", 0.4), ("stop it", 0.0)])
    assert agreeing.score == pytest.approx(0.8)
    torn = move_in_words([("top left", 0.8), ("top right", 0.8)])
    assert torn.cell == 0 and torn.score == pytest.approx(0.4)
    assert move_in_words([("stop it", 0.9), ("top left", 0.8)]) is None  # the best decides
    assert move_in_words([]) is None and move_in_words([("", 0.5)]) is None


def test_an_n_best_torn_between_two_cells_is_told_apart_from_one_with_misheard_rivals():
    torn = move_in_words([("top left", 0.8), ("top right", 0.8)])
    assert torn is not None and torn.agreement == 0.5 < MIN_AGREEMENT
    # Whisper's rivals are the same words misheard, naming no cell or the same one
    sure = move_in_words([("top middle", 0.99), ("top right middle", 0.35), ("top middle", 0.2)])
    assert sure is not None and sure.cell == 1 and sure.agreement == 1.0
