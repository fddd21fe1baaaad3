from dataclasses import replace

import pytest

from oxbot.dialogue.domain import GAME_MOVE_TEMPLATE, game_move_cell, load_domain
from oxbot.dialogue.understanding import UserAct, UserActClassifier, similarity
from oxbot.errors import DataError, InvalidInputError
from oxbot.speech.recognition import Hypothesis

CONFIRM, REJECT = "Confirm(playGame=yes)", "Reject(playGame=no)"


@pytest.fixture(scope="module")
def domain():
    return load_domain()


@pytest.fixture(scope="module")
def classifier(domain):
    return UserActClassifier(domain)


def test_every_user_line_of_the_domain_gets_its_own_act(domain, classifier):
    lines = [u for alternatives in domain.responses.values() for u in alternatives]
    lines += [u for dialogue in domain.dialogues for u in dialogue if u.speaker == "USR"]
    for utterance in lines:
        heard = classifier.classify(utterance.text)
        if not utterance.words:  # a silent drawing or no answer
            assert heard == UserAct("Silence", 0.0)
            continue
        is_move = game_move_cell(utterance.act) is not None
        expected = GAME_MOVE_TEMPLATE if is_move else utterance.act
        assert (heard.act, heard.score) == (expected, 1.0), utterance.text


def test_the_papers_figure_1_answer(classifier):
    assert classifier.classify("Yes, let's play.") == UserAct(CONFIRM, 1.0, "yes let's play")
    assert classifier.classify("I take this one").act == GAME_MOVE_TEMPLATE


@pytest.mark.parametrize(
    ("text", "act"),
    [
        ("yes play", CONFIRM),  # the recogniser lost a word
        ("yes", CONFIRM),
        ("no not", REJECT),
        ("not", REJECT),
        ("i pick", GAME_MOVE_TEMPLATE),
        ("yes let's play please", CONFIRM),  # extra words
        ("well no not now thank you", REJECT),
        ("okay then let's go", CONFIRM),
        ("lets play", CONFIRM),  # a typed spelling
    ],
)
def test_fragments_extra_words_and_spellings_find_the_nearest_phrase(classifier, text, act):
    heard = classifier.classify(text)
    assert heard.act == act
    assert 0.3 <= heard.score < 1.0
    assert classifier.phrases[heard.phrase] == act


@pytest.mark.parametrize(
    ("text", "act"),
    [("ok", CONFIRM), ("Yeah!", CONFIRM), ("nope", REJECT), ("Goodbye.", "Salutation(closing)")],
)
def test_common_typed_words_are_read_as_the_domains(classifier, text, act):
    assert classifier.classify(text).act == act


def test_more_of_the_phrase_scores_higher(classifier):
    scores = [classifier.classify(t).score for t in ("yes", "yes play", "yes let's play")]
    assert scores == sorted(scores) and scores[-1] == 1.0 and scores[0] < scores[1]


def test_empty_and_unmatched_text(classifier):
    assert classifier.classify("") == UserAct("Silence", 0.0)
    assert classifier.classify("  ?! ") == UserAct("Silence", 0.0)
    assert classifier.classify("the cat sat on the mat") == UserAct("Unknown", 0.0)
    assert classifier.classify("purple elephants").act == "Unknown"


def test_similarity_is_a_dice_coefficient_of_the_aligned_words():
    assert similarity(["no", "not", "now"], ["no", "not", "now"]) == 1.0
    assert similarity(["not", "now"], ["now", "not"]) == pytest.approx(0.5)  # order counts
    assert similarity([], ["no"]) == similarity(["no"], []) == 0.0
    assert similarity(["no", "thank"], ["no", "thanks"]) > 0.9


def test_intent_of_lets_agreeing_hypotheses_outvote_a_near_tie(classifier):
    nbest = [("hello", 0.66), ("no", 0.65), ("not now", 0.64)]
    assert classifier.classify(nbest[0][0]).act == "Salutation(greeting)"
    voted = classifier.intent_of(nbest)
    assert voted.act == REJECT and 0.0 < voted.score < 1.0
    hypotheses = [Hypothesis(text, confidence) for text, confidence in nbest]
    assert classifier.intent_of(hypotheses) == voted
    assert classifier.intent_of([list(pair) for pair in nbest]) == voted  # as JSON gives it


def test_intent_of_nothing_heard_or_nothing_matched(classifier):
    assert classifier.intent_of([]) == UserAct("Silence", 0.0)
    assert classifier.intent_of([("purple elephants", 0.9)]) == UserAct("Unknown", 0.0)
    assert classifier.intent_of([("okay", 0.0)]).act == "Unknown"
    with pytest.raises(InvalidInputError, match=r"not in \[0, 1\]"):
        classifier.intent_of([("okay", 1.5)])


def test_a_domain_without_user_phrases_is_refused(domain):
    silent = replace(domain, dialogues=(), responses={})
    with pytest.raises(DataError, match="no user phrase"):
        UserActClassifier(silent)
