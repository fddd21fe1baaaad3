import logging
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from oxbot.dialogue.domain import ACCEPT, DECLINE, INVITATION, POSTPONE, load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.errors import InvalidInputError
from oxbot.speech import RATE, PocketsphinxRecognizer, Voice, pcm16, synthesize
from oxbot.speech.audio import add_noise, with_noise_floor
from oxbot.speech.evaluation import CHECK_VOICES, Condition, chatter_sentences
from oxbot.speech.nbest import normalise
from oxbot.speech.recognition import shipped_recognizer

PHRASES = [
    "yes let's go for it",
    "yes please",
    "sure why not",
    "okay let's play",
    "no thanks",
    "not now",
    "maybe later",
    "hello",
    "good bye",
    "i pick this one",
]


@pytest.fixture(scope="module")
def recognizer():
    return PocketsphinxRecognizer(PHRASES)


@pytest.mark.parametrize("voice", ["en-us", "en-us+m3", "en-us+f2"])
def test_domain_phrases_are_recognised_in_several_voices(recognizer, voice):
    right = 0
    for phrase in PHRASES:
        nbest = recognizer.recognize(synthesize(phrase, Voice(voice)))
        right += bool(nbest) and nbest[0].text == phrase
    assert right >= 8, f"{right}/10 right with voice {voice}"


def test_nbest_is_ordered_with_confidences_in_range(recognizer):
    nbest = recognizer.recognize(synthesize("yes please"))
    assert nbest and nbest[0].text == "yes please"
    confidences = [h.confidence for h in nbest]
    assert all(0.0 <= c <= 1.0 for c in confidences)
    assert confidences == sorted(confidences, reverse=True)
    assert [w for w, _ in nbest[0].words] == ["yes", "please"]
    assert all(0.0 <= c <= 1.0 for _, c in nbest[0].words)
    assert len({h.text for h in nbest}) == len(nbest)


def test_decoding_is_faster_than_real_time(recognizer):
    samples = pcm16(synthesize("okay let's play"))
    start = time.perf_counter()
    recognizer.decode(samples)
    assert time.perf_counter() - start < len(samples) / 16000


def test_silence_and_clicks_give_an_empty_list(recognizer):
    assert recognizer.decode(np.zeros(800, dtype=np.int16)) == []
    assert all(h.confidence < 0.9 for h in recognizer.decode(np.zeros(16000, dtype=np.int16)))


def test_bad_input_is_refused_clearly(recognizer):
    with pytest.raises(InvalidInputError, match="int16"):
        recognizer.decode(np.zeros(16000, dtype=np.float32))
    with pytest.raises(InvalidInputError, match="not a PCM WAV"):
        recognizer.recognize(b"garbage")
    with pytest.raises(InvalidInputError, match="at least one"):
        PocketsphinxRecognizer(["", "  "])


def test_spec_recognize_uses_the_shipped_domain():
    from oxbot.speech import recognize

    nbest = recognize(synthesize("i pick this one"))
    assert nbest and nbest[0][0] == "i pick this one"
    assert all(isinstance(t, str) and 0.0 <= c <= 1.0 for t, c in nbest)


def test_every_word_the_shipped_domain_lets_people_say_can_be_pronounced():
    # A word left out of the dictionary is silently never heard ("hiya" was, with a warning
    # at every start).
    recognizer = shipped_recognizer("pocketsphinx")
    assert {w for p in recognizer.phrases for w in p.split()} <= recognizer.vocabulary


def test_digital_silence_no_longer_throws_the_decoder_off():
    # espeak-ng pads with exact zeros; before the noise floor this "okay" came back as "hi".
    samples = pcm16(synthesize("okay", Voice("en-gb")))
    assert (samples == 0).mean() > 0.3
    nbest = shipped_recognizer("pocketsphinx").decode(samples)
    assert nbest and nbest[0].text == "okay"


def test_the_noise_floor_is_faint_and_the_same_every_time():
    samples = np.zeros(RATE, dtype=np.int16)
    hiss = with_noise_floor(samples)
    assert hiss.dtype == np.int16 and 20 < hiss.std() < 45
    assert (with_noise_floor(samples) == hiss).all()
    loud = np.full(RATE, 32767, dtype=np.int16)
    assert with_noise_floor(loud).max() == 32767  # clipped, not wrapped round


def test_grammar_fragments_are_not_offered_as_hypotheses():
    # "hi" in this voice used to come back with "i take", "i pick" and "i" below it.
    recognizer = shipped_recognizer("pocketsphinx")
    for voice in ("en+f3", "en-gb-scotland"):
        nbest = recognizer.decode(pcm16(synthesize("hi", Voice(voice))))
        assert nbest[0].text in ("hi", "hiya")  # both greetings of the domain
        assert all(h.text in recognizer.phrases for h in nbest), nbest


def test_one_recogniser_can_serve_several_threads():
    recognizer = PocketsphinxRecognizer(PHRASES)
    said = ["yes please", "no thanks", "good bye", "i pick this one"] * 3
    recordings = {text: pcm16(synthesize(text)) for text in set(said)}
    alone = {text: recognizer.decode(samples) for text, samples in recordings.items()}
    with ThreadPoolExecutor(max_workers=6) as pool:
        together = list(pool.map(lambda text: recognizer.decode(recordings[text]), said))
    assert together == [alone[text] for text in said]


def test_only_the_domain_words_are_loaded_so_building_is_quick(caplog):
    started = time.perf_counter()
    with caplog.at_level(logging.WARNING):
        recognizer = PocketsphinxRecognizer(["hello there", "zzyzxq"])
    assert time.perf_counter() - started < 3.0  # 8 s with the whole dictionary
    assert recognizer.vocabulary == {"hello", "there"}
    assert "zzyzxq" in caplog.text


def test_what_was_decoded_before_does_not_change_the_answer(recognizer):
    yes, bye = pcm16(synthesize("yes please")), pcm16(synthesize("good bye", Voice("en-us+f2")))
    first = recognizer.decode(yes)
    recognizer.decode(bye)
    assert recognizer.decode(yes) == first


# What the shipped recogniser does with speech it was not tuned on: the check voices (the half
# of VOICES `bench/tune_recognition.py` does not fit on), the check lines of the chatter, and a
# sample of the domain's phrasings. Floors are set from what was measured, with some room
# (docs/robot.md, "Hearing the person").

YES_OR_NO = {ACCEPT, DECLINE, POSTPONE}


def _acts() -> dict[str, str]:
    acts: dict[str, str] = {}
    for text, act in load_domain().user_phrases():
        acts.setdefault(normalise(text), act)
    return acts


@pytest.fixture(scope="module")
def chatter_heard():
    """(sentence, N-best) for ten check lines of the chatter, each in a check voice."""
    recognizer = shipped_recognizer("pocketsphinx")
    sentences = chatter_sentences()[1::2][:10]
    return [
        (normalise(s), recognizer.decode(pcm16(synthesize(s, Voice(CHECK_VOICES[i % 6])))))
        for i, s in enumerate(sentences)
    ]


@pytest.fixture(scope="module")
def phrases_heard():
    """(phrase, N-best) for sixteen of the domain's phrasings in check voices at 20 dB SNR."""
    recognizer = shipped_recognizer("pocketsphinx")
    phrases = sorted(_acts())[3::37][:16]
    heard = []
    for i, phrase in enumerate(phrases):
        clean = pcm16(synthesize(phrase, Voice(CHECK_VOICES[i % 6])))
        noisy = add_noise(clean, 20.0, np.random.default_rng(i))
        heard.append((phrase, recognizer.decode(noisy)))
    return heard


def test_chatter_is_not_forced_onto_an_accept_or_a_decline(chatter_heard):
    acts = _acts()
    forced = [(s, n[0].text) for s, n in chatter_heard if n and acts.get(n[0].text) in YES_OR_NO]
    assert len(forced) <= 1, forced  # measured: 0 of 10
    # What the understanding makes of the words heard ("i think it's really dumb on often
    # really" reads as a no).
    classifier = UserActClassifier(load_domain())
    taken = [s for s, n in chatter_heard if classifier.intent_of(n, INVITATION).act in YES_OR_NO]
    assert len(taken) <= 2, taken  # measured: 1 of 10


def test_chatter_is_heard_as_other_words_not_as_a_phrase(chatter_heard):
    acts = _acts()
    phrases = [(s, n[0].text) for s, n in chatter_heard if n and n[0].text in acts]
    assert len(phrases) <= 2, phrases  # measured: 0 of 10, all heard by the general model


def test_right_hypotheses_are_more_confident_than_wrong_ones(chatter_heard, phrases_heard):
    heard = [(said, nbest) for said, nbest in chatter_heard + phrases_heard if nbest]
    for _, nbest in heard:
        confidences = [h.confidence for h in nbest]
        assert all(0.0 <= c <= 1.0 for c in confidences)
        assert confidences == sorted(confidences, reverse=True)
    right = np.array([n[0].confidence for said, n in heard if n[0].text == said])
    wrong = np.array([n[0].confidence for said, n in heard if n[0].text != said])
    assert len(right) >= 10 and len(wrong) >= 8  # measured: 13 and 13
    assert right.mean() > wrong.mean() + 0.3  # measured: 0.76 and 0.25
    auc = (right[:, None] > wrong[None, :]).mean()
    assert auc >= 0.85, (right, wrong)  # measured: 0.92


@pytest.mark.parametrize(
    "condition",
    [
        Condition("1.5 s of zeros", lead_seconds=(1.5, 1.5)),
        Condition("1.5 s of noise floor", lead_seconds=(1.5, 1.5), floor=16.0),
        Condition("quiet microphone", peak_dbfs=-30.0),
    ],
    ids=lambda c: c.name,
)
def test_leading_silence_and_a_quiet_microphone_do_not_change_what_is_heard(condition):
    recognizer = shipped_recognizer("pocketsphinx")
    for i, (phrase, voice) in enumerate(
        [
            ("yes please", "en-gb"),
            ("no thanks", "en+f3"),
            ("maybe later", "en-gb-scotland"),
            ("sure why not", "en-gb+f4"),
            ("i'm done", "en+f2"),
            ("one more game", "en-gb-x-rp"),
        ]
    ):
        plain = pcm16(synthesize(phrase, Voice(voice)))
        changed = condition.apply(plain, np.random.default_rng(i))
        assert len(changed) >= len(plain)
        heard, as_recorded = recognizer.decode(changed), recognizer.decode(plain)
        assert heard[0].text == as_recorded[0].text, (phrase, voice)
        # The cut can move by a frame, so the confidence may move a little; the words may not.
        assert heard[0].confidence == pytest.approx(as_recorded[0].confidence, abs=0.3)
