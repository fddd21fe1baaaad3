"""Listening tests: synthesised answers through the real recogniser, scored by their user act.

Issue 6's acceptance: "On espeak-ng recordings of the user answers in several voices, with and
without 20 dB noise, the recogniser gets the accept/decline intent right in ≥ 95% and decodes
faster than real time." `listening_test` runs that measurement (and the same for any phrases);
`bench/bench_speech.py` prints it and `tests/speech/test_evaluation.py` asserts it.

Each phrase is spoken by espeak-ng in each voice, optionally mixed with white noise at the given
SNR (seeded by voice and phrase, so every run hears the same audio), decoded to an N-best list,
and read as a user act by `UserActClassifier.intent_of`.
"""

from __future__ import annotations

import statistics
import time
import zlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from oxbot.dialogue.domain import INVITATION, SILENCE, Domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech.audio import RATE, add_noise, pcm16
from oxbot.speech.recognition import Recognizer, default_recognizer
from oxbot.speech.synthesis import Voice, synthesize

VOICES: tuple[str, ...] = (
    "en-us",
    "en-gb",
    "en+m3",
    "en+f3",
    "en+m7",
    "en-gb+f4",
    "en-us+f2",
    "en-gb-scotland",
    "en+m1",
    "en+f2",
    "en-us+m5",
    "en-gb-x-rp",
)
"""espeak-ng voices: American, British and Scottish accents, male and female variants."""


@dataclass(frozen=True)
class Trial:
    """One phrase in one voice at one noise level, as the robot heard and understood it."""

    voice: str
    snr_db: float | None
    """Signal-to-noise ratio of the added white noise; None for clean audio."""
    phrase: str
    expected: str
    """The phrase's user act in the domain."""
    heard: str
    """The recogniser's best hypothesis ("" when nothing was heard)."""
    act: str
    """The act the whole N-best list votes for (`UserActClassifier.intent_of`)."""
    top_act: str
    """The act of the best hypothesis alone (`UserActClassifier.classify`)."""
    decode_seconds: float
    audio_seconds: float

    @property
    def right(self) -> bool:
        return self.act == self.expected

    @property
    def real_time_factor(self) -> float:
        return self.decode_seconds / self.audio_seconds


def accept_decline_phrases(domain: Domain) -> dict[str, str]:
    """The person's answers to the invitation (`Request(playGame)`), phrase -> act."""
    return {" ".join(u.words): u.act for u in domain.responses_to(INVITATION) if u.words}


def listening_test(
    phrases: Mapping[str, str],
    classifier: UserActClassifier,
    voices: Sequence[str] = VOICES,
    snrs_db: Iterable[float | None] = (None, 20.0),
    recognizer: Recognizer | None = None,
    seed: int = 0,
) -> list[Trial]:
    """Every phrase (text -> expected act) in every voice at every noise level, recognised."""
    recognizer = recognizer or default_recognizer()
    trials = []
    snrs_db = tuple(snrs_db)
    for voice in voices:
        for phrase, expected in phrases.items():
            clean = pcm16(synthesize(phrase, Voice(voice)))
            for snr in snrs_db:
                key = zlib.crc32(f"{voice}|{phrase}|{snr}".encode())
                rng = np.random.default_rng([seed, key])
                samples = clean if snr is None else add_noise(clean, snr, rng)
                started = time.perf_counter()
                nbest = recognizer.decode(samples)
                decode_seconds = time.perf_counter() - started
                top = classifier.classify(nbest[0].text).act if nbest else SILENCE
                trials.append(
                    Trial(
                        voice,
                        snr,
                        phrase,
                        expected,
                        nbest[0].text if nbest else "",
                        classifier.intent_of(nbest).act,
                        top,
                        decode_seconds,
                        len(samples) / RATE,
                    )
                )
    return trials


def accuracy(trials: Sequence[Trial]) -> float:
    """The share of trials whose act was understood right."""
    return sum(t.right for t in trials) / len(trials) if trials else 0.0


def median_real_time_factor(trials: Sequence[Trial]) -> float:
    """The median over trials of decoding time / audio duration (< 1: faster than real time)."""
    return statistics.median(t.real_time_factor for t in trials) if trials else 0.0
