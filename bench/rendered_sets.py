"""The rendered photos the board benches read (`oxbot.testing.render`): every style by name with
the seed its figures are recorded at, a style's photos, and frames holding an empty board or no
grid at all. Used by `bench_board.py` and `bench_readers.py`."""

from __future__ import annotations

import numpy as np

from oxbot.game.board import N_CELLS
from oxbot.testing.render import STYLES, TUNING_VARIANTS, RenderedPhoto, random_scene, render_photo

RENDER_STYLES = {**STYLES, **TUNING_VARIANTS}
"""Every rendered style by name: the tuning style and its harder variants, the held-out ones."""

HELD_OUT_STYLES = ("held-out", "wide-held-out")
"""The styles kept apart to measure on, never tuned on."""

EMPTY_SEED = 2025
"""Seed of the empty boards (`empty_boards`)."""
GRIDLESS_SEED = 2026
"""Seed of the frames without a grid (`gridless_frames`)."""


def usual_seed(style: str) -> int:
    """The seed a style's figures are recorded at (docs/perception.md): 2024 for the held-out
    styles, 7000 for the tuning style and its variants (7001-7003 were later development sets)."""
    return 2024 if style in HELD_OUT_STYLES else 7000


def render_photos(style: str, photos: int, seed: int) -> list[RenderedPhoto]:
    """`photos` photos of random boards in `style`, from one stream seeded `seed` (so the first
    100 of 200 are the 100 of a shorter run)."""
    rng = np.random.default_rng(seed)
    return [render_photo(rng, style=RENDER_STYLES[style]) for _ in range(photos)]


def empty_boards(photos: int, seed: int = EMPTY_SEED) -> list[np.ndarray]:
    """Photos of sheets with a grid and no symbol, the styles taken in turn: all 9 cells must
    read nothing."""
    rng = np.random.default_rng(seed)
    styles = list(RENDER_STYLES.values())
    nothing = ("nothing",) * N_CELLS
    return [render_photo(rng, nothing, styles[i % len(styles)]).image for i in range(photos)]


def gridless_frames(photos: int, seed: int = GRIDLESS_SEED) -> list[np.ndarray]:
    """Frames holding no grid, which must be refused: in turn a blank sheet, a sheet with
    circles and crosses but no grid, and a desk with no paper, the styles taken in turn."""
    rng = np.random.default_rng(seed)
    styles = list(RENDER_STYLES.values())
    frames = []
    for i in range(photos):
        kind = i % 3
        scene = random_scene(rng, styles[i % len(styles)], with_grid=False, with_paper=kind < 2)
        if kind == 1:
            for cell in rng.choice(N_CELLS, size=int(rng.integers(2, 6)), replace=False):
                scene = scene.with_symbol(int(cell), str(rng.choice(["circle", "cross"])), rng)
        frames.append(scene.photo(rng))
    return frames
