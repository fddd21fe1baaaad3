"""The learned rejector: is the ink in a cell a whole circle or cross? (experimental)

The symbol classifier (`classifier.py`) has three outputs and no word for ink that is no move
(a letter, a star, a scribble, half a circle); the wholeness check (`wholeness.py`) turns some of
those into "partial" by hand-written skeleton rules. The rejector is a small CNN with one
output, the probability that a cell's ink is a whole circle or cross, trained on drawings of both
(`bench/train_rejector.py`). The board reader (`BoardReader.classify`, with `[perception]
rejector = true`) reads a circle or cross whose probability is below the model's threshold as
"partial".

Each cell is first cut again as a square around its ink (`wholeness.zoom`, as the wholeness check
does), so that a small drawing alone in a cell and a drawing the board reader cut around its ink
look alike, then normalised as the classifier's input (`classifier.to_input`).

    rejector = load_rejector()                # the shipped model, checksum checked
    rejector.whole_probability(cells)         # uint8 (N, 40, 40) -> float (N,)
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from oxbot import artifacts
from oxbot.errors import ModelFileError
from oxbot.perception.classifier import CellReading, check_cells, to_input, torch_threads
from oxbot.perception.synth import PARTIAL
from oxbot.perception.wholeness import ink_masks, zoom

log = logging.getLogger(__name__)

FORMAT = "oxbot.rejector"
FORMAT_VERSION = 1
ARTIFACT_KIND = "rejector"
SIZE = 40
SYMBOLS = ("circle", "cross")


def shipped_rejector_path() -> Path:
    """Where the trained rejector that ships with oxbot lives."""
    return Path(str(importlib.resources.files("oxbot") / "data" / "models" / "rejector.pt"))


@dataclasses.dataclass(frozen=True)
class RejectorArchitecture:
    """The rejector network's widths."""

    width: int = 16
    """Filters of the first convolution; each later stage doubles them."""


class RejectorNet(nn.Module):
    """Four conv stages (40 -> 20 -> 10 -> 5), global max and mean pooling, one logit."""

    def __init__(self, width: int = 16) -> None:
        super().__init__()
        w = width

        def stage(cin: int, cout: int) -> list[nn.Module]:
            return [nn.Conv2d(cin, cout, 3, padding=1), nn.BatchNorm2d(cout), nn.ReLU()]

        self.features = nn.Sequential(
            *stage(1, w),
            nn.MaxPool2d(2),
            *stage(w, 2 * w),
            nn.MaxPool2d(2),
            *stage(2 * w, 2 * w),
            *stage(2 * w, 4 * w),
            nn.MaxPool2d(2),
            *stage(4 * w, 4 * w),
        )
        self.head = nn.Sequential(nn.Linear(8 * w, 4 * w), nn.ReLU(), nn.Linear(4 * w, 1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        f = self.features(x)
        pooled = torch.cat([f.amax(dim=(2, 3)), f.mean(dim=(2, 3))], dim=1)
        return self.head(pooled).squeeze(1)


def rejector_input(cells: np.ndarray, painted: np.ndarray | None = None) -> torch.Tensor:
    """uint8 (N, 40, 40) cells as the rejector's input: cut again around their ink, then
    normalised as the classifier's input."""
    cells = check_cells(cells, SIZE)
    lines = np.zeros(cells.shape, bool) if painted is None else np.asarray(painted, bool)
    zoomed, _ = zoom(cells, ink_masks(cells), lines)
    return to_input(zoomed)


class Rejector:
    """P(whole circle or cross) for cell crops, with the threshold below which a symbol reading
    becomes "partial"."""

    def __init__(
        self,
        architecture: RejectorArchitecture | None = None,
        threshold: float = 0.5,
        seed: int = 0,
    ) -> None:
        self.architecture = architecture or RejectorArchitecture()
        self.threshold = threshold
        self.seed = seed
        self.metadata: dict[str, Any] = {}
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            self.net = RejectorNet(self.architecture.width).eval()

    def logits(self, x: torch.Tensor) -> np.ndarray:
        """The network's logit for each prepared input (`rejector_input`)."""
        self.net.eval()
        out = []
        with torch_threads(1 if len(x) <= 64 else None), torch.inference_mode():
            for start in range(0, len(x), 1024):
                out.append(self.net(x[start : start + 1024]).numpy())
        return np.concatenate(out) if out else np.zeros(0, np.float32)

    def whole_probability(self, cells: np.ndarray, painted: np.ndarray | None = None) -> np.ndarray:
        """P(whole circle or cross) of each uint8 (N, 40, 40) cell, float64 (N,)."""
        z = self.logits(rejector_input(cells, painted)).astype(np.float64)
        return 1.0 / (1.0 + np.exp(-z))

    def veto(
        self,
        cells: np.ndarray,
        readings: Sequence[CellReading],
        painted: np.ndarray | None = None,
    ) -> list[CellReading]:
        """`readings` of `cells`, each circle or cross whose P(whole) is below the threshold read
        "partial" (the network's confidence and ink kept)."""
        todo = [i for i, r in enumerate(readings) if r.label in SYMBOLS]
        out = list(readings)
        if not todo:
            return out
        lines = None if painted is None else np.asarray(painted)[todo]
        p = self.whole_probability(np.asarray(cells)[todo], lines)
        for k, i in enumerate(todo):
            if p[k] < self.threshold:
                r = readings[i]
                out[i] = CellReading(PARTIAL, r.confidence, r.ink)
        return out

    def save(self, path: str | Path, **metadata: Any) -> Path:
        """Write the model with its architecture, threshold, seed and metadata, checksummed."""
        self.metadata.update(metadata)
        payload = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "architecture": dataclasses.asdict(self.architecture),
            "threshold": float(self.threshold),
            "seed": int(self.seed),
            "metadata": self.metadata,
            "state_dict": self.net.state_dict(),
        }
        return artifacts.save(path, ARTIFACT_KIND, FORMAT_VERSION, payload)

    @classmethod
    def load(cls, path: str | Path) -> Rejector:
        """Read a model written by `save`; refuse a damaged file (checksum) or another one."""
        path = Path(path)
        what = "rejector model file"
        remedy = (
            "retrain it with `bench/train_rejector.py`, or restore "
            "oxbot/data/models/rejector.pt from the oxbot repository"
        )
        payload = artifacts.load(path, ARTIFACT_KIND, FORMAT_VERSION, what, remedy)
        if not isinstance(payload, dict) or payload.get("format") != FORMAT:
            raise ModelFileError(f"model file {path} is not an oxbot rejector")
        try:
            with artifacts.checked(path, what, remedy):
                architecture = RejectorArchitecture(**dict(payload["architecture"]))
                rejector = cls(architecture, float(payload["threshold"]), int(payload["seed"]))
                rejector.net.load_state_dict(payload["state_dict"])
                rejector.metadata = dict(payload.get("metadata", {}))
        except (TypeError, ValueError, RuntimeError) as exc:
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise ModelFileError(
                f"model file {path} does not match the rejector: {first}"
            ) from None
        rejector.net.eval()
        return rejector


def load_rejector(path: str | Path | None = None) -> Rejector:
    """The trained rejector: the one shipped with oxbot, or the model saved at `path`."""
    return Rejector.load(path if path is not None else shipped_rejector_path())
