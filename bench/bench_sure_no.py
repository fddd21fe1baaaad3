"""How `SURE_NO` was chosen: the scores the simulated recogniser gives to real noes and to
answers misheard as a no, in answer to "Would you like to play?".

    .venv/bin/python bench/bench_sure_no.py                  # 2,000 answers a kind and noise
    .venv/bin/python bench/bench_sure_no.py --answers 5000 --threshold 0.5

For each recogniser noise level, each kind of answer (accept, "no thanks", "maybe later") is said
`--answers` times in its phrasings through `UserSimulator.hear` and read by the real
`UserActClassifier`; printed: how many were understood as a clear no (`Reject(playGame=no)`)
and how many of those keep a score of at least the threshold. A clear no at or above it is final
(`oxbot.dialogue.wellformed`), so an accept misheard that way must be rare. Not a test.
"""

from __future__ import annotations

import argparse

import numpy as np

from oxbot.dialogue.domain import ACCEPT, DECLINE, INVITATION, POSTPONE
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.dialogue.simulator import UserSimulator
from oxbot.dialogue.wellformed import SURE_NO


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--answers", type=int, default=2000, help="answers of each kind")
    parser.add_argument("--threshold", type=float, default=SURE_NO)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    model = shipped_dialogue_model()
    print(f"threshold {args.threshold}; {args.answers} answers of each kind to the invitation")
    print(f"{'noise':>5}  {'meant':<24} {'heard as a no':>13} {'of them sure':>13}")
    for noise in (0.2, 0.3, 0.4):
        person = UserSimulator(
            model.domain,
            rng=np.random.default_rng(args.seed),
            asr_noise=noise,
            understanding=model.understanding,
        )
        for meant in (ACCEPT, DECLINE, POSTPONE):
            phrasings = person.phrasings(meant)
            scores = []
            for i in range(args.answers):
                _, (act, score) = person.hear(phrasings[i % len(phrasings)], INVITATION)
                if act == DECLINE:
                    scores.append(score)
            sure = sum(s >= args.threshold for s in scores)
            print(f"{noise:>5}  {meant:<24} {len(scores):>13} {sure:>13}")


if __name__ == "__main__":
    main()
