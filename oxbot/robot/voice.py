"""The robot's voice and ears: speech synthesis and speech recognition as components.

Synthesis (paper §3.1: MARY TTS from templates; oxbot: espeak-ng) turns each Utterance into
WAV audio and brackets it with SpeakingStarted and SpeakingFinished, so that a face can move
its mouth while the audio plays and nobody talks over the robot. Utterances queue: the robot
never says two things at once. Without espeak-ng the robot still "speaks" in text, after one
clear warning.

Recognition (paper: Google ASR, push-to-talk, N-best lists; oxbot: offline pocketsphinx)
turns each push-to-talk SpeechAudio into SpeechHypotheses. Typed text needs no component:
other code publishes it directly as SpeechHypotheses(nbest=((text, 1.0),), source="text").
"""

from __future__ import annotations

import logging

from oxbot.config import SpeechConfig
from oxbot.errors import ConfigError, SpeechUnavailable
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import (
    Message,
    SpeakingFinished,
    SpeakingStarted,
    SpeechAudio,
    SpeechHypotheses,
    Utterance,
)
from oxbot.speech.audio import read_wav
from oxbot.speech.nbest import Recognizer
from oxbot.speech.recognition import load_recognizer
from oxbot.speech.sphinx import PocketsphinxRecognizer
from oxbot.speech.synthesis import Voice, espeak_available, synthesize

log = logging.getLogger(__name__)


class SpeechSynthesisComponent(Component):
    """On Utterance: SpeakingStarted(text, audio, seconds), the audio's duration, SpeakingFinished.

    `realtime=False` skips the wait (for batch runs); `speed_factor` shortens it (tests). The
    audio itself is played by whoever shows the robot (the web page, the terminal); this
    component keeps the time, so every listener agrees on when the robot is speaking.
    """

    listens_to = (Utterance,)
    retries = (Utterance,)  # the manager waits for SpeakingFinished
    part = "voice"

    def __init__(
        self,
        bus: Bus,
        voice: Voice | None = None,
        realtime: bool = True,
        speed_factor: float = 1.0,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        if speed_factor <= 0:
            raise ValueError(f"speed_factor must be positive; got {speed_factor}")
        self.voice = voice or Voice()
        self.realtime = realtime
        self.speed_factor = speed_factor
        self.speaking = False
        self._warned = False

    def handle(self, message: Message) -> None:
        assert isinstance(message, Utterance)
        audio, seconds = self._speak(message.text)
        self.speaking = True
        try:
            self.bus.publish(SpeakingStarted(text=message.text, audio=audio, seconds=seconds))
            if self.realtime:
                self.expect(seconds / self.speed_factor)  # a long sentence is not a hang
            if self.realtime and self._stop.wait(seconds / self.speed_factor):
                return  # stopped while speaking: the sentence is cut off
        finally:
            self.speaking = False
        self.bus.publish(SpeakingFinished(text=message.text))

    def restart(self) -> None:
        self.speaking = False

    def _speak(self, text: str) -> tuple[bytes, float]:
        """The WAV and its duration; no audio (and no wait) when it cannot be synthesised."""
        if not text.strip():
            return b"", 0.0
        if not espeak_available():
            if not self._warned:
                self._warned = True
                log.warning(
                    "espeak-ng is not installed, so the robot's speech is text only; install "
                    "it with `apt-get install espeak-ng` (make run does this)"
                )
            return b"", 0.0
        try:
            wav = synthesize(text, self.voice)
        except SpeechUnavailable as exc:
            log.warning("saying this in text only: %s", exc)
            return b"", 0.0
        return wav, read_wav(wav).seconds


class SpeechRecognitionComponent(Component):
    """On SpeechAudio: SpeechHypotheses with the recogniser's N-best list (empty: nothing heard)
    and the best hypothesis's words with their own confidences.

    The recogniser is the one given, or the one `config.recognizer` names, built at the first
    recording (building the shipped domain's takes a few seconds). When it cannot be built,
    recordings are dropped after one warning and the person types instead.
    """

    listens_to = (SpeechAudio,)
    part = "hearing"
    essential = False  # the person can type

    def __init__(
        self,
        bus: Bus,
        recognizer: Recognizer | None = None,
        config: SpeechConfig | None = None,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        self.recognizer = recognizer
        self.config = config if config is not None else SpeechConfig()
        self._unavailable = False

    def handle(self, message: Message) -> None:
        assert isinstance(message, SpeechAudio)
        if self._unavailable:
            return
        if self.recognizer is None:
            try:
                self.recognizer = load_recognizer(self.config)
            except (SpeechUnavailable, ConfigError) as exc:
                self._unavailable = True
                log.warning("speech recognition is off, type your answers instead: %s", exc)
                return
        self.expect(read_wav(message.audio).seconds)  # a long recording takes longer to hear
        if isinstance(self.recognizer, PocketsphinxRecognizer):
            hypotheses, keywords = self.recognizer.hear(message.audio)
        else:  # another recogniser: an N-best list and no keyword model
            hypotheses, keywords = self.recognizer.recognize(message.audio), ()
        nbest = tuple((h.text, h.confidence) for h in hypotheses)
        words = hypotheses[0].words if hypotheses else ()
        self.bus.publish(
            SpeechHypotheses(nbest=nbest, source="microphone", words=words, keywords=keywords)
        )
