"""Fit the Whisper recogniser's confidence (`oxbot.speech.whisper.CALIBRATION`) and draw its
reliability diagram.

The development recordings: phrasings of every user act of the shipped domain
(`Domain.user_phrases()`, a fixed sample) spoken by the tuning half of the project's espeak-ng
voices (`TUNING_VOICES`), clean and in white noise at 20 and 10 dB SNR, and, when they are
restored, the development part of the Speech Commands people (bench/data/speech_commands_dev,
"yes" and "no"). Each recording is decoded once; the label is whether the best hypothesis is
the phrase word for word (after `clean_text`). A logistic regression of the label on the
decoder's evidence (`WhisperListening.features`) is fitted on the tuning voices and checked on
the other half (`CHECK_VOICES`), which it never saw: the expected calibration error over ten
bins, and a reliability diagram (docs/figures/whisper_reliability.png).

    .venv/bin/python bench/tune_whisper.py [--model base] [--phrases 60] [--seed 0]

Paste the printed CALIBRATION into oxbot/speech/whisper.py. Nothing held out is read.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
import zlib
from pathlib import Path

import numpy as np

from oxbot.atomic import save_figure
from oxbot.config import WhisperConfig
from oxbot.dialogue.domain import load_domain
from oxbot.speech.audio import pcm16
from oxbot.speech.evaluation import (
    CHECK_VOICES,
    CLEAN,
    TUNING_VOICES,
    speak,
    white_noise,
)
from oxbot.speech.whisper import CALIBRATION, WhisperRecognizer, calibrated, clean_text

CONDITIONS = (CLEAN, white_noise(20.0), white_noise(10.0))
FEATURES = ("logprob", "no_speech", "lead")
FITTED = ("logprob", "lead")
"""What the confidence is fitted on. The no-speech probability is left to the gate: on the
development recordings it rose with the chance of being right (short answers were both), and a
confidence that rises with it would trust a cough."""
DEV_PEOPLE = Path(__file__).parent / "data" / "speech_commands_dev"


def phrases(count: int, seed: int) -> list[str]:
    """A fixed sample of the domain's phrasings of its user acts (silence left out)."""
    every = sorted({text for text, _ in load_domain().user_phrases() if text.strip()})
    rng = np.random.default_rng(seed)
    return [every[i] for i in sorted(rng.choice(len(every), min(count, len(every)), False))]


def observe(recognizer: WhisperRecognizer, said: str, samples: np.ndarray) -> dict | None:
    """One decoding: its features and whether the best hypothesis is right word for word."""
    heard = recognizer.listen(samples)
    if not heard.hypotheses:
        return None
    best = heard.hypotheses[0].text
    return {
        "features": list(heard.features),
        "right": best == clean_text(said),
        "said": said,
        "heard": best,
        "seconds": heard.seconds,
    }


def voices_set(recognizer, voices, texts, seed) -> list[dict]:
    rows = []
    for voice in voices:
        for text in texts:
            clean = pcm16(speak(text, voice))
            for condition in CONDITIONS:
                key = zlib.crc32(f"{voice}|{text}|{condition.name}".encode())
                samples = condition.apply(clean, np.random.default_rng([seed, key]))
                row = observe(recognizer, text, samples)
                if row is not None:
                    rows.append({**row, "voice": voice, "condition": condition.name})
    return rows


def people_set(recognizer) -> list[dict]:
    rows = []
    for word in ("yes", "no"):
        for path in sorted((DEV_PEOPLE / word).glob("*.wav")):
            row = observe(recognizer, word, pcm16(path))
            if row is not None:
                rows.append({**row, "voice": path.name, "condition": "person"})
    return rows


def nonspeech_set(recognizer) -> list[dict]:
    """The development part of the real non-speech clips (bench/data/nonspeech/dev), each at
    the level a microphone hears a room at (peak brought to -20 dBFS) and as recorded: what
    the decoder and the gates make of them. Empty when the clips are not restored."""
    from sound_sets import nonspeech_clips

    try:
        clips = nonspeech_clips("dev")
    except SystemExit as missing:
        print(f"(no development non-speech clips: {missing})")
        return []
    rows = []
    for path, category in clips:
        samples = pcm16(path)
        for level in ("as recorded", "-20 dBFS peak"):
            x = samples
            if level != "as recorded" and np.abs(x).max() > 0:
                x = np.clip(x * (3277 / np.abs(x).max()), -32768, 32767).astype(np.int16)
            heard = recognizer.listen(x)
            rows.append(
                {
                    "category": category,
                    "level": level,
                    "speech": heard.speech_seconds,
                    "no_speech": heard.no_speech,
                    "heard": heard.hypotheses[0].text if heard.hypotheses else "",
                    "why": heard.silent_because,
                    "raw": [t for t, _, _ in heard.raw][:1],
                }
            )
    return rows


def fit(rows: list[dict]) -> dict[str, float]:
    from sklearn.linear_model import LogisticRegression

    columns = [FEATURES.index(name) for name in FITTED]
    x = np.array([r["features"] for r in rows])[:, columns]
    y = np.array([r["right"] for r in rows])
    model = LogisticRegression(C=10.0).fit(x, y)
    out = {"intercept": round(float(model.intercept_[0]), 3), "no_speech": 0.0}
    out.update({name: round(float(w), 3) for name, w in zip(FITTED, model.coef_[0], strict=True)})
    return out


def reliability(rows: list[dict], calibration: dict[str, float], bins: int = 10):
    """(mean confidence, share right, count) per bin, and the expected calibration error."""
    import oxbot.speech.whisper as whisper

    saved = whisper.CALIBRATION.get("fit")
    whisper.CALIBRATION["fit"] = calibration
    try:
        conf = np.array([calibrated(*r["features"], model="fit") for r in rows])
    finally:
        if saved is None:
            del whisper.CALIBRATION["fit"]
    right = np.array([r["right"] for r in rows], dtype=float)
    edges = np.linspace(0, 1, bins + 1)
    table, ece = [], 0.0
    for lo, hi in itertools.pairwise(edges):
        inside = (conf >= lo) & ((conf < hi) | (hi == 1.0))
        if inside.any():
            table.append(
                (float(conf[inside].mean()), float(right[inside].mean()), int(inside.sum()))
            )
            ece += inside.mean() * abs(conf[inside].mean() - right[inside].mean())
    return table, float(ece)


def plot(path: Path, curves: dict[str, list], model: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot([0, 1], [0, 1], color="0.6", linestyle="--", label="perfect calibration")
    for name, table in curves.items():
        conf = [c for c, _, _ in table]
        right = [r for _, r, _ in table]
        ax.plot(conf, right, marker="o", label=name)
    ax.set_xlabel("confidence of the best hypothesis")
    ax.set_ylabel("share right word for word")
    ax.set_title(f"Whisper {model}: reliability of its confidence")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    return save_figure(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--phrases", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("docs/figures"))
    parser.add_argument("--model", choices=["base", "tiny.en"], default="base")
    parser.add_argument(
        "--reuse", action="store_true", help="keep the decodings in --out and refit from them"
    )
    args = parser.parse_args()
    recognizer = WhisperRecognizer(config=WhisperConfig(model=args.model))
    texts = phrases(args.phrases, args.seed)
    started = time.perf_counter()
    cache = args.out / f".tune_whisper_{args.model}_{args.phrases}_{args.seed}.json"
    if args.reuse and cache.exists():  # the decodings of an earlier run, to refit in seconds
        tuning, people, checking = json.loads(cache.read_text())
    else:
        tuning = voices_set(recognizer, TUNING_VOICES, texts, args.seed)
        people = people_set(recognizer)
        checking = voices_set(recognizer, CHECK_VOICES, texts, args.seed + 1)
        if args.reuse:
            cache.write_text(json.dumps([tuning, people, checking]))
    print(
        f"{len(texts)} phrases; decoded {len(tuning)} tuning, {len(checking)} checking and "
        f"{len(people)} development people's recordings in {time.perf_counter() - started:.0f} s"
    )
    calibration = fit(tuning + people)
    shipped = CALIBRATION[args.model]
    print(f'CALIBRATION["{args.model}"] = {json.dumps(calibration)}  (shipped: {shipped})')
    curves = {}
    for name, rows in (("tuning voices (fitted)", tuning), ("check voices (held out)", checking)):
        table, ece = reliability(rows, calibration)
        before = reliability(rows, shipped)[1]
        right = np.mean([r["right"] for r in rows])
        print(f"{name}: {len(rows)} heard, {right:.1%} right word for word, ECE {ece:.3f}")
        print(f"  (with the shipped CALIBRATION: ECE {before:.3f})")
        for conf, share, count in table:
            print(f"  confidence {conf:.2f}: {share:.1%} right of {count}")
        curves[name] = table
    noise = nonspeech_set(recognizer)
    if noise:
        answered = [r for r in noise if r["heard"]]
        print(f"development non-speech: {len(answered)} of {len(noise)} heard as words")
        for r in answered:
            print(
                f"  {r['category']} ({r['level']}): {r['heard']!r} no-speech {r['no_speech']:.2f}"
            )
        why = {}
        for r in noise:
            why[r["why"] or "answered"] = why.get(r["why"] or "answered", 0) + 1
        print(f"  why nothing: {why}")
    if people:
        table, ece = reliability(people, calibration)
        print(f"development people: {len(people)} heard, ECE {ece:.3f}")
        curves["people (development)"] = table
    name = f"whisper_{args.model.replace('.', '_')}_reliability.png"
    print(f"wrote {plot(args.out / name, curves, args.model)}")


if __name__ == "__main__":
    main()
