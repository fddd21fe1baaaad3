import numpy as np
import pytest

from oxbot.errors import InvalidInputError
from oxbot.speech import Recognizer, Voice, pcm16, synthesize

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
    return Recognizer(PHRASES)


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
    import time

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
        Recognizer(["", "  "])


def test_spec_recognize_uses_the_shipped_domain():
    from oxbot.speech import recognize

    nbest = recognize(synthesize("i pick this one"))
    assert nbest and nbest[0][0] == "i pick this one"
    assert all(isinstance(t, str) and 0.0 <= c <= 1.0 for t, c in nbest)
