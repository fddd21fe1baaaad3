"""The interaction managers compared on the same people: this run's DQN and the shipped one, the
hand-written rules, the script and tabular Q-learning given this run's DQN's experiences, each
with its training budget in experiences and CPU seconds, at every word mishearing level
(`oxbot.dialogue.comparison`), and their section of the report."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from oxbot.config import OxbotConfig
from oxbot.dialogue.comparison import MISHEARING, compare_manager
from oxbot.reproduce.budgets import Budgets
from oxbot.reproduce.cells import _pct, _seconds

MANAGER_NAMES = {
    "dqn_run": "oxbot DQN, this run",
    "dqn_shipped": "oxbot DQN, shipped (`agent.pt`)",
    "rules": "rules (`RuleBasedManager`)",
    "script": "script (`ScriptedManager`)",
    "tabular_q": "tabular Q",
}
"""The managers compared, in the report's order."""

SEED = 0
"""The simulated people's seed: the same people for every manager (the evaluations' seed)."""


def compare_run_managers(
    work_dir: Path,
    config: OxbotConfig,
    eval_config: OxbotConfig,
    agent: dict[str, Any],
    shipped: dict[str, Any],
    budgets: Budgets,
    show_progress: bool,
) -> dict[str, Any]:
    """Train tabular Q for this run's DQN's experiences in its conditions (`config`), then
    compare every manager of `MANAGER_NAMES` on `eval_config`'s people at every mishearing
    level; `agent` is `train_and_evaluate_agent`'s figures, `shipped` `measure_shipped`'s
    agent figures."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from oxbot.dialogue.agent import load_policy
    from oxbot.dialogue.baselines import load_manager, train_tabular_q

    dialogues = budgets.comparison_dialogues
    experiences = int(agent["experiences"])
    with Progress(
        TextColumn("[bold]{task.description}[/]"),
        BarColumn(),
        TextColumn("{task.completed:,.0f}/{task.total:,.0f} {task.fields[unit]}"),
        TimeElapsedColumn(),
        disable=not show_progress,
    ) as progress:
        task = progress.add_task("tabular Q", total=experiences, unit="experiences")
        table = train_tabular_q(
            config, experiences, on_progress=lambda n: progress.update(task, completed=n)
        )
        policies = {
            "dqn_run": load_policy(work_dir / "agent" / "agent.pt").act_batch,
            "dqn_shipped": load_policy().act_batch,
            "rules": load_manager("rules", eval_config).act_batch,
            "script": load_manager("script", eval_config).act_batch,
            "tabular_q": table.act_batch,
        }
        trained = {
            "dqn_run": (experiences, agent["cpu_s"]),
            "dqn_shipped": (shipped["experiences"], shipped["cpu_s"]),
            "rules": (0, 0.0),
            "script": (0, 0.0),
            "tabular_q": (table.experiences, round(table.cpu_seconds, 1)),
        }
        cells = progress.add_task(
            "managers compared", total=len(policies) * len(MISHEARING), unit="managers x levels"
        )
        managers = {}
        for key, policy in policies.items():
            progress.update(cells, description=f"compared: {MANAGER_NAMES[key]}")
            rows = compare_manager(
                policy,
                eval_config,
                dialogues,
                MISHEARING,
                SEED,
                on_level=lambda _, c=cells: progress.advance(c),
            )
            managers[key] = {
                "experiences": trained[key][0],
                "cpu_s": trained[key][1],
                "rows": rows,
            }
    return {
        "dialogues": dialogues,
        "levels": list(MISHEARING),
        "seed": SEED,
        "tabular_q_states": len(table.table),
        "tabular_q_kept_at": table.experiences,
        "managers": managers,
    }


def _managers_section(f: dict[str, Any]) -> list[str]:
    """The managers compared: each one's training budget, then their figures at each level."""
    m = f["managers"]
    n = m["dialogues"]
    lines = [
        "## The interaction managers compared on the same people",
        "",
        "| manager | trained for (experiences) | training CPU time | what it is |",
        "|---|---|---|---|",
    ]
    for key, name in MANAGER_NAMES.items():
        run = m["managers"][key]
        lines.append(
            f"| {name} | {run['experiences']:,} | {_seconds(run['cpu_s'])} | "
            f"{_what_it_is(key, m)} |"
        )
    lines += [
        "",
        "| misheard | manager | task success [95% CI] | turns | asked again | reward ± 95% | "
        "well formed | ill formed by its own fault | CPU time |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for level, share in enumerate(m["levels"]):
        for key, name in MANAGER_NAMES.items():
            r = m["managers"][key]["rows"][level]
            lines.append(
                f"| {share:.0%} | {name} | {_pct(r['success'])} "
                f"[{_pct(r['success_low'])}, {_pct(r['success_high'])}] | {r['turns']:.1f} | "
                f"{r['asked_again']:.3f} | {r['reward']:.2f} ± {r['reward_half']:.2f} | "
                f"{_pct(r['well_formed'])} | {r['policy_faults']:,} of {r['n']:,} | "
                f"{_seconds(r['cpu_s'])} |"
            )
    lines += [
        "",
        f"Each manager talks with the same {n:,} simulated people per level (the default "
        "people, who decline once or for good, stop, chatter, say nothing or ask for another "
        f"game; a random opponent; half the dialogues with the robot starting; seed {m['seed']}), "
        "heard with the share of words misheard in the first column (`dialogue.asr_noise` = 2 x "
        "the share). Task success: well formed and as the person wanted, with its 95% Wilson "
        "interval; turns and times the robot asked again per dialogue; reward with its 95% "
        "interval (mean ± 1.96 standard errors); ill formed by its own fault: the ill-formed "
        "dialogues that are the manager's mistakes by what it understood (`wellformed.blame`), "
        "the others went wrong only because the robot misheard; CPU time: the dialogues', not "
        "the training's. Training CPU time counts the trainer's and its checkpoint judge's. "
        "`bench/bench_mishearing.py` prints the same figures for the shipped DQN, the rules and "
        "the script (`oxbot.dialogue.comparison`).",
        "",
    ]
    return lines


def _what_it_is(key: str, m: dict[str, Any]) -> str:
    """How a compared manager was made, for the budget table."""
    return {
        "dqn_run": "trained in this run (`oxbot train agent`), the best of its greedy evaluations",
        "dqn_shipped": "trained with `agent.toml`; its budget from its metrics file",
        "rules": "hand-written finite-state rules, thresholds chosen on development people",
        "script": "no learning: the action model's most probable offered act, the solver's cell",
        "tabular_q": (
            "Q-learning with a table over the states read as 0/1, in this run's DQN's training "
            f"conditions and experiences; {m['tabular_q_states']:,} states, the best of its "
            f"greedy evaluations kept (experience {m['tabular_q_kept_at']:,})"
        ),
    }[key]
