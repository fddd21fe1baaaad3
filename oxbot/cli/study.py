"""`oxbot study`: a user study in the box (docs/study.md).

`oxbot study` serves the study's page (consent, questionnaires, the games in their
counterbalanced conditions) and the experimenter's page behind a token it prints;
`oxbot study list`, `oxbot study export DIR` and `oxbot study forget ID` read, write out and
delete what the participants left.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

import typer

from oxbot.cli.context import config_of, err_console
from oxbot.config import with_overrides

study_app = typer.Typer(
    help="Run a user study with the robot: consent, conditions, questionnaires, export.",
    rich_markup_mode=None,
    invoke_without_command=True,
)

DataDir = Annotated[
    Path | None,
    typer.Option(help="The study's folder (default: `study` in the user's data folder)."),
]


def study_folder(data_dir: Path | None) -> Path:
    """Where the study's database lives."""
    if data_dir is not None:
        return data_dir
    from oxbot.recording.store import default_data_dir

    return default_data_dir() / "study"


def open_store(data_dir: Path | None):
    """The study's database; a DataError if no participant has consented in that folder."""
    from oxbot.errors import DataError
    from oxbot.study.store import DB_NAME, StudyStore

    folder = study_folder(data_dir)
    if not (folder / DB_NAME).exists():
        raise DataError(f"no study in {folder} (no participant yet); check --data-dir")
    return StudyStore(folder)


@study_app.callback()
def run_study(
    ctx: typer.Context,
    games: Annotated[int, typer.Option(help="Games per condition, for each participant.")] = 1,
    vary: Annotated[
        str,
        typer.Option(help="The factors that vary, comma-separated: manager, starter, input."),
    ] = "manager,starter,input",
    blocks: Annotated[int, typer.Option(help="Conditions per participant (0: all of them).")] = 0,
    retention: Annotated[
        str | None, typer.Option(help="How long the data is kept, as the consent page says it.")
    ] = None,
    consent: Annotated[
        Path | None,
        typer.Option(help="A text file replacing the consent text ({retention} is filled in)."),
    ] = None,
    host: Annotated[str | None, typer.Option(help="The address to listen on.")] = None,
    port: Annotated[int | None, typer.Option(help="The port to listen on.")] = None,
    data_dir: DataDir = None,
) -> None:
    """Serve the study's page for participants and the experimenter's page (its token printed)."""
    if ctx.invoked_subcommand is not None:
        return
    from oxbot.study.conditions import Design
    from oxbot.study.page import add_routes
    from oxbot.study.session import CONSENT, DEFAULT_RETENTION, Study
    from oxbot.web.server import serve

    config = with_overrides(
        config_of(ctx),
        {"web": {k: v for k, v in {"host": host, "port": port}.items() if v is not None}},
    )
    design = Design(tuple(f.strip() for f in vary.split(",") if f.strip()), games, blocks)
    study = Study(
        study_folder(data_dir),
        design,
        retention or DEFAULT_RETENTION,
        consent.read_text() if consent is not None else CONSENT,
    )
    err_console.print(
        f"Study: {len(design.conditions)} conditions ({vary}), {design.per_participant} per "
        f"participant, {games} game(s) each; data in {study.folder}",
        highlight=False,
    )

    def announce(text: str) -> None:
        typer.echo(text.replace("in a browser to play", "for the participant"))
        page = re.search(r"https?://\S+", text)
        if page is not None:  # the experimenter's page is at the same address
            typer.echo(
                "The experimenter's page (keep its token to yourself): "
                f"{page.group(0)}/experimenter?token={study.token}"
            )

    serve(
        config,
        announce=announce,
        add_routes=lambda app: add_routes(app, study, config),
        page="study",
    )


@study_app.command("list")
def list_command(data_dir: DataDir = None) -> None:
    """List the participants so far: code, conditions in order, games, answers."""
    from oxbot.study.conditions import label

    with open_store(data_dir) as store:
        for p in store.participants():
            games, answers = len(store.games(p["id"])), len(store.answers(p["id"]))
            order = ", ".join(label(c) for c in p["conditions"])
            typer.echo(f"{p['id']}  {order}  games={games} answers={answers}")


@study_app.command("export")
def export_command(
    folder: Annotated[Path, typer.Argument(help="Where to write the CSV and JSON files.")],
    data_dir: DataDir = None,
) -> None:
    """Write every participant's answers and games as CSV and JSON, with a data dictionary."""
    from oxbot.study.export import export

    with open_store(data_dir) as store:
        for path in export(store, folder):
            typer.echo(str(path))


@study_app.command("forget")
def forget_command(
    participant: Annotated[str, typer.Argument(help="The participant's code (oxbot study list).")],
    data_dir: DataDir = None,
) -> None:
    """Delete everything of one participant, their recorded games too; no byte of it stays in
    the database files."""
    from oxbot.study.withdrawal import forget_participant

    open_store(data_dir).close()  # a DataError if there is no study there
    for path in forget_participant(study_folder(data_dir), participant):
        typer.echo(f"deleted {path} (made from their recorded games)")
    typer.echo(f"forgot {participant}; exports written before this still hold it: delete them")
