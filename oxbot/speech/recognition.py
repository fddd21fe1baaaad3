"""Speech recognition with pocketsphinx, restricted to what people say in this game.

The paper used Google's recogniser through push-to-talk and passed its N-best lists on. oxbot
decodes offline with pocketsphinx and its en-us acoustic model (shipped in the PyPI wheel, no
download). A general English language model mishears short answers ("yes let's go for it" came
back as "yeah snow for"), so decoding is restricted to the domain in two passes:

1. a JSGF grammar whose sentences are the domain's user phrases — exact and fast; only its
   complete phrases are kept;
2. when the grammar finds no complete phrase, an n-gram model built from the same phrases,
   which still allows other word orders and fragments of them.

Before decoding, a faint hiss is added (`NOISE_FLOOR`): synthesised and browser audio has
stretches of exact zeros that throw pocketsphinx's features off. One decoder serves every
caller, one utterance at a time (a lock), so a web server can share it between sessions.

Confidences: a word's confidence is its posterior in the decoder's lattice (`seg().prob`); the
best path's mean word posterior says how sure the decoder is overall, and each N-best entry
gets that certainty scaled by its path score relative to the best score. Complete domain
phrases rank before fragments; the list is ordered and every value lies in [0, 1].
"""

from __future__ import annotations

import functools
import importlib
import itertools
import logging
import os
import re
import tempfile
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from oxbot.config import SpeechConfig
from oxbot.errors import ConfigError, InvalidInputError, SpeechUnavailable
from oxbot.speech.audio import RATE, pcm16

if TYPE_CHECKING:
    from oxbot.dialogue.domain import Domain

log = logging.getLogger(__name__)

FILLERS = {"<s>", "</s>", "<sil>", "[NOISE]", "<unk>"}
NOISE_FLOOR = 32.0
"""Standard deviation, in 16-bit steps (-60 dBFS), of the hiss added before decoding.

Synthesised and browser audio holds stretches of exact zeros, which no microphone produces; on
them pocketsphinx's energy features and noise model go astray ("okay" heard as "hi"). With this
floor, the accept/decline answers in 12 espeak-ng voices, clean and at 20 dB SNR, were heard
word for word 97% of the time instead of 63%."""


@dataclass(frozen=True)
class Hypothesis:
    """One entry of an N-best list."""

    text: str
    confidence: float
    words: tuple[tuple[str, float], ...] = ()
    """Each word with its confidence in [0, 1]; filled for the best hypothesis."""


def normalise(text: str) -> str:
    """Lower case, letters, digits and apostrophes only: the form the recogniser speaks in."""
    return " ".join(re.sub(r"[^a-z0-9' ]+", " ", text.lower()).split())


class Recognizer(Protocol):
    """What the robot needs of a speech recogniser: a recording in, an N-best list out.

    Another recogniser plugs in by having this method, passed to the robot as an object or
    named in the config as `speech.recognizer = "module:factory"`, where `factory(phrases,
    nbest)` builds it (`load_recognizer`)."""

    def recognize(self, wav: str | os.PathLike[str] | bytes) -> list[Hypothesis]:
        """N-best hypotheses for a WAV (path or bytes), best first; empty if nothing was heard."""
        ...


class PocketsphinxRecognizer:
    """pocketsphinx decoding restricted to `phrases` (what the person is expected to say)."""

    def __init__(self, phrases: Sequence[str], nbest: int = 5) -> None:
        try:
            from pocketsphinx import Config, Decoder
            from pocketsphinx.lm import ArpaBoLM
        except ImportError:
            raise SpeechUnavailable(
                "pocketsphinx is not installed; run `make run` or `pip install pocketsphinx`"
            ) from None
        self.phrases = sorted({normalise(p) for p in phrases if normalise(p)})
        self._phrase_set = set(self.phrases)
        if not self.phrases:
            raise InvalidInputError("the recogniser needs at least one non-empty phrase")
        self.nbest = nbest
        self._lock = threading.Lock()  # one decoder, shared by every session of the web server
        words = {w for p in self.phrases for w in p.split()}
        lexicon = pronunciations(Path(Config()["dict"]), words)
        self.vocabulary = {line.split()[0].split("(")[0] for line in lexicon}
        if words - self.vocabulary:
            log.warning(
                "not in the pronunciation dictionary, ignored: %s", sorted(words - self.vocabulary)
            )
        usable = [p for p in self.phrases if all(w in self.vocabulary for w in p.split())]
        if not usable:
            raise InvalidInputError(
                "none of the phrases can be pronounced with the en-us dictionary; "
                f"first phrase: {self.phrases[0]!r}"
            )
        grammar = "#JSGF V1.0;\ngrammar oxbot;\npublic <utterance> = "
        grammar += " | ".join(usable) + " ;\n"
        lm = ArpaBoLM(text="\n".join(usable), case="lower", add_start=True)
        lm.compute()
        with tempfile.TemporaryDirectory() as tmp:
            # Only the domain's words: with the whole 135,000-word dictionary, adding the
            # n-gram search takes 8 s instead of a few milliseconds.
            dictionary, model = Path(tmp) / "domain.dict", Path(tmp) / "domain.lm"
            dictionary.write_text("".join(lexicon), encoding="utf-8")
            lm.write_file(str(model))
            self._decoder = Decoder(samprate=RATE, loglevel="FATAL", dict=str(dictionary))
            self._decoder.add_jsgf_string("phrases", grammar)
            self._decoder.add_lm_file("words", str(model))

    def recognize(self, wav: str | os.PathLike[str] | bytes) -> list[Hypothesis]:
        """N-best hypotheses for a WAV (path or bytes), best first; empty if nothing was heard."""
        return self.decode(pcm16(wav))

    def decode(self, samples: np.ndarray) -> list[Hypothesis]:
        """N-best hypotheses for mono int16 samples at 16 kHz, best first."""
        samples = np.asarray(samples)
        if samples.dtype != np.int16 or samples.ndim != 1:
            raise InvalidInputError(
                f"audio must be 1-D int16 samples at 16 kHz; got {samples.dtype} {samples.shape}"
            )
        if len(samples) < RATE // 10:
            return []  # under 0.1 s: a click of the button, not speech
        data = with_noise_floor(samples).tobytes()
        with self._lock:
            return self._run("phrases", data, complete_only=True) or self._run("words", data)

    def _run(self, search: str, data: bytes, complete_only: bool = False) -> list[Hypothesis]:
        decoder = self._decoder
        # The feature front end keeps state from the last recording (its cepstral mean among
        # others): start afresh, so one session's audio never changes what another's gives.
        decoder.reinit_feat()
        decoder.activate_search(search)
        decoder.start_utt()
        decoder.process_raw(data, full_utt=True)
        decoder.end_utt()
        best = decoder.hyp()
        if best is None or not normalise(best.hypstr):
            return []
        words = tuple(
            (seg.word.split("(")[0], float(np.clip(seg.prob, 0.0, 1.0)))
            for seg in decoder.seg()
            if seg.word not in FILLERS
        )
        certainty = float(np.mean([c for _, c in words])) if words else 0.0
        scores: dict[str, float] = {normalise(best.hypstr): best.score}
        for entry in itertools.islice(decoder.nbest(), 4 * self.nbest):
            text = normalise(entry.hypstr) if entry is not None else ""
            if text and entry.score > 0:
                scores[text] = max(scores.get(text, 0.0), entry.score)
        # A grammar search that ran out of audio returns a fragment of a phrase; a complete
        # phrase further down the list is the better answer. The grammar's fragments are
        # dropped: they outvote the right phrase when the list is read as a whole ("i take",
        # "i pick", "i" for "hi").
        if complete_only:
            scores = {t: s for t, s in scores.items() if t in self._phrase_set}
            if not scores:
                return []
        ranked = sorted(scores, key=lambda t: (t not in self._phrase_set, -scores[t]))
        ranked = ranked[: self.nbest]
        top = max(scores.values())
        confidences = np.minimum.accumulate([certainty * scores[t] / top for t in ranked])
        posterior = dict(words)
        return [
            Hypothesis(
                text,
                float(conf),
                tuple((w, posterior.get(w, float(conf))) for w in text.split()) if i == 0 else (),
            )
            for i, (text, conf) in enumerate(zip(ranked, confidences, strict=True))
        ]


def pronunciations(dictionary: Path, words: set[str]) -> list[str]:
    """The lines of a CMU-style pronunciation dictionary (`word(2) PH ON ES`) for `words`."""
    with dictionary.open(encoding="utf-8") as handle:
        return [
            line.rstrip("\n") + "\n"
            for line in handle
            if line.split("(", 1)[0].split(" ", 1)[0] in words
        ]


def with_noise_floor(samples: np.ndarray, level: float = NOISE_FLOOR) -> np.ndarray:
    """`samples` plus faint white noise, the same for the same input (fixed seed)."""
    hiss = np.random.default_rng(0).normal(0.0, level, len(samples))
    return np.clip(np.round(samples + hiss), -32768, 32767).astype(np.int16)


def user_phrases(domain: Domain) -> list[str]:
    """Everything the person says in a domain: user response alternatives and seed dialogues."""
    return sorted({" ".join(u.words) for u in domain.user_utterances() if u.words})


RECOGNIZERS: dict[str, Callable[..., Recognizer]] = {"pocketsphinx": PocketsphinxRecognizer}
"""The recognisers `speech.recognizer` can name without a module path."""


def load_recognizer(config: SpeechConfig | None = None, domain: Domain | None = None) -> Recognizer:
    """The recogniser `config` names, built for the phrases of `domain` (default: shipped).

    The shipped domain's recogniser is built once per process and shared (building one takes a
    few seconds; a recogniser serves one recording at a time, under its own lock)."""
    config = config if config is not None else SpeechConfig()
    if domain is None:
        return _shipped_recognizer(config.recognizer, config.nbest)
    return _build(config.recognizer, user_phrases(domain), config.nbest)


@functools.cache
def _shipped_recognizer(name: str, nbest: int) -> Recognizer:
    from oxbot.dialogue.domain import load_domain

    return _build(name, user_phrases(load_domain()), nbest)


def _build(name: str, phrases: list[str], nbest: int) -> Recognizer:
    return recognizer_factory(name)(phrases, nbest=nbest)


def recognizer_factory(name: str) -> Callable[..., Recognizer]:
    """The factory `speech.recognizer` names: one of RECOGNIZERS, or `module:factory`."""
    factory = RECOGNIZERS.get(name)
    if factory is not None:
        return factory
    module_name, _, attribute = name.partition(":")
    if not attribute:
        raise ConfigError(
            f"speech.recognizer is {name!r}; use {', '.join(RECOGNIZERS)} or module:factory"
        )
    try:
        return getattr(importlib.import_module(module_name), attribute)
    except (ImportError, AttributeError) as exc:
        raise ConfigError(f"speech.recognizer {name!r} cannot be imported: {exc}") from None


def default_recognizer() -> Recognizer:
    """The recogniser for the shipped domain with the default config, shared by every caller."""
    return load_recognizer()


def recognize(wav: str | os.PathLike[str] | bytes) -> list[tuple[str, float]]:
    """SPEC §5: a 16 kHz mono WAV (path or bytes) -> N-best list of (text, confidence)."""
    return [(h.text, h.confidence) for h in default_recognizer().recognize(wav)]
