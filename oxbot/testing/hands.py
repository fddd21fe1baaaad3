"""A new hand for the project's own tests and benchmarks: a person whose crosses the shipped
perceiver often misreads (learning from recorded games).

`plus_strokes` draws like `oxbot.testing.sheet.person_strokes`, except that crosses are drawn
upright, as a plus sign turned by up to `PLUS_TILT` degrees, as some people mark them. The
shipped classifier reads the cells of this hand at about 88% (crosses about 60%), measured by
`bench/bench_learn.py`; its circles are the page's usual ones.
"""

from __future__ import annotations

import numpy as np

from oxbot.testing.sheet import person_strokes

PLUS_TILT = 10.0
"""Largest tilt of the plus sign's strokes from upright, in degrees."""


def plus_strokes(symbol: str, rng: np.random.Generator) -> list[np.ndarray]:
    """The new hand's circle or cross in the unit square of a cell (crosses as a plus)."""
    if symbol != "cross":
        return person_strokes(symbol, rng)
    centre = 0.5 + rng.uniform(-0.06, 0.06, size=2)
    size = rng.uniform(0.26, 0.34)
    strokes = []
    for base in (0.0, 90.0):
        angle = np.radians(base + rng.uniform(-PLUS_TILT, PLUS_TILT))
        half = size * rng.uniform(0.9, 1.1) * np.array([np.sin(angle), -np.cos(angle)])
        strokes.append(np.stack([centre - half, centre + half]))
    return strokes
