"""Hands-free listening: a microphone's stream cut into utterances by a voice activity detector.

The stream comes in chunks of any size (the web page's, sox's `rec`); `UtteranceCutter.feed`
classifies it frame by frame with the VAD and returns each utterance as it ends:

- it starts once `start_seconds` of frames within the last `2 * start_seconds` are speech
  (a click or a cough is not enough), and begins `pre_roll_seconds` before the first of
  them, so the first word's onset, quieter than the vowel that triggers the VAD, is kept;
- it ends once `end_silence_seconds` hold almost no speech (at most a tenth of the frames),
  or is cut at `max_utterance_seconds`.

`reset()` forgets a half-heard utterance and the pre-roll: the caller's way of not listening
(while the robot speaks). Each utterance is what a push-to-talk recording is, 16-bit mono
PCM, handed to the recogniser as one.

The detector is Silero VAD (`silero-vad`: a small neural network whose model ships in the
wheel, run with the torch oxbot already has), chosen over the WebRTC VAD by measurement
(`bench/bench_vad.py`, docs/robot.md): no false start in a minute of room noise where the
WebRTC VAD made four, for 0.4 ms of CPU per 32 ms frame. Another plugs in through
`FrameClassifier`.
"""

from __future__ import annotations

import math
import warnings
from collections import deque
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from oxbot.config import ListeningConfig
from oxbot.errors import InvalidInputError
from oxbot.speech.audio import RATE
from oxbot.torch_threads import one_thread

END_SPEECH_RATIO = 0.1
"""At most this share of speech frames in the last `end_silence_seconds` ends an utterance."""


class FrameClassifier(Protocol):
    """A voice activity detector: is this frame (`frame_samples` int16 samples) speech?"""

    frame_samples: int

    def is_speech(self, frame: np.ndarray) -> bool: ...

    def reset(self) -> None:
        """Forget what was heard so far (a detector with memory starts afresh)."""


class SileroVad:
    """Silero VAD (the `silero-vad` wheel's TorchScript model) on 32 ms frames at 16 kHz:
    a frame is speech when the model's probability exceeds `threshold`.

    The model remembers the frames before (an LSTM); one instance per stream.
    """

    frame_samples = 512  # the model's frame at 16 kHz

    def __init__(self, threshold: float = 0.5, rate: int = RATE) -> None:
        import torch

        if rate != RATE:
            raise InvalidInputError(f"the VAD listens at {RATE} Hz; got {rate} Hz")
        threads = torch.get_num_threads()
        from silero_vad import load_silero_vad  # its import sets this thread's torch to 1

        torch.set_num_threads(threads)
        self._torch = torch
        with warnings.catch_warnings():  # the package's own: legacy importlib, torch.jit
            warnings.simplefilter("ignore", DeprecationWarning)
            self._model = load_silero_vad()
        self.threshold = threshold

    def reset(self) -> None:
        self._model.reset_states()

    def is_speech(self, frame: np.ndarray) -> bool:
        torch = self._torch
        x = torch.from_numpy(frame.astype(np.float32) / 32768)
        # one 32 ms frame: 8x cheaper on one thread than on two
        with one_thread(), torch.inference_mode():
            return float(self._model(x, RATE)) > self.threshold


@dataclass(frozen=True)
class HeardUtterance:
    """One utterance cut from the stream: its samples and where it began in the stream."""

    samples: np.ndarray
    start: int
    """The sample (counted from the stream's start, resets included) where it begins."""
    rate: int = RATE

    @property
    def seconds(self) -> float:
        return len(self.samples) / self.rate


class UtteranceCutter:
    """Cuts a stream of 16-bit mono PCM into utterances (see the module's docstring)."""

    def __init__(
        self,
        config: ListeningConfig | None = None,
        rate: int = RATE,
        vad: FrameClassifier | None = None,
    ) -> None:
        self.config = config if config is not None else ListeningConfig()
        self.rate = rate
        self.vad = vad if vad is not None else SileroVad(self.config.threshold, rate)
        n = self.vad.frame_samples

        def frames(seconds: float) -> int:
            return max(1, math.ceil(seconds * rate / n))

        self._window = frames(2 * self.config.start_seconds)
        self._start_needed = frames(self.config.start_seconds)
        self._frames = frames
        self._pre_roll = math.ceil(self.config.pre_roll_seconds * rate / n)
        self._end_window = frames(self.config.end_silence_seconds)
        self._max_frames = frames(self.config.max_utterance_seconds)
        self._leftover = np.zeros(0, np.int16)
        self._judged_leftover = np.zeros(0, np.int16)
        self._position = 0  # samples of the stream seen, leftover included
        self._history: deque[tuple[np.ndarray, bool]] = deque(maxlen=self._window + self._pre_roll)
        self._utterance: list[np.ndarray] | None = None
        self._utterance_start = 0
        self._recent: deque[bool] = deque(maxlen=self._end_window)
        self.frames_heard = 0
        self.speech_frames = 0

    def start_after(self, seconds: float) -> None:
        """From now on, an utterance starts once `seconds` of frames within twice that are
        speech (no more than the config's `start_seconds`; the listener asks for less while
        the robot speaks, its echo taken out, so that a person cuts it short at once)."""
        seconds = min(seconds, self.config.start_seconds)
        self._window = self._frames(2 * seconds)
        self._start_needed = self._frames(seconds)

    @property
    def in_utterance(self) -> bool:
        """Whether an utterance has started and not yet ended."""
        return self._utterance is not None

    @property
    def utterance_start(self) -> int | None:
        """Where the utterance under way began in the stream (None: none is under way)."""
        return self._utterance_start if self._utterance is not None else None

    def reset(self) -> None:
        """Forget the utterance under way and the pre-roll; the stream's count goes on."""
        self._position += len(self._leftover)
        self._leftover = np.zeros(0, np.int16)
        self._judged_leftover = np.zeros(0, np.int16)
        self._history.clear()
        self._utterance = None
        self._recent.clear()
        self.vad.reset()

    def skip(self, samples: int) -> None:
        """Count `samples` of the stream that were not listened to (see `reset`)."""
        self.reset()
        self._position += samples

    def feed(self, samples: np.ndarray, judged: np.ndarray | None = None) -> list[HeardUtterance]:
        """Take the stream's next int16 samples; return the utterances that ended in them. The
        VAD judges `judged` (as many samples; `samples` themselves when None) and the
        utterances keep `samples`: the listener has it judge what is surely the person."""
        samples = np.asarray(samples)
        if samples.dtype != np.int16 or samples.ndim != 1:
            raise InvalidInputError("the stream is 1-D int16 samples (16-bit mono PCM)")
        judged = samples if judged is None else np.asarray(judged, np.int16)
        if len(judged) != len(samples):
            raise InvalidInputError("feed() judges as many samples as it is given")
        data = np.concatenate([self._leftover, samples]) if len(self._leftover) else samples
        seen = np.concatenate([self._judged_leftover, judged]) if len(self._leftover) else judged
        n = self.vad.frame_samples
        whole = len(data) // n * n
        self._leftover, self._judged_leftover = data[whole:].copy(), seen[whole:].copy()
        ended = []
        for at in range(0, whole, n):
            speech = self.vad.is_speech(seen[at : at + n])
            done = self._frame(data[at : at + n], speech, self._position + at)
            if done is not None:
                ended.append(done)
        self._position += whole
        return ended

    def _frame(self, frame: np.ndarray, speech: bool, at: int) -> HeardUtterance | None:
        self.frames_heard += 1
        self.speech_frames += speech
        if self._utterance is None:
            self._history.append((frame, speech))
            history = list(self._history)
            window = [s for _, s in history[-self._window :]]
            if sum(window) < self._start_needed:
                return None
            # the utterance begins pre_roll before the window's first speech frame
            first = len(history) - len(window) + window.index(True)
            kept = history[max(0, first - self._pre_roll) :]
            self._utterance = [f for f, _ in kept]
            self._utterance_start = at + len(frame) - len(kept) * len(frame)
            self._history.clear()
            self._recent.clear()
            self._recent.extend(s for _, s in kept)
            return None
        self._utterance.append(frame)
        self._recent.append(speech)
        quiet = (
            len(self._recent) == self._end_window
            and sum(self._recent) <= END_SPEECH_RATIO * self._end_window
        )
        if quiet or len(self._utterance) >= self._max_frames:
            heard = HeardUtterance(
                np.concatenate(self._utterance), self._utterance_start, self.rate
            )
            self._utterance = None
            self._recent.clear()
            return heard
        return None

    def flush(self) -> HeardUtterance | None:
        """The stream ends: the utterance under way, if any, as it is."""
        if self._utterance is None:
            self.reset()
            return None
        heard = HeardUtterance(np.concatenate(self._utterance), self._utterance_start, self.rate)
        self.reset()
        return heard


def first_speech(
    samples: np.ndarray, config: ListeningConfig | None = None, vad: FrameClassifier | None = None
) -> int | None:
    """Where a recording's first utterance begins, its pre-roll included (None: no speech):
    leading audio before it (a device's click, a wait) can go."""
    cutter = UtteranceCutter(config, RATE, vad)
    for at in range(0, len(samples), RATE):
        heard = cutter.feed(samples[at : at + RATE])
        if heard:
            return heard[0].start
        if cutter.in_utterance:
            return cutter.utterance_start
    return None


__all__ = ["FrameClassifier", "HeardUtterance", "SileroVad", "UtteranceCutter", "first_speech"]
