"""The DEVELOPMENT set of real people's yes and no (bench/data/speech_commands_dev/) as the two
listeners hear it: the recogniser alone, and the keyword model, joined by `second_opinion`.

`decode_development` decodes every recording under every condition of
`oxbot.speech.evaluation.CONDITIONS` once, with bench_speech.py's seeds; the rest re-reads
those decodings: the keyword model alone, the two joined at given thresholds, and the grid of
thresholds ranked. `bench_keywords.py` chose `SURE`, `AGREE` and `DOUBT` with it and
`bench_listeners.py` asks how far the two listeners can go. Never the held-out set.
"""

from __future__ import annotations

import itertools
import zlib
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from oxbot.dialogue.domain import INVITATION, load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech import keywords as kw
from oxbot.speech.audio import pcm16
from oxbot.speech.evaluation import CONDITIONS, intent_of_act, speech_commands
from oxbot.speech.nbest import Hypothesis
from oxbot.speech.recognition import user_phrases
from oxbot.speech.sphinx import PocketsphinxRecognizer

DEVELOPMENT = Path(__file__).parent / "data" / "speech_commands_dev"
WANT = {"accept": "yes", "decline": "no"}
GRID = ((0.7, 0.8, 0.9, 0.95), (0.3, 0.5, 0.7, 0.9), (0.05, 0.1, 0.2, 0.3))
"""The thresholds searched: SURE, AGREE and DOUBT."""


@dataclass(frozen=True)
class Heard:
    """One development recording under one condition, as the recogniser heard it alone."""

    condition: str
    expected: str
    """"accept" or "decline"."""
    speaker: str
    nbest: list[Hypothesis]
    window: np.ndarray | None
    """What the keyword model hears (`keywords.short_window`); None when the sound is long."""


def decode_development(seed: int = 0) -> list[Heard]:
    """Every development recording under every condition of `CONDITIONS`, with bench_speech.py's
    seeds: the recogniser's N-best (the keyword model left out) and the keyword model's window."""
    recordings = list(speech_commands(DEVELOPMENT))
    if not recordings:
        raise SystemExit(
            f"no development recordings in {DEVELOPMENT}: restore them first "
            "(bench/README.md, 'Data kept out of the repository')"
        )
    recognizer = PocketsphinxRecognizer(user_phrases(load_domain()), keywords=False)
    heard = []
    for rec in recordings:
        clean = pcm16(rec.path)
        for condition in CONDITIONS:
            key = zlib.crc32(f"{rec.speaker}|{rec.path.name}|{condition.seed_key}".encode())
            samples = condition.apply(clean, np.random.default_rng([seed, key]))
            nbest = recognizer.decode(samples)
            window = kw.short_window(samples)
            heard.append(Heard(condition.name, rec.expected, rec.speaker, nbest, window))
    return heard


def keyword_probabilities(spotter: kw.KeywordSpotter, heard: list[Heard]) -> list:
    """The keyword model's [P(yes), P(no), P(other)] for each of `heard`, None where it is not
    asked (`KeywordSpotter.probabilities`, in one batch)."""
    asked = [i for i, h in enumerate(heard) if h.window is not None]
    out: list = [None] * len(heard)
    for i, p in zip(asked, spotter.classify([heard[i].window for i in asked]), strict=True):
        out[i] = p
    return out


def joined_counts(
    classifier: UserActClassifier,
    heard: list[Heard],
    probabilities: list,
    thresholds: tuple[float, float, float] | None,
) -> dict[str, list[int]]:
    """[answers, understood, flips, unsure] per condition, the keyword model joined by
    `second_opinion` at `thresholds` (sure, agree, doubt), or the recogniser alone (None)."""
    counts: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0, 0])
    for h, p in zip(heard, probabilities, strict=True):
        nbest = kw.second_opinion(h.nbest, p, *thresholds) if thresholds is not None else h.nbest
        got = intent_of_act(classifier.intent_of(nbest, INVITATION).act)
        c = counts[h.condition]
        c[0] += 1
        c[1] += got == h.expected
        c[2] += {got, h.expected} == {"accept", "decline"}
        c[3] += got == "unsure"
    return counts


def totals(counts: dict[str, list[int]]) -> tuple[float, int, int]:
    """Understood, flips and unsure over every condition."""
    n, right, flips, unsure = np.sum(list(counts.values()), axis=0)
    return right / n, int(flips), int(unsure)


def keyword_alone(heard: list[Heard], probabilities: list) -> tuple[float, int]:
    """The keyword model alone, its most probable label: the share right and the flips (a yes
    taken for a no or the reverse)."""
    said = [kw.LABELS[int(np.argmax(p))] if p is not None else "none" for p in probabilities]
    wanted = [WANT[h.expected] for h in heard]
    right = np.mean([s == w for s, w in zip(said, wanted, strict=True)])
    flips = sum({s, w} == {"yes", "no"} for s, w in zip(said, wanted, strict=True))
    return float(right), flips


def grid_rows(
    classifier: UserActClassifier, heard: list[Heard], probabilities: list
) -> list[tuple[tuple[float, int, int], tuple[float, float, float]]]:
    """Every (sure, agree, doubt) of `GRID` with its totals, fewest flips then most understood
    first."""
    rows = [
        (totals(joined_counts(classifier, heard, probabilities, t)), t)
        for t in itertools.product(*GRID)
    ]
    return sorted(rows, key=lambda r: (r[0][1], -r[0][0]))
