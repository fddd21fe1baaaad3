"""The robot's voice and ears: speech synthesis and speech recognition as components.

Synthesis (paper §3.1: MARY TTS from templates; oxbot: Piper's neural voice, or espeak-ng)
turns each Utterance into WAV audio, sentence by sentence so that the first plays while the
next is made, and brackets it with SpeakingStarted and SpeakingFinished, so that a face can
move its mouth while the audio plays and nobody talks over the robot. Utterances queue: the
robot never says two things at once. Without espeak-ng the robot still "speaks" in text, after
one clear warning.

Recognition (paper: Google ASR, push-to-talk, N-best lists; oxbot: offline pocketsphinx)
turns each push-to-talk SpeechAudio into SpeechHypotheses. Typed text needs no component:
other code publishes it directly as SpeechHypotheses(nbest=((text, 1.0),), source="text").
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator

from oxbot.config import SpeechConfig
from oxbot.errors import ConfigError, SpeechUnavailable
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import (
    Message,
    SpeakingContinued,
    SpeakingFinished,
    SpeakingStarted,
    SpeechAudio,
    SpeechHypotheses,
    StopSpeaking,
    Utterance,
)
from oxbot.speech.audio import read_wav
from oxbot.speech.nbest import Recognizer
from oxbot.speech.piper import PiperVoice
from oxbot.speech.recognition import load_recognizer
from oxbot.speech.sphinx import PocketsphinxRecognizer
from oxbot.speech.synthesis import Voice, espeak_available, synthesize
from oxbot.speech.visemes import Viseme

log = logging.getLogger(__name__)

SPOKEN_CHARS_PER_SECOND = 14.0
"""About how fast the robot speaks, in characters of text: making a sentence may take as long
as saying it (20 tabs at once on 2 cores) before the watchdog calls it hung."""


class SpeechSynthesisComponent(Component):
    """On Utterance: SpeakingStarted with the first sentence's audio, SpeakingContinued with each
    further sentence as soon as it is made, then SpeakingFinished when the last has played.

    The voice is Piper's (`PiperVoice`: sentence by sentence, each with its visemes) or
    espeak-ng's (`Voice`, the default: the whole text in one piece). `realtime=False` skips the
    wait (for batch runs); `speed_factor` shortens it (tests). The audio itself is played by
    whoever shows the robot (the web page, the terminal), each sentence after the one before;
    this component keeps the time, so every listener agrees on when the robot is speaking.
    """

    listens_to = (Utterance,)
    retries = (Utterance,)  # the manager waits for SpeakingFinished
    part = "voice"

    def __init__(
        self,
        bus: Bus,
        voice: Voice | PiperVoice | None = None,
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
        self._cuts = bus.subscribe(StopSpeaking)  # read while speaking, not queued behind it

    def handle(self, message: Message) -> None:
        assert isinstance(message, Utterance)
        text = message.text
        self.speaking = True
        if isinstance(self.voice, PiperVoice):  # a crowded machine makes sentences slowly
            self.expect(len(text) / SPOKEN_CHARS_PER_SECOND)
        self._cuts.drain()  # a cut asked for before this utterance is not for it
        try:
            ends = time.monotonic()  # when the audio sent so far has played
            for i, (audio, seconds, visemes) in enumerate(self._sentences(text)):
                if self._stop.is_set():
                    return  # stopped between sentences: the rest is not said
                if self._cut(text, 0.0):
                    break  # the person talks over the robot: the rest is not said
                kind = SpeakingStarted if i == 0 else SpeakingContinued
                self.bus.publish(kind(text=text, audio=audio, seconds=seconds, visemes=visemes))
                # a sentence made after the one before ended starts late: the clock waits for it
                ends = max(ends, time.monotonic()) + seconds / self.speed_factor
                if self.realtime:
                    self.expect(seconds / self.speed_factor)  # a long sentence is not a hang
            else:
                while self.realtime and (left := ends - time.monotonic()) > 0:
                    if self._stop.is_set():
                        return  # stopped while speaking: the sentence is cut off
                    if self._cut(text, min(left, 0.02)):
                        break
        finally:
            self.speaking = False
        self.bus.publish(SpeakingFinished(text=text))

    def _cut(self, text: str, wait: float) -> bool:
        """Whether the person cut `text` short (StopSpeaking), waiting up to `wait` s for it."""
        cut = self._cuts.get(wait)
        while cut is not None:
            assert isinstance(cut, StopSpeaking)
            if cut.text == text:
                return True
            cut = self._cuts.get(0)
        return False

    def restart(self) -> None:
        self.speaking = False

    def _sentences(self, text: str) -> Iterator[tuple[bytes, float, tuple[Viseme, ...]]]:
        """Each sentence's WAV, duration and visemes, as it is made; one silent piece when the
        text cannot be synthesised (so that SpeakingStarted and SpeakingFinished still come)."""
        if not text.strip():
            yield b"", 0.0, ()
            return
        if not espeak_available():  # Piper phonemises with it too
            if not self._warned:
                self._warned = True
                log.warning(
                    "espeak-ng is not installed, so the robot's speech is text only; install "
                    "it with `apt-get install espeak-ng` (make run does this)"
                )
            yield b"", 0.0, ()
            return
        said = False
        try:
            if isinstance(self.voice, PiperVoice):
                for sentence in self.voice.stream(text):
                    said = True
                    yield sentence.wav(), sentence.seconds, sentence.visemes()
            else:
                wav = synthesize(text, self.voice)
                said = True
                yield wav, read_wav(wav).seconds, ()
        except SpeechUnavailable as exc:
            log.warning("saying this in text only: %s", exc)
        if not said:
            yield b"", 0.0, ()


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
