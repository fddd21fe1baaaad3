"""The agent's peers: Stable-Baselines3's DQN and sb3-contrib's MaskablePPO trained for oxbot's
agent's wall-clock time, and again for its number of experiences, and evaluated as it was; the
interaction peers table with its notes, which name what each side brings."""

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
BUDGET_NAMES = {"time": "oxbot's time", "experiences": "oxbot's experiences"}
"""The peers' two budgets: the agent's wall-clock time (`agent_peers` in the figures) and its
number of experiences (`agent_peers_by_experiences`)."""


def train_agent_peers(
    config: OxbotConfig,
    eval_config: OxbotConfig,
    agent: dict[str, Any],
    budgets: Budgets,
    announce: Callable[[str], None],
    show_progress: bool,
    by: str = "time",
) -> dict[str, Any]:
    """Train the SB3 peers for the agent's wall-clock time (`by` "time") or its number of
    experiences (`by` "experiences") with as many evaluations, then evaluate their last
    policies as the agent was; `agent` is `train_and_evaluate_agent`'s."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    # The same budget and as many evaluations as oxbot's agent had, on as many games each.
    n_evals = max(1, len(agent["evaluations"]))
    if by == "time":
        budget: float = float(agent["train_s"])
        limits: dict[str, Any] = {"budget_s": budget, "eval_every_s": budget / n_evals}
        unit = "s of training"
    else:
        budget = int(agent["experiences"])
        limits = {"budget_steps": budget, "eval_every_steps": max(1, round(budget / n_evals))}
        unit = "experiences"
    peers = {}
    for algorithm in PEER_AGENTS:
        announce(f"    {algorithm}: {budget:,.0f} {unit}, evaluated {n_evals} times")
        with Progress(
            TextColumn(f"[bold]{LEARNER_NAMES[algorithm]}, {BUDGET_NAMES[by]}[/]"),
            BarColumn(),
            TextColumn(f"{{task.completed:,.0f}}/{{task.total:,.0f}} {unit}"),
            TimeElapsedColumn(),
            disable=not show_progress,
        ) as progress:
            task = progress.add_task(algorithm, total=budget)
            run = train_peer_agent(
                algorithm,
                config,
                eval_games=config.agent.eval_games,
                seed=config.agent.seed,
                on_progress=lambda s, t=task: progress.update(t, completed=s),
                **limits,
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
    """The interaction peers table: oxbot's DQN beside SB3's DQN and MaskablePPO, each trained
    for oxbot's time and for its experiences, the time to their first evaluation without a loss
    and their final games."""
    agent = f["agent"]
    budget, ours = agent["train_s"], agent["time_to_zero_losses_s"]
    header = "| learner | training (time, experiences) | first evaluation without a loss | "
    header += "ratio to oxbot | " + " | ".join(
        f"{OPPONENT_NAMES[n]}, {'robot' if s else 'person'} starts: W / D / L"
        for n, s in CONDITIONS
    )
    header += " | well formed |"
    lines = ["### Learning to interact", "", header, "|" + "---|" * (5 + len(CONDITIONS))]
    rows = [("oxbot DQN (`agent.toml`)", agent, ours, budget)]
    for by, runs in _peer_runs(f).items():
        for k, p in runs.items():
            limit = p["budget_s"] if p.get("budget_s") is not None else p["train_s"]
            name = f"{LEARNER_NAMES[k]}, {BUDGET_NAMES[by]}"
            rows.append((name, p, p["time_to_zero_losses_s"], limit))
    for name, run, t, limit in rows:
        steps = run.get("experiences", run.get("steps"))
        cells = [
            name,
            f"{_seconds(run['train_s'])}, {steps:,}",
            _seconds(t) if t is not None else f"none within {limit:.0f} s",
            "1.0x" if run is agent else _ratio(t, ours, limit),
        ]
        cells += [_wdl(run["final"][condition_key(n, s)]) for n, s in CONDITIONS]
        cells.append(_pct(min(r["well_formed"] for r in run["final"].values())))
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    return lines


def _peer_runs(f: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The peers' runs by budget ("time", "experiences"); a report of before the runs for
    oxbot's experiences has only the first."""
    return {"time": f["agent_peers"], "experiences": f.get("agent_peers_by_experiences", {})}


def _agent_peers_notes(f: dict[str, Any]) -> list[str]:
    """Under the interaction peers table: the losses plot, how the peers were trained and
    judged, what each side brings, and each peer's settings."""
    agent = f["agent"]
    lines = [
        "![losses against training time](losses_vs_time.png)",
        "",
        "Each peer trains on `oxbot/NoughtsAndCrosses-v0` twice: for oxbot's wall-clock time "
        f"({agent['train_s']:.0f} s, its evaluations not counted; oxbot's own time counts its "
        f"evaluations; the plot shows these runs), and for oxbot's {agent['experiences']:,} "
        "experiences (evaluated at the same experiences as oxbot), in oxbot's training "
        "conditions (the same opponent mix, both who-starts "
        "conditions, the same simulated person), with oxbot's network size and discount. "
        "Time without a loss: the first greedy evaluation "
        f"({len(agent['evaluations'])} along each run, every learner the same number, "
        f"{f['configs']['train']['agent']['eval_games']:,} games in each of the six "
        "conditions against the training person) with no game lost. Final columns: the last "
        f"policy of each peer and oxbot's kept one, {f['budgets']['evaluation_games']:,} games "
        "per condition against people who always play a whole game. DQN cannot mask its "
        "exploration, but it is "
        "judged like oxbot's agent, greedy over the offered acts; MaskablePPO gets the mask "
        "through sb3-contrib's `ActionMasker` and acts by its most likely act.",
        "",
        "What each side brings. oxbot's DQN (this run's config, docs/deviations.md): "
        + "; ".join(_oxbot_dqn_brings(f["configs"]["train"]["agent"]))
        + ". SB3 DQN: oxbot's network, discount, replay size, batch, learning rate, "
        "exploration schedule and target sync (`oxbot.peers.build_peer`), and SB3's own "
        "otherwise: the Huber loss, gradients clipped at norm 10, targets over every act (no "
        "mask while it learns), one environment, no symmetries, its last policy kept. "
        "MaskablePPO: oxbot's network and discount, the mask in learning and in acting, and "
        "sb3-contrib's defaults otherwise (its settings below: rollouts of n_steps, "
        "minibatches, epochs, GAE, a clipped ratio), one environment, its last policy kept; it "
        "learns from whole rollouts, so on oxbot's experiences the last rollout, cut short at "
        "the budget, is collected but not learnt from. Peer settings:",
        "",
    ]
    for k, p in f["agent_peers"].items():
        settings = ", ".join(f"{a}={b}" for a, b in p["settings"].items())
        lines.append(f"- {LEARNER_NAMES[k]}: {settings}; SB3 defaults otherwise.")
    lines.append("")
    return lines


def _oxbot_dqn_brings(a: dict[str, Any]) -> list[str]:
    """What oxbot's DQN adds to the paper's and the peers' learners, from its `[agent]` config."""
    brought = []
    if a["double_dqn"]:
        brought.append("Double DQN targets")
    if a["symmetries"]:
        brought.append("a random board symmetry on every sampled experience")
    if a["misheard_words"]:
        brought.append(
            f"one extra misheard word on {a['misheard_words']:.0%} of the sampled states"
        )
    if a["board_head"]:
        brought.append("the board head (each cell's value from the board alone, a dueling split)")
    brought.append("targets and exploration over the offered acts only (the action mask)")
    if a["n_envs"] > 1:
        brought.append(f"{a['n_envs']} dialogues stepped at once (vectorised environments)")
    if a["anneal_learning_rate"]:
        brought.append("the learning rate falling linearly to 0")
    if a["eval_every"]:
        brought.append(
            "the best of its greedy evaluations kept (games, the game-tree check and the "
            "people's will heard cleanly)"
        )
    return brought
