"""The dialogue manager's commands: training the DQN agent (`oxbot train agent`) and measuring
it against simulated people (`oxbot evaluate agent`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from oxbot.cli.context import config_of, resumable
from oxbot.config import OxbotConfig, who_starts, with_overrides


def train_agent_command(
    ctx: typer.Context,
    out: Annotated[
        Path, typer.Option(help="Folder for agent.pt, its metrics, the two plots, the checkpoint.")
    ] = Path("runs/agent"),
    resume: Annotated[
        bool, typer.Option("--resume/--no-resume", help="Continue from OUT/checkpoint.pt.")
    ] = True,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
    init_from: Annotated[
        Path | None,
        typer.Option(
            help="Start from this policy's weights (a fine-tune; its provenance is kept in the "
            "new policy's metrics)."
        ),
    ] = None,
    domain: Annotated[
        str | None,
        typer.Option(help="Train on this folder of domain files (default: the shipped domain)."),
    ] = None,
) -> None:
    """Train the DQN interaction manager against the user simulator (agent config section)."""
    from oxbot.dialogue.agent import load_policy
    from oxbot.dialogue.model import build_dialogue_model
    from oxbot.dialogue.policy import play_command, retrain_advice
    from oxbot.dialogue.training import train_agent

    config = with_domain(config_of(ctx), domain)
    start = None
    if init_from is not None:
        names = build_dialogue_model(config).layout.names
        start = load_policy(init_from, names, retrain_advice(config.dialogue.domain, str(out)))
    again = ["train", "agent", "--out", str(out), "--resume"]
    if domain is not None:
        again += ["--domain", domain]
    if init_from is not None:
        again += ["--init-from", str(init_from)]
    with resumable(ctx, again):
        result = train_agent(config, out, resume=resume, show_progress=not quiet, init_from=start)
    m = result.metrics
    typer.echo(
        f"trained on {m['experiences']} experiences ({m['games']} games) in "
        f"{m['wall_clock_s']:.0f} s; wrote {out}/agent.pt, agent_metrics.json, "
        f"agent_reward.png, agent_win_draw.png; play with it: "
        f"{play_command(config.dialogue.domain, str(out / 'agent.pt'))}"
    )


def with_domain(config: OxbotConfig, domain: str | None) -> OxbotConfig:
    """`config` with `--domain` in `[dialogue] domain`, when given."""
    if domain is None:
        return config
    return with_overrides(config, {"dialogue": {"domain": domain}})


def evaluate_agent_command(
    ctx: typer.Context,
    opponent: Annotated[
        str, typer.Option(help="The person's strategy: random, blocker, minimax or all.")
    ] = "random",
    robot_starts: Annotated[
        str, typer.Option("--robot-starts", help="Who draws first: yes, no or both.")
    ] = "both",
    games: Annotated[
        int, typer.Option(help="Games per opponent and who-starts condition.")
    ] = 10_000,
    as_json: Annotated[bool, typer.Option("--json", help="Print the figures as JSON.")] = False,
    show: Annotated[int, typer.Option(help="Print this many transcripts like Figure 1.")] = 0,
    policy_file: Annotated[
        Path | None,
        typer.Option(
            "--policy",
            help="The DQN's policy file or its folder, or an SB3 DQN / MaskablePPO model's .zip "
            "(default: the shipped one).",
        ),
    ] = None,
    domain: Annotated[
        str | None,
        typer.Option(help="A folder of domain files (default: the shipped domain)."),
    ] = None,
    manager: Annotated[
        str,
        typer.Option(
            help="The manager measured: dqn (the trained policy), rules (hand-written) or "
            "script (the action model's most probable act)."
        ),
    ] = "dqn",
    seed: Annotated[int, typer.Option(help="Seed of the simulated people.")] = 0,
    cooperative: Annotated[
        bool,
        typer.Option(
            "--cooperative",
            help="People who always agree and play a whole game (game play, as in the paper).",
        ),
    ] = False,
) -> None:
    """Play the greedy policy (or a baseline) against simulated people and measure its
    dialogues."""
    import json

    from oxbot.dialogue.evaluation import evaluate, format_transcript
    from oxbot.errors import ConfigError
    from oxbot.game.opponents import OPPONENTS
    from oxbot.peers import load_robot_policy

    names = list(OPPONENTS) if opponent == "all" else [opponent]
    if any(n not in OPPONENTS for n in names):
        raise ConfigError(f"unknown opponent {opponent!r}; choose random, blocker, minimax or all")
    starts = who_starts(robot_starts, "--robot-starts")
    if games <= 0:
        raise ConfigError(f"--games is {games}; play at least one game")
    if policy_file is not None and manager != "dqn":
        raise ConfigError(f"--policy is a DQN's file; leave it out with --manager {manager}")
    config = with_domain(config_of(ctx), domain)
    if policy_file is not None:
        config = with_overrides(config, {"robot": {"policy": str(policy_file)}})
    policy = load_robot_policy(config, manager)
    results = [
        evaluate(
            policy.act_batch,
            name,
            start,
            games,
            config,
            seed=seed,
            keep_transcripts=show,
            cooperative=cooperative,
        )
        for name in names
        for start in starts
    ]
    if as_json:
        typer.echo(json.dumps([r.summary() for r in results], indent=2))
    else:
        for r in results:
            who = "robot starts" if r.robot_starts else "person starts"
            typer.echo(
                f"{r.opponent:8s} {who:14s} games {r.games}  win {r.win_rate:.2%}  "
                f"draw {r.draw_rate:.2%}  loss {r.loss_rate:.2%}  reward {r.average_reward:.2f}  "
                f"turns {r.average_turns:.1f}  well-formed {r.well_formed:.2%} "
                f"(its own mistakes {r.policy_faults})  declined {r.declined_rate:.2%}  "
                f"stopped {r.stopped_rate:.2%}  abandoned {r.abandoned_rate:.2%}  "
                f"as wanted {r.task_success:.2%}"
            )
    for r in results:
        for transcript in r.transcripts[:show]:
            typer.echo(f"\n# {r.opponent}, robot starts: {r.robot_starts}", err=as_json)
            typer.echo(format_transcript(transcript), err=as_json)
