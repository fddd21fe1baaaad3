"""The `oxbot` command. Subcommands mirror the package: play, game, see, perceive, train,
evaluate, reproduce, config.

Every command reads the configuration from `--config FILE` and `--set section.field=value`
given before the subcommand, e.g. `oxbot --set game.opponent=blocker game`; a command's own
options (`oxbot play --port 8080`) override both.
"""

from __future__ import annotations

import contextlib
import logging
import shlex
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape

from oxbot.config import OxbotConfig, load_config, to_toml, who_starts, with_overrides
from oxbot.errors import OxbotError, TrainingInterrupted

app = typer.Typer(
    name="oxbot",
    help="A talking robot that learns to play noughts and crosses on paper.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # click's plain help: no "<bool>" after every flag
)

err_console = Console(stderr=True, highlight=False)

# Command groups; each domain registers its commands below, next to the others of its group.
train_app = typer.Typer(
    help="Train a learner and write its model, metrics and plots.", rich_markup_mode=None
)
evaluate_app = typer.Typer(
    help="Measure a trained learner, as in the paper's experiments.", rich_markup_mode=None
)


@app.callback()
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


def _config(ctx: typer.Context) -> OxbotConfig:
    return ctx.obj if isinstance(ctx.obj, OxbotConfig) else OxbotConfig()


@contextlib.contextmanager
def _resumable(ctx: typer.Context, command: list[str]) -> Iterator[None]:
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


@app.command("config")
def show_config(ctx: typer.Context) -> None:
    """Print the effective configuration as TOML, each field with where its default comes from."""
    typer.echo(to_toml(_config(ctx)))


@app.command("game")
def game(
    ctx: typer.Context,
    opponent: Annotated[
        str | None,
        typer.Option(help="The robot's strategy: random, blocker or minimax (default: config)."),
    ] = None,
    robot_starts: Annotated[
        bool | None,
        typer.Option("--robot-starts/--person-starts", help="Who draws first, with circles."),
    ] = None,
    seed: Annotated[int | None, typer.Option(help="Seed for the robot's tie-breaking.")] = None,
) -> None:
    """Play noughts and crosses in the terminal against the robot's game strategy."""
    import numpy as np

    from oxbot.game.opponents import as_robot, make_opponent
    from oxbot.game.terminal import TerminalGame

    cfg = _config(ctx).game
    rng = np.random.default_rng(seed)
    robot = as_robot(make_opponent(opponent or cfg.opponent, rng))
    starts = cfg.robot_starts if robot_starts is None else robot_starts
    TerminalGame(robot, robot_starts=starts).play_session()


# --- perception commands (issue 3) ---

perceive_app = typer.Typer(
    help="The perceiver's data: seed images and the other-hand test set.", rich_markup_mode=None
)


@perceive_app.command("make-seeds")
def make_seeds_command(
    ctx: typer.Context,
    out: Annotated[
        Path | None, typer.Option(help="Seed folder to write (default: the shipped one).")
    ] = None,
    seed: Annotated[int | None, typer.Option(help="Seed of the synthesiser.")] = None,
) -> None:
    """Draw the seed images (36 per label) with the handwriting synthesiser, as PNGs."""
    from oxbot.perception.seeds import make_seeds, shipped_seeds_dir

    cfg = _config(ctx).perception
    folder = out if out is not None else shipped_seeds_dir()
    written = make_seeds(
        folder, cfg.seeds_per_class, cfg.seed if seed is None else seed, cfg.image_size
    )
    typer.echo(f"wrote {len(written)} seed images to {folder}/{{circle,cross,nothing}}/")


@perceive_app.command("make-font-set")
def make_font_set_command(
    out: Annotated[Path, typer.Argument(help="Folder to write circle/, cross/, nothing/ into.")],
    images: Annotated[int, typer.Option(help="How many cells, the labels in turn.")] = 1500,
    seed: Annotated[int, typer.Option(help="Seed of the sizes, places and papers.")] = 0,
) -> None:
    """Render the other-hand test set from handwriting fonts as a labelled folder."""
    from oxbot.perception.fonts import write_font_set

    written = write_font_set(out, images, seed)
    typer.echo(f"wrote {len(written)} font cells to {out}/{{circle,cross,nothing}}/")


@train_app.command("perceiver")
def train_perceiver_command(
    ctx: typer.Context,
    images: Annotated[
        int | None, typer.Option(help="Training images to generate (default: config, 10K).")
    ] = None,
    seeds: Annotated[
        Path | None, typer.Option(help="Seed folder of circle/, cross/, nothing/ PNGs.")
    ] = None,
    out: Annotated[
        Path, typer.Option(help="Model file; metrics JSON and curve PNG are written beside it.")
    ] = Path("runs/perceiver/perceiver.pt"),
    curve: Annotated[
        bool, typer.Option("--curve/--no-curve", help="Also train the learning curve's points.")
    ] = True,
    resume: Annotated[
        bool,
        typer.Option(
            "--resume/--no-resume",
            help="Continue an interrupted run from the checkpoint beside OUT (.checkpoint.pt).",
        ),
    ] = True,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Train the CNN+SVM perceiver on images generated from the seeds (paper §3.3)."""
    from oxbot.perception.training import train_perceiver

    options = ["--out", str(out)]
    options += ["--images", str(images)] if images is not None else []
    options += ["--seeds", str(seeds)] if seeds is not None else []
    options += [] if curve else ["--no-curve"]
    with _resumable(ctx, ["train", "perceiver", *options, "--resume"]):
        result = train_perceiver(
            _config(ctx).perception,
            images,
            seeds,
            out,
            curve=curve,
            show_progress=not quiet,
            resume=resume,
        )
    m = result.metrics
    typer.echo(
        f"trained on {m['train_images']:,} images in {m['fit_seconds']:.1f} s "
        f"(+{m['generate_seconds']:.1f} s generating them); accuracy on "
        f"{m['test']['images']:,} generated test images {m['test']['accuracy']:.2%}"
    )
    if "accuracy" in m["fonts"]:
        typer.echo(f"accuracy on the handwriting-font set {m['fonts']['accuracy']:.2%}")
    typer.echo(f"wrote {result.model_path}, {result.metrics_path}, {result.curve_path}")


@evaluate_app.command("perceiver")
def evaluate_perceiver_command(
    ctx: typer.Context,
    folders: Annotated[
        list[Path] | None,
        typer.Argument(help="Labelled folders of circle/, cross/, nothing/ PNGs to measure too."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the figures as JSON.")] = False,
    model: Annotated[
        Path | None, typer.Option(help="A model file (default: the shipped one).")
    ] = None,
    seeds: Annotated[
        Path | None, typer.Option(help="Seed folder the test images are generated from.")
    ] = None,
    images: Annotated[
        int | None, typer.Option(help="Generated test images (default: config, 1,000).")
    ] = None,
    fonts: Annotated[
        bool, typer.Option("--fonts/--no-fonts", help="Also measure the handwriting-font set.")
    ] = True,
    seed: Annotated[int | None, typer.Option(help="Seed of the generated test images.")] = None,
) -> None:
    """Accuracy, per-label precision/recall and confusion matrix on fresh test images."""
    import json

    from oxbot.perception.classifier import load_classifier
    from oxbot.perception.evaluation import (
        evaluate_folder,
        evaluate_fonts,
        evaluate_generated,
    )
    from oxbot.perception.seeds import load_seeds

    clf = load_classifier(model)
    seed_set = load_seeds(seeds, clf.image_size)
    results = [evaluate_generated(clf, seed_set, images, seed)]
    if fonts:
        try:
            results.append(evaluate_fonts(clf, seed=clf.config.seed if seed is None else seed))
        except OxbotError as exc:
            err_console.print(f"[yellow]skipping the font set:[/] {exc}")
    results += [evaluate_folder(clf, folder) for folder in folders or []]
    if as_json:
        typer.echo(json.dumps([r.to_dict() for r in results], indent=2))
    else:
        for r in results:
            typer.echo(r.summary())


app.add_typer(perceive_app, name="perceive")

# --- board-reading commands (issue 4) ---


@app.command("see")
def see(
    ctx: typer.Context,
    images: Annotated[list[Path], typer.Argument(help="Photos of the game sheet (PNG or JPEG).")],
    debug: Annotated[
        Path | None,
        typer.Option("--debug", help="Write the found grid, rectified sheet and 9 cells here."),
    ] = None,
) -> None:
    """Print the board read from each photo of the game sheet (O circles, X crosses)."""

    from oxbot.game.board import CELL_NAMES, render_labels
    from oxbot.perception.board import default_reader, save_debug, save_refusal
    from oxbot.perception.sources import load_image

    failed = 0
    for path in images:
        frame = None
        try:
            frame = load_image(path)
            reading = default_reader(_config(ctx).perception).read(frame)
        except OxbotError as exc:
            failed += 1
            err_console.print(f"[bold red]error:[/] {escape(f'{path}: {exc}')}", soft_wrap=True)
            if debug is not None and frame is not None:
                typer.echo(f"wrote {save_refusal(frame, str(exc), debug, path.stem)}")
            continue
        typer.echo(f"{path}: {' '.join(reading.labels)}")
        typer.echo(render_labels(reading.labels))
        typer.echo(cell_confidences(reading.readings))
        unseen = reading.grid.cells_out_of_view()
        if unseen:  # drawn empty above: the frame's edge cuts them off
            typer.echo(f"out of view: {', '.join(CELL_NAMES[i] for i in unseen)}")
        if debug is not None:
            written = save_debug(reading, frame, debug, path.stem)
            typer.echo(f"wrote {len(written)} images to {debug}/{path.stem}_*.png")
    if failed:
        raise typer.Exit(2)


def cell_confidences(readings) -> str:
    """Each cell's reading (partial included) and its confidence, as three rows."""
    from oxbot.game.board import SIZE

    cells = [f"{r.label:>7s} {r.confidence:4.2f}" for r in readings]
    return "\n".join("  ".join(cells[row : row + SIZE]) for row in range(0, len(cells), SIZE))


# --- dialogue commands (issue 5) ---


@train_app.command("agent")
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
) -> None:
    """Train the DQN interaction manager against the user simulator (agent config section)."""
    from oxbot.dialogue.agent import load_policy
    from oxbot.dialogue.training import train_agent

    start = load_policy(init_from) if init_from is not None else None
    again = ["train", "agent", "--out", str(out), "--resume"]
    if init_from is not None:
        again += ["--init-from", str(init_from)]
    with _resumable(ctx, again):
        result = train_agent(
            _config(ctx), out, resume=resume, show_progress=not quiet, init_from=start
        )
    m = result.metrics
    typer.echo(
        f"trained on {m['experiences']} experiences ({m['games']} games) in "
        f"{m['wall_clock_s']:.0f} s; wrote {out}/agent.pt, agent_metrics.json, "
        "agent_reward.png, agent_win_draw.png"
    )


# --- speech commands (issue 14) ---


@train_app.command("keywords")
def train_keywords_command(
    repo: Annotated[
        Path,
        typer.Option(
            help="Git directory of the fetched MahmoudEhab3/Yes-No-Speech-Classifier "
            "(oxbot/data/models/keywords.SOURCES.md); read, never written."
        ),
    ],
    out: Annotated[
        Path, typer.Option(help="Model file to write (the shipped one: oxbot/data/models/).")
    ] = Path("runs/keywords/keywords.pt"),
    seed: Annotated[int, typer.Option(help="Seed of the weights and augmentation.")] = 0,
    epochs: Annotated[int | None, typer.Option(help="Passes (default: KeywordConfig).")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Train the yes / no / other keyword model that double-checks short spoken answers."""
    import dataclasses

    from oxbot.speech.keywords import KeywordConfig, load_training_data, train_keywords

    config = KeywordConfig(seed=seed)
    if epochs is not None:
        config = dataclasses.replace(config, epochs=epochs)
    from oxbot.dialogue.domain import load_domain
    from oxbot.speech.keywords import spoken_clips

    data = load_training_data(repo) + spoken_clips(load_domain())
    spotter = train_keywords(data, config, out, show_progress=not quiet)
    m = spotter.metadata
    typer.echo(
        f"trained on {sum(m['clips'].values()):,} clips ({m['clips']}) in "
        f"{m['train_cpu_seconds']:.0f} s of CPU; last loss {m['loss_per_epoch'][-1]:.3f}; "
        f"wrote {out}"
    )


@evaluate_app.command("agent")
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
        Path | None, typer.Option("--policy", help="A policy file (default: the shipped one).")
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed of the simulated people.")] = 0,
    cooperative: Annotated[
        bool,
        typer.Option(
            "--cooperative",
            help="People who always agree and play a whole game (game play, as in the paper).",
        ),
    ] = False,
) -> None:
    """Play the greedy policy against simulated people and measure its dialogues."""
    import json

    from oxbot.dialogue.agent import load_policy
    from oxbot.dialogue.evaluation import evaluate, format_transcript
    from oxbot.errors import ConfigError
    from oxbot.game.opponents import OPPONENTS

    names = list(OPPONENTS) if opponent == "all" else [opponent]
    if any(n not in OPPONENTS for n in names):
        raise ConfigError(f"unknown opponent {opponent!r}; choose random, blocker, minimax or all")
    starts = who_starts(robot_starts, "--robot-starts")
    if games <= 0:
        raise ConfigError(f"--games is {games}; play at least one game")
    policy = load_policy(policy_file)
    results = [
        evaluate(
            policy.act_batch,
            name,
            start,
            games,
            _config(ctx),
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


# --- the integrated robot: oxbot play (issues 6 and 7) ---


@app.command("play")
def play(
    ctx: typer.Context,
    terminal: Annotated[
        bool, typer.Option("--terminal", help="Play in this terminal instead of the web page.")
    ] = False,
    camera: Annotated[
        str | None,
        typer.Option(help="Watch real paper: a camera index (0), a video or an image folder."),
    ] = None,
    robot_starts: Annotated[
        bool | None,
        typer.Option("--robot-starts/--person-starts", help="Who draws first (default: config)."),
    ] = None,
    mute: Annotated[bool, typer.Option("--mute", help="Print the robot's words only.")] = False,
    host: Annotated[
        str | None, typer.Option(help="Web page: the address to listen on (default: config).")
    ] = None,
    port: Annotated[
        int | None, typer.Option(help="Web page: the port to listen on (default: config).")
    ] = None,
    speed: Annotated[
        float | None,
        typer.Option(help="Run speech, the arm and the waits this much faster (default: 1)."),
    ] = None,
    https: Annotated[
        bool | None,
        typer.Option(
            "--https/--http",
            help="Web page: HTTPS with a self-signed certificate, so that a phone's browser "
            "lends the page its camera (default: HTTPS when --host is not a loopback address).",
        ),
    ] = None,
    record: Annotated[
        bool, typer.Option("--record", help="Keep what the robot saw and heard (oxbot data).")
    ] = False,
    record_audio: Annotated[
        bool, typer.Option("--record-audio", help="With --record: keep the recordings too.")
    ] = False,
    data_dir: Annotated[
        Path | None, typer.Option(help="Folder of the recordings (default: user data folder).")
    ] = None,
) -> None:
    """Play with the whole robot: the web page at http(s)://HOST:PORT, or --terminal."""
    changes = {
        "game": {"robot_starts": robot_starts},
        "robot": {"speed_factor": speed},
        "web": {"host": host, "port": port, "https": {True: "on", False: "off"}.get(https)},
    }
    config = with_overrides(
        _config(ctx),
        {
            section: {k: v for k, v in values.items() if v is not None}
            for section, values in changes.items()
        },
    )
    if terminal:
        from oxbot.perception.sources import open_source
        from oxbot.robot.session import Robot
        from oxbot.robot.terminal import Speakers, TerminalRobot

        source = open_source(camera) if camera is not None else None
        joining = []
        if record:  # opt-in, and the person is told what is kept
            from oxbot.recording import RecordingStore, notice
            from oxbot.recording.recorder import joining as recorder

            store = RecordingStore(data_dir)
            err_console.print(notice(store, record_audio), highlight=False)
            joining.append(recorder(store, "terminal", keep_audio=record_audio))
        robot = Robot(config, sheet_camera=source, joining=joining)
        TerminalRobot(robot, speakers=Speakers(not mute)).run()
        return
    from oxbot.web.server import serve

    serve(
        config,
        announce=typer.echo,
        record=record,
        data_dir=data_dir,
        record_audio=record_audio,
    )


# --- reproducing the paper: oxbot reproduce (issue 8) ---


@app.command("reproduce")
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
        train_config = eval_config = _config(ctx)
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


# --- the robot across processes and machines, on Zenoh (issue 19) ---

_CONNECT = typer.Option("--connect", help="A Zenoh peer or router to reach: tcp/HOST:PORT.")
_LISTEN = typer.Option("--listen", help="Accept connections here: tcp/0.0.0.0:PORT.")
_SCOUTING = typer.Option("--scouting/--no-scouting", help="Find peers by multicast on the LAN.")
_ROBOT = typer.Option("--robot", help="The robot's name: key expressions oxbot/ROBOT/...")


@app.command("component")
def component_command(
    ctx: typer.Context,
    name: Annotated[
        str,
        typer.Argument(
            help="manager, perception, recognition, voice, arm, head-tracking or head-movement."
        ),
    ],
    robot: Annotated[str, _ROBOT] = "oxbot",
    connect: Annotated[list[str] | None, _CONNECT] = None,
    listen: Annotated[list[str] | None, _LISTEN] = None,
    scouting: Annotated[bool, _SCOUTING] = True,
    camera: Annotated[str | None, typer.Option(help="perception, head-tracking: a camera.")] = None,
) -> None:
    """Run one component of a robot in this process, over Zenoh, until Ctrl-C."""
    from oxbot.robot.launch import endpoints_of, run_component

    endpoints = endpoints_of(connect, listen, scouting)
    run_component(name, robot, endpoints, _config(ctx), camera)


@app.command("robot")
def robot_command(
    ctx: typer.Context,
    launch: Annotated[
        Path | None, typer.Option("--launch", help="Start these components, respawning them.")
    ] = None,
    robot: Annotated[str, _ROBOT] = "oxbot",
    connect: Annotated[list[str] | None, _CONNECT] = None,
    listen: Annotated[list[str] | None, _LISTEN] = None,
    scouting: Annotated[bool, _SCOUTING] = True,
    terminal: Annotated[bool, typer.Option("--terminal", help="Drive it from here.")] = False,
    web: Annotated[bool, typer.Option("--web", help="Serve the page for it ([web]).")] = False,
) -> None:
    """A robot as processes: --launch FILE starts them; --terminal / --web drive one."""
    from oxbot.robot.launch import endpoints_of, load_launch_file, run_robot

    config = _config(ctx)
    plan = load_launch_file(launch) if launch is not None else None
    drive: Callable[[Any], None] | None = None
    if terminal:
        from oxbot.robot.terminal import TerminalRobot

        def drive(remote: Any) -> None:
            TerminalRobot(remote).run()
    elif web:
        from oxbot.web.server import serve

        def drive(remote: Any) -> None:
            serve(config, announce=print, robot_factory=lambda: remote)

    run_robot(config, plan, robot, endpoints_of(connect, listen, scouting), drive)


app.add_typer(train_app, name="train")
app.add_typer(evaluate_app, name="evaluate")

# --- learning from recorded games (issue 18) ---
from oxbot.cli.data import data_app, learn_app  # noqa: E402

app.add_typer(data_app, name="data")
app.add_typer(learn_app, name="learn")


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
