"""Seed images: the few labelled drawings that all training data is generated from (paper §2.1).

A seed folder holds one subfolder per label, `circle/`, `cross/` and `nothing/`, of PNG files of
any size, grayscale or colour, dark ink on light paper. oxbot ships 108 seeds (36 per label) made
by its own handwriting synthesiser (`oxbot perceive make-seeds`); a user's folder of the same
shape is accepted wherever the shipped one is.

    seeds = load_seeds()              # the shipped seeds, or load_seeds("my_seeds/")
    seeds.images["cross"]             # list of uint8 (40, 40) arrays
"""

from __future__ import annotations

import importlib.resources
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from oxbot.atomic import atomic_write
from oxbot.errors import DataError, InvalidInputError
from oxbot.image_size import check_pixels
from oxbot.perception.synth import LABELS, draw_cell

IMAGE_SUFFIXES = (".png",)


def shipped_seeds_dir() -> Path:
    """The folder of the 108 seed images that ship with oxbot."""
    return Path(str(importlib.resources.files("oxbot") / "data" / "seeds"))


def to_gray_cell(image: np.ndarray, size: int = 40, source: str = "image") -> np.ndarray:
    """`image` as a uint8 (size, size) grayscale cell: colour converted, other sizes resized."""
    image = np.asarray(image)
    if image.dtype != np.uint8:
        if image.dtype == np.uint16:
            image = (image // 257).astype(np.uint8)
        else:
            raise InvalidInputError(f"{source} has dtype {image.dtype}; expected uint8 pixels")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    elif image.ndim == 3 and image.shape[2] == 4:  # transparent pixels become white paper
        alpha = image[:, :, 3:4].astype(np.float32) / 255.0
        rgb = image[:, :, :3].astype(np.float32) * alpha + 255.0 * (1 - alpha)
        image = cv2.cvtColor(rgb.astype(np.uint8), cv2.COLOR_RGB2GRAY)
    elif image.ndim == 3 and image.shape[2] == 3:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    elif image.ndim != 2:
        raise InvalidInputError(
            f"{source} has shape {image.shape}; expected (H, W) gray or (H, W, 3) colour"
        )
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise InvalidInputError(f"{source} has shape {image.shape}; it has no pixels")
    if image.shape != (size, size):
        shrinking = image.shape[0] > size or image.shape[1] > size
        interpolation = cv2.INTER_AREA if shrinking else cv2.INTER_LINEAR
        image = cv2.resize(image, (size, size), interpolation=interpolation)
    return np.ascontiguousarray(image)


def read_cell(path: str | Path, size: int = 40) -> np.ndarray:
    """A PNG file as a uint8 (size, size) grayscale cell; clear errors for missing or bad files."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"image {path} does not exist")
    raw = path.read_bytes()
    try:
        known = check_pixels(raw, f"image {path}")
    except InvalidInputError as exc:
        raise DataError(str(exc)) from None
    data = np.frombuffer(raw, np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED) if known is not None else None
    if image is None:
        raise DataError(f"image {path} is not a readable PNG (corrupt or empty); replace it")
    if image.ndim == 3 and image.shape[2] >= 3:  # OpenCV decodes to BGR(A)
        image = cv2.cvtColor(
            image, cv2.COLOR_BGRA2RGBA if image.shape[2] == 4 else cv2.COLOR_BGR2RGB
        )
    try:
        return to_gray_cell(image, size, source=f"image {path}")
    except InvalidInputError as exc:
        raise DataError(str(exc)) from None


def write_png(path: str | Path, image: np.ndarray) -> None:
    """Save a uint8 image (grayscale, or colour in OpenCV's BGR order) as PNG, atomically."""
    ok, encoded = cv2.imencode(".png", image)
    if not ok:
        raise DataError(f"could not encode an image of shape {image.shape} as PNG")
    with atomic_write(path) as handle:
        handle.write(encoded.tobytes())


@dataclass(frozen=True)
class LabelledImages:
    """Images by label, each a uint8 (40, 40) grayscale array, and the files they came from."""

    images: dict[str, list[np.ndarray]]
    files: dict[str, list[Path]]
    folder: Path

    def arrays(self) -> tuple[np.ndarray, list[str]]:
        """All images as one uint8 (N, 40, 40) array, with their labels."""
        images = [image for label in LABELS for image in self.images[label]]
        labels = [label for label in LABELS for _ in self.images[label]]
        return np.stack(images), labels

    def __len__(self) -> int:
        return sum(len(v) for v in self.images.values())


def load_labelled_folder(
    folder: str | Path, size: int = 40, require_all: bool = True
) -> LabelledImages:
    """Read a folder of `circle/`, `cross/`, `nothing/` subfolders of PNGs (any size)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"folder {folder} does not exist; give a folder with {', '.join(LABELS)}/")
    images: dict[str, list[np.ndarray]] = {}
    files: dict[str, list[Path]] = {}
    for label in LABELS:
        sub = folder / label
        paths = sorted(p for p in sub.glob("*") if p.suffix.lower() in IMAGE_SUFFIXES)
        if not paths and require_all:
            what = "is missing" if not sub.is_dir() else "has no PNG images"
            raise DataError(
                f"seed folder {folder} has no {label!r} images: {sub} {what}; every label "
                f"({', '.join(LABELS)}) needs at least one PNG"
            )
        files[label] = paths
        images[label] = [read_cell(p, size) for p in paths]
    if not any(files.values()):
        raise DataError(f"folder {folder} has no PNG images under {', '.join(LABELS)}/")
    return LabelledImages(images, files, folder)


def load_seeds(folder: str | Path | None = None, size: int = 40) -> LabelledImages:
    """The seed images of every label: the shipped ones, or those of a user's `folder`."""
    return load_labelled_folder(folder if folder is not None else shipped_seeds_dir(), size)


def make_seeds(
    folder: str | Path, per_class: int = 36, seed: int = 0, size: int = 40
) -> list[Path]:
    """Draw `per_class` seed cells of every label with the synthesiser and save them as PNGs.

    Drawings are clean, as a person would photograph a seed; blanks carry the grid remnants,
    smudges and shadows that a blank cell cut from a sheet has. Data generation adds remnants
    to every label.
    """
    folder = Path(folder)
    rng = np.random.default_rng(seed)
    written = []
    for label in LABELS:
        for i in range(per_class):
            path = folder / label / f"{label}_{i:03d}.png"
            remnants = 0.5 if label == "nothing" else 0.0
            write_png(path, draw_cell(label, rng, size, remnants=remnants))
            written.append(path)
    return written
