"""The agent's peers: Stable-Baselines3's DQN and sb3-contrib's MaskablePPO trained for oxbot's
agent's wall-clock time and evaluated as it was, and the interaction peers table with its notes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from oxbot.config import OxbotConfig
from oxbot.dialogue.evaluation import CONDITIONS, condition_key
from oxbot.peers import (
    PEER_AGENTS,
    evaluate_conditions,
    peer_batch_policy,
    peer_settings,
    train_peer_agent,
    zero_losses,
)
from oxbot.reproduce.agent import OPPONENT_NAMES
from oxbot.reproduce.budgets import Budgets
from oxbot.reproduce.cells import _pct, _ratio, _seconds, _wdl

LEARNER_NAMES = {"dqn": "SB3 DQN", "maskable_ppo": "sb3-contrib MaskablePPO"}


def train_agent_peers(
    config: OxbotConfig,
    eval_config: OxbotConfig,
    agent: dict[str, Any],
    budgets: Budgets,
    announce: Callable[[str], None],
    show_progress: bool,
) -> dict[str, Any]:
    """Train the SB3 peers for the agent's wall-clock time with as many evaluations, then
    evaluate their last policies as the agent was; `agent` is `train_and_evaluate_agent`'s."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    # The same budget and as many evaluations as oxbot's agent had, on as many games each.
    budget = float(agent["train_s"])
    n_evals = max(1, len(agent["evaluations"]))
    peers = {}
    for algorithm in PEER_AGENTS:
        announce(f"    {algorithm}: {budget:.0f} s of training, evaluated {n_evals} times")
        with Progress(
            TextColumn(f"[bold]{LEARNER_NAMES[algorithm]}[/]"),
            BarColumn(),
            TextColumn("{task.completed:.0f}/{task.total:.0f} s of training"),
            TimeElapsedColumn(),
            disable=not show_progress,
        ) as progress:
            task = progress.add_task(algorithm, total=budget)
            run = train_peer_agent(
                algorithm,
                config,
                budget_s=budget,
                eval_every_s=budget / n_evals,
                eval_games=config.agent.eval_games,
                seed=config.agent.seed,
                on_progress=lambda s, t=task: progress.update(t, completed=s),
            )
        final = evaluate_conditions(
            peer_batch_policy(algorithm, run.model),
            budgets.evaluation_games,
            eval_config,
            seed=0,
            cooperative=True,
        )
        peers[algorithm] = {
            **run.to_dict(),
            "evaluations": [
                {
                    "train_s": e["train_s"],
                    "steps": e["steps"],
                    "losses": {k: r["loss_rate"] for k, r in e["results"].items()},
                }
                for e in run.evaluations
            ],
            "zero_losses_at_end": zero_losses(final),
            "settings": peer_settings(algorithm, run.model),
            "final": final,
        }
    return peers


def _agent_peers_section(f: dict[str, Any]) -> list[str]:
    """The interaction peers table: oxbot's DQN beside SB3's DQN and MaskablePPO, the time to
    their first evaluation without a loss and their final games."""
    agent = f["agent"]
    budget, ours = agent["train_s"], agent["time_to_zero_losses_s"]
    header = "| learner | training (time, experiences) | first evaluation without a loss | "
    header += "ratio to oxbot | " + " | ".join(
        f"{OPPONENT_NAMES[n]}, {'robot' if s else 'person'} starts: W / D / L"
        for n, s in CONDITIONS
    )
    header += " | well formed |"
    lines = ["### Learning to interact", "", header, "|" + "---|" * (5 + len(CONDITIONS))]
    rows = [("oxbot DQN (`agent.toml`)", agent, ours)]
    rows += [(LEARNER_NAMES[k], p, p["time_to_zero_losses_s"]) for k, p in f["agent_peers"].items()]
    for name, run, t in rows:
        steps = run.get("experiences", run.get("steps"))
        cells = [
            name,
            f"{_seconds(run['train_s'])}, {steps:,}",
            _seconds(t) if t is not None else f"none within {budget:.0f} s",
            "1.0x" if run is agent else _ratio(t, ours, budget),
        ]
        cells += [_wdl(run["final"][condition_key(n, s)]) for n, s in CONDITIONS]
        cells.append(_pct(min(r["well_formed"] for r in run["final"].values())))
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    return lines


def _agent_peers_notes(f: dict[str, Any]) -> list[str]:
    """Under the interaction peers table: the losses plot, how the peers were trained and
    judged, and each peer's settings."""
    agent = f["agent"]
    lines = [
        "![losses against training time](losses_vs_time.png)",
        "",
        f"Each peer trains on `oxbot/NoughtsAndCrosses-v0` for oxbot's wall-clock time "
        f"({agent['train_s']:.0f} s, its evaluations not counted; oxbot's own time counts its "
        "evaluations), in oxbot's training conditions (the same opponent mix, both who-starts "
        "conditions, the same simulated person), with oxbot's network size and discount. "
        "Time without a loss: the first greedy evaluation "
        f"({len(agent['evaluations'])} along each run, every learner the same number, "
        f"{f['configs']['train']['agent']['eval_games']:,} games in each of the six "
        "conditions against the training person) with no game lost. Final columns: the last "
        f"policy of each peer and oxbot's kept one, {f['budgets']['evaluation_games']:,} games "
        "per condition against people who always play a whole game. DQN cannot mask its "
        "exploration, but it is "
        "judged like oxbot's agent, greedy over the offered acts; MaskablePPO gets the mask "
        "through sb3-contrib's `ActionMasker` and acts by its most likely act. Peer settings:",
        "",
    ]
    for k, p in f["agent_peers"].items():
        settings = ", ".join(f"{a}={b}" for a, b in p["settings"].items())
        lines.append(f"- {LEARNER_NAMES[k]}: {settings}; SB3 defaults otherwise.")
    lines.append("")
    return lines
