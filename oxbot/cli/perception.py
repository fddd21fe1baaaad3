"""The perceiver's commands: its seed images and other-hand test set (`oxbot perceive`), its
training and measurement (`oxbot train|evaluate perceiver`), and reading the board from photos
(`oxbot see`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from oxbot.cli.context import config_of, err_console, resumable
from oxbot.errors import OxbotError

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

    cfg = config_of(ctx).perception
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
    with resumable(ctx, ["train", "perceiver", *options, "--resume"]):
        result = train_perceiver(
            config_of(ctx).perception,
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


def train_reader_command(
    ctx: typer.Context,
    out: Annotated[
        Path, typer.Option(help="Model file; metrics JSON and curve PNG are written beside it.")
    ] = Path("runs/reader/grid_points.pt"),
    scenes: Annotated[
        int | None, typer.Option(help="Randomised renders to train on (default: config).")
    ] = None,
    epochs: Annotated[int | None, typer.Option(help="Passes over them (default: config).")] = None,
    finetune: Annotated[
        list[Path] | None,
        typer.Option(
            metavar="DIR",
            help="Instead of training from nothing, go on from --start with the photos of this "
            "folder (images/ and lattices.json, as bench/compose_boards.py writes); repeatable.",
        ),
    ] = None,
    start: Annotated[
        Path | None,
        typer.Option(help="The model --finetune goes on from (default: the shipped one)."),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Train the learned grid finder from nothing on randomised renders (`[grid_model]`), or
    fine-tune one on photos whose grids are known."""
    import dataclasses

    from oxbot.perception.grid_points import shipped_path
    from oxbot.perception.grid_training import finetune_reader, train_reader

    config = config_of(ctx).grid_model
    if finetune:
        if epochs is not None:
            config = dataclasses.replace(config, finetune_epochs=epochs)
        try:
            result = finetune_reader(
                config, start or shipped_path(), finetune, out, show_progress=not quiet
            )
        except (FileNotFoundError, ValueError) as err:
            raise typer.BadParameter(str(err), param_hint="--finetune") from None
        m, v = result.metrics, result.metrics["validation"]
        typer.echo(
            f"fine-tuned on {m['photos']['trained_on']:,} photos and {config.finetune_renders:,} "
            f"renders in {m['train_seconds']:.0f} s; photos kept apart: "
            f"{m['before']['photos']['found']} -> {v['photos_found']} of {v['photos_grids']} "
            f"grids found, median point error {m['before']['photos']['median_point_error_px']:.2f}"
            f" -> {v['photos_median_point_error_px']:.2f} px; validation renders: {v['found']}/"
            f"{v['grids']} grids found (before {m['before']['renders']['found']})"
        )
        typer.echo(f"wrote {result.model_path}, {result.metrics_path}, {result.curve_path}")
        typer.echo(_read_with(result.model_path))
        return
    changes = {"scenes": scenes, "epochs": epochs}
    config = dataclasses.replace(config, **{k: v for k, v in changes.items() if v is not None})
    result = train_reader(config, out, show_progress=not quiet)
    m, v = result.metrics, result.metrics["validation"]
    typer.echo(
        f"trained on {config.scenes:,} renders in {m['train_seconds']:.0f} s "
        f"(+{m['render_seconds']:.0f} s rendering); validation renders: "
        f"{v['found']}/{v['grids']} grids found, median point error "
        f"{v['median_point_error_px']:.2f} px, {v['false_grids']}/{v['without_grid']} "
        "without a grid given one"
    )
    typer.echo(f"wrote {result.model_path}, {result.metrics_path}, {result.curve_path}")
    typer.echo(_read_with(result.model_path))


def _read_with(model: Path) -> str:
    return (
        "read boards with it: oxbot --set perception.grid_finder=learned "
        f"--set perception.grid_model_path={model} see PHOTO"
    )


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


def see(
    ctx: typer.Context,
    images: Annotated[list[Path], typer.Argument(help="Photos of the game sheet (PNG or JPEG).")],
    debug: Annotated[
        Path | None,
        typer.Option("--debug", help="Write the found grid, rectified sheet and 9 cells here."),
    ] = None,
    reader: Annotated[
        str | None,
        typer.Option(help="Grid finder: classical or learned (default: perception.grid_finder)."),
    ] = None,
) -> None:
    """Print the board read from each photo of the game sheet (O circles, X crosses)."""

    import dataclasses

    from oxbot.game.board import CELL_NAMES, render_labels
    from oxbot.perception.board import default_reader, save_debug, save_refusal
    from oxbot.perception.sources import load_image

    perception = config_of(ctx).perception
    if reader is not None:
        perception = dataclasses.replace(perception, grid_finder=reader)
    board_reader = default_reader(perception)
    failed = 0
    for path in images:
        frame = None
        try:
            frame = load_image(path)
            reading = board_reader.read(frame)
        except OxbotError as exc:
            failed += 1
            err_console.print(f"[bold red]error:[/] {escape(f'{path}: {exc}')}", soft_wrap=True)
            if debug is not None and frame is not None:
                typer.echo(f"wrote {save_refusal(frame, str(exc), debug, path.stem)}")
                save_heatmaps(perception, frame, debug, path.stem)
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
            save_heatmaps(perception, frame, debug, path.stem)
    if failed:
        raise typer.Exit(2)


def save_heatmaps(perception, frame, folder: Path, stem: str) -> None:
    """With the learned grid finder, what its network saw: `<stem>_heatmaps.png`."""
    if perception.grid_finder != "learned":
        return
    from oxbot.perception.grid_points import heatmap_picture, learned_finder
    from oxbot.perception.seeds import write_png

    finder = learned_finder(perception.grid_model_path or None)  # the reader's, loaded once
    picture = heatmap_picture(finder.look(frame), frame)
    path = folder / f"{stem}_heatmaps.png"
    write_png(path, picture[:, :, ::-1].copy())
    typer.echo(f"wrote {path}")


def cell_confidences(readings) -> str:
    """Each cell's reading (partial included) and its confidence, as three rows."""
    from oxbot.game.board import SIZE

    cells = [f"{r.label:>7s} {r.confidence:4.2f}" for r in readings]
    return "\n".join("  ".join(cells[row : row + SIZE]) for row in range(0, len(cells), SIZE))
