"""Listening while the robot speaks: its own voice fed back into the microphone is never taken
for the person, and a person who talks over it cuts it short (barge-in) and is heard."""

from __future__ import annotations

import time

import numpy as np
import pytest

from oxbot.config import ListeningConfig
from oxbot.robot.bus import LocalBus
from oxbot.robot.listening import HandsFreeListener
from oxbot.robot.messages import (
    PersonAnswering,
    SpeakingContinued,
    SpeakingFinished,
    SpeakingStarted,
    StopSpeaking,
    Utterance,
)
from oxbot.robot.voice import SpeechSynthesisComponent
from oxbot.speech import Voice, pcm16, read_wav, synthesize
from oxbot.speech.audio import RATE, Audio, resample
from oxbot.speech.echo import ESTIMATE_AFTER, MAX_DELAY, EchoCanceller
from oxbot.testing.sounds import noise_only
from tests.robot.test_listening import Ears

PIECE = 1600  # the page's 0.1 s
ROBOT = ("Would you like to play a game of noughts and crosses?", "I'm oxbot, a robot.")
ECHO_DB = -10.0


@pytest.fixture(scope="module")
def robot_wavs() -> list[bytes]:
    """The robot's two sentences as a player gets them (22,050 Hz WAVs)."""
    return [synthesize(text, Voice("en-us")) for text in ROBOT]


@pytest.fixture(scope="module")
def stop_word() -> np.ndarray:
    return pcm16(synthesize("stop", Voice("en-us+f3")))


def heard_in_the_room(wav: bytes, delay: float) -> np.ndarray:
    """`wav` as a microphone hears it played: another resampling than the listener's (through
    48 kHz, linear), `delay` late, 10 dB down, with a short room tail."""
    audio = read_wav(wav)
    x = audio.samples.astype(np.float64)
    at_48k = np.interp(
        np.arange(round(len(x) * 48_000 / audio.rate)) * audio.rate / 48_000, np.arange(len(x)), x
    )
    played = resample(Audio(np.round(at_48k).astype(np.int16), 48_000), RATE).samples
    tail = np.exp(-np.arange(int(0.03 * RATE)) / (0.008 * RATE))
    tail /= tail.sum() * 1.6  # the direct sound and a little of the room
    tail[0] += 0.4
    echo = np.convolve(played.astype(np.float64), tail)[: len(played)]
    return np.concatenate([np.zeros(int(delay * RATE)), echo * 10 ** (ECHO_DB / 20)])


def play(
    robot_wavs: list[bytes],
    delay: float = 0.12,
    person: np.ndarray | None = None,
    person_at: float = 0.0,
    config: ListeningConfig | None = None,
    room: np.ndarray | None = None,
    late: float = 0.0,
    marked: bool = False,
) -> tuple[Ears, HandsFreeListener, list, int]:
    """The robot says its two sentences from 1 s into the stream, the player plays them `late`
    s after, and the microphone hears their echo (and the person from `person_at` s after the
    robot starts); the stream is fed in 0.1 s pieces, `marked` with where the player began each
    sentence (as the page says it) or not. Returns the ears, the listener, the StopSpeaking /
    PersonAnswering published (with the stream position they came at) and where the robot
    started."""
    ears = Ears()
    listener = HandsFreeListener(ears, config or ListeningConfig())
    news = ears.bus.subscribe(StopSpeaking, PersonAnswering)
    started = RATE
    sentences = [heard_in_the_room(w, 0.0) for w in robot_wavs]
    sound = np.concatenate(sentences)
    plays = started + int(late * RATE)
    echo = np.zeros(plays + int(delay * RATE) + len(sound) + 3 * RATE)
    echo[plays + int(delay * RATE) :][: len(sound)] = sound
    # the page marks both sentences in the piece where the first begins: it queues the next
    marks = [(" ".join(ROBOT), 0, plays), (" ".join(ROBOT), 1, plays + len(sentences[0]))]
    voice = np.zeros(len(echo))
    if room is not None:  # the room's own sounds, all along
        voice += np.resize(room, len(voice))
    if person is not None:
        at = started + int(person_at * RATE)
        voice[at : at + len(person)] = person
    published = []
    for at in range(0, len(echo), PIECE):
        if at == started:
            for i, wav in enumerate(robot_wavs):
                kind = SpeakingStarted if i == 0 else SpeakingContinued
                seconds = read_wav(wav).seconds
                ears.bus.publish(kind(text=" ".join(ROBOT), audio=wav, seconds=seconds))
        piece = np.round(echo[at : at + PIECE] + voice[at : at + PIECE])
        played = [(t, i, p - at) for t, i, p in marks if marked and at <= plays < at + PIECE]
        listener.placed_by_player = marked
        listener.feed(np.clip(piece, -32768, 32767).astype(np.int16), played)
        for message in news.drain():
            published.append((message, at + PIECE))
            if isinstance(message, StopSpeaking):  # the voice finishes, the player stops
                ears.bus.publish(SpeakingFinished(text=message.text))
                echo[at + PIECE + PIECE :] = 0.0
    return ears, listener, published, started


@pytest.mark.parametrize("delay", [-0.1, 0.12, 0.6])
def test_the_robots_own_voice_fed_back_is_never_taken_for_the_person(robot_wavs, delay):
    ears, listener, published, _ = play(robot_wavs, delay)
    assert ears.recordings == [] and published == []
    assert listener.echo.correlation > 0.9
    assert listener.echo.delay == pytest.approx(delay * RATE, abs=0.005 * RATE)
    assert 0.03 < listener.echo.gain < 10 ** (ECHO_DB / 20)  # the direct sound's share


def test_a_player_late_by_more_than_the_echo_search_is_followed_where_it_says_it_played(
    robot_wavs, stop_word
):
    """A loaded page plays the robot's voice 1.5 s after the bus said it: placed where the
    page says it began, the echo is found at its room delay, never taken for the person, and a
    stop said over it is still heard."""
    late = 1.5
    assert late > MAX_DELAY  # placed where the bus said it, the echo could not be found
    ears, listener, published, _ = play(robot_wavs, 0.12, late=late, marked=True)
    assert ears.recordings == [] and published == []
    assert listener.echo.delay == pytest.approx(0.12 * RATE, abs=0.005 * RATE)
    ears, _, published, _ = play(
        robot_wavs, 0.12, person=stop_word, person_at=late + 1.5, late=late, marked=True
    )
    assert [type(m) for m, _ in published] == [StopSpeaking, PersonAnswering]
    assert len(ears.recordings) == 1


def test_a_room_s_noise_over_the_robot_cuts_nothing_short(robot_wavs):
    room = noise_only(8.0, np.random.default_rng(7))  # hiss, fan, clicks, hum
    ears, _, published, _ = play(robot_wavs, room=room)
    assert ears.recordings == [] and published == []


def test_a_stop_said_over_the_robot_cuts_it_short_and_is_heard(robot_wavs, stop_word):
    onset = 1.5  # seconds after the robot starts
    ears, _, published, started = play(robot_wavs, person=stop_word, person_at=onset)
    kinds = [type(m) for m, _ in published]
    assert kinds == [StopSpeaking, PersonAnswering], published
    cut, position = published[0]
    assert cut.text == " ".join(ROBOT)
    # the stream's position when the cut was published: within 0.3 s of the word's first sound
    first_sound = started + int(onset * RATE) + int(np.argmax(np.abs(stop_word) > 500))
    assert 0 < position - first_sound <= 0.3 * RATE
    assert len(ears.recordings) == 1  # the person's word, to the recogniser
    heard = read_wav(ears.recordings[0]).samples.astype(np.float64)
    assert 0.3 < len(heard) / RATE < 2.0
    # what was heard is the person's word, the robot's echo taken out around it
    word = stop_word.astype(np.float64)
    lag = np.argmax(np.correlate(heard, word, "valid")) if len(heard) >= len(word) else 0
    part = heard[lag : lag + len(word)]
    assert np.corrcoef(part, word[: len(part)])[0, 1] > 0.8


def test_without_barge_in_the_person_is_not_listened_to_while_the_robot_speaks(
    robot_wavs, stop_word
):
    config = ListeningConfig(barge_in=False)
    ears, _, published, _ = play(robot_wavs, person=stop_word, person_at=1.5, config=config)
    assert ears.recordings == [] and published == []


def test_the_canceller_finds_no_echo_where_none_is_played():
    canceller = EchoCanceller()
    rng = np.random.default_rng(0)
    canceller.speak(rng.normal(0, 3000, RATE).astype(np.int16), 0, first=True)
    reference = rng.normal(0, 3000, RATE).astype(np.int16)
    canceller.speak(reference, 0, first=True)
    for at in range(0, 2 * RATE, PIECE):  # not before the latest echo would have shown
        canceller.hear(np.zeros(PIECE, np.int16), at)
        heard = at + PIECE
        assert (canceller.delay is None) == (heard < (MAX_DELAY + ESTIMATE_AFTER) * RATE)
    assert canceller.delay == 0 and canceller.gain == 0.0
    assert not canceller.active(RATE + int(0.3 * RATE), 0.3)
    # a microphone that hears something else (the person, no echo): the same
    canceller.speak(reference, 2 * RATE, first=True)
    for at in range(2 * RATE, 4 * RATE, PIECE):
        canceller.hear(rng.normal(0, 3000, PIECE).astype(np.int16), at)
        heard = at + PIECE - 2 * RATE
        assert (canceller.delay is None) == (heard < (MAX_DELAY + ESTIMATE_AFTER) * RATE)
    assert canceller.delay == 0 and canceller.gain == 0.0


def test_a_voice_cut_short_finishes_at_once_and_says_no_more(robot_wavs):
    bus = LocalBus()
    out = bus.subscribe(SpeakingStarted, SpeakingContinued, SpeakingFinished)
    voice = SpeechSynthesisComponent(bus, Voice("en-us")).start()
    try:
        text = " ".join(ROBOT) + " " + " ".join(ROBOT)
        bus.publish(Utterance(text=text, act="Request(playGame)"))
        assert isinstance(out.get(5.0), SpeakingStarted)
        bus.publish(StopSpeaking(text="something said before"))  # not this utterance
        time.sleep(0.2)
        assert out.drain() == []
        cut = time.monotonic()
        bus.publish(StopSpeaking(text=text))
        finished = out.get(1.0)
        assert isinstance(finished, SpeakingFinished) and finished.text == text
        assert time.monotonic() - cut < 0.1
    finally:
        voice.stop()


def test_a_placed_utterance_that_cuts_off_the_last_is_taken_out_at_once(robot_wavs):
    """A player that says where it plays: the second utterance starts while the first plays
    (the page cuts the first off), sooner than a path could be found for it alone. Its echo is
    taken out from its first sample on the room's path found before, and never heard."""
    ears = Ears()
    listener = HandsFreeListener(ears, ListeningConfig())
    listener.placed_by_player = True
    news = ears.bus.subscribe(StopSpeaking, PersonAnswering)
    first, second = (heard_in_the_room(w, 0.05) for w in robot_wavs)
    starts = (RATE, RATE + len(first) // 2)  # the second cuts the first off halfway
    stream = np.zeros(starts[1] + len(second) + 2 * RATE)
    stream[starts[0] : starts[1]] = first[: starts[1] - starts[0]]
    stream[starts[1] :][: len(second)] = second
    texts = ("first utterance", "second utterance")
    for at in range(0, len(stream), PIECE):
        played = []
        for text, wav, start in zip(texts, robot_wavs, starts, strict=True):
            if at <= start < at + PIECE:
                ears.bus.publish(SpeakingStarted(text=text, audio=wav, seconds=1.0))
                played.append((text, 0, start - at))
        piece = np.clip(np.round(stream[at : at + PIECE]), -32768, 32767).astype(np.int16)
        listener.feed(piece, played)
        if at == starts[1]:  # the path found on the first holds for the second at once
            assert listener.echo.gain > 0.03 and listener.echo.delay is not None
    assert ears.recordings == [] and news.drain() == []
    assert listener.echo.delay == pytest.approx(0.05 * RATE, abs=0.005 * RATE)


def test_hands_free_turned_on_while_the_robot_speaks_hears_the_person_not_the_robot(
    robot_wavs, stop_word
):
    """The page's hands-free is turned on halfway through the robot's sentence: the listener,
    made then, is told what the robot said before it (`remember`) and where the sentence
    began, before its stream did; the rest of the echo is not heard, the person after it is."""
    ears = Ears()
    # the robot is done with it (faster than real time, as in the tests) but the page plays on
    said = [
        SpeakingStarted(text=ROBOT[0], audio=robot_wavs[0], seconds=1.0),
        SpeakingFinished(text=ROBOT[0]),
    ]
    for message in said:
        ears.bus.publish(message)
    listener = HandsFreeListener(ears, ListeningConfig())
    listener.placed_by_player = True
    listener.remember(said)
    echo = heard_in_the_room(robot_wavs[0], 0.05)
    began = -len(echo) // 2  # where the sentence began, from the stream's first sample
    stream = np.zeros(len(echo) // 2 + 3 * RATE)
    stream[: len(echo) + began] = echo[-began:]
    at_person = len(echo) // 2 + RATE
    stream[at_person : at_person + len(stop_word)] = stop_word
    for at in range(0, len(stream), PIECE):
        played = [(ROBOT[0], 0, began)] if at == 0 else []
        piece = np.clip(np.round(stream[at : at + PIECE]), -32768, 32767).astype(np.int16)
        listener.feed(piece, played)
    assert len(ears.recordings) == 1  # the person's word, and nothing of the robot's
    assert listener.echo.gain > 0.03


def test_each_placed_sentence_s_echo_is_taken_out_on_its_own_path(robot_wavs):
    """A page's marks of two sentences can be a few milliseconds off from where each really
    played (its two audio clocks read at slightly different moments): here the second's echo
    comes 10 ms later than marked. From 0.5 s into it, it is taken out on a path fitted to it
    alone, not on the one found on the first, which leaves much of it for the recogniser when
    the person talks over the robot."""
    ears = Ears()
    listener = HandsFreeListener(ears, ListeningConfig())
    listener.placed_by_player = True
    first, second = (heard_in_the_room(w, 0.05) for w in robot_wavs)
    text = " ".join(ROBOT)
    marks = (RATE, RATE + len(first))  # where the page says each began
    late = int(0.01 * RATE)
    stream = np.zeros(marks[1] + late + len(second) + 2 * RATE)
    stream[marks[0] :][: len(first)] = first
    stream[marks[1] + late :][: len(second)] = second
    judged = range(marks[1] + late + RATE // 2, marks[1] + late + len(second) - PIECE)
    echo_energy = left_energy = 0.0
    for at in range(0, len(stream), PIECE):
        if at == marks[0]:
            for i, wav in enumerate(robot_wavs):
                kind = SpeakingStarted if i == 0 else SpeakingContinued
                ears.bus.publish(kind(text=text, audio=wav, seconds=read_wav(wav).seconds))
        played = [(text, i, m - at) for i, m in enumerate(marks) if at <= marks[0] < at + PIECE]
        piece = np.clip(np.round(stream[at : at + PIECE]), -32768, 32767).astype(np.int16)
        if at in judged:  # what the recogniser would get of it, on the path known then
            residual, _ = listener.echo.separate(piece, at)
            echo_energy += float(np.sum(piece.astype(np.float64) ** 2))
            left_energy += float(np.sum(residual.astype(np.float64) ** 2))
        listener.feed(piece, played)
    assert ears.recordings == []
    assert listener.echo.delay == pytest.approx(0.05 * RATE + late, abs=0.002 * RATE)
    assert left_energy < 0.05 * echo_energy, left_energy / echo_energy  # 13 dB taken out
