"""Speech recognition with pocketsphinx, the fallback: the game's phrases, and a way out.

The paper used Google's recogniser through push-to-talk and passed its N-best lists on. oxbot
decodes offline with pocketsphinx and its en-us acoustic model (shipped in the PyPI wheel, no
download). The domain's user phrases (`Domain.user_phrases()`: some 600 phrasings of the
person's acts, and chatter that is none of them) give the recogniser its words; a recording
goes through up to three searches, one after the other:

1. **words**: a trigram model of the domain's phrases (its ~310 words, pronunciations from the
   shipped cmudict). It hears the phrases, their fragments and new orders of their words, and
   how well its best path fits the audio (`Listening.fit`) says whether the person spoke the
   domain's language at all.
2. **outside**: when the fit is poor (`OUTSIDE_FIT`), the general English model shipped with
   pocketsphinx (`en-us.lm.bin`, 130,000 words) listens too; its words are kept when they fit
   the audio better than the domain's. Chatter ("my brother plays football every sunday") is
   then heard as the words it is, not forced onto "maybe later" or "no".
3. **phrases**: otherwise, when the best path of (1) is no complete phrase, a grammar of the
   complete phrases (a prefix tree, so shared beginnings are searched once) decides which one
   it was; complete phrases are heard more reliably than their fragments.

A short answer (at most 1.25 s of sound) is also heard by a keyword model trained on real
people saying yes, no and other words (`oxbot.speech.keywords`); its opinion is joined into the
N-best list: both agreeing makes the answer surer, disagreeing makes it Unknown. A mumbled "no"
that the recogniser took for "hi" becomes "no" when the keyword model is sure, but only as the
answer to a yes/no question: `hear` hands the keyword model's opinion on, and the robot, which
knows what it asked, decides (`oxbot.speech.keywords.keyword_rescue`).

Before decoding, the recording's level is brought to a fixed peak, its silence trimmed to 0.2 s
either side of the sound, and a faint hiss added (`oxbot.speech.audio`: `NOISE_FLOOR`), so that
a quiet microphone, long pauses or exact zeros do not change what is heard. One recogniser
serves every caller, one recording at a time (a lock), so a web server can share it.

Confidences: the best hypothesis's is the probability that it is word for word what was said,
from how well the domain's words fit the audio, their mean lattice posterior and the search
that found it (a logistic regression, `CALIBRATION`, fitted on the tuning recordings); each other
N-best entry gets it scaled by its path score relative to the best one's. Each word of the best
hypothesis carries its own lattice posterior. The list is ordered and every value lies in
[0, 1]. What was measured, and the designs that lost, are in docs/robot.md ("Hearing the
person"); `bench/tune_recognition.py` reproduces the constants.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
import os
import re
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from oxbot.errors import InvalidInputError, SpeechUnavailable
from oxbot.speech.audio import (
    RATE,
    level_dbfs,
    normalise_level,
    pcm16,
    trim_silence,
    with_noise_floor,
)
from oxbot.speech.nbest import Hypothesis, normalise

if TYPE_CHECKING:
    from pocketsphinx import Decoder

    from oxbot.speech.keywords import KeywordSpotter

log = logging.getLogger(__name__)

FILLERS = {"<s>", "</s>", "<sil>", "[NOISE]", "[SPEECH]", "<unk>"}
PRONUNCIATIONS = {"oxbot": "AA K S B AA T", "noughts": "N AO T S", "hiya": "HH AY Y AH"}
"""Words of the domain that the en-us dictionary lacks ("hi oxbot"), in its phone set."""
SILENT_DBFS = -50.0
"""A recording whose peak lies below this is nothing heard (a muted microphone); a quiet one,
-30 dBFS, is brought up to the normal level."""
DISCOUNT = 0.02
"""Probability mass the domain's trigram model keeps for unseen word sequences (ArpaBoLM's
discount; its default is 0.5). Small: the model prefers the phrases as written but still allows
new orders. On the tuning recordings, the best path was the phrase word for word 76-78% of the
time with 0.02, 74-75% with 0.1 and 66% with 0.5, and told chatter from the domain better."""
SCORE_SCALE = 1024.0
"""pocketsphinx reports path scores shrunk by 2^10 (its senone scores are shifted by 10 bits);
multiplied back, differences of scores are log-likelihood ratios in nats. With the raw scores,
the N-best entries were near ties and their votes took the understanding from 90% to 78% of acts
right on the tuning recordings; scaled, it matches the best hypothesis alone."""
OUTSIDE_FIT = -5.62
"""Below this fit (`Listening.fit`, nats per frame) the domain's words do not explain the
recording and the general English model listens too: 5% of the domain's phrases in the tuning
voices (clean and at 20 dB SNR) fit worse, and about 90% of the chatter."""
CALIBRATION = {
    "intercept": -0.357,
    "fit": 0.098,
    "posterior": 4.139,
    "phrases": -1.271,
    "outside": -3.008,
    "fragment": 0.0,
}
"""Logistic regression of P(best hypothesis right word for word) on the fit, the mean lattice
posterior of the domain's best path, and which search found the hypothesis (coefficients for
the grammar of complete phrases, `phrases`; the general model, `outside`; a domain path that
is no complete phrase, `fragment`; none for a complete phrase of the trigram model)."""


@dataclass(frozen=True)
class Search:
    """What one search of the decoder made of a recording."""

    name: str
    """`words`, `phrases` or `outside` (see the module)."""
    nbest: tuple[tuple[str, float], ...]
    """Distinct normalised texts with their path scores (nats), best first."""
    words: tuple[tuple[str, float], ...]
    """The best path's words with their lattice posteriors."""
    fit: float
    """The best path's score per frame (nats; 0 is the best-scoring senone in every frame):
    how well its words, acoustics and language model together, explain the audio."""
    seconds: float = 0.0
    """How long the search took (wall clock)."""


@dataclass(frozen=True)
class Listening:
    """Everything the searches heard in one recording, and what the recogniser makes of it."""

    words: Search
    phrases: Search | None = None
    outside: Search | None = None
    chosen: str = "words"
    """The search whose hypotheses are the answer: `words` (a complete phrase), `fragment`
    (words of the domain that are no complete phrase), `phrases` or `outside`."""
    hypotheses: list[Hypothesis] = field(default_factory=list)
    keywords: np.ndarray | None = None
    """The keyword model's P(yes), P(no), P(other) of a short answer, joined into `hypotheses`
    (`oxbot.speech.keywords.second_opinion`, steps 1-2; step 3, `keyword_rescue`, is the
    robot's, in context); None when it was not asked."""

    @property
    def fit(self) -> float:
        """How well the domain's words explain the recording (`Search.fit` of `words`)."""
        return self.words.fit


class PocketsphinxRecognizer:
    """pocketsphinx decoding of what people say in the domain (`phrases`), with a way out for
    what they say outside it (see the module)."""

    def __init__(
        self, phrases: Sequence[str], nbest: int = 5, keywords: KeywordSpotter | bool = True
    ) -> None:
        """`keywords`: the keyword model asked about short answers (`oxbot.speech.keywords`);
        True for the shipped one, False for none (the recogniser alone)."""
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
        if keywords is True:
            from oxbot.speech.keywords import shipped_keyword_spotter

            keywords = shipped_keyword_spotter() or False
        self.keywords = keywords or None
        self._lock = threading.Lock()  # one decoder, shared by every session of the web server
        words = {w for p in self.phrases for w in p.split()}
        general = Config()
        lexicon = pronunciations(Path(general["dict"]), words)
        known = {line.split()[0].split("(")[0] for line in lexicon}
        lexicon += [
            f"{w} {PRONUNCIATIONS[w]}\n" for w in sorted(words - known) if w in PRONUNCIATIONS
        ]
        self.vocabulary = {line.split()[0].split("(")[0] for line in lexicon}
        missing = sorted(words - self.vocabulary)
        if missing:
            log.warning("not in the pronunciation dictionary, left out of the phrases: %s", missing)
        complete = [p for p in self.phrases if all(w in self.vocabulary for w in p.split())]
        if not complete:
            raise InvalidInputError(
                "none of the phrases can be pronounced with the en-us dictionary; "
                f"first phrase: {self.phrases[0]!r}"
            )
        # A phrase with a word the dictionary lacks still teaches the trigram model the words
        # around it ("hello oxbot" -> "hello").
        pieces = (
            [
                piece
                for p in self.phrases
                for piece in re.split(
                    r"\s*\b(?:" + "|".join(map(re.escape, missing)) + r")\b\s*", p
                )
                if piece
            ]
            if missing
            else list(self.phrases)
        )
        model = ArpaBoLM(
            text="\n".join(pieces), case="lower", add_start=True, discount_mass=DISCOUNT
        )
        model.compute()
        with tempfile.TemporaryDirectory() as tmp:
            # Only the domain's words: with the whole 135,000-word dictionary, adding the
            # n-gram search takes 8 s instead of a few milliseconds.
            dictionary, lm = Path(tmp) / "domain.dict", Path(tmp) / "domain.lm"
            dictionary.write_text("".join(lexicon), encoding="utf-8")
            model.write_file(str(lm))
            self._domain = Decoder(
                samprate=RATE, loglevel="FATAL", dict=str(dictionary), lm=str(lm), fwdflat=False
            )
        self._domain.add_fsg("phrases", self._domain.create_fsg("phrases", *phrase_tree(complete)))
        # The general model keeps its own decoder: its dictionary is the whole cmudict.
        self._general = Decoder(samprate=RATE, loglevel="FATAL", fwdflat=False)

    def recognize(self, wav: str | os.PathLike[str] | bytes) -> list[Hypothesis]:
        """N-best hypotheses for a WAV (path or bytes), best first; empty if nothing was heard."""
        return self.decode(pcm16(wav))

    def decode(self, samples: np.ndarray) -> list[Hypothesis]:
        """N-best hypotheses for mono int16 samples at 16 kHz, best first."""
        listening = self.listen(samples)
        return listening.hypotheses if listening is not None else []

    def listen(self, samples: np.ndarray, every_search: bool = False) -> Listening | None:
        """What the searches heard in mono int16 samples at 16 kHz and the hypotheses made of
        it, or None when nothing was heard; `every_search` runs all three searches (for tuning:
        `bench/tune_recognition.py`) without changing the answer."""
        data = prepared(samples)
        if data is None:
            return None
        with self._lock:
            heard = self._search(self._domain, "_default", data, "words")
            outside = phrases = None
            if every_search or heard.fit < OUTSIDE_FIT:
                outside = self._search(self._general, "_default", data, "outside")
            if every_search or not self.is_phrase(heard):
                phrases = self._search(self._domain, "phrases", data, "phrases")
                complete = [(t, s) for t, s in phrases.nbest if t in self._phrase_set]
                phrases = Search(
                    "phrases", tuple(complete), phrases.words, phrases.fit, phrases.seconds
                )
        if not heard.nbest:
            return None
        listening = self.choose(heard, phrases, outside)
        if self.keywords is None:
            return listening
        from oxbot.speech.keywords import second_opinion

        keywords = self.keywords.probabilities(samples)
        # steps 1-2 only: whether a bare keyword may stand for the answer depends on what the
        # robot asked, which the robot knows and the recogniser does not
        hypotheses = second_opinion(listening.hypotheses, keywords, rescue=False)
        return dataclasses.replace(listening, hypotheses=hypotheses, keywords=keywords)

    def hear(
        self, wav: str | os.PathLike[str] | bytes
    ) -> tuple[list[Hypothesis], tuple[float, ...]]:
        """`recognize`, with the keyword model's P(yes), P(no), P(other) of a short answer
        (empty when it was not asked), for `oxbot.speech.keywords.keyword_rescue`."""
        listening = self.listen(pcm16(wav))
        if listening is None:
            return [], ()
        keywords = () if listening.keywords is None else tuple(map(float, listening.keywords))
        return listening.hypotheses, keywords

    def choose(
        self,
        heard: Search,
        phrases: Search | None,
        outside: Search | None,
        outside_fit: float = OUTSIDE_FIT,
        calibration: dict[str, float] = CALIBRATION,
    ) -> Listening:
        """The answer from what the searches heard (see the module); `outside_fit` and
        `calibration` are given only when tuning them."""
        if (
            heard.fit < outside_fit
            and outside is not None
            and outside.nbest
            and outside.fit > heard.fit
        ):
            chosen, entries, words = "outside", list(outside.nbest), outside.words
        elif self.is_phrase(heard):
            # Below a complete phrase, only complete phrases: a fragment of one ("i" under
            # "hi") is no other reading of the recording, only a worse path through it.
            chosen, words = "words", heard.words
            entries = [e for e in heard.nbest if e[0] in self._phrase_set]
        elif phrases is not None and phrases.nbest:
            chosen, words = "phrases", ()
            entries = list(phrases.nbest)
        else:
            chosen, entries, words = "fragment", list(heard.nbest), heard.words
        entries = entries[: self.nbest]
        confidence = calibrated(heard, chosen, calibration)
        best = entries[0][1]
        confidences = np.minimum.accumulate(
            [confidence * min(1.0, math.exp(score - best)) for _, score in entries]
        )
        top = entries[0][0]
        if not words or " ".join(w for w, _ in words) != top:
            words = tuple((w, confidence) for w in top.split())
        hypotheses = [
            Hypothesis(text, float(c), words if i == 0 else ())
            for i, ((text, _), c) in enumerate(zip(entries, confidences, strict=True))
        ]
        return Listening(heard, phrases, outside, chosen, hypotheses)

    def is_phrase(self, search: Search) -> bool:
        """Whether the best path of a search is one of the domain's complete phrases."""
        return bool(search.nbest) and search.nbest[0][0] in self._phrase_set

    def _search(self, decoder: Decoder, search: str, data: bytes, name: str) -> Search:
        started = time.perf_counter()
        # The feature front end keeps state from the last recording (its cepstral mean among
        # others): start afresh, so one session's audio never changes what another's gives.
        decoder.reinit_feat()
        decoder.activate_search(search)
        decoder.start_utt()
        decoder.process_raw(data, full_utt=True)
        decoder.end_utt()
        best = decoder.hyp()
        frames = max(decoder.n_frames(), 1)
        if best is None or not normalise(best.hypstr):
            return Search(name, (), (), -math.inf, time.perf_counter() - started)
        scores: dict[str, float] = {normalise(best.hypstr): _nats(best.score)}
        for entry in itertools.islice(decoder.nbest(), 6 * self.nbest):
            text = normalise(entry.hypstr) if entry is not None else ""
            if text:
                scores[text] = max(scores.get(text, -math.inf), _nats(entry.score))
        words = tuple(
            (seg.word.split("(")[0], float(np.clip(seg.prob, 0.0, 1.0)))
            for seg in decoder.seg()
            if seg.word not in FILLERS
        )
        ranked = sorted(scores.items(), key=lambda e: -e[1])
        fit = _nats(best.score) / frames
        return Search(name, tuple(ranked), words, fit, time.perf_counter() - started)


def _nats(score: float) -> float:
    """A path score as pocketsphinx's Python API gives it (exp of a shrunk log) in nats."""
    return SCORE_SCALE * math.log(score) if score > 0 else -math.inf


def calibrated(heard: Search, chosen: str, calibration: dict[str, float] = CALIBRATION) -> float:
    """P(best hypothesis right word for word), from what the domain's trigram model heard and
    the search `chosen` for the answer (`CALIBRATION`)."""
    z = (
        calibration["intercept"]
        + calibration["fit"] * heard.fit
        + calibration["posterior"] * mean_posterior(heard)
        + calibration.get(chosen, 0.0)
    )
    return float(1.0 / (1.0 + math.exp(-z)))


def mean_posterior(search: Search) -> float:
    """The mean lattice posterior of the words of a search's best path (0 without words)."""
    return float(np.mean([p for _, p in search.words])) if search.words else 0.0


def prepared(samples: np.ndarray) -> bytes | None:
    """The recording as the decoder hears it: level normalised, silence trimmed to a margin,
    the noise floor added; None when it holds nothing (under 0.1 s, or silent)."""
    samples = np.asarray(samples)
    if samples.dtype != np.int16 or samples.ndim != 1:
        raise InvalidInputError(
            f"audio must be 1-D int16 samples at 16 kHz; got {samples.dtype} {samples.shape}"
        )
    if len(samples) < RATE // 10 or level_dbfs(samples) < SILENT_DBFS:
        return None  # under 0.1 s: a click of the button, not speech; or a muted microphone
    trimmed = trim_silence(normalise_level(samples))
    if trimmed is None:
        return None
    return with_noise_floor(trimmed).tobytes()


def phrase_tree(phrases: Sequence[str]) -> tuple[int, int, list[tuple]]:
    """A finite-state grammar of `phrases` as a prefix tree: (start state, final state,
    transitions `(from, to, probability[, word])`), every phrase equally likely."""
    through: dict[tuple[str, ...], int] = {}
    ending: dict[tuple[str, ...], int] = {}
    states: dict[tuple[str, ...], int] = {(): 0}
    for phrase in phrases:
        words = tuple(phrase.split())
        for i in range(len(words) + 1):
            through[words[:i]] = through.get(words[:i], 0) + 1
            states.setdefault(words[:i], len(states))
        ending[words] = ending.get(words, 0) + 1
    final = len(states)
    transitions: list[tuple] = []
    for prefix, state in states.items():
        if prefix:
            parent = states[prefix[:-1]]
            transitions.append((parent, state, through[prefix] / through[prefix[:-1]], prefix[-1]))
        if prefix in ending:
            transitions.append((state, final, ending[prefix] / through[prefix]))
    return 0, final, transitions


def pronunciations(dictionary: Path, words: set[str]) -> list[str]:
    """The lines of a CMU-style pronunciation dictionary (`word(2) PH ON ES`) for `words`."""
    with dictionary.open(encoding="utf-8") as handle:
        return [
            line.rstrip("\n") + "\n"
            for line in handle
            if line.split("(", 1)[0].split(" ", 1)[0] in words
        ]
