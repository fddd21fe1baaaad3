"""The symbol classifier: a small CNN with an SVM output layer (paper §2.1).

Paper: input 40x40 → conv 8 filters → ReLU → max-pool 2x2 stride 2 → conv 16 filters → ReLU →
max-pool 3x3 stride 3 → SVM output with 3 labels. The paper's toolkit (ConvNetJS, in SimpleDS)
uses 5x5 kernels with padding 2 and a multi-class hinge loss for its "svm" layer; here that is
`nn.MultiMarginLoss`, and the output layer is a linear map to one score per label.

oxbot: `read` gives each cell's label with a confidence: the softmax of the hinge
scores divided by a temperature fitted on held-out images (`fit_temperature`), saved in the
model's metadata. The shipped model has the paper's three outputs. Trained with
`[perception] partial_output` (experimental), the output layer has a fourth score, "partial",
after them, for ink that is not a whole symbol (an arc, one stroke, a plus, a tick); `predict`
keeps the three public labels and says "nothing" for it. A model file says how many outputs it
has, and `load` builds the network to match.

The classifier has scikit-learn's shape: configured in `__init__`, learned by `fit`, and
`predict` takes a batch:

    clf = load_classifier()                  # the shipped model
    clf.predict(cells)                       # uint8 (N, 40, 40) -> ["circle", "nothing", ...]
    clf.read(cells)                          # -> [CellReading("circle", 0.99, 0.08), ...]
    clf = SymbolClassifier(PerceptionConfig()).fit(images, labels)
    clf.save("perceiver.pt")                 # atomic; load with load_classifier(path)
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.resources
import itertools
import logging
import math
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import torch
from torch import nn

from oxbot import artifacts
from oxbot.config import PerceptionConfig
from oxbot.errors import InvalidInputError, ModelFileError
from oxbot.perception.synth import LABELS, OUTPUTS, PARTIAL

log = logging.getLogger(__name__)

FORMAT = "oxbot.perceiver"
FORMAT_VERSION = 2
"""2: the payload behind `oxbot.artifacts`' checksummed header; 1 had none."""
ARTIFACT_KIND = "perceiver"
ARCHITECTURE_FIELDS = (
    "image_size",
    "conv1_filters",
    "conv2_filters",
    "kernel_size",
    "pool1",
    "pool2",
)


def shipped_model_path() -> Path:
    """Where the trained model that ships with oxbot lives."""
    return Path(str(importlib.resources.files("oxbot") / "data" / "models" / "perceiver.pt"))


class SymbolNet(nn.Module):
    """The paper's network: two conv/ReLU/max-pool stages, then one score per label."""

    def __init__(
        self,
        image_size: int = 40,
        conv1_filters: int = 8,
        conv2_filters: int = 16,
        kernel_size: int = 5,
        pool1: int = 2,
        pool2: int = 3,
        outputs: int = len(LABELS),
    ) -> None:
        super().__init__()
        pad = kernel_size // 2  # "same" convolutions, as ConvNetJS's pad 2 for 5x5
        self.features = nn.Sequential(
            nn.Conv2d(1, conv1_filters, kernel_size, padding=pad),
            nn.ReLU(),
            nn.MaxPool2d(pool1, stride=pool1),
            nn.Conv2d(conv1_filters, conv2_filters, kernel_size, padding=pad),
            nn.ReLU(),
            nn.MaxPool2d(pool2, stride=pool2),
        )
        side = (image_size // pool1) // pool2
        if side < 1:
            raise InvalidInputError(f"image_size {image_size} is too small for the two poolings")
        self.svm = nn.Linear(conv2_filters * side * side, outputs)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.svm(self.features(x).flatten(1))

    def scores(self, x: torch.Tensor) -> torch.Tensor:
        """`forward`'s scores, for inference: each max pooling is taken as the maximum of its
        strided slices, several times faster than MaxPool2d on one thread for maps this small
        (training keeps MaxPool2d, whose gradient goes to one pixel of a tie)."""
        for layer in self.features:
            x = _max_pool(x, layer.kernel_size) if isinstance(layer, nn.MaxPool2d) else layer(x)
        return self.svm(x.flatten(1))


def _max_pool(x: torch.Tensor, k: int) -> torch.Tensor:
    """MaxPool2d(k, stride=k) of (N, C, H, W): the maximum over the k*k strided slices, of
    the map cropped (as MaxPool2d does) to a multiple of k."""
    h, w = x.shape[2] // k * k, x.shape[3] // k * k
    out = torch.maximum(x[:, :, 0:h:k, 0:w:k], x[:, :, 0:h:k, 1:w:k])
    for i, j in itertools.product(range(k), range(k)):
        if i > 0 or j > 1:
            torch.maximum(out, x[:, :, i:h:k, j:w:k], out=out)
    return out


def check_cells(cells: Any, size: int = 40) -> np.ndarray:
    """A batch of cells as uint8 (N, size, size): checked, colour converted, resized.

    Accepts (N, H, W) grayscale or (N, H, W, 3) RGB, uint8 or any integer or float type with
    values in 0-255; a single (H, W) cell is not a batch and is refused.
    """
    try:
        array = np.asarray(cells)
    except (ValueError, TypeError) as exc:
        raise InvalidInputError(f"cells could not be read as an array: {exc}") from None
    if array.ndim not in (3, 4) or (array.ndim == 4 and array.shape[3] not in (1, 3, 4)):
        raise InvalidInputError(
            f"cells have shape {array.shape}; expected a batch (N, 40, 40) of grayscale cells "
            f"or (N, H, W, 3) colour cells"
        )
    if array.shape[0] == 0:
        raise InvalidInputError(f"cells have shape {array.shape}: the batch is empty")
    if array.shape[1] == 0 or array.shape[2] == 0:
        raise InvalidInputError(f"cells have shape {array.shape}: the cells have no pixels")
    if array.dtype != np.uint8:
        if array.dtype.kind not in "uif":
            raise InvalidInputError(
                f"cells have dtype {array.dtype}; expected uint8 pixels (0-255)"
            )
        if array.dtype.kind == "f":
            bad = ~np.isfinite(array).reshape(len(array), -1).all(axis=1)
            if bad.any():
                raise InvalidInputError(
                    f"cells of shape {array.shape} contain NaN or infinite values "
                    f"(cells {np.flatnonzero(bad)[:10].tolist()}); give uint8 pixels 0-255"
                )
        low, high = array.min(), array.max()
        if low < 0 or high > 255:
            raise InvalidInputError(
                f"cells of dtype {array.dtype} have values from {low} to {high}; "
                f"expected pixels 0-255 (uint8)"
            )
        array = np.rint(array).astype(np.uint8)
    if array.ndim == 4:
        if array.shape[3] == 1:
            array = array[..., 0]
        else:
            code = cv2.COLOR_RGBA2GRAY if array.shape[3] == 4 else cv2.COLOR_RGB2GRAY
            array = np.stack([cv2.cvtColor(np.ascontiguousarray(c), code) for c in array])
    if array.shape[1:] != (size, size):
        shrink = array.shape[1] > size or array.shape[2] > size
        how = cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
        array = np.stack(
            [cv2.resize(np.ascontiguousarray(c), (size, size), interpolation=how) for c in array]
        )
    return np.ascontiguousarray(array)


def to_input(cells: np.ndarray) -> torch.Tensor:
    """uint8 (N, H, W) cells as the network's input: ink as positive values, paper near 0.

    Each cell is measured against its own paper (a bright percentile) and contrast, so that a
    dim photo and a bright scan of the same drawing look alike to the network; the contrast
    floor keeps the noise of a blank cell from being stretched into strokes.
    """
    flat = cells.reshape(len(cells), -1).astype(np.float32)
    paper = np.percentile(flat, 90, axis=1, keepdims=True)
    darkest = flat.min(axis=1, keepdims=True)
    contrast = np.maximum(paper - darkest, 64.0)
    x = np.clip((paper - flat) / contrast, -0.5, 1.5)
    return torch.from_numpy(x.reshape(len(cells), 1, *cells.shape[1:]))


INK_SHARE_LEVEL = 0.35
"""oxbot: a pixel at least this far from paper to the darkest ink (`to_input`) counts as ink."""


def ink_share(cells: np.ndarray) -> np.ndarray:
    """Share of each uint8 cell's pixels that are ink, float64 (N,), on `to_input`'s scale."""
    x = to_input(cells).numpy()
    return (x > INK_SHARE_LEVEL).reshape(len(cells), -1).mean(axis=1).astype(np.float64)


def label_indices(labels: Sequence[str] | np.ndarray) -> np.ndarray:
    """Labels given as strings or indices, as int64 indices into OUTPUTS (LABELS, then
    PARTIAL)."""
    array = np.asarray(labels)
    if array.dtype.kind in "iu":
        if array.size and (array.min() < 0 or array.max() >= len(OUTPUTS)):
            raise InvalidInputError(f"label indices must be 0-{len(OUTPUTS) - 1}")
        return array.astype(np.int64)
    unknown = sorted({str(v) for v in array.tolist()} - set(OUTPUTS))
    if unknown:
        raise InvalidInputError(f"unknown labels {unknown}; labels are {', '.join(OUTPUTS)}")
    lookup = {label: i for i, label in enumerate(OUTPUTS)}
    return np.array([lookup[str(v)] for v in array.tolist()], np.int64)


@dataclasses.dataclass(frozen=True)
class CellReading:
    """What the classifier makes of one cell, beside the public bare label."""

    label: str
    """One of OUTPUTS: circle, cross, nothing, or partial (ink that is not a whole symbol)."""
    confidence: float
    """The calibrated probability of `label`, in (0, 1]."""
    ink: float = 0.0
    """Share of the cell's pixels that are ink, as the network sees them: a drawing under
    way grows it from one reading to the next (the move tracker waits until it stops)."""

    @property
    def spec_label(self) -> str:
        """The public label: a partial cell is "nothing" (no move)."""
        return "nothing" if self.label == PARTIAL else self.label


def spec_label(label: str) -> str:
    """The public label of one of OUTPUTS: PARTIAL is "nothing", since it is no move."""
    return "nothing" if label == PARTIAL else label


def softmax(scores: np.ndarray, temperature: float) -> np.ndarray:
    """Row-wise softmax of `scores / temperature`, float64."""
    z = scores.astype(np.float64) / temperature
    z -= z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)


SMALL_BATCH = 64
"""oxbot: batches up to this many cells are classified on one torch thread."""


@contextlib.contextmanager
def torch_threads(n: int | None) -> Iterator[None]:
    """Run the block with `n` torch threads (None: leave as is), then restore the old count."""
    before = torch.get_num_threads()
    if n is not None and n != before:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        if torch.get_num_threads() != before:
            torch.set_num_threads(before)


def _turn_or_flip(x: torch.Tensor, k: int) -> torch.Tensor:
    """One of the 8 quarter turns and mirror images of a batch (k in 0-7).

    Circles, crosses and blanks keep their label under each, so every pass over the same
    generated images shows the network new views of them at no cost.
    """
    x = torch.rot90(x, k % 4, dims=(2, 3)) if k % 4 else x
    return x.flip(3) if k >= 4 else x


class SymbolClassifier:
    """Classifies 40x40 cells as circle, cross or nothing; the paper's CNN+SVM (§2.1).

    Paper: the architecture and 10K generated training images; 99.9% on 1,000 generated
    test images. oxbot: Adam with a one-cycle schedule over a few epochs, each batch seen in one
    of its 8 quarter turns and mirror images, and per-cell contrast normalisation (`to_input`).
    """

    def __init__(self, config: PerceptionConfig | None = None, seed: int | None = None) -> None:
        self.config = config if config is not None else PerceptionConfig()
        self.seed = self.config.seed if seed is None else seed
        self.metadata: dict[str, Any] = {}
        self.net = self._build()
        self.fitted = False

    def _build(self) -> SymbolNet:
        with torch.random.fork_rng(devices=[]):  # seeded init without touching global state
            torch.manual_seed(self.seed)
            architecture = {f: getattr(self.config, f) for f in ARCHITECTURE_FIELDS}
            net = SymbolNet(**architecture, outputs=len(self.outputs))
        return net.eval()

    @property
    def image_size(self) -> int:
        return self.config.image_size

    @property
    def outputs(self) -> tuple[str, ...]:
        """The network's outputs in score order: the three public labels, then "partial" when
        the model was trained with `partial_output` (experimental)."""
        return OUTPUTS if self.config.partial_output else LABELS

    def fit(
        self,
        images: np.ndarray,
        labels: Sequence[str] | np.ndarray,
        progress: Callable[[int], None] | None = None,
    ) -> SymbolClassifier:
        """Learn from uint8 (N, 40, 40) images and their labels (strings or indices).

        `progress`, if given, is called with the number of images processed so far.
        """
        cells = check_cells(images, self.image_size)
        y = torch.from_numpy(label_indices(labels))
        if len(y) != len(cells):
            raise InvalidInputError(f"{len(cells)} images but {len(y)} labels; give one each")
        if len(y) and int(y.max()) >= len(self.outputs):
            raise InvalidInputError(
                f"labels include {PARTIAL!r}, which this classifier has no output for; "
                f"its outputs are {', '.join(self.outputs)} (see partial_output)"
            )
        with torch_threads(self.config.threads):
            self._fit(cells, y, progress)
        return self

    def _fit(
        self, cells: np.ndarray, y: torch.Tensor, progress: Callable[[int], None] | None
    ) -> None:
        cfg = self.config
        x = to_input(cells)
        rng = np.random.default_rng(self.seed)
        self.net = self._build().train()
        optimiser = torch.optim.Adam(
            self.net.parameters(), lr=cfg.learning_rate, weight_decay=cfg.weight_decay
        )
        steps = cfg.epochs * math.ceil(len(x) / cfg.batch_size)
        schedule = torch.optim.lr_scheduler.OneCycleLR(
            optimiser, max_lr=cfg.learning_rate, total_steps=max(steps, 1)
        )
        loss_fn = nn.MultiMarginLoss(margin=1.0)
        done = 0
        for _epoch in range(cfg.epochs):
            order = torch.from_numpy(rng.permutation(len(x)))
            for start in range(0, len(x), cfg.batch_size):
                batch = order[start : start + cfg.batch_size]
                inputs = _turn_or_flip(x[batch], int(rng.integers(8)))
                optimiser.zero_grad(set_to_none=True)
                loss = loss_fn(self.net(inputs), y[batch])
                loss.backward()
                optimiser.step()
                schedule.step()
                done += len(batch)
                if progress is not None:
                    progress(done)
        self.net.eval()
        self.fitted = True
        self.metadata.update(trained_images=len(x), final_loss=float(loss.item()))

    def decision_function(self, cells: Any) -> np.ndarray:
        """The SVM layer's score of each output for each cell, float32 (N, K), in the order of
        `outputs` (K = 3, or 4 with partial)."""
        x = to_input(check_cells(cells, self.image_size))
        # A frame's 9 cells take well under a millisecond on one thread; spreading so little
        # work over threads costs more than it saves, many times more when cores are shared.
        with torch_threads(1 if len(x) <= SMALL_BATCH else None), torch.inference_mode():
            return self.net.scores(x).numpy()

    def predict(self, cells: Any) -> list[str]:
        """The label of each cell of a batch: uint8 (N, 40, 40) dark-on-light -> N strings.

        The public labels only: a cell a four-output network reads as partial is "nothing" (no
        move).
        """
        scores = self.decision_function(cells)
        return [spec_label(self.outputs[i]) for i in scores.argmax(axis=1)]

    @property
    def temperature(self) -> float:
        """Divides the hinge scores before the softmax of `read`; fitted by `fit_temperature`."""
        return float(self.metadata.get("temperature", 1.0))

    def probabilities(self, cells: Any) -> np.ndarray:
        """Calibrated probability of each output for each cell, float64 (N, K), as
        `decision_function`."""
        return softmax(self.decision_function(cells), self.temperature)

    def read(self, cells: Any) -> list[CellReading]:
        """Each cell's label among `outputs` with its calibrated confidence and ink. A
        three-output model never says "partial" here (`BoardReader`'s single-stroke rule and its
        wholeness check, `oxbot.perception.wholeness`, may)."""
        checked = check_cells(cells, self.image_size)
        p = self.probabilities(checked)
        ink = ink_share(checked)
        best = p.argmax(axis=1)
        names = self.outputs
        return [CellReading(names[k], float(p[i, k]), float(ink[i])) for i, k in enumerate(best)]

    def fit_temperature(self, cells: Any, labels: Sequence[str] | np.ndarray) -> float:
        """Fit the softmax temperature on held-out labelled cells (least negative log
        likelihood over a log grid), keep it in the metadata and return it."""
        scores = self.decision_function(cells)
        y = label_indices(labels)
        grid = np.exp(np.linspace(np.log(0.02), np.log(5.0), 121))
        nll = [-np.log(softmax(scores, t)[np.arange(len(y)), y] + 1e-12).mean() for t in grid]
        self.metadata["temperature"] = float(grid[int(np.argmin(nll))])
        return self.temperature

    def lower_partial(self, cells: Any, labels: Sequence[str] | np.ndarray, share: float) -> float:
        """Lower the "partial" output's bias until at most `share` of the labelled whole
        symbols among `cells` read as partial; return by how much.

        A whole symbol read as partial is a move the robot does not see, and oxbot's
        accuracy goal counts it wrong; partial ink read as a symbol is what the tracker's
        confidence and still-ink checks are for. Four-output models only.
        """
        if PARTIAL not in self.outputs:
            raise InvalidInputError("this classifier has no partial output to lower")
        scores = self.decision_function(cells).astype(np.float64)
        y = label_indices(labels)
        whole = scores[y < 2]
        best_whole = whole[:, :3].max(axis=1)
        margins = np.sort(whole[:, 3] - best_whole)[::-1]  # how far partial wins, worst first
        allowed = int(share * len(whole))
        offset = max(float(margins[allowed]) + 1e-3, 0.0) if allowed < len(margins) else 0.0
        with torch.no_grad():
            self.net.svm.bias[3] -= offset
        self.metadata["partial_offset"] = offset
        return offset

    def score(self, cells: Any, labels: Sequence[str] | np.ndarray) -> float:
        """Accuracy on labelled cells, over all the network's outputs."""
        y = label_indices(labels)
        return float((self.decision_function(cells).argmax(axis=1) == y).mean())

    # --- saving and loading ---------------------------------------------------------------

    def save(self, path: str | Path, **metadata: Any) -> Path:
        """Write the model with its configuration, seed and `metadata`, checksummed; never
        half-written."""
        path = Path(path)
        merged = {**self.metadata, **metadata}
        payload = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "labels": list(LABELS),
            "outputs": list(self.outputs),
            "architecture": {f: getattr(self.config, f) for f in ARCHITECTURE_FIELDS},
            "config": dataclasses.asdict(self.config),
            "seed": self.seed,
            "metadata": merged,
            "state_dict": self.net.state_dict(),
        }
        artifacts.save(path, ARTIFACT_KIND, FORMAT_VERSION, payload)
        self.metadata = merged
        log.info("saved the perceiver to %s", path)
        return path

    @classmethod
    def load(cls, path: str | Path) -> SymbolClassifier:
        """Read a model written by `save`; refuse damaged files and other architectures."""
        path = Path(path)
        what = "perceiver model file"
        remedy = (
            "retrain it with `oxbot train perceiver`, or re-download "
            "oxbot/data/models/perceiver.pt from the oxbot repository"
        )
        payload = artifacts.load(path, ARTIFACT_KIND, FORMAT_VERSION, what, remedy, _is_legacy)
        if payload.get("format") != FORMAT:
            raise ModelFileError(
                f"model file {path} is not an oxbot perceiver (another architecture or "
                f"another program's file)"
            )
        if payload.get("labels") != list(LABELS):
            raise ModelFileError(
                f"model file {path} has labels {payload.get('labels')}; this oxbot reads "
                f"{list(LABELS)}; {remedy}"
            )
        outputs = payload.get("outputs", list(LABELS))  # older files have three
        if outputs not in (list(LABELS), list(OUTPUTS)):
            raise ModelFileError(
                f"model file {path} has outputs {outputs}; this oxbot reads {list(LABELS)} "
                f"or {list(OUTPUTS)}; {remedy}"
            )
        known = {f.name for f in dataclasses.fields(PerceptionConfig)}
        with artifacts.checked(path, what, remedy):
            saved = {k: v for k, v in dict(payload.get("config", {})).items() if k in known}
            metadata = dict(payload.get("metadata", {}))
            seed = int(payload.get("seed", 0))
        try:
            config = dataclasses.replace(
                PerceptionConfig(**saved),
                **payload["architecture"],
                partial_output=outputs == list(OUTPUTS),
            )
            clf = cls(config, seed=seed)
            clf.net.load_state_dict(payload["state_dict"])
        except (KeyError, TypeError, ValueError, RuntimeError, AttributeError) as exc:
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise ModelFileError(
                f"model file {path} does not match the perceiver's architecture: {first}"
            ) from None
        clf.net.eval()
        clf.metadata = metadata
        clf.fitted = True
        return clf


def _is_legacy(payload: Any) -> bool:
    """A perceiver saved before files carried a checksum (format version 1)."""
    return (
        isinstance(payload, dict)
        and payload.get("format") == FORMAT
        and payload.get("format_version") == 1
    )


def load_classifier(path: str | Path | None = None) -> SymbolClassifier:
    """The trained classifier: the one shipped with oxbot, or the model saved at `path`."""
    return SymbolClassifier.load(path if path is not None else shipped_model_path())
