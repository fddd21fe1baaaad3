"""Hands-free listening for a robot: a person's microphone stream, cut into utterances by the
VAD (`oxbot.speech.vad`), each handed to the robot as a push-to-talk recording.

The robot must not hear itself. While it speaks, and until its audio's echo has ended in the
stream (`oxbot.speech.echo`: each sentence's audio, as the players play it in full, plus
`echo_seconds`), the stream is listened to only for the person: the robot's modelled echo is
taken out and what is left is heard where it is louder than that echo (`barge_in`; without it,
the stream is not listened to then, and an utterance under way when the robot starts is
dropped). Each sentence's audio is placed on the stream where the player says it began
(`feed`'s `played`: a page knows where in its microphone stream it started each sentence),
or, from a player that does not say, where the stream was when the bus said it. A person who
speaks over the robot cuts it short (barge-in): the listener publishes
StopSpeaking once the VAD starts an utterance in what is left, and the utterance, heard to its
end, goes to the robot as any other. The web page's hands-free mode and the terminal's `listen`
share this.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from oxbot.config import ListeningConfig
from oxbot.robot.messages import (
    Message,
    PersonAnswering,
    SpeakingContinued,
    SpeakingFinished,
    SpeakingStarted,
    StopSpeaking,
)
from oxbot.speech.audio import RATE, Audio, pcm16, to_wav_bytes
from oxbot.speech.echo import EchoCanceller
from oxbot.speech.vad import FrameClassifier, HeardUtterance, UtteranceCutter

log = logging.getLogger(__name__)

KEPT_UTTERANCES = 4
"""The robot's latest utterances kept for a player to say it began (see `feed`)."""
MAX_UNDECIDED = 2.0
"""Seconds of stream kept while the robot's echo path is not known yet, to be heard once it is."""


class HandsFreeListener:
    """Feeds a person's stream to `robot.hear`, one utterance at a time (not thread-safe: one
    feeder). `robot` needs `bus` (for when it speaks) and `hear(wav)`."""

    def __init__(
        self,
        robot: Any,
        config: ListeningConfig | None = None,
        vad: FrameClassifier | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.robot = robot
        self.config = config if config is not None else ListeningConfig()
        self.cutter = UtteranceCutter(self.config, RATE, vad)
        self.clock = clock
        self.echo = EchoCanceller(RATE)
        self._speech = robot.bus.subscribe(SpeakingStarted, SpeakingContinued, SpeakingFinished)
        self._speaking = False
        self._said = ""  # the utterance the robot says or said last
        self._deaf_until = 0.0
        self._position = 0  # samples of the stream fed so far
        self._over_the_robot = False  # the utterance under way began while the robot spoke
        self._undecided: list[tuple[int, np.ndarray]] = []  # heard before the echo is known
        # the latest utterances' audio, sentence by sentence, by text: a player may still
        # begin one the robot has moved on from
        self._sentences: dict[str, list[np.ndarray]] = {}
        self._placed = ""  # the utterance whose sentences were placed last
        self._remembered: list[Message] = []  # said before it listened (`remember`)
        self.placed_by_player = False
        """Whether the player says where each sentence began (`feed`'s `played`); until it
        does, a sentence is placed where the stream was when the bus said it."""
        self.heard: list[HeardUtterance] = []
        """Every utterance handed to the robot, oldest first."""
        self.ignored_seconds = 0.0
        """Stream heard while the robot spoke (or just after), not listened to."""
        self.cuts: list[float] = []
        """When (`clock`) each StopSpeaking was published."""

    def remember(self, said: list[Message]) -> None:
        """What the robot said before this listener was made (SpeakingStarted, -Continued and
        -Finished, oldest first): hands-free turned on while it speaks hears it too."""
        for message in said:
            self._on_speech(message)
        self._deaf_until = 0.0  # a goodbye's echo is long gone; one still playing is marked
        self._remembered = list(said)  # the subscription may hold them again

    def _follow_speech(self) -> None:
        messages = self._speech.drain()
        if self._remembered and messages:
            remembered, self._remembered = self._remembered, []
            messages = [m for m in messages if m not in remembered]
        for message in messages:
            self._on_speech(message)

    def _on_speech(self, message: Message) -> None:
        if isinstance(message, SpeakingFinished):
            self._speaking = False
            self._deaf_until = self.clock() + self.config.echo_seconds
            return
        if not isinstance(message, SpeakingStarted | SpeakingContinued):
            return
        first = isinstance(message, SpeakingStarted)
        self._speaking, self._said = True, message.text
        if first and not self._over_the_robot:
            self.cutter.reset()  # an utterance under way when the robot starts is dropped
        audio = pcm16(message.audio) if message.audio else np.zeros(0, np.int16)
        if first:
            self._sentences.pop(message.text, None)
            while len(self._sentences) >= KEPT_UTTERANCES:
                del self._sentences[next(iter(self._sentences))]
            self._sentences[message.text] = []
        self._sentences.setdefault(message.text, []).append(audio)
        if len(audio) and not self.placed_by_player:
            self.echo.speak(audio, self._position, first)

    def _place(self, played: list[tuple[str, int, int]], position: int) -> None:
        """The player began sentence `sentence` of the utterance `text` at `at` samples from
        `position`."""
        for text, sentence, at in played:
            sentences = self._sentences.get(text, [])
            if sentence >= len(sentences) or not len(sentences[sentence]):
                continue  # not the robot's (or long past)
            # an utterance's first sentence replaces the one playing (the player cut it off)
            first = sentence == 0 or text != self._placed
            self.echo.speak(sentences[sentence], position + at, first, placed=True)
            self._placed = text

    @property
    def robot_speaking(self) -> bool:
        """Whether the robot speaks now (or did just now: its echo), after the bus's news."""
        self._follow_speech()
        echoing = self.echo.active(self._position, self.config.echo_seconds)
        return self._speaking or self.clock() < self._deaf_until or echoing

    def feed(
        self, samples: np.ndarray, played: list[tuple[str, int, int]] = ()
    ) -> list[HeardUtterance]:
        """The stream's next 16 kHz int16 samples; returns the utterances handed to the robot.
        `played`: the robot's sentences the player began since the last call, each (the
        utterance's text, the sentence's index in it, the sample from these samples' first
        where it began; past their end when it began later)."""
        samples = np.asarray(samples)
        position = self._position
        self._follow_speech()  # the sentences a player may say it began
        self._place(list(played), position)
        speaking = self.robot_speaking  # with a sentence begun in these samples
        self.echo.hear(samples, position)
        self._position += len(samples)
        cancelling = self.echo.active(position, self.config.echo_seconds)  # audio to take out
        # an utterance begun over the robot is heard to its end, the robot cut short or not
        if speaking and self.config.barge_in and (cancelling or self._over_the_robot):
            self._undecided.append((position, samples))
            if self.echo.delay is None and not self._over_the_robot:
                if sum(len(s) for _, s in self._undecided) > MAX_UNDECIDED * RATE:
                    self._not_listened(self._undecided.pop(0)[1])
                return []  # kept until the echo's path is known
            pieces, self._undecided = self._undecided, []
            heard = [self._listen(p, s, cancelling) for p, s in pieces]
            return [u for h in heard for u in h]
        self._undecided_not_listened()
        if speaking:
            self._not_listened(samples)
            return []
        return self._listen(position, samples, False)

    def _not_listened(self, samples: np.ndarray) -> None:
        self.cutter.skip(len(samples))
        self.ignored_seconds += len(samples) / RATE

    def _undecided_not_listened(self) -> None:
        """The robot's echo ended before its path was known: what was kept is not heard."""
        for _, samples in self._undecided:
            self._not_listened(samples)
        self._undecided = []

    def _listen(self, position: int, samples: np.ndarray, speaking: bool) -> list[HeardUtterance]:
        judged = None
        if speaking:  # the robot's echo taken out, where its path is known
            parts = self.echo.separate(samples, position)
            if parts is not None:
                samples, judged = parts
        seconds = self.config.barge_in_seconds if speaking else self.config.start_seconds
        self.cutter.start_after(seconds)
        began = self.cutter.in_utterance
        ended = self.cutter.feed(samples, judged)
        if self.cutter.in_utterance and not began:  # the robot waits for them to finish
            log.debug(
                "an utterance begins at %.2f s (over the robot: %s; echo delay %s, gain %.3f, "
                "correlation %.2f)",
                position / RATE,
                speaking,
                self.echo.delay,
                self.echo.gain,
                self.echo.correlation,
            )
            if speaking:  # over the robot: cut it short, in every player too
                self._over_the_robot = True
                self.robot.bus.publish(StopSpeaking(text=self._said))
                self.cuts.append(self.clock())
                self.echo.cut(self._position)
            self.robot.bus.publish(PersonAnswering(how="speaking"))
        for utterance in ended:
            log.debug("heard %.2f s at %.2f s", utterance.seconds, utterance.start / RATE)
            self.robot.hear(to_wav_bytes(Audio(utterance.samples, RATE)))
        if ended and not self.cutter.in_utterance:
            self._over_the_robot = False
        self.heard += ended
        return ended

    def stop_listening(self) -> None:
        """The stream pauses or ends: an utterance under way is dropped."""
        self._undecided = []
        self.cutter.reset()
        self._over_the_robot = False

    def close(self) -> None:
        self._speech.close()


__all__ = ["HandsFreeListener"]
