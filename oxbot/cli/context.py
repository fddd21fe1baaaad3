"""What every `oxbot` command reads from its context: the global options (`--config`, `--set`,
`-v`), the configuration they make, the line that resumes an interrupted training, and the
console errors are printed on.
"""

from __future__ import annotations

import contextlib
import logging
import shlex
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from oxbot.config import OxbotConfig, load_config, to_toml
from oxbot.errors import TrainingInterrupted

err_console = Console(stderr=True, highlight=False)


def main_options(
    ctx: typer.Context,
    config: Annotated[
        Path | None, typer.Option("--config", help="TOML file overriding the paper's defaults.")
    ] = None,
    overrides: Annotated[
        list[str] | None,
        typer.Option("--set", help="Override one field: section.field=value (repeatable)."),
    ] = None,
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log debug messages.")] = False,
) -> None:
    """A talking robot that learns to play noughts and crosses on paper."""
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    ctx.obj = load_config(config, overrides or [])


def config_of(ctx: typer.Context) -> OxbotConfig:
    """The configuration the global options made (the defaults when there were none)."""
    return ctx.obj if isinstance(ctx.obj, OxbotConfig) else OxbotConfig()


@contextlib.contextmanager
def resumable(ctx: typer.Context, command: list[str]) -> Iterator[None]:
    """On Ctrl-C during training: one line saying where the checkpoint is and the exact
    command that resumes (`command` after the global options this run was given); exit 130."""
    try:
        yield
    except TrainingInterrupted as exc:
        root = ctx.find_root().params
        words = ["oxbot"]
        words += ["--config", str(root["config"])] if root.get("config") else []
        for item in root.get("overrides") or []:
            words += ["--set", item]
        typer.echo(f"{exc}; resume with: {shlex.join([*words, *command])}", err=True)
        raise typer.Exit(130) from None


def show_config(ctx: typer.Context) -> None:
    """Print the effective configuration as TOML, each field with where its default comes from."""
    typer.echo(to_toml(config_of(ctx)))
