import time

from oxbot.dialogue.domain import load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech.evaluation import (
    VOICES,
    accept_decline_phrases,
    accuracy,
    intent_of_act,
    listening_test,
    median_real_time_factor,
)


def test_accept_decline_intent_in_twelve_voices_clean_and_at_20_db():
    """The answers to the invitation: never a yes heard for a no or the reverse, most
    understood, decoded faster than real time. The first goal asked 95% of a grammar of 16
    phrases (97%); the recogniser of ~600 phrasings hears 97% clean and 85% at 20 dB, the rest
    unsure (asked again), and far more of what it never saw (docs/robot.md)."""
    domain = load_domain()
    answers = accept_decline_phrases(domain)
    assert {intent_of_act(act) for act in answers.values()} == {"accept", "decline"}
    assert len(VOICES) >= 6
    started = time.perf_counter()
    trials = listening_test(answers, UserActClassifier(domain), VOICES, (None, 20.0))
    assert len(trials) == len(VOICES) * len(answers) * 2
    wrong = [(t.voice, t.snr_db, t.phrase, t.heard) for t in trials if not t.right]
    flips = [
        w
        for w, t in zip(wrong, [t for t in trials if not t.right], strict=True)
        if intent_of_act(t.act) in ("accept", "decline")
    ]
    assert flips == []
    assert accuracy(trials) >= 0.88, wrong
    assert accuracy([t for t in trials if t.snr_db is None]) >= 0.95, wrong
    assert accuracy([t for t in trials if t.snr_db is not None]) >= 0.82, wrong
    # Faster than real time as a rule; the slowest single answer, which another process on
    # the machine can hold up, is bench/bench_speech.py's to print ("RTF ... max").
    assert median_real_time_factor(trials) < 1.0
    assert time.perf_counter() - started < 60


def test_trials_are_the_same_every_run():
    domain = load_domain()
    classifier = UserActClassifier(domain)
    answers = {"no not now": "Reject(playGame=no)"}
    first, again = (listening_test(answers, classifier, ["en-gb"], (20.0,)) for _ in range(2))
    assert [(t.heard, t.act) for t in first] == [(t.heard, t.act) for t in again]
    assert first[0].audio_seconds > 0.5 and first[0].snr_db == 20.0
