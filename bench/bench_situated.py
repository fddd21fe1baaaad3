"""The robot's words about its moves over simulated games: true claims, no sentence twice in a
row, and how varied its words are before and after.

    PYTHONPATH=. .venv/bin/python bench/bench_situated.py                 # 1,000 games a start
    PYTHONPATH=. .venv/bin/python bench/bench_situated.py --games 200 --people default

The shipped policy plays `--games` dialogues from each start against a random opponent
(`--people cooperative`: people who agree and play a whole game; `default`: the default
simulated people, who may decline, stop or say nothing). Each robot move is then worded as the
running robot words it (`oxbot.dialogue.situated.situated_sentence`, never its last sentence
again) and each claim checked against the board by `oxbot.testing.board_claims`, a checker
written apart from it. Printed: the claims made by kind and how many were false, the robot's
sentences said twice in a row, distinct-2 (distinct word pairs over all word pairs of the
robot's sentences) with the templates alone and with the situated words, and the games'
outcomes and well-formed share. The words are not in the policy's state, so the outcomes are
the same with or without them. Not a test.
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np
import torch

from oxbot.config import OxbotConfig
from oxbot.dialogue.agent import load_policy
from oxbot.dialogue.domain import words_of
from oxbot.dialogue.evaluation import evaluate
from oxbot.testing.board_claims import robot_sentences_said


def distinct_2(sentences: list[str]) -> float:
    pairs = [pair for s in sentences for pair in zip(words_of(s), words_of(s)[1:], strict=False)]
    return len(set(pairs)) / max(1, len(pairs))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--games", type=int, default=1_000, help="per who-starts condition")
    parser.add_argument("--people", choices=("cooperative", "default"), default="cooperative")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    torch.set_num_threads(1)
    policy, rng = load_policy(), np.random.default_rng(args.seed)
    made, false, repeats = Counter(), Counter(), 0
    templates: list[str] = []
    situated: list[str] = []
    for robot_starts in (True, False):
        r = evaluate(
            policy.act_batch,
            "random",
            robot_starts,
            args.games,
            OxbotConfig(),
            seed=args.seed,
            keep_transcripts=args.games,
            cooperative=args.people == "cooperative",
        )
        print(
            f"{'robot' if robot_starts else 'person'} starts: win {r.win_rate:.2%}, draw "
            f"{r.draw_rate:.2%}, loss {r.loss_rate:.2%}, well formed {r.well_formed:.2%}"
        )
        for transcript in r.transcripts:
            last = ""
            for said in robot_sentences_said(transcript, rng):
                for claim in said.made:
                    made[claim] += 1
                    false[claim] += claim not in said.held
                repeats += said.sentence == last
                templates.append(said.template)
                situated.append(said.sentence)
                last = said.sentence
    moves = sum(1 for s in situated if s)
    print(f"robot sentences: {moves:,}; claims made: {dict(made)}; false: {sum(false.values())}")
    print(f"said twice in a row: {repeats}")
    print(f"distinct-2: templates {distinct_2(templates):.4f}, situated {distinct_2(situated):.4f}")


if __name__ == "__main__":
    main()
