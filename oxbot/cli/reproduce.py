"""`oxbot reproduce`: the paper from scratch, side by side with peers, into REPORT.md."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from oxbot.cli.context import config_of, err_console
from oxbot.config import load_config
from oxbot.errors import TrainingInterrupted


def reproduce_command(
    ctx: typer.Context,
    quick: Annotated[
        bool, typer.Option("--quick", help="Small budgets (a few minutes); the report says so.")
    ] = False,
    out: Annotated[
        Path | None,
        typer.Option(
            help="Folder for REPORT.md, its plots and report.json "
            "(default: reports/, or runs/quick/reports with --quick)."
        ),
    ] = None,
    work: Annotated[
        Path, typer.Option(help="Working folder for seeds, models and checkpoints (cleared).")
    ] = Path("runs/reproduce"),
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bars.")] = False,
) -> None:
    """Reproduce the paper from scratch side by side with peers, and write REPORT.md.

    Trains with the shipped agent's config (oxbot/data/models/agent.toml) unless --config is
    given, and evaluates against the default simulated person; --set applies to both.
    """
    from oxbot.dialogue.agent import shipped_policy_path
    from oxbot.reproduce import reproduce

    if out is None:  # a quick run never overwrites the committed full report
        out = Path("runs/quick/reports") if quick else Path("reports")
    params = ctx.parent.params if ctx.parent is not None else {}
    overrides = params.get("overrides") or []
    if params.get("config") is not None:
        train_config = eval_config = config_of(ctx)
    else:
        train_config = load_config(shipped_policy_path().with_suffix(".toml"), overrides)
        eval_config = load_config(None, overrides)
    try:
        result = reproduce(
            out,
            work,
            train_config,
            eval_config,
            quick=quick,
            show_progress=not quiet,
            announce=lambda text: err_console.print(f"[bold]{text}[/]"),
        )
    except TrainingInterrupted:
        # a reproduction times whole runs, so it does not resume; its next run starts afresh
        typer.echo(f"reproduce interrupted; run it again to start afresh (clears {work})", err=True)
        raise typer.Exit(130) from None
    typer.echo(
        f"wrote {result.report_path}, {result.json_path} and {len(result.plots)} plots "
        f"in {result.figures['wall_clock_s']:.0f} s"
    )
