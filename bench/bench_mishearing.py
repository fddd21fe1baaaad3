"""The DQN, the rule-based manager and the script, on the same people misheard more and more.

    .venv/bin/python bench/bench_mishearing.py                       # 10,000 dialogues a cell
    .venv/bin/python bench/bench_mishearing.py --dialogues 2000 --managers dqn,rules

Each manager (`oxbot.dialogue.baselines.load_manager`: the shipped DQN, `RuleBasedManager`,
`ScriptedManager`) talks with the default simulated people (who decline once or for good,
stop, chatter, say nothing, ask for another game) against a random opponent, half the
dialogues with the robot starting, heard through the simulator's recogniser at word mishearing
0, 10, 20 and 30% (`dialogue.asr_noise` n drops a word with probability n/4 and swaps it for a
random one with probability n/4: n = 2 x the share misheard). The same people and the same seeds
for every manager. Printed per manager and mishearing: task success (well formed and as the
person wanted) with its 95% Wilson interval, turns and times the robot asked again per
dialogue, reward with its 95% interval (mean ± 1.96 standard errors), well-formed share, the
ill-formed dialogues that are the manager's own faults by what it understood (`wellformed.blame`;
the rest went wrong only because the robot misheard), and the CPU seconds the dialogues took.
The figures are `oxbot.dialogue.comparison`'s, which `oxbot reproduce` reports too. Not a
test: the simulated mishearing is not calibrated to a real recogniser's confidences.
"""

from __future__ import annotations

import argparse

from oxbot.config import load_config
from oxbot.dialogue.baselines import load_manager
from oxbot.dialogue.comparison import MISHEARING, compare_manager

HEADER = (
    f"{'manager':8s} {'misheard':>8s} {'task success [95% CI]':>27s} {'turns':>6s} "
    f"{'asked again':>11s} {'reward ± 95%':>15s} {'well formed':>11s} {'own faults':>10s} "
    f"{'CPU s':>6s}"
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dialogues", type=int, default=10_000, help="per manager and level")
    parser.add_argument("--managers", default="dqn,rules,script")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    config = load_config(None)
    print(HEADER)
    for name in args.managers.split(","):
        manager = load_manager(name, config)
        for f in compare_manager(manager.act_batch, config, args.dialogues, MISHEARING, args.seed):
            print(
                f"{name:8s} {f['misheard']:8.0%} {f['success']:9.2%} "
                f"[{f['success_low']:6.2%}, {f['success_high']:6.2%}] "
                f"{f['turns']:6.1f} {f['asked_again']:11.3f} "
                f"{f['reward']:8.2f} ± {f['reward_half']:4.2f} {f['well_formed']:11.2%} "
                f"{f['policy_faults']:10d} {f['cpu_s']:6.0f}",
                flush=True,
            )


if __name__ == "__main__":
    main()
