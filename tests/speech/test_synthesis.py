import pytest

from oxbot.errors import SpeechUnavailable
from oxbot.speech import synthesis
from oxbot.speech.audio import read_wav
from oxbot.speech.synthesis import Voice, synthesize


def test_espeak_says_a_sentence_as_a_wav_of_plausible_length():
    short = read_wav(synthesize("Your turn."))
    long = read_wav(synthesize("Hello! I am oxbot. Would you like to play a game with me?"))
    assert short.rate == 22050
    assert 0.4 < short.seconds < 2.0
    assert long.seconds > 2 * short.seconds
    assert short.samples.std() > 500  # there is speech in it, not silence


def test_the_wav_header_gives_the_real_length():
    data = synthesize("I take this one")
    assert int.from_bytes(data[40:44], "little") == len(data) - 44


def test_voices_differ():
    a = read_wav(synthesize("Yes, I won.", Voice("en-us"))).samples
    b = read_wav(synthesize("Yes, I won.", Voice("en-us+f2", pitch=80))).samples
    assert len(a) != len(b) or (a != b).any()


def test_missing_espeak_is_one_clear_error(monkeypatch):
    monkeypatch.setattr(synthesis, "ESPEAK", "espeak-ng-not-installed")
    assert not synthesis.espeak_available()
    with pytest.raises(SpeechUnavailable, match="apt-get install espeak-ng"):
        synthesize("Hello")


def test_empty_text_is_refused():
    with pytest.raises(SpeechUnavailable, match="nothing to say"):
        synthesize("   ")
