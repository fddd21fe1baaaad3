"""The Whisper recogniser: the pinned weights, what it hears, what it refuses to hear."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from oxbot.config import SpeechConfig, WhisperConfig
from oxbot.errors import SpeechUnavailable
from oxbot.speech import recognition, whisper
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes
from oxbot.speech.synthesis import synthesize
from oxbot.speech.whisper import (
    WhisperListening,
    WhisperRecognizer,
    clean_text,
    echoes_prompt,
    model_folder,
    without_repeats,
    word_posteriors,
)
from oxbot.testing.sounds import NOISES, room_noise


@pytest.fixture(scope="module")
def recognizer() -> WhisperRecognizer:
    return WhisperRecognizer()


def test_the_shipped_weights_are_the_pinned_ones():
    assert (model_folder() / "model.bin").stat().st_size > 10_000_000


def test_weights_that_differ_are_refused_naming_the_fix(tmp_path):
    fake = tmp_path / "model.bin"
    fake.write_bytes(b"not whisper")
    with pytest.raises(SpeechUnavailable, match=r"not the pinned ones.*make setup"):
        whisper._check_weights.__wrapped__(fake, "0" * 64)
    with pytest.raises(SpeechUnavailable, match=r"missing.*make setup"):
        whisper._check_weights.__wrapped__(tmp_path / "absent.bin", "0" * 64)


def test_without_whisper_the_robot_hears_with_pocketsphinx_and_says_so(monkeypatch, caplog):
    def missing(*args, **kwargs):
        raise SpeechUnavailable("the Whisper recogniser is not installed: make setup")

    monkeypatch.setattr(whisper, "make_whisper", missing)
    with caplog.at_level(logging.WARNING, logger="oxbot.speech.recognition"):
        heard_with = recognition._build(SpeechConfig(), ["yes please", "no thanks"])
    assert type(heard_with).__name__ == "PocketsphinxRecognizer"
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "pocketsphinx instead of Whisper" in lines[0], lines


@pytest.mark.parametrize(
    ("text", "clean"),
    [
        ("Yes, let's play!", "yes let's play"),
        ("[Music] No thanks.", "no thanks"),
        ("(coughs)", ""),
        ("♪ ♪", ""),
        ("Row 2, column 3.", "row two column three"),
        ("Go for it. Go for it. Go for it.", "go for it"),
        ("Okay. Okay.", "okay"),
        ("No, no, no.", "no"),
        ("OK, sure.", "okay sure"),
        ("Lets play!", "let's play"),
        ("All right then.", "alright then"),
    ],
)
def test_what_whisper_writes_is_read_as_plain_words(text, clean):
    assert clean_text(text) == clean


def test_two_spellings_of_the_same_words_are_one_hypothesis_and_no_rival():
    """ "okay sure" beside "ok sure" once left a lead of 0.05, a confidence of 0.41 and a yes the
    domain lists, heard word for word, not understood."""
    recognizer = object.__new__(WhisperRecognizer)  # no model: only the N-best is built here
    recognizer.config, recognizer.nbest = WhisperConfig(model="tiny.en"), 5
    raw = (("Okay, sure.", -0.20, 3), ("OK sure", -0.25, 3), ("Okay, shore.", -0.90, 3))
    heard = recognizer._hypotheses(WhisperListening(1.0, raw, no_speech=0.01))
    assert [h.text for h in heard.hypotheses] == ["okay sure", "okay shore"]
    assert heard.features[2] == pytest.approx(0.70)
    split = recognizer._hypotheses(WhisperListening(1.0, (raw[0], ("Okay, shore.", -0.25, 3))))
    assert heard.hypotheses[0].confidence > split.hypotheses[0].confidence + 0.1


def test_the_prompt_said_back_is_nothing_heard_a_short_part_of_it_is_an_answer():
    prompt = WhisperConfig().prompt
    for echo in ("noughts and crosses", "top left middle", "yes no thanks let's play"):
        assert echoes_prompt(echo, prompt), echo
    for answer in ("top left", "no thanks", "let's play noughts and crosses", "stop"):
        assert not echoes_prompt(answer, prompt), answer


def test_only_phrases_said_back_to_back_are_kept_once():
    assert without_repeats("i said no i said no") == "i said no"
    assert without_repeats("no not now") == "no not now"
    assert without_repeats("top left then top right") == "top left then top right"


def test_a_word_every_hypothesis_holds_is_surer_than_one_only_the_best_holds():
    raw = (
        ("I pick this one.", -0.3, 5),
        ("I think this one.", -0.5, 5),
        ("Pick this one", -0.9, 4),
    )
    words = dict(word_posteriors("i pick this one", raw, no_speech=0.1))
    assert words["this"] == pytest.approx(0.9, abs=1e-3)  # in every one: 1 - no_speech
    assert words["i"] < words["this"] and words["pick"] < words["this"]
    assert all(0.0 <= c <= 1.0 for c in words.values())


def test_answers_are_heard_word_for_word_with_a_confidence(recognizer):
    for text in ("yes let's play", "no thanks", "go for it", "top left"):
        heard = recognizer.recognize(synthesize(text))
        assert heard and heard[0].text == text, (text, heard)
        assert 0.5 < heard[0].confidence <= 1.0
        assert [w for w, _ in heard[0].words] == text.split()
        confidences = [h.confidence for h in heard]
        assert confidences == sorted(confidences, reverse=True)
        assert len({h.text for h in heard}) == len(heard)  # no two spellings of one text


def test_room_noise_and_silence_are_nothing_heard(recognizer):
    rng = np.random.default_rng(5)
    for kind in NOISES:
        noise = np.clip(room_noise(kind, 2.0, rng), -32768, 32767).astype(np.int16)
        listening = recognizer.listen(noise)
        assert listening.hypotheses == [], (kind, listening)
    assert recognizer.recognize(to_wav_bytes(Audio(np.zeros(RATE, np.int16), RATE))) == []


def test_a_long_recording_is_heard_in_whisper_s_whole_window():
    recognizer = WhisperRecognizer(config=WhisperConfig(window_seconds=1.0))
    speech = pcm16(synthesize("yes let's play"))
    padded = np.concatenate([speech, np.zeros(RATE // 2, np.int16), speech])
    heard = recognizer.listen(padded)
    assert heard.hypotheses and heard.hypotheses[0].text.startswith("yes let's play")


def test_the_spec_call_hears_with_whisper():
    nbest = recognition.recognize(synthesize("i pick this one"))
    assert nbest and nbest[0][0] == "i pick this one"
    assert all(isinstance(t, str) and 0.0 <= c <= 1.0 for t, c in nbest)
    assert type(recognition.default_recognizer()).__name__ == "WhisperRecognizer"
