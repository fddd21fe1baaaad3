"""A policy's own faults, read one by one: the ill-formed dialogues `wellformed.blame` puts on the
policy, not on the hearing, with what the robot understood at each of the person's turns.

    PYTHONPATH=. .venv/bin/python bench/bench_own_faults.py                  # shipped policy
    PYTHONPATH=. .venv/bin/python bench/bench_own_faults.py --seeds 4-11 --games 5000
    PYTHONPATH=. .venv/bin/python bench/bench_own_faults.py --policy runs/agent.pt --noise 1

The people are `oxbot.testing.simulated_people.population`: the default simulated people,
declining `--decline` times as often and heard with `--noise` times the recognition noise (2 and
2: the population the learning-from-games line is measured against). For each seed, `--games`
dialogues a who-starts condition against a random opponent. Prints the count, then each fault
(at most 20 a condition): its problem, the person's kind and the outcome, and the dialogue with
each of the person's turns as meant, as said and as understood, with its score. Not a test.
"""

from __future__ import annotations

import argparse

import torch
from bench_learn_seeds import seed_range

from oxbot.dialogue.agent import load_policy
from oxbot.dialogue.evaluation import evaluate
from oxbot.testing.simulated_people import population


def print_fault(fault: dict) -> None:
    print(f"== {fault['problem']} (a person who {fault['person']}; outcome {fault['outcome']})")
    for turn, act, score in zip(
        fault["transcript"], fault["understood"], fault["scores"], strict=True
    ):
        if turn["speaker"] == "sys":
            print(f"   robot:  {turn['act']}")
        else:
            print(f"   person: {turn['act']:32s} {turn['text'][:34]!r:36s} heard {act} {score:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--policy", default=None, help="a policy file (default: the shipped one)")
    parser.add_argument("--seeds", default="1-3", help="e.g. 1-3 or 4,7")
    parser.add_argument("--games", type=int, default=5_000, help="per seed and who starts")
    parser.add_argument("--decline", type=float, default=2.0)
    parser.add_argument("--noise", type=float, default=2.0)
    args = parser.parse_args()
    torch.set_num_threads(1)
    policy = load_policy(args.policy) if args.policy else load_policy()
    people = population(args.decline, args.noise)
    dialogues, faults = 0, []
    for seed in seed_range(args.seeds):
        for robot_starts in (True, False):
            r = evaluate(policy.act_batch, "random", robot_starts, args.games, people, seed=seed)
            dialogues += r.games
            faults += r.own_faults
            print(
                f"seed {seed}, {'robot' if robot_starts else 'person'} starts: "
                f"{r.policy_faults} own faults, {r.ill_formed} ill formed, of {r.games}",
                flush=True,
            )
    print(f"{len(faults)} own faults kept of {dialogues:,} dialogues")
    for fault in faults:
        print_fault(fault)


if __name__ == "__main__":
    main()
