"""How far the two listeners of a short yes or no (pocketsphinx and the keyword model) can go
together on the DEVELOPMENT set of real people, and how much the keyword model's training data
limits them, against the goal for single words (>= 95% understood, 0 flips).

    PYTHONPATH=. .venv/bin/python bench/bench_listeners.py                          # ~15 min
    PYTHONPATH=. .venv/bin/python bench/bench_listeners.py --repo B.git  # +10 min/share

1. The shipped rule (`keywords.second_opinion` at SURE, AGREE, DOUBT), as bench_keywords.py.
2. A learned combiner in place of the rule, wherever the keyword model's most probable label is
   yes or no: a logistic regression on the keyword model's log-probabilities, the share of the
   recogniser's N-best confidence read as an accept and as a decline, what its best words say
   and their confidence. Out-of-fold by speaker (5 folds), so no answer is judged by a model that
   saw its speaker; a yes needs P(accept) >= tau, a no P(accept) <= 1 - tau, else it is unsure.
3. With `--repo` (a fetched MahmoudEhab3/Yes-No-Speech-Classifier, as `oxbot train keywords`
   takes): the keyword model retrained, seed 0, on a share of the real yes and no clips (the
   "other" clips and the synthesised ones all kept), alone and joined at the best thresholds of
   bench_keywords.py's grid: the learning curve of the data it has.

Only the development set (bench/data/speech_commands_dev/); never the held-out one. Not a test.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from development_answers import (
    Heard,
    decode_development,
    grid_rows,
    keyword_alone,
    keyword_probabilities,
)

from oxbot.dialogue.domain import INVITATION, load_domain
from oxbot.dialogue.understanding import UserActClassifier, polarity
from oxbot.speech import keywords as kw
from oxbot.speech.evaluation import intent_of_act

TAUS = (0.8, 0.9, 0.95, 0.97, 0.98, 0.99, 0.995)


def features(classifier: UserActClassifier, h: Heard, p: np.ndarray | None) -> list[float]:
    """What the combiner reads of one answer."""
    p = np.full(3, 1 / 3) if p is None else p
    mass = {"accept": 0.0, "decline": 0.0}
    for hypothesis in h.nbest:
        intent = intent_of_act(classifier.read(hypothesis.text, INVITATION).act)
        if intent in mass:
            mass[intent] += hypothesis.confidence
    said = polarity(h.nbest[0].text) if h.nbest else None
    confidence = h.nbest[0].confidence if h.nbest else 0.0
    logs = np.log(np.clip(p, 1e-4, 1.0))
    return [*logs, mass["accept"], mass["decline"], said == "yes", said == "no", confidence]


def combiner(classifier: UserActClassifier, heard: list[Heard], probabilities: list) -> None:
    from sklearn.linear_model import LogisticRegression
    from sklearn.model_selection import GroupKFold

    x = np.array([features(classifier, h, p) for h, p in zip(heard, probabilities, strict=True)])
    y = np.array([h.expected == "accept" for h in heard])
    speakers = np.array([h.speaker for h in heard])
    judged = np.array([p is not None and int(np.argmax(p)) < 2 for p in probabilities])
    shipped = (kw.SURE, kw.AGREE, kw.DOUBT)
    rule = []
    for h, p in zip(heard, probabilities, strict=True):
        nbest = kw.second_opinion(h.nbest, p, *shipped)
        rule.append(intent_of_act(classifier.intent_of(nbest, INVITATION).act))
    p_accept = np.zeros(len(y))
    for train, test in GroupKFold(5).split(x, y, speakers):
        model = LogisticRegression(max_iter=1000).fit(x[train], y[train])
        p_accept[test] = model.predict_proba(x[test])[:, 1]
    want = np.where(y, "accept", "decline")
    print(
        f"\nlearned combiner, out of fold by speaker ({judged.mean():.0%} of answers judged by it)"
    )
    for tau in TAUS:
        said = np.where(
            p_accept >= tau, "accept", np.where(p_accept <= 1 - tau, "decline", "unsure")
        )
        got = np.where(judged, said, np.array(rule))
        flips = int(np.sum((got != want) & np.isin(got, ["accept", "decline"])))
        print(
            f"  tau {tau}: {np.mean(got == want):6.2%}  flips {flips}  "
            f"unsure {int(np.sum(got == 'unsure'))}"
        )


def learning_curve(
    classifier: UserActClassifier, heard: list[Heard], repo: Path, shares: list[float]
) -> None:
    from oxbot.speech.keywords import KeywordConfig, KeywordData, load_training_data, spoken_clips

    real = load_training_data(repo)
    synthesised = spoken_clips(load_domain())
    print("\nthe keyword model retrained on a share of the real yes/no clips (seed 0)")
    for share in shares:
        keep = np.random.default_rng(123).random(len(real.labels)) < share
        keep |= real.labels == kw.LABELS.index("other")
        data = KeywordData(real.clips[keep], real.labels[keep], real.rule) + synthesised
        spotter = kw.train_keywords(data, KeywordConfig(seed=0), show_progress=False)
        report(
            f"share {share} (yes {int((data.labels == 0).sum())}, no "
            f"{int((data.labels == 1).sum())})",
            classifier,
            heard,
            spotter,
        )


def report(
    label: str, classifier: UserActClassifier, heard: list[Heard], spotter: kw.KeywordSpotter
) -> list:
    """The keyword model alone and joined at the grid's best thresholds; its probabilities."""
    probabilities = keyword_probabilities(spotter, heard)
    right, flips = keyword_alone(heard, probabilities)
    (best, best_flips, unsure), t = grid_rows(classifier, heard, probabilities)[0]
    print(
        f"  {label}: alone {right:6.2%}, flips {flips}; joined at its best {t}: {best:6.2%}, "
        f"flips {best_flips}, unsure {unsure}"
    )
    return probabilities


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=kw.shipped_keyword_path())
    parser.add_argument(
        "--repo", type=Path, help="git dir of MahmoudEhab3/Yes-No-Speech-Classifier"
    )
    parser.add_argument("--shares", type=float, nargs="*", default=[0.5, 0.25])
    args = parser.parse_args()
    classifier = UserActClassifier(load_domain())
    heard = decode_development()
    print(f"development set: {len(heard)} answers (300 people x 7 conditions)")
    probabilities = report("shipped model", classifier, heard, kw.KeywordSpotter.load(args.model))
    combiner(classifier, heard, probabilities)
    if args.repo is not None:
        learning_curve(classifier, heard, args.repo, args.shares)


if __name__ == "__main__":
    main()
