"""Hands-free listening for a robot: a person's microphone stream, cut into utterances by the
VAD (`oxbot.speech.vad`), each handed to the robot as a push-to-talk recording.

The robot must not hear itself: from its `SpeakingStarted` until `echo_seconds` after its
`SpeakingFinished` the stream is not listened to, and an utterance under way when it starts
to speak is dropped. The web page's hands-free mode and the terminal's `listen` share this.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from oxbot.config import ListeningConfig
from oxbot.robot.messages import PersonAnswering, SpeakingFinished, SpeakingStarted
from oxbot.speech.audio import RATE, Audio, to_wav_bytes
from oxbot.speech.vad import FrameClassifier, HeardUtterance, UtteranceCutter

log = logging.getLogger(__name__)


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
        self._speech = robot.bus.subscribe(SpeakingStarted, SpeakingFinished)
        self._speaking = False
        self._deaf_until = 0.0
        self.heard: list[HeardUtterance] = []
        """Every utterance handed to the robot, oldest first."""
        self.ignored_seconds = 0.0
        """Stream heard while the robot spoke (or just after), not listened to."""

    @property
    def robot_speaking(self) -> bool:
        """Whether the robot speaks now (or did just now: its echo), after the bus's news."""
        for message in self._speech.drain():
            if isinstance(message, SpeakingStarted):
                self._speaking = True
            else:
                self._speaking = False
                self._deaf_until = self.clock() + self.config.echo_seconds
        return self._speaking or self.clock() < self._deaf_until

    def feed(self, samples: np.ndarray) -> list[HeardUtterance]:
        """The stream's next 16 kHz int16 samples; returns the utterances handed to the robot."""
        if self.robot_speaking:
            self.cutter.skip(len(samples))
            self.ignored_seconds += len(samples) / RATE
            return []
        began = self.cutter.in_utterance
        ended = self.cutter.feed(samples)
        if self.cutter.in_utterance and not began:  # the robot waits for them to finish
            self.robot.bus.publish(PersonAnswering(how="speaking"))
        for utterance in ended:
            log.debug("heard %.2f s at %.2f s", utterance.seconds, utterance.start / RATE)
            self.robot.hear(to_wav_bytes(Audio(utterance.samples, RATE)))
        self.heard += ended
        return ended

    def stop_listening(self) -> None:
        """The stream pauses or ends: an utterance under way is dropped."""
        self.cutter.reset()

    def close(self) -> None:
        self._speech.close()


__all__ = ["HandsFreeListener"]
