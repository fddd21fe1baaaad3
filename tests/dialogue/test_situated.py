"""The robot's words about its moves: each claim is checked against the board by a checker of
its own (the lines written out here, not the game module's), on hand-made boards and over
simulated dialogues."""

from __future__ import annotations

import numpy as np
import pytest

from oxbot.config import OxbotConfig
from oxbot.dialogue.agent import load_policy
from oxbot.dialogue.evaluation import evaluate
from oxbot.dialogue.situated import claims, situated_sentence, template_in
from oxbot.testing.board_claims import board, robot_sentences_said, said_claims, true_claims


@pytest.mark.parametrize(
    ("before_person", "person_cell", "before", "cell", "expected"),
    [
        (None, None, board("UU. .R. ..."), 2, ["blocks"]),
        (None, None, board("RR. ..U ..U"), 2, ["wins"]),  # a win is not also called a block
        (None, None, board("R.. .U. ..R"), 2, ["two_ways"]),
        (None, None, board("... .R. ..U"), 1, ["one_away"]),
        (board("RR. ... UU."), 2, board("RRU ... UU."), 8, ["good_block", "blocks"]),
        (board("R.. .R. UU."), 2, board("R.U .R. UU."), 8, ["missed_win", "wins"]),
        (None, None, board("RUR RUU U.."), 7, ["blocks", "draw_coming"]),
        (None, None, board("... ... ..."), 4, []),
    ],
)
def test_each_claim_holds_where_it_is_made(before_person, person_cell, before, cell, expected):
    made = claims(before_person, person_cell, before, cell)
    assert made == expected
    assert set(made) <= true_claims(before_person, person_cell, before, cell)


def test_the_template_is_said_with_the_claims_and_can_be_found_again():
    rng = np.random.default_rng(0)
    opening = [{"speaker": "sys", "act": "GameMove(gridloc=middle)", "text": "I take this one"}]
    assert situated_sentence(opening, "I take this one", rng) == "I take this one."
    block = [
        {"speaker": "usr", "act": "GameMove(gridloc=upperleft)", "text": ""},
        {"speaker": "sys", "act": "GameMove(gridloc=middle)", "text": ""},
        {"speaker": "usr", "act": "GameMove(gridloc=uppermiddle)", "text": ""},
        {"speaker": "sys", "act": "GameMove(gridloc=upperright)", "text": ""},
    ]
    sentence = situated_sentence(block, "I'll go here", rng)
    assert said_claims(sentence) == {"blocks"} and sentence.startswith("I'll go here. ")
    templates = ["I take this one", "I'll go here", "This one is mine"]
    assert template_in(sentence, templates) == "I'll go here"
    assert template_in("I'll block you here.", templates) is None
    # never two sentences that open alike ("This one is mine. This one wins it.")
    cells = [("sys", "upperleft"), ("usr", "uppermiddle"), ("sys", "middle")]
    cells += [("usr", "upperright"), ("sys", "lowerright")]  # the diagonal: the robot wins
    wins = [{"speaker": who, "act": f"GameMove(gridloc={c})", "text": ""} for who, c in cells]
    for seed in range(10):
        said = situated_sentence(wins, "This one is mine", np.random.default_rng(seed))
        assert "wins" in said_claims(said) and "This one wins it." not in said, said
    # on paper the robot says where it plays, first
    where = "I draw in the top right."
    on_paper = situated_sentence(block, where, rng, says_where=True)
    assert on_paper.startswith(where) and said_claims(on_paper) == {"blocks"}


def test_over_simulated_dialogues_every_claim_is_true_and_no_sentence_comes_twice_in_a_row():
    policy, rng = load_policy(), np.random.default_rng(1)
    claimed = 0
    for robot_starts in (True, False):
        r = evaluate(
            policy.act_batch,
            "random",
            robot_starts,
            150,
            OxbotConfig(),
            seed=3,
            keep_transcripts=150,
        )
        for transcript in r.transcripts:
            last = ""
            for said in robot_sentences_said(transcript, rng):
                assert said.made <= said.held, said
                claimed += len(said.made)
                assert said.sentence != last, (said.sentence, transcript)
                last = said.sentence
    assert claimed > 200  # the robot has things to say in most games
