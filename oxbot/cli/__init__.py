"""The `oxbot` command. Subcommands mirror the package: play, game, see, perceive, train,
evaluate, reproduce, config, data, learn, study.

Every command reads the configuration from `--config FILE` and `--set section.field=value`
given before the subcommand, e.g. `oxbot --set game.opponent=blocker game`; a command's own
options (`oxbot play --port 8080`) override both.

Each command group is a module of this package; this one builds the `oxbot` app from them,
in the order `oxbot --help` lists the commands.
"""

from __future__ import annotations

import sys

import typer
from rich.markup import escape

from oxbot.cli import dialogue, perception, play, reproduce, robot, speech
from oxbot.cli.context import err_console, main_options, show_config
from oxbot.cli.data import data_app, learn_app
from oxbot.cli.study import study_app
from oxbot.errors import OxbotError

app = typer.Typer(
    name="oxbot",
    help="A talking robot that learns to play noughts and crosses on paper.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # click's plain help: no "<bool>" after every flag
)
app.callback()(main_options)

# Groups whose commands come from several domains: each learner's module owns its command.
train_app = typer.Typer(
    help="Train a learner and write its model, metrics and plots.", rich_markup_mode=None
)
evaluate_app = typer.Typer(
    help="Measure a trained learner, as in the paper's experiments.", rich_markup_mode=None
)

app.command("config")(show_config)
app.command("game")(play.game)
app.command("see")(perception.see)
app.command("play")(play.play)
app.command("reproduce")(reproduce.reproduce_command)
app.command("component")(robot.component_command)
app.command("robot")(robot.robot_command)

train_app.command("perceiver")(perception.train_perceiver_command)
train_app.command("agent")(dialogue.train_agent_command)
train_app.command("keywords")(speech.train_keywords_command)
train_app.command("reader")(perception.train_reader_command)
evaluate_app.command("perceiver")(perception.evaluate_perceiver_command)
evaluate_app.command("agent")(dialogue.evaluate_agent_command)

app.add_typer(perception.perceive_app, name="perceive")
app.add_typer(train_app, name="train")
app.add_typer(evaluate_app, name="evaluate")
app.add_typer(data_app, name="data")
app.add_typer(learn_app, name="learn")
app.add_typer(study_app, name="study")


def main() -> None:
    """Entry point: run the app, printing oxbot's own errors as one clear line."""
    try:
        app()
    except OxbotError as exc:
        # escaped: messages name TOML sections like [agent], which rich would take for markup
        err_console.print(f"[bold red]error:[/] {escape(str(exc))}", soft_wrap=True)
        sys.exit(2)
    except KeyboardInterrupt:
        sys.exit(130)
