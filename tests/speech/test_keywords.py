import numpy as np
import pytest
import torch

from oxbot.dialogue.domain import ACCEPT, DECLINE, INVITATION, UNKNOWN, load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech import Voice, pcm16, synthesize
from oxbot.speech.keywords import (
    LABELS,
    KeywordConfig,
    KeywordData,
    KeywordSpotter,
    keyword_rescue,
    second_opinion,
    shipped_keyword_path,
    shipped_keyword_spotter,
    train_keywords,
)
from oxbot.speech.nbest import Hypothesis
from oxbot.speech.recognition import shipped_recognizer
from oxbot.speech.speech_commands import split_of

YES, NO, OTHER = (LABELS.index(label) for label in ("yes", "no", "other"))


@pytest.fixture(scope="module")
def spotter():
    found = shipped_keyword_spotter()
    assert found is not None, "the keyword model is shipped in oxbot/data/models/"
    return found


@pytest.fixture(scope="module")
def classifier():
    return UserActClassifier(load_domain())


def test_keyword_model_is_shipped_small_with_its_metadata(spotter):
    assert shipped_keyword_path().stat().st_size < 1_000_000
    meta = spotter.metadata
    assert meta["seed"] == meta["config"]["seed"]
    assert "TEST split" in meta["data_rule"]
    assert meta["clips"]["yes"] > 200 and meta["clips"]["no"] > 200
    assert 0.9 < meta["dev"]["keyword_alone"]["clean"] <= 1.0
    reloaded = KeywordSpotter.load(shipped_keyword_path())
    samples = pcm16(synthesize("yes"))
    assert np.allclose(reloaded.probabilities(samples), spotter.probabilities(samples))


@pytest.mark.parametrize("speed", [120, 160, 220])
@pytest.mark.parametrize(("word", "label"), [("yes", YES), ("no", NO)])
def test_spoken_yes_and_no_are_classified_at_several_speeds(spotter, word, label, speed):
    probabilities = spotter.probabilities(pcm16(synthesize(word, Voice("en-us", speed))))
    assert probabilities is not None
    assert int(np.argmax(probabilities)) == label, probabilities


def test_noise_and_other_words_are_other(spotter):
    rng = np.random.default_rng(0)
    hiss = np.round(rng.normal(0.0, 2000.0, 16_000)).astype(np.int16)
    assert int(np.argmax(spotter.probabilities(hiss))) == OTHER
    left = spotter.probabilities(pcm16(synthesize("left")))
    assert left[YES] < 0.5 and left[NO] < 0.5, left


def test_long_answers_get_no_keyword_opinion(spotter):
    assert (
        spotter.probabilities(pcm16(synthesize("yes let's play a game of noughts and crosses")))
        is None
    )


def test_a_short_yes_becomes_an_accept_through_the_real_recogniser(classifier):
    recognizer = shipped_recognizer("pocketsphinx")
    listening = recognizer.listen(pcm16(synthesize("yes", Voice("en-us+m3"))))
    assert listening is not None and listening.keywords is not None
    assert listening.keywords[YES] > 0.9
    assert classifier.intent_of(listening.hypotheses, INVITATION).act == ACCEPT


def test_the_keyword_model_makes_a_mumbled_no_a_no_when_sure(classifier):
    heard = [Hypothesis("hi", 0.6)]
    joined = second_opinion(heard, np.array([0.01, 0.97, 0.02]))
    assert classifier.intent_of(joined, INVITATION).act == DECLINE
    # the recogniser leaves that step to the robot, which knows whether it asked yes or no
    assert second_opinion(heard, np.array([0.01, 0.97, 0.02]), rescue=False) == heard
    assert keyword_rescue(heard, (0.01, 0.97, 0.02))[0].text == "no"
    assert keyword_rescue(heard, (0.01, 0.6, 0.39)) == heard  # not sure enough
    assert (
        keyword_rescue([Hypothesis("hi", 0.6), Hypothesis("yes", 0.2)], (0, 1, 0))[0].text == "hi"
    )


def test_disagreeing_listeners_give_unknown(classifier):
    heard = [Hypothesis("yeah", 0.9), Hypothesis("no", 0.3)]
    assert classifier.intent_of(heard, INVITATION).act == ACCEPT
    joined = second_opinion(heard, np.array([0.05, 0.9, 0.05]))
    assert classifier.intent_of(joined, INVITATION).act == UNKNOWN


def test_agreeing_listeners_keep_the_recognisers_words():
    heard = [Hypothesis("no thanks", 0.5)]
    joined = second_opinion(heard, np.array([0.01, 0.8, 0.19]))
    assert joined[0].text == "no thanks"
    assert joined[0].confidence == pytest.approx(1 - 0.5 * 0.2)


def test_split_rule_matches_the_datasets_lists():
    # Speakers from Speech Commands v0.01's testing_list.txt and validation_list.txt.
    assert split_of("563aa4e6") == "testing"
    assert split_of("97f4c236") == "testing"
    assert split_of("439c84f4") == "validation"
    assert split_of("0135f3f2") == "training"


def test_training_is_reproducible_from_the_seed_and_round_trips(tmp_path):
    words = ("yes", "no", "left")
    clips = np.zeros((3, 16_000), np.int16)
    for i, word in enumerate(words):
        samples = pcm16(synthesize(word))[:16_000]
        clips[i, : len(samples)] = samples
    data = KeywordData(clips, np.array([YES, NO, OTHER]), "three espeak-ng words")
    config = KeywordConfig(seed=3, epochs=2, per_class=8, batch_size=8)
    first = train_keywords(data, config, tmp_path / "a.pt", show_progress=False)
    second = train_keywords(data, config, tmp_path / "b.pt", show_progress=False)
    weights = second.network.state_dict()
    assert all(torch.equal(w, weights[name]) for name, w in first.network.state_dict().items())
    loaded = KeywordSpotter.load(tmp_path / "a.pt")
    assert loaded.metadata["config"]["seed"] == 3
    assert loaded.metadata["data_rule"] == "three espeak-ng words"
    assert np.allclose(loaded.classify([clips[0]]), first.classify([clips[0]]))
