"""`oxbot learn perceiver`: fine-tune the classifier on the crops of recorded games.

The recorded crops carry labels the finished games confirmed (`oxbot.recording.recorder`).
Their drawings are split (whole drawings, never single crops of one, since a drawing is read
many times) into a training part and a held-back part (`held_back`) that only measures. The
shipped model is fine-tuned on the training part, its first convolution stage kept as it is
(`frozen_stages`), each crop weighted by how unsure or wrong the model was about it (active
learning: 1 + `uncertainty_weight` x (1 - its probability of the right label)), mixed with
`replay_images` images generated from the seeds as in training, so that what it knew stays
known. The softmax temperature is fitted again as in training.

The new model is measured before and after on the held-back crops and on the project's test
sets (1,000 generated images; the handwriting-font set); it is refused
(`LearningRefused`) if any test set is worse than before (by more than `tolerance`) or the
person's own held-back crops are not better read. Written beside `out`: the model (with its
config, seed and metrics), `.metrics.json` and `.before_after.png`; each is registered as
derived from the sessions used before it is written, so forgetting one of them deletes them. A
refused model's metrics and plot are `.refused.metrics.json` and `.refused.before_after.png`:
the kept model's stay as they were.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import torch
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from torch import nn

from oxbot.atomic import save_figure, write_text_atomic
from oxbot.errors import DataError, InvalidInputError, LearningRefused
from oxbot.image_size import check_pixels
from oxbot.perception.augment import generate
from oxbot.perception.classifier import (
    SymbolClassifier,
    _turn_or_flip,
    label_indices,
    load_classifier,
    to_input,
    torch_threads,
)
from oxbot.perception.evaluation import TRAIN_STREAM, evaluate, evaluate_fonts, evaluate_generated
from oxbot.perception.seeds import load_seeds
from oxbot.perception.training import calibrate
from oxbot.recording.derived import make_private
from oxbot.recording.store import RecordingStore

log = logging.getLogger(__name__)

CROP_SIZE = 40
"""The recorded crops' side in pixels (the classifier's input)."""
STAGE_LAYERS = 3
"""Layers of one convolution stage in `SymbolNet.features`: convolution, ReLU, max pooling."""
LEARN_STREAM = 18
"""The replayed generated images come from `default_rng([seed, TRAIN_STREAM, LEARN_STREAM])`."""


@dataclass(frozen=True)
class LearnPerceiverConfig:
    """How the perceiver is fine-tuned on recorded crops (oxbot; the paper has no such step)."""

    seed: int = 0
    """Seed of the split, the replayed images and the fine-tuning."""
    held_back: float = 0.25
    """Share of the person's drawings kept back to measure on (at least one per label)."""
    uncertainty_weight: float = 4.0
    """A crop's weight is 1 + this x (1 - the model's probability of its right label)."""
    person_repeats: int = 8
    """Each recorded crop is shown this many times per epoch (in different turns and flips); at
    4 a plus-shaped hand's crosses were still read as circles now and then (98.89% of its later
    cells with one seed, docs/learning.md)."""
    replay_images: int = 3_000
    """Generated images from the seeds mixed in, so that the model keeps what it knew."""
    epochs: int = 4
    """Passes over the mix."""
    learning_rate: float = 0.001
    """Adam step size, falling to 0 by cosine (a tenth of training's: a fine-tune; at 0.002 the
    generated test set lost 0.2 points, at 0.0005 the font set 0.07)."""
    batch_size: int = 64
    """Images per step."""
    tolerance: float = 0.0
    """How much worse (accuracy) a project test set may get before the model is refused."""
    font_images: int = 1_500
    """Cells of the handwriting-font test set (as `evaluate perceiver`)."""
    frozen_stages: int = 1
    """Convolution stages kept as shipped (0-2). The first stage's filters find strokes, which
    a new hand draws too; what is new is how they combine. Keeping it halved the replayed-like
    images the fine-tune newly got wrong on development seeds (docs/learning.md)."""

    def __post_init__(self) -> None:
        if not 0.0 < self.held_back < 1.0:
            raise DataError(f"held_back is {self.held_back}; keep back a share in (0, 1)")
        if min(self.epochs, self.batch_size, self.person_repeats) < 1 or self.replay_images < 0:
            raise DataError("epochs, batch_size and person_repeats must be >= 1")
        if not 0 <= self.frozen_stages <= 2:
            raise DataError(f"frozen_stages is {self.frozen_stages}; the network has 2 (0-2)")


@dataclass
class LearnPerceiverResult:
    classifier: SymbolClassifier
    metrics: dict[str, Any]
    model_path: Path | None
    metrics_path: Path | None
    plot_path: Path | None


def decode_crops(rows: list[dict[str, Any]], size: int = CROP_SIZE) -> np.ndarray:
    """The recorded crops' PNGs as uint8 (N, size, size) gray; a DataError for one that is not
    such a PNG (its header is read before it is decoded, so a huge one costs nothing)."""
    images = []
    for r in rows:
        data = r["image"]
        what = f"the crop of cell {r.get('cell', '?')} in session {r.get('session_id', '?')}"
        try:
            found = check_pixels(data, what, size * size) if isinstance(data, bytes) else None
        except InvalidInputError as exc:
            raise DataError(f"{exc}; the recordings database is damaged") from None
        image = None
        if found == (size, size):
            image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
        if image is None or image.shape != (size, size):
            raise DataError(
                f"{what} is not a readable {size}x{size} PNG; the recordings database is damaged: "
                f"forget that session (oxbot data forget {r.get('session_id', '?')})"
            )
        images.append(image)
    if not images:
        return np.zeros((0, size, size), np.uint8)
    return np.stack(images)


def split_drawings(
    rows: list[dict[str, Any]], share: float, rng: np.random.Generator
) -> np.ndarray:
    """True for the crops held back: whole drawings (a session's cell), `share` of each label's."""
    groups: dict[str, list[tuple[int, int]]] = {}
    for r in rows:
        groups.setdefault(r["label"], [])
        key = (r["session_id"], r["cell"])
        if key not in groups[r["label"]]:
            groups[r["label"]].append(key)
    held: set[tuple[int, int]] = set()
    for keys in groups.values():
        if len(keys) < 2:
            continue  # a single drawing of a label is needed to learn it
        n = min(len(keys) - 1, max(1, round(share * len(keys))))
        held.update(keys[i] for i in rng.choice(len(keys), n, replace=False))
    return np.array([(r["session_id"], r["cell"]) in held for r in rows], bool)


def learn_perceiver(
    store: RecordingStore,
    out: str | Path | None,
    config: LearnPerceiverConfig | None = None,
    base: str | Path | None = None,
    session_ids: list[int] | None = None,
    show_progress: bool = True,
) -> LearnPerceiverResult:
    """Fine-tune the classifier at `base` (the shipped one) on the recorded crops; measure,
    refuse or write (see the module docstring). Nothing is written when `out` is None."""
    config = config if config is not None else LearnPerceiverConfig()
    store.check_integrity()  # never learn from a damaged file
    rows = store.labelled_crops(session_ids)
    if not rows:
        raise DataError(
            f"no labelled crops in {store.path}: record finished games first (oxbot play --record)"
        )
    sessions = sorted({r["session_id"] for r in rows})
    rng = np.random.default_rng(config.seed)
    images = decode_crops(rows)
    labels = label_indices([r["label"] for r in rows])
    held = split_drawings(rows, config.held_back, rng)
    if not held.any() or held.all():
        raise DataError(
            f"{len(rows)} labelled crops from {len(sessions)} sessions are too few drawings to "
            "keep some back to measure on; record more games"
        )
    before = load_classifier(base)
    seeds = load_seeds(size=before.image_size)

    def measure(clf: SymbolClassifier) -> dict[str, Any]:
        return {
            "held_back": evaluate(clf, images[held], labels[held], "held-back crops").to_dict(),
            "recorded_train": evaluate(
                clf, images[~held], labels[~held], "training crops"
            ).to_dict(),
            "generated": evaluate_generated(clf, seeds).to_dict(),
            "fonts": evaluate_fonts(clf, config.font_images, seed=clf.config.seed).to_dict(),
        }

    metrics_before = measure(before)
    after = _fine_tune(before, images[~held], labels[~held], seeds, config, show_progress)
    calibrate(after, seeds)
    metrics_after = measure(after)

    def acc(m: dict[str, Any], key: str) -> float:
        return float(m[key]["accuracy"])

    worse = [
        key
        for key in ("generated", "fonts")
        if acc(metrics_after, key) < acc(metrics_before, key) - config.tolerance
    ]
    if acc(metrics_after, "held_back") <= acc(metrics_before, "held_back") < 1.0:
        worse.append("held_back")
    metrics: dict[str, Any] = {
        "sessions": sessions,
        "crops": {"train": int((~held).sum()), "held_back": int(held.sum())},
        "drawings_held_back": len(
            {(r["session_id"], r["cell"]) for r, h in zip(rows, held, strict=True) if h}
        ),
        "before": metrics_before,
        "after": metrics_after,
        "refused": worse,
        "config": dataclasses.asdict(config),
        "base": str(base) if base is not None else "shipped",
    }
    model_path = metrics_path = plot_path = None
    if out is not None:
        out = Path(out)
        # a refused model's figures go beside the kept model's, never over them
        refused = ".refused" if worse else ""
        metrics_path = out.with_suffix(f"{refused}.metrics.json")
        plot_path = out.with_suffix(f"{refused}.before_after.png")
        written = [metrics_path, plot_path] + ([] if worse else [out])
        store.register_derived(written, sessions, "perceiver")  # before: nothing unregistered
        write_text_atomic(metrics_path, json.dumps(metrics, indent=2) + "\n")
        plot_before_after(metrics, plot_path)
        if not worse:
            model_path = after.save(
                out,
                learned_from_sessions=sessions,
                learn_config=dataclasses.asdict(config),
                learn_metrics={
                    k: acc(metrics_after, k) for k in ("held_back", "generated", "fonts")
                },
            )
        make_private(written)
    result = LearnPerceiverResult(after, metrics, model_path, metrics_path, plot_path)
    if worse:
        raise LearningRefused(
            "the fine-tuned perceiver is refused: "
            + ", ".join(
                f"{k} {acc(metrics_before, k):.2%} -> {acc(metrics_after, k):.2%}" for k in worse
            )
            + (f"; see {metrics_path}" if metrics_path else "")
            + ". The shipped model stays in use; record more games, or try another --seed (a "
            "fine-tune that loses a single cell of a test set is refused too)",
            result,
        )
    return result


def _fine_tune(
    base: SymbolClassifier,
    x_person: np.ndarray,
    y_person: np.ndarray,
    seeds: Any,
    config: LearnPerceiverConfig,
    show_progress: bool,
) -> SymbolClassifier:
    """A copy of `base` trained further on the person's crops (weighted by how unsure it was)
    and on generated images."""
    clf = SymbolClassifier(base.config, seed=config.seed)
    clf.net.load_state_dict(base.net.state_dict())
    clf.metadata = dict(base.metadata)
    # active learning: the crops the model was unsure or wrong about count more
    p_right = base.probabilities(x_person)[np.arange(len(y_person)), y_person]
    w_person = 1.0 + config.uncertainty_weight * (1.0 - p_right)
    rng = np.random.default_rng([config.seed, TRAIN_STREAM, LEARN_STREAM])
    x = to_input(np.repeat(x_person, config.person_repeats, axis=0))
    x_gen, y_gen = x_person[:0], y_person[:0]
    if config.replay_images:
        x_gen, y_gen = generate(seeds, config.replay_images, rng, base.image_size)
        x = torch.cat([x, to_input(x_gen)])
    y = torch.from_numpy(np.concatenate([np.repeat(y_person, config.person_repeats), y_gen]))
    w = torch.from_numpy(
        np.concatenate([np.repeat(w_person, config.person_repeats), np.ones(len(y_gen))])
    ).float()
    steps = config.epochs * math.ceil(len(x) / config.batch_size)
    net = clf.net.train()
    for layer in list(net.features)[: STAGE_LAYERS * config.frozen_stages]:
        layer.requires_grad_(False)
    optimiser = torch.optim.Adam(
        [q for q in net.parameters() if q.requires_grad],
        lr=config.learning_rate,
        weight_decay=base.config.weight_decay,
    )
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, steps)
    loss_fn = nn.MultiMarginLoss(margin=1.0, reduction="none")
    torch_rng = torch.Generator().manual_seed(config.seed)
    with (
        torch_threads(base.config.threads),
        Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TimeElapsedColumn(),
            disable=not show_progress,
            transient=True,
        ) as progress,
    ):
        task = progress.add_task("fine-tuning the perceiver", total=steps)
        for _ in range(config.epochs):
            order = torch.randperm(len(x), generator=torch_rng)
            for start in range(0, len(x), config.batch_size):
                batch = order[start : start + config.batch_size]
                k = int(torch.randint(8, (1,), generator=torch_rng))
                losses = loss_fn(net(_turn_or_flip(x[batch], k)), y[batch])
                loss = (losses * w[batch]).sum() / w[batch].sum()
                optimiser.zero_grad(set_to_none=True)
                loss.backward()
                optimiser.step()
                schedule.step()
                progress.advance(task)
    net.eval()
    clf.fitted = True
    return clf


def plot_before_after(metrics: dict[str, Any], path: str | Path) -> Path:
    """Accuracy before and after fine-tuning on each set, as grouped bars in a PNG."""

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = {
        "held_back": "your held-back\ndrawings",
        "generated": "generated\nimages",
        "fonts": "handwriting\nfonts",
    }
    at = np.arange(len(names))
    fig, ax = plt.subplots(figsize=(5.5, 3.4), dpi=110)
    for offset, (when, colour) in zip(
        (-0.2, 0.2), (("before", "tab:grey"), ("after", "tab:blue")), strict=True
    ):
        values = [100 * metrics[when][k]["accuracy"] for k in names]
        bars = ax.bar(at + offset, values, 0.38, label=when, color=colour)
        ax.bar_label(bars, fmt="%.1f", fontsize=7)
    ax.set_xticks(at, list(names.values()))
    ax.set_ylabel("accuracy (%)")
    low = min(100 * metrics[w][k]["accuracy"] for w in ("before", "after") for k in names)
    ax.set_ylim(max(0.0, low - 5), 100.5)
    ax.legend(loc="lower right")
    ax.set_title("Learning from recorded games: perceiver")
    fig.tight_layout()
    return save_figure(fig, path)
