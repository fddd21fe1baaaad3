"""Benchmark of learning from recorded games: a new hand, new people, before and after.

    .venv/bin/python bench/bench_learn.py                       # 3 games, 60 later sheets
    .venv/bin/python bench/bench_learn.py --games 3 --sheets 100 --seed 1
    .venv/bin/python bench/bench_learn.py --part agent --steps 100000   # the dialogue side

The new hand (`oxbot.testing.hands.plus_strokes`) draws crosses as a plus sign. First its
"later drawings" are measured with the shipped classifier: `--sheets` sheets of the page
(`oxbot.testing.sheet.Sheet`), 5 symbols each, read by the real board reader, every cell
counted (blanks too) and the symbols alone. Then `--games` whole games are played with a
headless robot that records (`oxbot.testing.recorded_game`; the robot starts in the 1st and 3rd,
the person in the 2nd), `oxbot learn perceiver` runs on their crops with its defaults, and the
later drawings are measured again with the new model; the project's test sets (1,000 generated
images, the font set) before and after come from the learning's own metrics.

Acceptance: the shipped classifier reads the hand below 97%; after 3 games, >= 99.5%
on the later drawings, the other test sets no worse.

`--part agent`: a population of simulated people who decline twice as often (at first and for
good) and are heard with twice the recognition noise of the default ones
(`oxbot.testing.simulated_people.population`) talks with the shipped policy for `--dialogues`
recorded dialogues; `oxbot learn agent` fits the person to them and fine-tunes the policy for
`--steps` experiences; both policies are measured in the same run against the fitted people
(as `learn agent` reports) and against the true population (`--eval-games` dialogues per
who-starts condition). Acceptance: fewer repeated questions and no ill-formed dialogue.

Not a test: it plays real games (about 15 s each) and trains for real.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from oxbot.errors import LearningRefused
from oxbot.perception.board import BoardReader
from oxbot.perception.classifier import SymbolClassifier, load_classifier
from oxbot.recording import RecordingStore
from oxbot.recording.perceiver import LearnPerceiverConfig, learn_perceiver
from oxbot.recording.store import DB_NAME
from oxbot.testing.hands import plus_strokes
from oxbot.testing.recorded_game import play_recorded_game
from oxbot.testing.sheet import Sheet

SHEET_SEEDS = 100_000
"""The later sheets' seeds start here: never a recorded game's."""


def later_drawings(sheets: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The new hand's later sheets as the board reader cuts them: crops and true labels."""
    rng = np.random.default_rng([seed, SHEET_SEEDS])
    reader = BoardReader()
    crops, labels = [], []
    for i in range(sheets):
        sheet = Sheet(SHEET_SEEDS + seed * 1_000 + i)
        truth = ["nothing"] * 9
        for cell in rng.choice(9, 5, replace=False):
            truth[cell] = ("circle", "cross")[int(rng.integers(2))]
            sheet.draw_strokes(int(cell), plus_strokes(truth[cell], rng))
        crops.append(reader.read(sheet.image).cells)
        labels += truth
    return np.concatenate(crops), np.array(labels)


def accuracy(clf: SymbolClassifier, crops: np.ndarray, labels: np.ndarray) -> tuple[float, float]:
    """Accuracy over every cell, and over the symbols alone."""
    predicted = np.array(clf.predict(crops))
    right = predicted == labels
    return float(right.mean()), float(right[labels != "nothing"].mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--games", type=int, default=3, help="recorded games to learn from")
    parser.add_argument("--sheets", type=int, default=60, help="later sheets to measure on")
    parser.add_argument("--seed", type=int, default=0, help="seed of the games and sheets")
    parser.add_argument("--part", choices=("perceiver", "agent", "both"), default="perceiver")
    parser.add_argument("--dialogues", type=int, default=200, help="recorded dialogues (agent)")
    parser.add_argument("--steps", type=int, default=30_000, help="fine-tuning steps (agent)")
    parser.add_argument("--eval-games", type=int, default=1_000, help="per condition (agent)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    if args.part in ("perceiver", "both"):
        bench_perceiver(args)
    if args.part in ("agent", "both"):
        bench_agent(args)


def bench_perceiver(args: argparse.Namespace) -> None:
    """The perceiver part for `args.seed`, with every figure printed."""
    run = perceiver_run(args.games, args.sheets, args.seed, say=print)
    print(
        f"learn perceiver: {run['learnt']} crops learnt from, "
        f"{run['held_back']} held back, in {run['learn_s']:.1f} s"
    )
    for key, name in (
        ("held_back", "held-back recorded crops"),
        ("generated", "generated test set (1,000)"),
        ("fonts", "handwriting-font set"),
    ):
        b, a = run["before"][key], run["after"][key]
        print(f"{name:30s} before {b:.2%}  after {a:.2%}")
    cells, symbols = run["after"]["later"]
    print(f"new hand, later drawings, learnt model: {cells:.2%} of cells, {symbols:.2%} of symbols")
    print(f"refused: {run['refused']}" if run["refused"] else "the learnt model was accepted")


def perceiver_run(
    games: int,
    sheets: int,
    seed: int,
    say: Callable[[str], object] = print,
    config: LearnPerceiverConfig | None = None,
    keep: Path | None = None,
) -> dict[str, Any]:
    """Record `games` games of the new hand, `learn perceiver` on them, and measure: accuracy
    on the later drawings ("later": cells, symbols) and the learning's own sets ("held_back",
    "generated", "fonts"), "before" and "after"; crops recorded and labelled; the refusal.

    With `keep`, the recordings are kept in that folder, and taken from it when it has them
    already (so that learning settings can be compared on the same games: games played again
    differ, since they run in real time)."""
    crops, labels = later_drawings(sheets, seed)
    shipped = load_classifier()
    before = accuracy(shipped, crops, labels)
    say(
        f"new hand, later drawings ({len(labels)} cells, {int((labels != 'nothing').sum())} "
        f"symbols), shipped model: {before[0]:.2%} of cells, {before[1]:.2%} of symbols"
    )
    with tempfile.TemporaryDirectory() as temporary:
        folder = keep if keep is not None else Path(temporary)
        folder.mkdir(parents=True, exist_ok=True)
        played_before = (folder / DB_NAME).exists()
        with RecordingStore(folder) as store:
            if not played_before:
                _record(store, games, seed, say)
            summaries = store.sessions()
            recorded = sum(s.crops for s in summaries), sum(s.labelled for s in summaries)
            say(f"recorded {recorded[0]} crops, {recorded[1]} labelled")
            started = time.perf_counter()
            out = Path(temporary) / "perceiver.pt"
            try:
                result = learn_perceiver(store, out, config, show_progress=False)
                metrics, learnt, refused = result.metrics, result.classifier, ""
            except LearningRefused as exc:
                metrics, learnt, refused = exc.result.metrics, exc.result.classifier, str(exc)
            learn_s = time.perf_counter() - started
    sets = ("held_back", "generated", "fonts")
    return {
        "recorded": recorded,
        "learnt": metrics["crops"]["train"],
        "held_back": metrics["crops"]["held_back"],
        "learn_s": learn_s,
        "before": {"later": before, **{k: metrics["before"][k]["accuracy"] for k in sets}},
        "after": {
            "later": accuracy(learnt, crops, labels),
            **{k: metrics["after"][k]["accuracy"] for k in sets},
        },
        "refused": refused,
    }


def _record(store: RecordingStore, games: int, seed: int, say: Callable[[str], object]) -> None:
    """Play `games` recorded games of the new hand (the robot starts in the 1st and 3rd)."""
    started = time.perf_counter()
    for game in range(games):
        record = play_recorded_game(
            store, seed=seed * 100 + game, hand=plus_strokes, robot_starts=game % 2 == 0
        )
        say(
            f"game {game + 1}: {record.outcome}, the person drew in {len(record.drawn)} "
            f"cells, {len(record.typed)} of them typed because the robot did not see them"
        )
    say(f"played {games} games in {time.perf_counter() - started:.0f} s")


def learn_agent_before_after(
    seed: int, dialogues: int, steps: int, eval_games: int
) -> tuple[dict, dict, dict, float, str]:
    """`learn agent` on `dialogues` recorded dialogues of the twice-declining, twice-noisy
    population: its metrics, the shipped and the learnt policy measured against the true
    population (`eval_games` per who-starts condition), its seconds, and why it was refused
    ("" if kept)."""
    from oxbot.dialogue.agent import load_policy
    from oxbot.recording.agent import LearnAgentConfig, learn_agent, measure
    from oxbot.testing.simulated_people import population, record_simulated_dialogues

    people = population()
    shipped = load_policy()
    config = LearnAgentConfig(seed=seed, steps=steps, eval_games=eval_games)
    with tempfile.TemporaryDirectory() as folder, RecordingStore(folder) as store:
        record_simulated_dialogues(store, shipped, people, dialogues, seed=seed)
        started = time.perf_counter()
        try:
            result = learn_agent(store, folder, config, show_progress=False)
            metrics, policy, refused = result.metrics, result.policy, ""
        except LearningRefused as exc:
            metrics, policy, refused = exc.result.metrics, exc.result.policy, str(exc)
        seconds = time.perf_counter() - started
    before = measure(shipped, people, eval_games, seed + 1)
    after = measure(policy, people, eval_games, seed + 1)
    return metrics, before, after, seconds, refused


def bench_agent(args: argparse.Namespace) -> None:
    from oxbot.testing.simulated_people import population

    d = population().dialogue
    print(
        f"population: decline {d.decline_probability}, refuse {d.refuse_probability}, "
        f"asr_noise {d.asr_noise} (default 0.1, 0.05, 0.2)"
    )
    metrics, true_before, true_after, seconds, refused = learn_agent_before_after(
        args.seed, args.dialogues, args.steps, args.eval_games
    )
    fitted = metrics["person"]["probabilities"]
    print("fitted person: " + ", ".join(f"{k} {v:.3f}" for k, v in fitted.items()))
    print(
        f"learn agent: {args.steps} steps in {len(metrics['pieces'])} pieces, kept after "
        f"{metrics['kept']} steps (0: none beat the shipped policy); {seconds:.0f} s with "
        "every measurement; pieces (losses, ill formed by the policy, all ill formed, repeats "
        f"per dialogue, on other people): "
        f"{[(p['steps'], p['score']) for p in metrics['pieces']]}"
    )
    for name, before, after in (
        ("fitted people", metrics["before"], metrics["after"]),
        ("true population", true_before, true_after),
    ):
        print(f"{name} ({after['dialogues']} dialogues each):")
        for key in (
            "repeated_questions_per_dialogue",
            "dialogues_with_a_repeat",
            "ill_formed",
            "ill_formed_by_the_policy",
            "losses",
            "task_success",
            "average_turns",
        ):
            print(f"  {key:32s} before {before[key]:.4g}  after {after[key]:.4g}")
        print(f"  problems after: {after['problems']}")
    print(f"refused: {refused}" if refused else "the retrained policy was accepted")


if __name__ == "__main__":
    main()
