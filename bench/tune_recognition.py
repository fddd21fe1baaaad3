"""Tuning of the recogniser's constants on the project's own material, and their check.

    .venv/bin/python bench/tune_recognition.py                 # about 80 min on one core
    .venv/bin/python bench/tune_recognition.py --every 4       # a quarter of it: ~20 min
    .venv/bin/python bench/tune_recognition.py --every 4 --cache /tmp/tune4.pkl   # again: ~1 min

The shipped constants were fitted with `--every 4` (docs/robot.md, "Hearing the person").

The material: every phrasing of the domain (`Domain.user_phrases()`) spoken by two of the 12
espeak-ng voices of `oxbot.speech.evaluation.VOICES` (phrase i by voices i and i + 6), and every
made-up chatter sentence (`chatter_sentences()`, none of the game's acts) by three (j, j + 4,
j + 8), each clean and with white noise at 20 dB SNR. Even voices (`TUNING_VOICES`, and so the
even phrases and sentences) fit the constants, odd ones (`CHECK_VOICES`) check them. Nothing
else: no held-out recordings, no other voices or synthesisers.

Every recording goes through all three searches (`PocketsphinxRecognizer.listen(every_search=
True)`), so that the choices can be replayed for any threshold. Prints, for the tuning and the
check halves: `OUTSIDE_FIT` (the fit below which the general model listens: a quantile of the
domain phrases' fits) and what it does to the domain phrases and the chatter, the fitted
`CALIBRATION`, the separation of right and wrong best hypotheses by their confidence, and the
real-time factor of the searches the recogniser would run. Not a test.
"""

from __future__ import annotations

import argparse
import pickle
import statistics
import time
import zlib
from pathlib import Path

import numpy as np

from oxbot.dialogue.domain import ACCEPT, DECLINE, INVITATION, POSTPONE, UNKNOWN, load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech.audio import RATE, add_noise, pcm16
from oxbot.speech.evaluation import TUNING_VOICES, VOICES, chatter_sentences
from oxbot.speech.nbest import normalise
from oxbot.speech.recognition import user_phrases
from oxbot.speech.sphinx import (
    CALIBRATION,
    OUTSIDE_FIT,
    Listening,
    PocketsphinxRecognizer,
    mean_posterior,
)
from oxbot.speech.synthesis import Voice, synthesize

YES_OR_NO = {ACCEPT, DECLINE, POSTPONE}


def material(every: int) -> list[tuple[str, str, str, str]]:
    """(kind, words, act, voice) of every recording: domain phrases and chatter."""
    acts: dict[str, str] = {}
    for text, act in load_domain().user_phrases():
        acts.setdefault(normalise(text), act)
    items = [
        ("domain", text, acts[text], VOICES[(i + k) % len(VOICES)])
        for i, text in enumerate(sorted(acts))
        for k in (0, 6)
    ]
    items += [
        ("chatter", normalise(text), UNKNOWN, VOICES[(j + k) % len(VOICES)])
        for j, text in enumerate(chatter_sentences())
        for k in (0, 4, 8)
    ]
    return [item for item in items if zlib.crc32(repr(item).encode()) % every == 0]


def listen_to_everything(recognizer: PocketsphinxRecognizer, every: int) -> list[dict]:
    """Each recording of the material, clean and at 20 dB SNR, through every search."""
    heard = []
    for n, (kind, text, act, voice) in enumerate(material(every)):
        clean = pcm16(synthesize(text, Voice(voice)))
        for snr in (None, 20.0):
            key = zlib.crc32(f"{voice}|{text}|{snr}".encode())
            samples = (
                clean if snr is None else add_noise(clean, snr, np.random.default_rng([0, key]))
            )
            started = time.perf_counter()
            listening = recognizer.listen(samples, every_search=True)
            heard.append(
                {
                    "kind": kind,
                    "text": text,
                    "act": act,
                    "voice": voice,
                    "snr": snr,
                    "seconds": len(samples) / RATE,
                    "listening": listening,
                    "wall": time.perf_counter() - started,
                }
            )
        if n % 100 == 0:
            print(f"  {n} recordings of {len(material(every))} heard", flush=True)
    return heard


def replay(recognizer, row: dict, outside_fit: float, calibration: dict) -> Listening | None:
    """The recogniser's answer for one recording under other constants."""
    listening: Listening | None = row["listening"]
    if listening is None:
        return None
    phrases = listening.phrases
    if recognizer.is_phrase(listening.words):
        phrases = None  # the recogniser would not have run the grammar
    return recognizer.choose(listening.words, phrases, listening.outside, outside_fit, calibration)


def seconds_spent(recognizer, row: dict, outside_fit: float) -> float:
    """The time the searches the recogniser would have run took."""
    listening: Listening | None = row["listening"]
    if listening is None:
        return 0.0
    spent = listening.words.seconds
    poor = listening.fit < outside_fit
    if poor and listening.outside is not None:
        spent += listening.outside.seconds
    if not recognizer.is_phrase(listening.words) and listening.phrases is not None:
        spent += listening.phrases.seconds
    return spent


def fit_calibration(rows: list[dict], recognizer, outside_fit: float) -> dict[str, float]:
    """Logistic regression of P(best hypothesis right word for word) on the tuning rows."""
    from sklearn.linear_model import LogisticRegression

    names = ("phrases", "outside", "fragment")
    features, right = [], []
    for row in rows:
        answer = replay(recognizer, row, outside_fit, CALIBRATION)
        if answer is None:
            continue
        chosen = [float(answer.chosen == name) for name in names]
        features.append([answer.fit, mean_posterior(answer.words), *chosen])
        right.append(answer.hypotheses[0].text == row["text"])
    model = LogisticRegression(C=10.0, max_iter=5_000).fit(features, right)
    coefficients = dict(zip(("fit", "posterior", *names), model.coef_[0], strict=True))
    return {"intercept": round(float(model.intercept_[0]), 3)} | {
        k: round(float(v), 3) for k, v in coefficients.items()
    }


def auc(positive: list[float], negative: list[float]) -> float:
    """Probability that a random positive scores above a random negative (ties count half)."""
    if not positive or not negative:
        return float("nan")
    p, n = np.array(positive)[:, None], np.array(negative)[None, :]
    return float((p > n).mean() + 0.5 * (p == n).mean())


def report(title: str, rows: list[dict], recognizer, classifier, outside_fit, calibration):
    print(f"\n{title}")
    answers = {id(r): replay(recognizer, r, outside_fit, calibration) for r in rows}
    heard = {id(r): answers[id(r)].hypotheses if answers[id(r)] else [] for r in rows}
    for snr in (None, 20.0):
        noise = "clean" if snr is None else f"{snr:g} dB"
        domain = [r for r in rows if r["snr"] == snr and r["kind"] == "domain"]
        chatter = [r for r in rows if r["snr"] == snr and r["kind"] == "chatter"]
        exact = share(bool(heard[id(r)]) and heard[id(r)][0].text == r["text"] for r in domain)
        acts = share(classifier.intent_of(heard[id(r)]).act == r["act"] for r in domain)
        flips = share(
            flipped(r["act"], classifier.intent_of(heard[id(r)], INVITATION).act) for r in domain
        )
        general = share(bool(answers[id(r)]) and answers[id(r)].chosen == "outside" for r in domain)
        print(
            f"  {noise:6s} domain phrases ({len(domain)}): word for word {exact:.1%}, "
            f"act {acts:.1%}, yes/no flipped {flips:.2%}, heard by the general model {general:.1%}"
        )
        general = share(
            bool(answers[id(r)]) and answers[id(r)].chosen == "outside" for r in chatter
        )
        forced = share(
            bool(heard[id(r)]) and acts_of(heard[id(r)][0].text) in YES_OR_NO for r in chatter
        )
        to_yes_no = share(
            classifier.intent_of(heard[id(r)], INVITATION).act in YES_OR_NO for r in chatter
        )
        print(
            f"  {noise:6s} chatter ({len(chatter)}): heard by the general model {general:.1%}, "
            f"heard as an accept/decline phrase {forced:.1%}, understood as accept/decline "
            f"when asked to play {to_yes_no:.1%}"
        )
    right = [
        heard[id(r)][0].confidence
        for r in rows
        if heard[id(r)] and heard[id(r)][0].text == r["text"]
    ]
    wrong = [
        heard[id(r)][0].confidence
        for r in rows
        if heard[id(r)] and heard[id(r)][0].text != r["text"]
    ]
    print(
        f"  confidence of the best hypothesis: right ({len(right)}) median {np.median(right):.2f} "
        f"(quartiles {np.percentile(right, 25):.2f}-{np.percentile(right, 75):.2f}), wrong "
        f"({len(wrong)}) median {np.median(wrong):.2f} (quartiles {np.percentile(wrong, 25):.2f}-"
        f"{np.percentile(wrong, 75):.2f}); AUC {auc(right, wrong):.3f}"
    )
    for threshold in (0.3, 0.5, 0.7):
        kept_right = sum(c >= threshold for c in right)
        kept_wrong = sum(c >= threshold for c in wrong)
        print(
            f"    confidence >= {threshold}: keeps {kept_right / len(right):.1%} of the right and "
            f"{kept_wrong / len(wrong):.1%} of the wrong; "
            f"{kept_right / max(kept_right + kept_wrong, 1):.1%} of those kept are right"
        )
    factors = [seconds_spent(recognizer, r, outside_fit) / r["seconds"] for r in rows]
    print(
        f"  real-time factor of the searches run: median {statistics.median(factors):.3f}, "
        f"90th percentile {np.percentile(factors, 90):.3f}, max {max(factors):.3f}"
    )


def share(flags) -> float:
    flags = list(flags)
    return sum(flags) / len(flags) if flags else float("nan")


def flipped(said: str, understood: str) -> bool:
    """A yes heard as a no or a no as a yes (asked to play)."""
    return (
        said in YES_OR_NO and understood in YES_OR_NO and (said == ACCEPT) != (understood == ACCEPT)
    )


_ACTS: dict[str, str] = {}


def acts_of(text: str) -> str:
    if not _ACTS:
        for phrase, act in load_domain().user_phrases():
            _ACTS.setdefault(normalise(phrase), act)
    return _ACTS.get(text, UNKNOWN)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--every", type=int, default=1, help="use every n-th recording only")
    parser.add_argument("--quantile", type=float, default=0.05, help="of the domain's fits")
    parser.add_argument("--cache", type=Path, help="keep what was heard in this pickle")
    args = parser.parse_args()

    domain = load_domain()
    classifier = UserActClassifier(domain)
    started = time.perf_counter()
    recognizer = PocketsphinxRecognizer(user_phrases(domain))
    print(f"recogniser built in {time.perf_counter() - started:.2f} s")
    if args.cache is not None and args.cache.exists():
        rows = pickle.loads(args.cache.read_bytes())
    else:
        rows = listen_to_everything(recognizer, args.every)
        if args.cache is not None:
            args.cache.write_bytes(pickle.dumps(rows))
    tuning = [r for r in rows if r["voice"] in TUNING_VOICES]
    check = [r for r in rows if r["voice"] not in TUNING_VOICES]

    fits = sorted(r["listening"].fit for r in tuning if r["kind"] == "domain" and r["listening"])
    outside_fit = round(fits[int(args.quantile * len(fits))], 2)
    calibration = fit_calibration(tuning, recognizer, outside_fit)
    print(f"OUTSIDE_FIT = {outside_fit}  (shipped: {OUTSIDE_FIT})")
    print(f"CALIBRATION = {calibration}  (shipped: {CALIBRATION})")
    for name, constants in (
        ("fitted", (outside_fit, calibration)),
        ("shipped", (OUTSIDE_FIT, CALIBRATION)),
    ):
        report(f"tuning voices, {name} constants", tuning, recognizer, classifier, *constants)
        report(f"check voices, {name} constants", check, recognizer, classifier, *constants)


if __name__ == "__main__":
    main()
