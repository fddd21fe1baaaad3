"""Training the perceiver (paper §3.3): generate images from the seeds, fit, measure, plot.

`train_perceiver` writes three files side by side: the model (`perceiver.pt`), its metrics
(`perceiver.metrics.json`) and the learning curve of accuracy against the number of training
images (`perceiver.curve.png`, the paper's Figure "plots", left). The curve retrains the same
classifier on the first 100, 300, 1,000, 3,000 ... of the generated images and measures each on
the same 1,000 test images; the last point is the shipped model itself.

    result = train_perceiver(PerceptionConfig(), out="runs/perceiver/perceiver.pt")
    result.metrics["test"]["accuracy"]
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from oxbot import artifacts
from oxbot.atomic import save_figure, write_text_atomic
from oxbot.config import PerceptionConfig
from oxbot.errors import DataError, ModelFileError, TrainingInterrupted
from oxbot.interrupt import deferred_interrupt
from oxbot.perception.augment import generate
from oxbot.perception.classifier import SymbolClassifier
from oxbot.perception.evaluation import (
    CALIBRATION_STREAM,
    TRAIN_STREAM,
    evaluate,
    evaluate_fonts,
    generated_test_set,
)
from oxbot.perception.seeds import LabelledImages, load_seeds

log = logging.getLogger(__name__)

CURVE_SIZES = (100, 300, 1_000, 3_000)
"""oxbot: the smaller training sets of the learning curve, below the full one."""
WHOLE_AS_PARTIAL = 0.003
"""oxbot: after training with `partial_output`, the "partial" output is lowered until
at most this share of held-out whole symbols read as partial. Without it, open circles on
rendered boards read as partial often enough to drop whole-board reading from 98.5% to 90%."""
CHECKPOINT_FORMAT = "oxbot-perceiver-checkpoint/1"
CHECKPOINT_KIND = "perceiver-checkpoint"
CHECKPOINT_VERSION = 1


@dataclass
class TrainingResult:
    """The trained classifier, its metrics and the files written."""

    classifier: SymbolClassifier
    metrics: dict[str, Any]
    model_path: Path | None
    metrics_path: Path | None
    curve_path: Path | None


def companion_paths(model_path: str | Path) -> tuple[Path, Path]:
    """The metrics JSON and learning-curve PNG written beside a model file."""
    path = Path(model_path)
    return path.with_suffix(".metrics.json"), path.with_suffix(".curve.png")


def checkpoint_path(model_path: str | Path) -> Path:
    """The checkpoint an interrupted run leaves beside its model file."""
    return Path(model_path).with_suffix(".checkpoint.pt")


def train_perceiver(
    config: PerceptionConfig | None = None,
    images: int | None = None,
    seeds_dir: str | Path | None = None,
    out: str | Path | None = None,
    curve: bool = True,
    show_progress: bool = True,
    resume: bool = True,
) -> TrainingResult:
    """Generate `images` (10K) training images from the seeds, train, measure and save.

    With `out` None nothing is written. `curve` False skips the learning curve's extra runs.
    Each finished fit of the curve is kept in a checkpoint beside `out` (`checkpoint_path`);
    Ctrl-C saves it and raises `TrainingInterrupted`, and with `resume` a later run with the
    same settings skips those fits. The checkpoint is deleted once the model is written.
    """
    config = config if config is not None else PerceptionConfig()
    n = images if images is not None else config.train_images
    if n < 3:
        raise DataError(f"--images is {n}; train on at least 3 images, one per label")
    seeds = load_seeds(seeds_dir, size=config.image_size)

    started = time.perf_counter()
    train_rng = np.random.default_rng([config.seed, TRAIN_STREAM])
    x, y = generate(seeds, n, train_rng, config.image_size, partial=config.partial_output)
    generate_s = time.perf_counter() - started
    test_x, test_y = generated_test_set(seeds, config.test_images, config.seed, config.image_size)

    sizes = [*([s for s in CURVE_SIZES if s < n] if curve else []), n]
    checkpoint = checkpoint_path(out) if out is not None else None
    settings = {
        "config": dataclasses.asdict(config),
        "images": n,
        "seeds": str(seeds.folder),
        "sizes": sizes,
    }
    points: list[dict[str, float]] = []
    if checkpoint is not None and resume and checkpoint.exists():
        points = _load_checkpoint(checkpoint, settings)
        log.info("resuming from %s: %d of %d fits done", checkpoint, len(points), len(sizes))

    def keep(point_list: list[dict[str, float]]) -> None:
        if checkpoint is not None:
            _save_checkpoint(checkpoint, settings, point_list)

    with deferred_interrupt() as stop:
        try:
            with stop.immediately():  # a fit cut short is simply redone on resuming
                clf = _fit_along_the_curve(
                    config, (x, y), (test_x, test_y), sizes, points, keep, show_progress
                )
        except KeyboardInterrupt:
            if checkpoint is None:
                raise
            keep(points)
            raise TrainingInterrupted(
                f"training interrupted after {len(points)} of {len(sizes)} fits "
                f"({', '.join(f'{s:,}' for s in sizes)} images); saved the checkpoint "
                f"{checkpoint}",
                checkpoint,
                len(points),
            ) from None

    calibration = calibrate(clf, seeds)
    test = evaluate(clf, test_x, test_y, "generated")
    points[-1]["accuracy"] = test.accuracy  # the curve ends at the shipped model, offset and all
    try:
        fonts = evaluate_fonts(clf, seed=config.seed).to_dict()
    except DataError as exc:  # no fonts installed: the metrics say so instead
        fonts = {"error": str(exc)}
    metrics: dict[str, Any] = {
        "train_images": n,
        "generate_seconds": round(generate_s, 3),
        "fit_seconds": round(points[-1]["fit_seconds"], 3),
        "test": test.to_dict(),
        **calibration,
        "fonts": fonts,
        "learning_curve": points,
        "seeds": str(seeds.folder),
        "seed_images": {label: len(v) for label, v in seeds.images.items()},
        "config": dataclasses.asdict(config),
    }
    clf.metadata.update(
        seeds=str(seeds.folder),
        generate_seconds=metrics["generate_seconds"],
        fit_seconds=metrics["fit_seconds"],
        test_accuracy=test.accuracy,
    )

    model_path = metrics_path = curve_path = None
    if out is not None:
        model_path = clf.save(out)
        metrics_path, curve_path = companion_paths(model_path)
        write_text_atomic(metrics_path, json.dumps(metrics, indent=2) + "\n")
        plot_learning_curve(points, curve_path)
        checkpoint_path(model_path).unlink(missing_ok=True)  # done: nothing left to resume
    return TrainingResult(clf, metrics, model_path, metrics_path, curve_path)


def calibrate(clf: SymbolClassifier, seeds: LabelledImages) -> dict[str, Any]:
    """Fit `clf`'s softmax temperature (and, for a four-output model, lower its partial output
    first, `WHOLE_AS_PARTIAL`) on held-out images that neither training nor testing sees:
    `config.test_images` of them from the calibration stream, of the model's own outputs.

    Returns what goes into the metrics: the temperature, and for a four-output model the
    partial offset and its accuracy on generated cells with partial ones among them."""
    config = clf.config
    rng = np.random.default_rng([config.seed, CALIBRATION_STREAM])
    partial = config.partial_output
    cal_x, cal_y = generate(seeds, config.test_images, rng, config.image_size, partial=partial)
    if not partial:
        return {"temperature": clf.fit_temperature(cal_x, cal_y)}
    partial_offset = clf.lower_partial(cal_x, cal_y, WHOLE_AS_PARTIAL)
    temperature = clf.fit_temperature(cal_x, cal_y)
    with_partial = evaluate(
        clf,
        *generated_test_set(seeds, config.test_images, config.seed, config.image_size, True),
        "generated with partial",
    )
    return {
        "test_with_partial": with_partial.to_dict(),
        "temperature": temperature,
        "partial_offset": partial_offset,
    }


def _fit_along_the_curve(
    config: PerceptionConfig,
    train: tuple[np.ndarray, np.ndarray],
    test: tuple[np.ndarray, np.ndarray],
    sizes: list[int],
    points: list[dict[str, float]],
    keep: Callable[[list[dict[str, float]]], None],
    show_progress: bool,
) -> SymbolClassifier:
    """A classifier fitted afresh on the first `size` training images for each of `sizes`,
    each measured on the test images; the last classifier.

    Each point of the learning curve is appended to `points` and handed to `keep` as soon as
    it is measured; the fits of points already there are skipped, except the last one, whose
    classifier is the result."""
    (x, y), (test_x, test_y) = train, test
    del points[len(sizes) - 1 :]  # the last fit is always made: it is the model
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
        disable=not show_progress,
        transient=True,
    ) as progress:
        offset = config.epochs * sum(sizes[: len(points)])
        task = progress.add_task(
            "training the perceiver", total=config.epochs * sum(sizes), completed=offset
        )
        for size in sizes[len(points) :]:
            progress.update(task, description=f"training on {size:,} images")
            log.info("training on %d images", size)
            base = offset
            tick = time.perf_counter()
            clf = SymbolClassifier(config).fit(
                x[:size],
                y[:size],
                progress=lambda done, b=base: progress.update(task, completed=b + done),
            )
            seconds = time.perf_counter() - tick
            offset += config.epochs * size
            accuracy = evaluate(clf, test_x, test_y).accuracy
            points.append({"images": size, "accuracy": accuracy, "fit_seconds": seconds})
            keep(points)
            log.info("%d images: accuracy %.4f in %.1f s", size, accuracy, seconds)
    return clf


def _save_checkpoint(path: Path, settings: dict[str, Any], points: list[dict[str, float]]) -> None:
    payload = {"format": CHECKPOINT_FORMAT, "settings": settings, "points": points}
    artifacts.save(path, CHECKPOINT_KIND, CHECKPOINT_VERSION, payload)


def _load_checkpoint(path: Path, settings: dict[str, Any]) -> list[dict[str, float]]:
    """The finished points of the learning curve an interrupted run saved with `settings`."""
    what = "perceiver checkpoint"
    remedy = "delete it, or start afresh with --no-resume"
    payload = artifacts.load(path, CHECKPOINT_KIND, CHECKPOINT_VERSION, what, remedy)
    with artifacts.checked(path, what, remedy):
        if payload["format"] != CHECKPOINT_FORMAT:
            raise ValueError(f"format {payload['format']!r}")
        saved = dict(payload["settings"])
        points = [
            {
                "images": int(p["images"]),
                "accuracy": float(p["accuracy"]),
                "fit_seconds": float(p["fit_seconds"]),
            }
            for p in payload["points"]
        ]
    changed = sorted(k for k in settings if saved.get(k) != settings[k])
    if changed:
        raise ModelFileError(
            f"perceiver checkpoint {path} was made with other settings ({', '.join(changed)}); "
            "use the same settings to resume, or --no-resume"
        )
    if [p["images"] for p in points] != settings["sizes"][: len(points)]:
        raise ModelFileError(f"perceiver checkpoint {path} is inconsistent; {remedy}")
    return points


def plot_learning_curve(points: list[dict[str, float]], path: str | Path) -> Path:
    """Accuracy (and training time, dotted) against the number of training images, as a PNG."""

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = [p["images"] for p in points]
    fig, ax = plt.subplots(figsize=(5, 3.4), dpi=110)
    ax.plot(sizes, [100 * p["accuracy"] for p in points], "o-", color="tab:blue")
    ax.set_xscale("log")
    ax.set_xlabel("training images")
    ax.set_ylabel("accuracy on 1,000 test images (%)", color="tab:blue")
    ax.grid(True, alpha=0.3)
    seconds = ax.twinx()
    seconds.plot(sizes, [p["fit_seconds"] for p in points], ":", color="tab:green")
    seconds.set_ylabel("training time (s)", color="tab:green")
    ax.set_title("Learning to perceive: CNN+SVM")
    fig.tight_layout()
    return save_figure(fig, path)
