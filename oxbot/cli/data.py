"""`oxbot data list|show|export|forget` and `oxbot learn perceiver|agent`: the commands over the
recorded games (oxbot.recording) and what is learned from them."""

from __future__ import annotations

import datetime
import json
from pathlib import Path
from typing import Annotated

import typer

DataDir = Annotated[
    Path | None,
    typer.Option(
        "--data-dir", help="Folder of recordings.sqlite3 (default: the user's data folder)."
    ),
]

data_app = typer.Typer(
    help="The recorded games (oxbot play --record): list, show, export, forget.",
    rich_markup_mode=None,
)
learn_app = typer.Typer(
    help="Learn from the recorded games: the perceiver from the crops, the agent from the "
    "dialogues.",
    rich_markup_mode=None,
)


def _when(stamp: float | None) -> str:
    if stamp is None:
        return "-"
    return datetime.datetime.fromtimestamp(stamp).strftime("%Y-%m-%d %H:%M:%S")


@data_app.command("list")
def list_command(data_dir: DataDir = None) -> None:
    """One line per recorded session (one dialogue): when, outcome, turns, crops."""
    from oxbot.recording.store import DB_NAME, RecordingStore, default_data_dir

    folder = data_dir if data_dir is not None else default_data_dir()
    if not (folder / DB_NAME).exists():  # listing makes nothing, not even the folder
        typer.echo(f"0 sessions: nothing kept in {folder} (oxbot play --record keeps games)")
        return
    with RecordingStore(folder, create=False) as store:
        sessions = store.sessions()
        typer.echo(f"{len(sessions)} sessions in {store.path}")
        for s in sessions:
            typer.echo(
                f"{s.id:5d}  {_when(s.started_at)}  {s.mode or '-':8s} {s.status:11s} "
                f"{s.outcome or '-':8s}  turns {s.turns:3d}  answers {s.answers:3d} "
                f"(asked again {s.repeated})  crops {s.crops:4d} ({s.labelled} labelled)"
            )


@data_app.command("show")
def show_command(
    session: Annotated[int, typer.Argument(help="The session's number (oxbot data list).")],
    data_dir: DataDir = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print it as JSON.")] = False,
) -> None:
    """A session's transcript, the answers heard and what was kept of it."""
    from oxbot.recording.store import RecordingStore

    with RecordingStore(data_dir, create=False) as store:
        record = store.session(session)
    if as_json:
        typer.echo(json.dumps(record, indent=2))
        return
    typer.echo(
        f"session {record['id']}: {_when(record['started_at'])}, {record['status']}, "
        f"outcome {record['outcome'] or '-'}, final board {record['final_board'] or '-'}"
    )
    for turn in record["turns"]:
        typer.echo(f"{turn['t']:7.1f} s  {turn['speaker']}: {turn['text']}  [{turn['act']}]")
    for a in record["answers"]:
        best = a["nbest"][0] if a["nbest"] else ["", 0.0]
        again = "  asked again" if a["repeated"] else ""
        typer.echo(
            f"heard {best[0]!r} ({best[1]:.2f}, {len(a['nbest'])} hypotheses) as "
            f"{a['understood'] or '-'}{again}"
        )
    crops = ", ".join(f"{c['n']} {c['label'] or 'unlabelled'}" for c in record["crops"])
    typer.echo(f"crops: {crops or 'none'}")
    if record["derived"]:
        typer.echo("made from it: " + ", ".join(record["derived"]))


@data_app.command("export")
def export_command(
    out: Annotated[Path, typer.Argument(help="Folder for sessions/turns/answers/crops.parquet.")],
    session: Annotated[
        list[int] | None, typer.Option(help="Only this session (repeatable; default: all).")
    ] = None,
    data_dir: DataDir = None,
) -> None:
    """Write the recordings as Parquet files, one per table."""
    from oxbot.recording.export import export
    from oxbot.recording.store import RecordingStore

    with RecordingStore(data_dir, create=False) as store:
        written = export(store, out, session or None)
    typer.echo("wrote " + ", ".join(str(p) for p in written))


@data_app.command("forget")
def forget_command(
    session: Annotated[int, typer.Argument(help="The session's number (oxbot data list).")],
    data_dir: DataDir = None,
) -> None:
    """Delete a session, everything recorded in it and every file made from it."""
    from oxbot.recording.store import RecordingStore

    with RecordingStore(data_dir, create=False) as store:
        forgotten = store.forget(session)
    deleted = forgotten.deleted
    typer.echo(
        f"forgot session {session}"
        + (f"; deleted {len(deleted)} files made from it" if deleted else "")
    )
    for path in deleted:
        typer.echo(f"  {path}")
    for name in forgotten.refused:
        typer.echo(
            f"  not touched: {name} (outside the data folder and not made by this one; "
            "delete it yourself if it is yours)"
        )


@learn_app.command("perceiver")
def learn_perceiver_command(
    data_dir: DataDir = None,
    out: Annotated[
        Path | None,
        typer.Option(
            help="Model file (default: DATA_DIR/learned/perceiver.pt); metrics and plot beside it."
        ),
    ] = None,
    session: Annotated[
        list[int] | None, typer.Option(help="Learn from this session only (repeatable).")
    ] = None,
    base: Annotated[
        Path | None, typer.Option(help="The model to fine-tune (default: the shipped one).")
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed of the split and the fine-tuning.")] = 0,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Fine-tune the perceiver on the recorded crops; refuse a model worse on the test sets."""
    from oxbot.errors import LearningRefused
    from oxbot.recording.perceiver import LearnPerceiverConfig, learn_perceiver
    from oxbot.recording.store import RecordingStore

    with RecordingStore(data_dir, create=False) as store:
        target = out if out is not None else store.data_dir / "learned" / "perceiver.pt"
        try:
            result = learn_perceiver(
                store, target, LearnPerceiverConfig(seed=seed), base, session, not quiet
            )
        except LearningRefused as exc:
            _print_perceiver(exc.result.metrics)  # type: ignore[attr-defined]
            raise
    _print_perceiver(result.metrics)
    typer.echo(f"wrote {result.model_path}, {result.metrics_path}, {result.plot_path}")


def _print_perceiver(metrics: dict) -> None:
    crops = metrics["crops"]
    typer.echo(
        f"{crops['train']} recorded crops to learn from, {crops['held_back']} held back "
        f"({metrics['drawings_held_back']} drawings), from sessions {metrics['sessions']}"
    )
    for key, name in (
        ("held_back", "held-back crops of the person"),
        ("generated", "generated test images"),
        ("fonts", "handwriting-font set"),
    ):
        before, after = metrics["before"][key], metrics["after"][key]
        typer.echo(
            f"{name:32s} {before['accuracy']:.2%} -> {after['accuracy']:.2%} "
            f"({after['images']} cells)"
        )


@learn_app.command("agent")
def learn_agent_command(
    data_dir: DataDir = None,
    out: Annotated[
        Path | None,
        typer.Option(help="Folder for agent.pt and learn_agent.json (default: DATA_DIR/learned)."),
    ] = None,
    session: Annotated[
        list[int] | None, typer.Option(help="Learn from this session only (repeatable).")
    ] = None,
    steps: Annotated[int, typer.Option(help="Experiences of fine-tuning.")] = 30_000,
    games: Annotated[
        int, typer.Option(help="Dialogues per who-starts condition, before and after.")
    ] = 1_000,
    chunks: Annotated[
        int, typer.Option(help="Pieces of the fine-tune, each measured; the best is kept.")
    ] = 5,
    select_games: Annotated[
        int, typer.Option(help="Dialogues per who-starts condition measuring each piece.")
    ] = 300,
    seed: Annotated[int, typer.Option(help="Seed of the fine-tuning and the measurement.")] = 0,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Fit the simulated person to the recorded dialogues and retrain the policy with it."""
    from oxbot.errors import LearningRefused
    from oxbot.recording.agent import LearnAgentConfig, learn_agent
    from oxbot.recording.store import RecordingStore

    config = LearnAgentConfig(
        seed=seed, steps=steps, eval_games=games, chunks=chunks, select_games=select_games
    )
    with RecordingStore(data_dir, create=False) as store:
        target = out if out is not None else store.data_dir / "learned"
        try:
            result = learn_agent(store, target, config, session, not quiet)
        except LearningRefused as exc:
            _print_agent(exc.result.metrics)  # type: ignore[attr-defined]
            raise
    _print_agent(result.metrics)
    typer.echo(f"wrote {result.policy_path}, {result.metrics_path}")


def _print_agent(metrics: dict) -> None:
    person = metrics["person"]
    fitted = ", ".join(f"{k} {v:.3f}" for k, v in person["probabilities"].items())
    typer.echo(f"fitted on {person['dialogues']} recorded dialogues: {fitted}")
    kept = metrics["kept"]
    if metrics.get("refused"):  # never "kept" for a run that is then refused
        typer.echo("refused: " + ", ".join(map(str, metrics["refused"])))
    elif kept:
        typer.echo(f"kept the policy after {kept} of {metrics['config']['steps']} steps")
    else:
        typer.echo("no piece of the fine-tune did better than the shipped policy")
    for key, name in (
        ("repeated_questions_per_dialogue", "repeated questions per dialogue"),
        ("ill_formed", "ill-formed dialogues"),
        ("losses", "games lost"),
        ("task_success", "ended as the person wanted"),
    ):
        before, after = metrics["before"][key], metrics["after"][key]
        typer.echo(
            f"{name:34s} {before:.4g} -> {after:.4g} ({metrics['after']['dialogues']} dialogues)"
        )
