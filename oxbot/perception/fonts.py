"""The other hand: a labelled test set of circles and crosses rendered from handwriting fonts.

The perceiver is trained only on the project's own synthesiser's seeds. To check that it reads
handwriting it never saw, this module renders "O", "o", "X" and "x" from handwriting fonts
(Debian packages fonts-dkg-handwriting, fonts-breip, fonts-femkeklaver, fonts-rufscript) at
varied sizes, positions and slants on a paper texture of its own, with blanks on the same
paper. Nothing here is ever used for training. Three capital X glyphs that are not two
crossing strokes are left out (`LEFT_OUT`).

    images, labels = font_cells(300, np.random.default_rng(1))   # uint8 (300, 40, 40), labels
    write_font_set("other_hand/", 300)                           # the same as a labelled folder
"""

from __future__ import annotations

import functools
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from oxbot.errors import DataError
from oxbot.perception.seeds import write_png
from oxbot.perception.synth import LABELS

FONT_DIRS = (
    Path("/usr/share/fonts/truetype/fifthhorseman"),  # fonts-dkg-handwriting
    Path("/usr/share/fonts/truetype/breip"),  # fonts-breip
    Path("/usr/share/fonts/truetype/femkeklaver"),  # fonts-femkeklaver
    Path("/usr/share/fonts/truetype/rufscript"),  # fonts-rufscript
)
GLYPHS = {"circle": ("O", "o"), "cross": ("X", "x")}
LEFT_OUT = frozenset({("femkeklaver.ttf", "X"), ("dkgIt.ttf", "X"), ("dkgBI.ttf", "X")})
"""Capital X glyphs that are not two crossing strokes: femkeklaver's is the outline of a hollow
block letter, dkg's italic ones a calligraphic capital (a hairline through two parallel
strokes). Nobody marks a game that way, so the set leaves them out (docs/deviations.md)."""


@functools.cache
def font_files() -> tuple[Path, ...]:
    """The installed handwriting fonts; a clear error naming the packages if there are none."""
    files = tuple(sorted(p for d in FONT_DIRS if d.is_dir() for p in d.glob("*.[ot]tf")))
    if not files:
        raise DataError(
            "no handwriting fonts found; install the Debian packages fonts-dkg-handwriting "
            "fonts-breip fonts-femkeklaver fonts-rufscript (`make setup` does)"
        )
    return files


@functools.cache
def glyphs(label: str) -> tuple[tuple[Path, str], ...]:
    """Every (font file, character) pair the set draws `label` with."""
    return tuple(
        (font, char)
        for font in font_files()
        for char in GLYPHS[label]
        if (font.name, char) not in LEFT_OUT
    )


@functools.cache
def _glyph_ink(font: Path, char: str) -> np.ndarray:
    """A glyph's coverage, float32 in [0, 1], cropped to its ink, rendered large."""
    face = ImageFont.truetype(str(font), 160)
    left, top, right, bottom = face.getbbox(char)
    canvas = Image.new("L", (right - left + 20, bottom - top + 20), 0)
    ImageDraw.Draw(canvas).text((10 - left, 10 - top), char, fill=255, font=face)
    ink = np.asarray(canvas, np.float32) / 255.0
    ys, xs = np.nonzero(ink > 0.1)
    if xs.size == 0:
        raise DataError(f"font {font} has no visible glyph for {char!r}")
    return ink[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]


def _paper(size: int, rng: np.random.Generator) -> np.ndarray:
    """Paper for this set: a flat tone, fibres along one direction, a little sensor noise."""
    tone = rng.uniform(160, 240)
    fibres = cv2.GaussianBlur(rng.normal(0, 1, (size, size)).astype(np.float32), (0, 0), 0.8)
    fibres = cv2.blur(fibres, (int(rng.integers(1, 6)), 1)) if rng.random() < 0.5 else fibres
    return tone + fibres * rng.uniform(1, 6) + rng.normal(0, 1.5, (size, size))


def font_cell(label: str, rng: np.random.Generator, size: int = 40) -> np.ndarray:
    """One 40x40 cell: a handwriting font's O or X (or nothing) on paper, dark on light."""
    sheet = _paper(size, rng)
    if label != "nothing":
        choices = glyphs(label)
        glyph = _glyph_ink(*choices[rng.integers(len(choices))])
        height = rng.uniform(0.4, 0.85) * size
        scale = height / max(glyph.shape)
        slant = rng.uniform(-0.15, 0.15)
        slack = max(size - height * 1.15, 0.0) / 2
        target = (size - 1) / 2 + rng.uniform(-slack, slack, size=2)
        centre = np.array([glyph.shape[1] - 1, glyph.shape[0] - 1]) / 2
        linear = np.array([[scale, slant * scale], [0.0, scale]])
        shift = target - linear @ centre
        matrix = np.hstack([linear, shift[:, None]]).astype(np.float32)
        ink = cv2.warpAffine(glyph, matrix, (size, size), flags=cv2.INTER_AREA)
        sheet = sheet * (1.0 - rng.uniform(0.5, 0.95) * np.clip(ink, 0, 1))
    return np.clip(sheet, 0, 255).astype(np.uint8)


def font_cells(n: int, rng: np.random.Generator, size: int = 40) -> tuple[np.ndarray, list[str]]:
    """`n` cells drawn by the fonts, the labels in turn: uint8 (n, size, size) and labels."""
    labels = [LABELS[i % len(LABELS)] for i in range(n)]
    return np.stack([font_cell(label, rng, size) for label in labels]), labels


def write_font_set(folder: str | Path, n: int = 300, seed: int = 1) -> list[Path]:
    """Save `n` font cells as a labelled folder (`circle/`, `cross/`, `nothing/` of PNGs)."""
    images, labels = font_cells(n, np.random.default_rng(seed))
    paths = []
    for i, (image, label) in enumerate(zip(images, labels, strict=True)):
        path = Path(folder) / label / f"font_{i:04d}.png"
        write_png(path, image)
        paths.append(path)
    return paths
