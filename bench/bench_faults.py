"""Benchmark of the robot's supervision: from a fault mid-game to recovery or a spoken ending.

    .venv/bin/python bench/bench_faults.py                    # shipped restart settings, 3 runs
    .venv/bin/python bench/bench_faults.py --runs 5 --set robot.hang_seconds=0.5
    .venv/bin/python bench/bench_faults.py --kinds manager,arm --modes hangs

For each component and fault (`oxbot.testing.faults`: raises once, raises always, hangs once;
`--modes` may add "hangs always") a typing person plays a whole game against the real robot
while the fault strikes, and this prints the median over runs of the seconds from the first
failing call to the robot's next sentence and to its goodbye, the slowest goodbye, and how the
game ended: "played" (to a win, draw or loss) or "said" (the robot said the part stopped
working). The robot runs 20 times faster than real time (its waits, speech and arm); the
restart settings (`robot.restart_*`, `robot.hang_*`) are the shipped ones unless `--set`
changes them. The goal: every game goes on or ends in words within 10 s of the fault.
Not a test.
"""

from __future__ import annotations

import argparse
import logging
import statistics
import time

from oxbot.config import load_config
from oxbot.robot.manager import STOPPED_SENTENCE
from oxbot.robot.session import Robot
from oxbot.speech.synthesis import Voice, synthesize
from oxbot.testing.faults import MODES, TARGETS, Fault, injected, play


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--kinds", default=",".join(TARGETS))
    parser.add_argument("--modes", default=",".join(MODES))
    parser.add_argument("--set", action="append", default=[], help="a config override")
    args = parser.parse_args()
    logging.basicConfig(level=logging.CRITICAL)  # the failures are the point; keep quiet
    fast = ["robot.speed_factor=20", "robot.answer_timeout=2", "robot.question_timeout=10"]
    config = load_config(None, [*fast, *args.set])
    body = config.robot
    print(
        f"restart_limit {body.restart_limit} in {body.restart_window:g} s, backoff "
        f"{body.restart_backoff:g} s doubling to {body.restart_backoff_max:g} s, hang after "
        f"{body.hang_seconds:g} s; speed x{body.speed_factor:g}; median of {args.runs} runs"
    )
    print(f"{'component':14} {'fault':14} {'next turn':>9} {'goodbye':>8} {'slowest':>8}  ended")
    yes = synthesize("Yes, let's play.", Voice("en-us+m3"))
    worst = 0.0
    for kind in args.kinds.split(","):
        target = TARGETS[kind]
        for mode in args.modes.split(","):
            nexts, ends, endings = [], [], set()
            for run_index in range(args.runs):
                fault = Fault(mode)  # type: ignore[arg-type]
                with injected(target, fault):
                    robot = Robot(config, seed=run_index).start()
                    try:
                        run = play(
                            robot,
                            fault,
                            voice=yes if kind == "recognition" else None,
                            bursts=body.restart_limit + 1 if mode == "raises always" else 1,
                            seconds=60,
                        )
                    finally:
                        robot.stop(timeout=0.5)
                if run.ended is None:
                    endings.add("fault never struck")
                    continue
                nexts.append(run.next_turn if run.next_turn is not None else run.ended)
                ends.append(run.ended)
                said = run.last_words == STOPPED_SENTENCE.format(part=target.cls.part)
                endings.add("said" if said else "played" if run.outcome else "ended")
            worst = max([worst, *ends])
            print(
                f"{kind:14} {mode:14} {_median(nexts):>9} {_median(ends):>8} "
                f"{max(ends, default=float('nan')):>7.2f}s  {'/'.join(sorted(endings))}",
                flush=True,
            )
    print(f"slowest fault to goodbye: {worst:.2f} s (goal: under 10 s)")


def _median(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}s" if values else "-"


if __name__ == "__main__":
    started = time.monotonic()
    main()
    print(f"({time.monotonic() - started:.0f} s)")
