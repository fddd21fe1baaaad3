"""The keyword model on the DEVELOPMENT set of real people: alone, and joined with the recogniser
over a grid of thresholds (how `SURE`, `AGREE` and `DOUBT` of `oxbot.speech.keywords` were
chosen). Also restores the Speech Commands benchmark sets' WAVs from fetched repositories.

    .venv/bin/python bench/bench_keywords.py                       # ~3 min: 2,100 decodes
    .venv/bin/python bench/bench_keywords.py --model runs/keywords/keywords.pt --write-metadata
    .venv/bin/python bench/bench_keywords.py --restore --repo-b B.git --repo-a A.git

Only ever the development set (bench/data/speech_commands_dev/): the held-out set
(bench/data/speech_commands/) is measured by bench_speech.py alone, never tuned on. The recogniser
here hears alone (`keywords=False`), each recording under each condition of
`oxbot.speech.evaluation.CONDITIONS` with bench_speech.py's seeds, so that the joined figures
at the chosen thresholds are the ones bench_speech.py prints with the keyword model in.
Not a test.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from development_answers import (
    decode_development,
    grid_rows,
    joined_counts,
    keyword_alone,
    keyword_probabilities,
    totals,
)

from oxbot.dialogue.domain import load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech import keywords as kw
from oxbot.speech import speech_commands as sc
from oxbot.speech.evaluation import CONDITIONS

DATA = Path(__file__).parent / "data"


def restore(repo_a: Path | None, repo_b: Path) -> None:
    """Copy the development and held-out sets' WAVs out of the fetched repositories."""
    b = (repo_b, sc.TRAINING_COMMIT, sc.TRAINING_FOLDER)
    print("development:", sc.restore(sc.DEV_MANIFEST, {"B": b}, DATA / "speech_commands_dev"))
    if repo_a is not None:
        a = (repo_a, "53317d51bc2c75de6118ede48b0da06a412a1341", "speech_commands_v0.01")
        print(
            "held out:",
            sc.restore(sc.HELD_OUT_MANIFEST, {"A": a, "B": b}, DATA / "speech_commands"),
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=kw.shipped_keyword_path())
    parser.add_argument(
        "--write-metadata",
        action="store_true",
        help="store the development figures in the model file",
    )
    parser.add_argument(
        "--grid", action=argparse.BooleanOptionalAction, default=True, help="search the grid"
    )
    parser.add_argument("--restore", action="store_true", help="restore the WAVs and stop")
    parser.add_argument("--repo-a", type=Path, help="git dir of vinsis/speech-commands-recognition")
    parser.add_argument(
        "--repo-b", type=Path, help="git dir of MahmoudEhab3/Yes-No-Speech-Classifier"
    )
    parser.add_argument("--seed", type=int, default=0, help="bench_speech.py's noise seed")
    args = parser.parse_args()
    if args.restore:
        if args.repo_b is None:
            parser.error("--restore needs --repo-b (and --repo-a for the held-out set)")
        restore(args.repo_a, args.repo_b)
        return

    spotter = kw.KeywordSpotter.load(args.model)
    classifier = UserActClassifier(load_domain())
    heard = decode_development(args.seed)
    probabilities = keyword_probabilities(spotter, heard)

    print("keyword model alone (argmax): right, flips (yes as no or the reverse)")
    alone = {}
    for condition in CONDITIONS:
        own = [
            (h, p)
            for h, p in zip(heard, probabilities, strict=True)
            if h.condition == condition.name
        ]
        right, flips = keyword_alone([h for h, _ in own], [p for _, p in own])
        alone[condition.name] = round(right, 4)
        print(f"  {condition.name:12s} {right:6.1%}  flips {flips}")

    def joined(thresholds: tuple[float, float, float] | None) -> dict[str, list[int]]:
        return joined_counts(classifier, heard, probabilities, thresholds)

    print("\njoined with the recogniser: sure, agree, doubt -> understood, flips, unsure")
    rows = grid_rows(classifier, heard, probabilities) if args.grid else []
    for (right, flips, unsure), t in rows[:12]:
        print(f"  {t}: {right:6.1%}  flips {flips}  unsure {unsure}")
    chosen = (kw.SURE, kw.AGREE, kw.DOUBT)
    figures = {}
    for label, thresholds in (("recogniser alone", None), (f"joined {chosen}", chosen)):
        counts = joined(thresholds)
        print(f"\n{label}: {totals(counts)[0]:.1%}, flips {totals(counts)[1]}")
        for name, (n, right, flips, unsure) in counts.items():
            print(f"  {name:12s} {right / n:6.1%}  flips {flips}  unsure {unsure}")
        figures[label] = {
            name: [round(right / n, 4), flips] for name, (n, right, flips, _) in counts.items()
        }

    if args.write_metadata:
        spotter.metadata["dev"] = {
            "set": "bench/data/speech_commands_dev (300 recordings x 7 conditions)",
            "keyword_alone": alone,
            "thresholds": {"sure": kw.SURE, "agree": kw.AGREE, "doubt": kw.DOUBT},
            "understood_and_flips": figures,
        }
        spotter.save(args.model)
        print(f"\nwrote the development figures into {args.model}")


if __name__ == "__main__":
    main()
