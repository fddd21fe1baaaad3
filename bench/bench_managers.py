"""Is the DQN worth learning? It, a script and tabular Q-learning, side by side, same people.

    .venv/bin/python bench/bench_managers.py                         # 1,000 games a condition
    .venv/bin/python bench/bench_managers.py --games 300 --experiences 100000 --policy my.pt

- DQN: the shipped interaction manager (or `--policy`), as `oxbot train agent` made it with
  `oxbot/data/models/agent.toml`.
- script: no learning; the action model's most probable offered act, and the exact solver's
  cell for a move (`oxbot.dialogue.baselines.scripted_policy`).
- tabular Q: Q-learning with a table over the states read as 0/1, given the DQN's budget in
  experiences (its metadata's, a fine-tune's and the runs it started from, unless
  `--experiences`), the same training conditions and the same checkpoint selection
  (`oxbot.dialogue.checkpoint_evaluation.evaluate_checkpoint`); its CPU time is printed beside
  the DQN's.

Each is measured on the same simulated people, seeded alike: the default people (who decline
once or for good, stop, chatter, say nothing) heard through the default recogniser noise (0.2)
and a noisier one (0.4), and cooperative people (who always play a whole game) for game play.
Printed per manager: task success, turns per dialogue, well-formed share and how many of the
ill-formed dialogues are its own mistakes rather than mishearing (`wellformed.blame`), W/D/L and
the most common problems, over all six opponent and who-starts conditions. Not a test.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

from oxbot.config import load_config
from oxbot.dialogue.agent import load_policy, shipped_policy_path, training_budget
from oxbot.dialogue.baselines import scripted_policy, train_tabular_q
from oxbot.dialogue.evaluation import CONDITIONS, Policy, evaluate
from oxbot.dialogue.model import build_dialogue_model

PEOPLE = {
    "default people, noise 0.2": (["dialogue.asr_noise=0.2"], False),
    "default people, noise 0.4": (["dialogue.asr_noise=0.4"], False),
    "cooperative people, noise 0.2": (["dialogue.asr_noise=0.2"], True),
}


def measure(name: str, policy: Policy, games: int) -> None:
    for people, (overrides, cooperative) in PEOPLE.items():
        config = load_config(None, overrides)
        rows = [
            evaluate(policy, opponent, starts, games, config, seed=7, cooperative=cooperative)
            for opponent, starts in CONDITIONS
        ]
        n = len(rows)
        win, draw, loss = (
            sum(getattr(r, k) for r in rows) / n for k in ("win_rate", "draw_rate", "loss_rate")
        )
        problems = Counter()
        for r in rows:
            problems.update(r.problems)
        print(
            f"{name:10s} {people:30s} success {sum(r.task_success for r in rows) / n:6.1%}  "
            f"turns {sum(r.average_turns for r in rows) / n:5.1f}  "
            f"well-formed {sum(r.well_formed for r in rows) / n:6.1%} "
            f"(own mistakes {sum(r.policy_faults for r in rows):4d} of "
            f"{sum(r.ill_formed for r in rows):4d} ill formed)  "
            f"W/D/L {win:.3f}/{draw:.3f}/{loss:.3f}  "
            f"lost games {max(r.loss_rate for r in rows):.2%} at most",
            flush=True,
        )
        for problem, count in problems.most_common(3):
            print(f"{'':42s}{count:5d} x {problem}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--games", type=int, default=1000, help="per condition")
    parser.add_argument("--policy", default=None, help="a DQN policy file (default: shipped)")
    parser.add_argument("--experiences", type=int, default=None, help="tabular Q's budget")
    args = parser.parse_args()

    train_config = load_config(shipped_policy_path().with_suffix(".toml"))
    model = build_dialogue_model(load_config())
    dqn = load_policy(args.policy, model.layout.names)
    steps, seconds = training_budget(dqn.metadata)  # a fine-tune's with the runs before it
    experiences = args.experiences or steps or 300_000
    cpu = round(seconds, 1)
    print(f"DQN: {experiences:,} experiences, {cpu} s wall-clock (one torch thread)")
    started = time.process_time()
    tabular = train_tabular_q(train_config, experiences)
    print(
        f"tabular Q: {experiences:,} experiences, {tabular.cpu_seconds:.0f} s CPU "
        f"({time.process_time() - started:.0f} s with its evaluations), "
        f"{len(tabular.table):,} states in its table"
    )
    measure("DQN", dqn.act_batch, args.games)
    measure("script", scripted_policy(model), args.games)
    measure("tabular Q", tabular.act_batch, args.games)


if __name__ == "__main__":
    main()
