"""Hands-free listening: utterances reach the robot, and the robot never hears itself."""

import numpy as np
import pytest

from oxbot.config import ListeningConfig
from oxbot.robot.bus import LocalBus
from oxbot.robot.listening import HandsFreeListener
from oxbot.robot.messages import SpeakingFinished, SpeakingStarted
from oxbot.speech import Voice, pcm16, read_wav, synthesize
from oxbot.testing.sounds import in_noise

PIECE = 1600  # the page's 0.1 s


class Ears:
    """What the listener needs of a robot: a bus, and `hear`, which keeps the recordings."""

    def __init__(self) -> None:
        self.bus = LocalBus()
        self.recordings: list[bytes] = []

    def hear(self, wav: bytes) -> None:
        self.recordings.append(wav)


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture(scope="module")
def answer() -> np.ndarray:
    """ "yes let's play" with a second of a quiet room before and after."""
    speech = pcm16(synthesize("yes let's play", Voice("en-us")))
    return in_noise(speech, np.random.default_rng(0))[0]


def stream(listener: HandsFreeListener, samples: np.ndarray, clock: Clock) -> None:
    for at in range(0, len(samples), PIECE):
        listener.feed(samples[at : at + PIECE])
        clock.now += PIECE / 16_000


def test_an_answer_reaches_the_robot_as_a_recording(answer):
    ears, clock = Ears(), Clock()
    listener = HandsFreeListener(ears, ListeningConfig(), clock=clock)
    stream(listener, answer, clock)
    assert len(ears.recordings) == 1 and len(listener.heard) == 1
    assert read_wav(ears.recordings[0]).rate == 16_000
    assert len(read_wav(ears.recordings[0]).samples) == len(listener.heard[0].samples)


def test_nothing_is_heard_while_the_robot_speaks_and_just_after(answer):
    ears, clock = Ears(), Clock()
    config = ListeningConfig(echo_seconds=0.3)
    listener = HandsFreeListener(ears, config, clock=clock)
    ears.bus.publish(SpeakingStarted(text="Would you like to play?"))
    stream(listener, answer, clock)  # the robot's own voice, say, or someone barging in
    ears.bus.publish(SpeakingFinished(text="Would you like to play?"))
    listener.feed(answer[:PIECE])  # the echo: the robot's last words still reach the mic
    assert ears.recordings == [] and listener.ignored_seconds == pytest.approx(
        (len(answer) + PIECE) / 16_000, abs=0.11
    )
    clock.now += config.echo_seconds
    stream(listener, answer, clock)
    assert len(ears.recordings) == 1


def test_an_utterance_under_way_when_the_robot_starts_speaking_is_dropped(answer):
    ears, clock = Ears(), Clock()
    listener = HandsFreeListener(ears, ListeningConfig(), clock=clock)
    stream(listener, answer[: len(answer) // 2], clock)
    assert listener.cutter.in_utterance
    ears.bus.publish(SpeakingStarted(text="Your turn."))
    stream(listener, answer[len(answer) // 2 :], clock)
    assert ears.recordings == [] and not listener.cutter.in_utterance
