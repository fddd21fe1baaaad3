"""Training the learned grid finder on randomised renders: `oxbot train reader`.

The renders (`grid_scenes.random_grid_scene`) vary paper, ink, view, light, camera and clutter
far beyond any one setting (domain randomisation: Tobin et al. 2017, Tremblay et al. 2018),
each at one of the frames' shapes (4:3, 16:9, square, upright), padded as `picture_of` pads a
frame. Targets are drawn from each render's lattice: a Gaussian peak of `heat_sigma` heatmap
pixels at each inner crossing (one channel) and each outer point (another), and the grid lines'
ink shrunk to the heatmaps' size. The loss is CenterNet's penalty-reduced focal loss on the
points, cross-entropy on the lines and on "board present". A flip or a quarter turn of a
picture is a picture of a grid too (the channels do not name the points), so each batch is
flipped and turned at random.

Writes the model (`artifacts`, with its checksum, config, seed and figures), a metrics JSON and
a learning-curve PNG beside it. Renders kept apart (their own seeds) measure each epoch: the
mean distance of the found lattice's points from the true ones, grids found, and renders
without a grid wrongly given one.

`finetune_reader` goes on from a trained model with photos whose lattices are known (folders
holding `images/` and a `lattices.json`, as `oxbot.testing.composite.write_set` writes for
boards composed from real handwriting on real paper, or as a person marks real photos), mixed
with fresh renders so that what the renders taught is kept (chesscog's recipe: a network
trained on renders, then fine-tuned on a few real photos of a new setting). Photos carry no
line ink, so their line loss is left out. A tenth of the photos are kept apart and measured
each epoch beside the validation renders.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import multiprocessing
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from oxbot import artifacts
from oxbot.atomic import save_figure, write_text_atomic
from oxbot.config import GridModelConfig
from oxbot.perception.grid_model import (
    CROSSINGS,
    INPUT_SIDE,
    LINES,
    OUTER,
    STRIDE,
    GridPointNet,
)
from oxbot.perception.grid_points import KIND, VERSION, LearnedGridFinder
from oxbot.perception.grid_scenes import random_grid_scene

log = logging.getLogger(__name__)

SHAPES = ((256, 192), (256, 144), (256, 256), (192, 256), (256, 160))
"""The renders' (width, height): webcams' 4:3 and 16:9, square, a phone held upright."""


@dataclass(frozen=True)
class Renders:
    """Pictures padded to INPUT_SIDE square, with what is in them."""

    pictures: np.ndarray
    """uint8 (N, INPUT_SIDE, INPUT_SIDE, 3)."""
    lattices: np.ndarray
    """float32 (N, 4, 4, 2) picture pixels; nan where no grid."""
    lines: np.ndarray
    """uint8 (N, INPUT_SIDE // STRIDE, same) line ink, 0 or 1."""
    present: np.ndarray
    """bool (N,)."""
    sizes: np.ndarray
    """int (N, 2): width and height of each render before padding."""
    lines_known: np.ndarray | None = None
    """bool (N,): whether `lines` is the truth (a photo's line ink is unknown and its line
    loss left out); None when all are."""

    def __len__(self) -> int:
        return len(self.pictures)

    @property
    def line_truth(self) -> np.ndarray:
        """bool (N,): `lines_known`, every picture's when None."""
        return self.lines_known if self.lines_known is not None else np.ones(len(self), bool)

    def take(self, index: np.ndarray) -> Renders:
        """The pictures of `index`, in that order."""
        return Renders(*(getattr(self, f)[index] for f in _ARRAYS), self.line_truth[index])


def joined(*parts: Renders) -> Renders:
    """The pictures of `parts`, one after another."""
    return Renders(
        *(np.concatenate([getattr(p, f) for p in parts]) for f in _ARRAYS),
        np.concatenate([p.line_truth for p in parts]),
    )


_ARRAYS = ("pictures", "lattices", "lines", "present", "sizes")

LATTICES = "lattices.json"
"""In a fine-tuning folder beside `images/`: {photo name: its (4, 4, 2) lattice of cell corners
in photo pixels, as nested lists}; `oxbot.testing.composite.write_set` writes one (it keeps its
own copy of the name: the composer imports nothing of the reader it measures)."""


def _render_one(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool, tuple[int, int]]:
    rng = np.random.default_rng(seed)
    width, height = SHAPES[int(rng.integers(len(SHAPES)))]
    scene = random_grid_scene(rng, (width, height))
    picture = np.zeros((INPUT_SIDE, INPUT_SIDE, 3), np.uint8)
    picture[:height, :width] = scene.image
    side = INPUT_SIDE // STRIDE
    ink = np.zeros((INPUT_SIDE, INPUT_SIDE), np.uint8)
    ink[:height, :width] = scene.lines > 0
    lines = ink.reshape(side, STRIDE, side, STRIDE).max(axis=(1, 3))
    lattice = np.asarray(scene.lattice, np.float32)
    if not scene.present:
        lattice = np.full((4, 4, 2), np.nan, np.float32)
    return picture, lattice, lines, bool(scene.present), (width, height)


def render(seeds: list[int], processes: int, show_progress: bool, what: str) -> Renders:
    """Render the scenes of `seeds`, in `processes` processes, with a progress bar."""
    from rich.progress import Progress

    results = []
    with Progress(disable=not show_progress, transient=True) as progress:
        task = progress.add_task(f"rendering the {what}", total=len(seeds))
        if processes > 1:
            context = multiprocessing.get_context("forkserver")
            with context.Pool(processes) as pool:
                for result in pool.imap(_render_one, seeds, chunksize=32):
                    results.append(result)
                    progress.advance(task)
        else:
            for seed in seeds:
                results.append(_render_one(seed))
                progress.advance(task)
    pictures, lattices, lines, present, sizes = zip(*results, strict=True)
    return Renders(
        np.stack(pictures), np.stack(lattices), np.stack(lines), np.array(present), np.array(sizes)
    )


def load_photos(folders: list[Path]) -> Renders:
    """The photos of `folders` (each with `images/` and `lattices.json`) as the network sees
    them: shrunk to INPUT_SIDE on the long side (as `picture_of` shrinks a frame), padded to
    INPUT_SIDE square, their lattices in those pictures' pixels, line ink unknown."""
    import cv2

    from oxbot.perception.grid_points import picture_of

    pictures, lattices, sizes = [], [], []
    for folder in folders:
        listed = folder / LATTICES
        if not listed.is_file():
            raise FileNotFoundError(
                f"{folder} has no {LATTICES}: fine-tune on folders of photos with their "
                "lattices, as bench/compose_boards.py writes them"
            )
        for name, lattice in sorted(json.loads(listed.read_text(encoding="utf-8")).items()):
            image = cv2.imread(str(folder / "images" / name), cv2.IMREAD_COLOR)
            if image is None:
                raise FileNotFoundError(f"{folder / 'images' / name} is listed but unreadable")
            picture, scale = picture_of(image[:, :, ::-1])
            h, w = (round(n / scale) for n in image.shape[:2])
            square = np.zeros((INPUT_SIDE, INPUT_SIDE, 3), np.uint8)
            square[:h, :w] = np.round(picture[:, :h, :w].transpose(1, 2, 0) * 255)
            pictures.append(square)
            lattices.append((np.asarray(lattice, np.float32) + 0.5) / scale - 0.5)
            sizes.append((w, h))
    n = len(pictures)
    if n == 0:
        raise FileNotFoundError(f"no photos listed in {', '.join(map(str, folders))}")
    side = INPUT_SIDE // STRIDE
    return Renders(
        np.stack(pictures),
        np.stack(lattices),
        np.zeros((n, side, side), np.uint8),
        np.ones(n, bool),
        np.array(sizes),
        np.zeros(n, bool),
    )


def point_targets(lattices: np.ndarray, sigma: float) -> np.ndarray:
    """Heatmap targets (N, 2, side, side) of lattices (N, 4, 4, 2) in picture pixels: the
    CROSSINGS and OUTER channels, the maximum of the Gaussian peaks (nan lattices: none)."""
    side = INPUT_SIDE // STRIDE
    n = len(lattices)
    targets = np.zeros((n, 2, side, side), np.float32)
    ys, xs = np.mgrid[0:side, 0:side].astype(np.float32)
    inner = np.zeros((4, 4), bool)
    inner[1:3, 1:3] = True
    for i in range(n):
        if np.isnan(lattices[i]).any():
            continue
        points = (lattices[i] + 0.5) / STRIDE - 0.5  # picture pixels to heatmap pixels
        for channel, mask in ((0, inner), (1, ~inner)):
            for x, y in points[mask]:
                if not (-3 * sigma < x < side + 3 * sigma and -3 * sigma < y < side + 3 * sigma):
                    continue
                peak = np.exp(-((xs - x) ** 2 + (ys - y) ** 2) / (2 * sigma**2))
                np.maximum(targets[i, channel], peak, out=targets[i, channel])
    return targets


def focal_loss(logits: Any, targets: Any) -> Any:
    """CenterNet's penalty-reduced focal loss (Zhou et al. 2019), per positive point."""
    import torch

    p = torch.sigmoid(logits).clamp(1e-4, 1 - 1e-4)
    positive = targets > 0.99
    pos_loss = -((1 - p) ** 2) * torch.log(p) * positive
    neg_loss = -((1 - targets) ** 4) * p**2 * torch.log(1 - p) * ~positive
    points = positive.sum().clamp(min=1)
    return (pos_loss.sum() + neg_loss.sum()) / points


def _batch(renders: Renders, index: np.ndarray, sigma: float, rng: np.random.Generator) -> tuple:
    """Tensors of one batch, each picture flipped and turned by a quarter at random."""
    import torch

    pictures = renders.pictures[index].copy()
    lines = renders.lines[index].copy()
    points = point_targets(renders.lattices[index], sigma)
    for k in range(len(index)):
        turns, flip = int(rng.integers(4)), bool(rng.integers(2))
        if flip:
            pictures[k], lines[k] = pictures[k][:, ::-1], lines[k][:, ::-1]
            points[k] = points[k][:, :, ::-1]
        pictures[k] = np.rot90(pictures[k], turns)
        lines[k] = np.rot90(lines[k], turns)
        points[k] = np.rot90(points[k], turns, axes=(1, 2))
    x = torch.from_numpy(pictures.transpose(0, 3, 1, 2).astype(np.float32) / 255.0)
    heat = np.concatenate([points, lines[:, None].astype(np.float32)], axis=1)
    present = torch.from_numpy(renders.present[index].astype(np.float32))
    lines_known = torch.from_numpy(renders.line_truth[index].astype(np.float32))
    return x, torch.from_numpy(np.ascontiguousarray(heat)), present, lines_known


def loss_of(net: GridPointNet, batch: tuple) -> Any:
    """The training loss of one batch: points, lines (where known) and presence."""
    from torch.nn import functional

    x, heat, present, lines_known = batch
    logits, presence = net(x)
    points = focal_loss(logits[:, [CROSSINGS, OUTER]], heat[:, :2])
    per_picture = functional.binary_cross_entropy_with_logits(
        logits[:, LINES], heat[:, 2], reduction="none"
    ).mean(dim=(1, 2))
    lines = (per_picture * lines_known).sum() / lines_known.sum().clamp(min=1)
    there = functional.binary_cross_entropy_with_logits(presence, present)
    return points + 0.5 * lines + 0.5 * there


def measure(finder: LearnedGridFinder, renders: Renders) -> dict[str, float]:
    """How well `finder` finds the grids of `renders`: mean and median distance of the 16
    lattice points from the truth in picture pixels (and per cell side), grids found, and
    renders without a grid given one."""
    errors, relative, found, false_grids = [], [], 0, 0
    for i in range(len(renders.pictures)):
        w, h = renders.sizes[i]
        grid = finder.look(renders.pictures[i][:h, :w]).grid
        if not renders.present[i]:
            false_grids += grid is not None
            continue
        if grid is None:
            continue
        found += 1
        truth = renders.lattices[i]
        distance = np.linalg.norm(grid.lattice - truth, axis=2)
        cell = np.linalg.norm(np.diff(truth, axis=1), axis=2).mean()
        errors.append(float(distance.mean()))
        relative.append(float(distance.mean() / cell))
    grids = int(renders.present.sum())
    return {
        "grids": grids,
        "found": found,
        "found_share": found / max(1, grids),
        "mean_point_error_px": float(np.mean(errors)) if errors else math.nan,
        "median_point_error_px": float(np.median(errors)) if errors else math.nan,
        "within_a_tenth_of_a_cell": float(np.mean(np.array(relative) < 0.1)) if relative else 0.0,
        "without_grid": int((~renders.present).sum()),
        "false_grids": false_grids,
    }


@dataclass(frozen=True)
class TrainedReader:
    """What `train_reader` wrote, and its figures."""

    model_path: Path
    metrics_path: Path
    curve_path: Path
    metrics: dict[str, Any]


def train_reader(
    config: GridModelConfig, out: str | Path, show_progress: bool = True
) -> TrainedReader:
    """Train the grid-point network from nothing on `config.scenes` renders; write the model,
    its metrics JSON and learning curve beside `out`."""
    import torch

    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    states = np.random.SeedSequence(config.seed).generate_state(
        config.scenes + config.validation_scenes
    )
    tick = time.perf_counter()
    seeds = [int(s) for s in states]
    train = render(seeds[: config.scenes], config.threads, show_progress, "training renders")
    valid = render(seeds[config.scenes :], config.threads, show_progress, "validation renders")
    render_seconds = time.perf_counter() - tick
    net = GridPointNet(config.width)
    fitted = _fit(
        net,
        train,
        {"": valid},
        config.epochs,
        config.learning_rate,
        config,
        np.random.default_rng(config.seed),
        show_progress,
    )
    metrics = {
        "config": dataclasses.asdict(config),
        "render_seconds": render_seconds,
        "train_seconds": fitted.seconds,
        "validation": fitted.curve[-1],
        "curve": fitted.curve,
    }
    return _written(net, config, metrics, {}, Path(out))


def finetune_reader(
    config: GridModelConfig,
    start: str | Path,
    folders: list[Path],
    out: str | Path,
    show_progress: bool = True,
) -> TrainedReader:
    """Go on training the model at `start` on the photos of `folders` (each with `images/` and
    `lattices.json`) and `config.finetune_renders` fresh renders, for `config.finetune_epochs`;
    write the model, its metrics JSON and learning curve beside `out`."""
    import torch

    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    begun = LearnedGridFinder.load(start)
    if begun.info.get("width") != config.width:
        raise ValueError(
            f"{start} has width {begun.info.get('width')}, the config {config.width}: fine-tune "
            "with the config the model was trained with"
        )
    photos = load_photos([Path(f) for f in folders])
    rng = np.random.default_rng([config.seed, 1])
    order = rng.permutation(len(photos))
    kept_apart = max(1, round(FINETUNE_VALIDATION_SHARE * len(photos)))
    tick = time.perf_counter()
    fresh = np.random.SeedSequence([config.seed, 1]).generate_state(config.finetune_renders)
    renders = render([int(s) for s in fresh], config.threads, show_progress, "fresh renders")
    states = np.random.SeedSequence(config.seed).generate_state(
        config.scenes + config.validation_scenes
    )
    valid = render(
        [int(s) for s in states[config.scenes :]], config.threads, show_progress, "validation"
    )
    render_seconds = time.perf_counter() - tick
    net = begun.net
    before = {
        "renders": measure(LearnedGridFinder(net), valid),
        "photos": measure(LearnedGridFinder(net), photos.take(order[:kept_apart])),
    }
    fitted = _fit(
        net,
        joined(photos.take(order[kept_apart:]), renders),
        {"": valid, "photos_": photos.take(order[:kept_apart])},
        config.finetune_epochs,
        config.finetune_learning_rate,
        config,
        rng,
        show_progress,
    )
    metrics = {
        "config": dataclasses.asdict(config),
        "finetuned_from": {"path": str(start), "sha256": _sha256(Path(start))},
        "photos": {
            "folders": [str(f) for f in folders],
            "trained_on": len(photos) - kept_apart,
            "kept_apart": kept_apart,
        },
        "before": before,
        "render_seconds": render_seconds,
        "train_seconds": fitted.seconds,
        "validation": fitted.curve[-1],
        "curve": fitted.curve,
    }
    extra = {"finetuned_from": metrics["finetuned_from"], "photos": metrics["photos"]}
    return _written(net, config, metrics, extra, Path(out))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


FINETUNE_VALIDATION_SHARE = 0.1
"""The share of fine-tuning photos kept apart to follow it with."""


@dataclass(frozen=True)
class _Fitted:
    curve: list[dict[str, float]]
    seconds: float


def _fit(
    net: GridPointNet,
    train: Renders,
    valid: dict[str, Renders],
    epochs: int,
    learning_rate: float,
    config: GridModelConfig,
    rng: np.random.Generator,
    show_progress: bool,
) -> _Fitted:
    """AdamW with a one-cycle schedule peaking at `learning_rate` over `epochs` passes of
    `train`; after each, `measure` on every set of `valid`, its figures named with its key
    as a prefix."""
    import torch
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    steps_per_epoch = math.ceil(len(train) / config.batch_size)
    optimiser = torch.optim.AdamW(
        net.parameters(), lr=learning_rate, weight_decay=config.weight_decay
    )
    schedule = torch.optim.lr_scheduler.OneCycleLR(
        optimiser, learning_rate, total_steps=epochs * steps_per_epoch
    )
    curve: list[dict[str, float]] = []
    tick = time.perf_counter()
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} steps"),
        TimeElapsedColumn(),
        disable=not show_progress,
        transient=True,
    ) as progress:
        task = progress.add_task("training", total=epochs * steps_per_epoch)
        for epoch in range(epochs):
            net.train()
            order = rng.permutation(len(train))
            losses = []
            for step in range(steps_per_epoch):
                index = order[step * config.batch_size : (step + 1) * config.batch_size]
                loss = loss_of(net, _batch(train, index, config.heat_sigma, rng))
                optimiser.zero_grad()
                loss.backward()
                optimiser.step()
                schedule.step()
                losses.append(float(loss.detach()))
                progress.update(task, advance=1, description=f"epoch {epoch + 1}: {losses[-1]:.3f}")
            point: dict[str, float] = {"epoch": epoch + 1, "loss": float(np.mean(losses))}
            for prefix, renders in valid.items():
                figures = measure(LearnedGridFinder(net), renders)
                point |= {prefix + k: v for k, v in figures.items()}
            curve.append(point)
            log.info("epoch %d: %s", epoch + 1, point)
    net.eval()
    return _Fitted(curve, time.perf_counter() - tick)


def _written(
    net: GridPointNet,
    config: GridModelConfig,
    metrics: dict[str, Any],
    extra: dict[str, Any],
    out: Path,
) -> TrainedReader:
    """The model (with its config, seed, figures and `extra`), its metrics JSON and learning
    curve, written beside `out`."""
    out.parent.mkdir(parents=True, exist_ok=True)
    payload = {
        "state_dict": net.state_dict(),
        "width": config.width,
        "config": dataclasses.asdict(config),
        "seed": config.seed,
        "metrics": {k: v for k, v in metrics.items() if k != "curve"},
        **extra,
    }
    model_path = artifacts.save(out, KIND, VERSION, payload)
    metrics_path = out.with_suffix(".metrics.json")
    write_text_atomic(metrics_path, json.dumps(metrics, indent=2) + "\n")
    curve_path = plot_curve(metrics["curve"], out.with_suffix(".curve.png"))
    return TrainedReader(model_path, metrics_path, curve_path, metrics)


def plot_curve(curve: list[dict[str, float]], path: Path) -> Path:
    """Training loss and the validation renders' point error and grids found, by epoch."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    epochs = [p["epoch"] for p in curve]
    fig, (left, right) = plt.subplots(1, 2, figsize=(8, 3.2), dpi=110)
    left.plot(epochs, [p["loss"] for p in curve], "o-")
    left.set_xlabel("epoch")
    left.set_ylabel("training loss")
    left.set_yscale("log")
    found = right.twinx()
    for prefix, what, colour in (("", "renders", "tab:blue"), ("photos_", "photos", "tab:orange")):
        if prefix + "found_share" not in curve[0]:
            continue
        errors = [p[prefix + "median_point_error_px"] for p in curve]
        right.plot(epochs, errors, "o-", color=colour, label=f"{what}: median error")
        shares = [100 * p[prefix + "found_share"] for p in curve]
        found.plot(epochs, shares, "s:", color=colour, label=f"{what}: found")
    right.set_xlabel("epoch")
    right.set_ylabel(f"lattice point error (px of {INPUT_SIDE})")
    found.set_ylabel("validation grids found (%, dotted)")
    right.legend(loc="upper left", fontsize=7)
    for ax in (left, right):
        ax.grid(True, alpha=0.3)
    fig.suptitle("Learning to find the grid: heatmaps of its points")
    fig.tight_layout()
    return save_figure(fig, path)


__all__ = [
    "TrainedReader",
    "finetune_reader",
    "joined",
    "load_photos",
    "measure",
    "render",
    "train_reader",
]
