"""Training and development-validation drawings for the learned rejector
(`oxbot.perception.rejector`): whole circles and crosses, and ink that is no move.

Sources (never `oxbot.testing.heldout_drawings`, nor Quick, Draw!, nor the real handwriting's
test part):
- positives: the training synthesiser's circles and crosses (`synth.symbol_strokes`), the
  development drawings' whole kinds (`dev_shapes`, many hands), the page's person
  (`sheet.person_strokes`) and, when `real_hands` is given, the UNIPEN circles and crosses of
  the composed boards' development writers (`HandwritingSource.split("dev")`; their Quick,
  Draw! circles are left out, since the held-out Quick, Draw! set is copied from the same
  file);
- negatives: the development drawings' refused kinds (`dev_shapes.REFUSED_KINDS`), the
  synthesiser's partial kinds (`synth.partial_strokes`) and shapes of this file's own
  (`EXTRA_KINDS`: random strokes, polygons, letters and signs the development drawings do not
  have, and whole symbols with something more: a circle with a stroke through it, a face, two
  rings, a cross in a circle, a cross with a third stroke).

Each drawing is rendered one of three ways: on the page's sheet (`Sheet`, a pen 3-8 pixels
wide) and cut by the board reader (`board.cut_board`), as the reader sees it; alone in a 40x40
cell as `dev_shapes.cell_image` draws it; or with the synthesiser's pens and paper (pencil
grain, uneven light, grid remnants).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from oxbot.errors import OxbotError
from oxbot.game.board import CELL_NAMES
from oxbot.perception.board import cut_board
from oxbot.perception.synth import (
    PARTIAL_KINDS,
    Pen,
    add_grid_remnants,
    ink_mask,
    paper,
    partial_strokes,
    symbol_strokes,
)
from oxbot.testing.composite import HandwritingSource
from oxbot.testing.dev_shapes import (
    REFUSED_KINDS,
    _arc,
    _resample,
    _smooth,
    by_hand,
    cell_image,
    draw_kind,
)
from oxbot.testing.sheet import Sheet, person_strokes, unit_to_canvas

POSITIVE_SOURCES = (
    "loose_circle",
    "loose_circle",
    "loose_cross",
    "dev_circle",
    "dev_cross",
    "synth_circle",
    "synth_cross",
    "person_circle",
    "person_cross",
)
EXTRA_KINDS = (
    "random_strokes",
    "polygon",
    "circle_and_stroke",
    "face",
    "two_rings",
    "circle_and_cross",
    "cross_and_stroke",
    "hash",
    "letter_more",
    "wave",
    "arrow",
    "heart",
    "crescent",
    "sun",
)
NEGATIVE_SOURCES = (
    *(f"dev_{k}" for k in REFUSED_KINDS),
    *(f"synth_{k}" for k in PARTIAL_KINDS),
    *(f"extra_{k}" for k in EXTRA_KINDS),
)
REAL_SOURCES = ("real_circle", "real_cross")
RENDERS = ("sheet", "cell", "synth")


def real_hands(folder: Path, manifest: Path) -> dict[str, list[list[np.ndarray]]]:
    """The development writers' UNIPEN circles and crosses of the composed boards' handwriting,
    each drawing's strokes in [-0.5, 0.5]^2 (its longer side 1, centred)."""
    dev = HandwritingSource.load(folder, manifest).split("dev")
    hands: dict[str, list[list[np.ndarray]]] = {}
    for name in ("circle", "cross"):
        hands[name] = []
        for strokes, writer in zip(dev.drawings[name], dev.writers[name], strict=True):
            if not writer.startswith("unipen:"):
                continue
            hands[name].append(_centred(strokes))
    return hands


def _centred(strokes: list[np.ndarray]) -> list[np.ndarray]:
    """`strokes` moved and scaled together into [-0.5, 0.5]^2: their box centred, its longer
    side 1."""
    points = np.concatenate(strokes)
    lo, hi = points.min(0), points.max(0)
    return [(s - (lo + hi) / 2) / float((hi - lo).max()) for s in strokes]


def _hand(template: list[np.ndarray], rng: np.random.Generator) -> list[np.ndarray]:
    """A template in [-0.5, 0.5]^2 drawn by a hand in a cell's unit square (as
    `dev_shapes.draw_kind`, a little larger and more turned)."""
    return by_hand(template, rng, rng.uniform(0.35, 0.78), turn_sd=10.0)


def _from_box(strokes: list[np.ndarray]) -> list[np.ndarray]:
    """Strokes in the synthesiser's [-1, 1]^2 as a template in [-0.5, 0.5]^2."""
    return [np.asarray(s, float) / 2 for s in strokes]


def _circle(
    rng: np.random.Generator, r: float = 0.5, cx: float = 0.0, cy: float = 0.0
) -> np.ndarray:
    start = rng.uniform(0, 360)
    return _arc(cx, cy, r, start, start + 360 * rng.uniform(1.0, 1.1), 48)


def _cross(rng: np.random.Generator, half: float = 0.5) -> list[np.ndarray]:
    a = half * rng.uniform(0.8, 1.0)
    return [np.array([[-a, -a], [a, a]]), np.array([[a, -a], [-a, a]])]


def _line(rng: np.random.Generator, length: float = 1.0) -> np.ndarray:
    a = rng.uniform(0, math.pi)
    d = np.array([math.cos(a), math.sin(a)]) * length / 2
    c = rng.uniform(-0.15, 0.15, 2)
    return np.stack([c - d, c + d])


def _letter_more(rng: np.random.Generator) -> list[np.ndarray]:
    """Capitals and signs the development drawings lack: B C D G J P R S U 6 8 9 & # @ ? ! = %."""
    p = lambda *pts: np.array(pts, float)  # noqa: E731
    c = str(rng.choice(list("BCDGJPRSU689&@?=%")))
    if c == "B":
        return [
            p((-0.3, -0.5), (-0.3, 0.5)),
            np.concatenate([_arc(-0.1, -0.25, 0.25, 270, 450), _arc(-0.1, 0.25, 0.25, 270, 450)]),
        ]
    if c == "C":
        return [_arc(0, 0, 0.5, 40, 320)]
    if c == "D":
        return [p((-0.3, -0.5), (-0.3, 0.5)), _arc(-0.3, 0, 0.5, -90, 90)]
    if c == "G":
        return [np.concatenate([_arc(0, 0, 0.5, -40, -330)[::-1], p((0.45, 0.1), (0.1, 0.1))])]
    if c == "J":
        return [np.concatenate([p((0.2, -0.5), (0.2, 0.2)), _arc(-0.05, 0.2, 0.25, 0, 180)])]
    if c == "P":
        return [p((-0.3, 0.5), (-0.3, -0.5)), _arc(-0.3, -0.25, 0.25, -90, 90)]
    if c == "R":
        return [
            p((-0.3, 0.5), (-0.3, -0.5)),
            _arc(-0.3, -0.25, 0.25, -90, 90),
            p((-0.2, 0.0), (0.3, 0.5)),
        ]
    if c == "S":
        return [
            np.concatenate(
                [_arc(0, -0.25, 0.25, -30, -270)[::-1][::-1], _arc(0, 0.25, 0.25, -90, 150)]
            )
        ]
    if c == "U":
        return [np.concatenate([p((-0.4, -0.5), (-0.4, 0.1)), _arc(0, 0.1, 0.4, 180, 0)])]
    if c == "6":
        return [np.concatenate([_arc(0.3, 0.0, 0.5, 200, 150)[:12], _arc(0, 0.25, 0.25, 180, 540)])]
    if c == "8":
        return [np.concatenate([_arc(0, -0.25, 0.25, 90, 450), _arc(0, 0.25, 0.25, 270, -90)])]
    if c == "9":
        return [np.concatenate([_arc(0, -0.25, 0.25, 0, 360), p((0.25, -0.25), (0.2, 0.5))])]
    if c == "&":
        return [
            _smooth(
                p(
                    (0.4, 0.5),
                    (-0.2, -0.1),
                    (-0.1, -0.5),
                    (0.15, -0.3),
                    (-0.4, 0.3),
                    (0, 0.5),
                    (0.35, 0.1),
                ),
                3,
            )
        ]
    if c == "@":
        return [np.concatenate([_arc(0, 0, 0.18, 0, 360), _arc(0, 0, 0.5, 0, 330)])]
    if c == "?":
        return [
            np.concatenate([_arc(0, -0.25, 0.25, 180, 450), p((0, 0), (0, 0.2))]),
            p((0, 0.42), (0.01, 0.46)),
        ]
    if c == "=":
        return [p((-0.5, -0.2), (0.5, -0.2)), p((-0.5, 0.2), (0.5, 0.2))]
    return [
        p((-0.4, 0.5), (0.4, -0.5)),
        _arc(-0.3, -0.3, 0.15, 0, 360),
        _arc(0.3, 0.3, 0.15, 0, 360),
    ]  # %


def _extra(kind: str, rng: np.random.Generator) -> list[np.ndarray]:
    """A template in [-0.5, 0.5]^2 of one of EXTRA_KINDS."""
    if kind == "random_strokes":
        out = []
        for _ in range(int(rng.integers(1, 6))):
            pts = rng.uniform(-0.5, 0.5, (int(rng.integers(2, 7)), 2))
            out.append(_smooth(pts, int(rng.integers(0, 4))))
        return out
    if kind == "polygon":
        n = int(rng.integers(3, 5))
        t = np.radians(rng.uniform(0, 360) + np.arange(n + 1) * 360 / n) + rng.normal(
            0, 0.08, n + 1
        )
        pts = np.stack([0.5 * np.cos(t), 0.5 * np.sin(t)], 1) * rng.uniform(0.85, 1.0, (n + 1, 1))
        pts[-1] = pts[0] + rng.normal(0, 0.03, 2)
        return [pts]
    if kind == "rounded_square":
        r = rng.uniform(0.08, 0.22)
        h = 0.5 - r
        corners = [(h, h, 0), (-h, h, 90), (-h, -h, 180), (h, -h, 270)]
        pts = np.concatenate([_arc(x, y, r, a, a + 90, 8) for x, y, a in corners])
        pts = np.concatenate([pts, pts[:2]])
        return [np.roll(pts, int(rng.integers(len(pts))), axis=0)]
    if kind == "circle_and_stroke":
        r = rng.uniform(0.3, 0.5)
        circle = _circle(rng, r)
        roll = rng.random()
        if roll < 0.4:  # a line through it: a slashed O, a theta
            return [circle, _line(rng, rng.uniform(0.8, 1.0))]
        if roll < 0.7:  # a tail: a Q, an a, a b, a d
            a = rng.uniform(0, 2 * math.pi)
            d = np.array([math.cos(a), math.sin(a)])
            return [circle, np.stack([d * r * 0.7, d * (r + rng.uniform(0.2, 0.4))])]
        return [circle, np.array([[-0.5, rng.uniform(-0.5, 0.5)], [0.5, rng.uniform(-0.5, 0.5)]])]
    if kind == "face":
        out = [
            _circle(rng),
            _arc(-0.18, -0.12, 0.04, 0, 360, 8),
            _arc(0.18, -0.12, 0.04, 0, 360, 8),
        ]
        if rng.random() < 0.8:
            out.append(_arc(0, 0.05, 0.25, 30, 150, 12))
        return out
    if kind == "two_rings":
        if rng.random() < 0.5:  # concentric, or side by side, or one above the other
            return [_circle(rng, 0.5), _circle(rng, rng.uniform(0.15, 0.35))]
        d = rng.uniform(0.2, 0.26)
        if rng.random() < 0.5:
            return [_circle(rng, 0.25, -d, 0), _circle(rng, 0.25, d, 0)]
        return [_circle(rng, 0.25, 0, -d), _circle(rng, 0.25, 0, d)]
    if kind == "circle_and_cross":
        if rng.random() < 0.5:
            return [_circle(rng, 0.5), *_cross(rng, 0.35 if rng.random() < 0.5 else 0.5)]
        return [_circle(rng, rng.uniform(0.2, 0.3)), *_cross(rng, 0.5)]
    if kind == "cross_and_stroke":
        cross = _cross(rng)
        if rng.random() < 0.5:  # a bar across: a star of six arms, a Russian zhe
            a = rng.uniform(-0.3, 0.3) + (math.pi / 2 if rng.random() < 0.5 else 0)
            d = np.array([math.cos(a), math.sin(a)]) * 0.5
            return [*cross, np.stack([-d, d])]
        y = rng.uniform(-0.5, 0.5)  # a line above or below, or a box's side
        return [*cross, np.array([[-0.5, y], [0.5, y + rng.normal(0, 0.05)]])]
    if kind == "hash":
        a, b = rng.uniform(0.15, 0.3, 2)
        tilt = rng.uniform(-0.2, 0.2)
        return [
            np.array([[-a + tilt, -0.5], [-a - tilt, 0.5]]),
            np.array([[b + tilt, -0.5], [b - tilt, 0.5]]),
            np.array([[-0.5, -a], [0.5, -a]]),
            np.array([[-0.5, b], [0.5, b]]),
        ]
    if kind == "letter_more":
        return _letter_more(rng)
    if kind == "wave":
        x = np.linspace(-0.5, 0.5, 60)
        return [np.stack([x, 0.25 * np.sin(x * rng.uniform(6, 18) + rng.uniform(0, 6))], 1)]
    if kind == "arrow":
        a = rng.uniform(0, 2 * math.pi)
        d = np.array([math.cos(a), math.sin(a)]) * 0.5
        n = np.array([-d[1], d[0]])
        tip = d
        return [
            np.stack([-d, d]),
            np.stack([tip - 0.4 * d + 0.4 * n, tip, tip - 0.4 * d - 0.4 * n]),
        ]
    if kind == "heart":
        t = np.linspace(0, 2 * math.pi, 80)
        x = 16 * np.sin(t) ** 3
        y = -(13 * np.cos(t) - 5 * np.cos(2 * t) - 2 * np.cos(3 * t) - np.cos(4 * t))
        return [np.stack([x, y], 1) / 34]
    if kind == "crescent":
        a = rng.uniform(0, 360)
        return [
            np.concatenate(
                [_arc(0, 0, 0.5, a + 40, a + 320, 30), _arc(0.25, 0, 0.42, a + 300, a + 60, 30)]
            )
        ]
    if kind == "cloud":
        bumps = int(rng.integers(5, 9))
        t = np.linspace(0, 2 * math.pi, 200)
        r = 0.42 + 0.08 * np.abs(np.sin(bumps * t / 2))
        return [np.stack([r * np.cos(t), r * np.sin(t)], 1)]
    if kind == "sun":
        out = [_circle(rng, 0.25)]
        for k in range(int(rng.integers(4, 10))):
            a = 2 * math.pi * k / 8 + rng.normal(0, 0.1)
            d = np.array([math.cos(a), math.sin(a)])
            out.append(np.stack([d * 0.33, d * 0.5]))
        return out
    raise ValueError(f"unknown extra kind {kind!r}")


def _loose_circle(rng: np.random.Generator) -> list[np.ndarray]:
    """A circle as people write an o: lumpy, angular or egg-shaped, beginning or ending with a
    hook inward or a tail outward, overlapping or a little open."""
    turn = rng.uniform(0.88, 1.3)
    t = rng.uniform(0, 2 * math.pi) + np.linspace(0, 2 * math.pi * turn, 90)
    r = 1.0 + rng.uniform(-0.15, 0.15) * np.linspace(0, 1, t.size)
    for k in (2, 3, 4, 5):
        r = r + rng.uniform(0, 0.12 if k < 4 else 0.05) * np.cos(k * t + rng.uniform(0, 6.3))
    pts = np.stack([r * np.cos(t), r * rng.uniform(0.45, 1.0) * np.sin(t)], 1)
    if rng.random() < 0.3:  # angular: straight between a few irregular corners
        n = int(rng.integers(6, 11))
        keep = np.unique(
            [*np.sort(rng.choice(len(pts), n, replace=False)).tolist(), 0, len(pts) - 1]
        )
        pts = _resample(pts[keep], 0.02)
        pts = _smooth(pts, int(rng.integers(0, 2)))
    for end in ("start", "end"):
        if rng.random() < 0.3:  # a hook in or a tail out
            at = pts[0] if end == "start" else pts[-1]
            inward = -at / max(float(np.hypot(*at)), 1e-6)
            way = inward if rng.random() < 0.7 else -inward
            way = way + rng.normal(0, 0.4, 2)
            tail = at + np.linspace(0, rng.uniform(0.1, 0.45), 8)[1:, None] * way
            pts = (
                np.concatenate([tail[::-1], pts]) if end == "start" else np.concatenate([pts, tail])
            )
    a = rng.uniform(0, math.pi)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return _centred([pts @ rot.T])


def _loose_cross(rng: np.random.Generator) -> list[np.ndarray]:
    """Two strokes crossing as people write an x: at 50-130 degrees, crossing anywhere along
    the middle half of each, unequal, bowed, hooked at an end."""
    between = math.radians(rng.uniform(50, 130))
    upright = math.pi / 2 + (math.pi / 2 if rng.random() < 0.5 else 0.0)
    out = []
    for a in (
        upright - between / 2 + rng.normal(0, 0.15),
        upright + between / 2 + rng.normal(0, 0.15),
    ):
        d = np.array([math.cos(a), math.sin(a)])
        n = np.array([-d[1], d[0]])
        at = rng.uniform(0.3, 0.7)
        u = np.linspace(0, 1, 24)[:, None]
        stroke = (u - at) * d * rng.uniform(0.6, 1.0) + rng.uniform(-0.15, 0.15) * (
            1 - (2 * u - 1) ** 2
        ) * n
        if rng.random() < 0.2:
            hook = stroke[-1] + np.linspace(0, rng.uniform(0.05, 0.15), 5)[1:, None] * (
                n * rng.choice((-1, 1)) - 0.5 * d
            )
            stroke = np.concatenate([stroke, hook])
        out.append(stroke if rng.random() < 0.5 else stroke[::-1])
    return _centred(out)


def strokes_of(
    source: str, rng: np.random.Generator, hands: dict[str, list[list[np.ndarray]]] | None = None
) -> list[np.ndarray]:
    """One drawing of `source` (POSITIVE_SOURCES, REAL_SOURCES, NEGATIVE_SOURCES) in a cell's
    unit square; `hands` holds the real drawings (`real_hands`)."""
    group, _, kind = source.partition("_")
    if group == "real":
        if not hands:
            raise ValueError("real drawings asked for without real_hands")
        drawings = hands[kind]
        return _hand(drawings[int(rng.integers(len(drawings)))], rng)
    if group == "dev":
        return draw_kind(kind, rng)
    if group == "loose":
        return _hand(_loose_circle(rng) if kind == "circle" else _loose_cross(rng), rng)
    if group == "person":
        return person_strokes(kind, rng)
    if group == "synth":
        if kind in ("circle", "cross"):
            return _hand(_from_box(symbol_strokes(kind, rng)), rng)
        return _hand(_from_box(partial_strokes(rng, kind)), rng)
    return _hand(_extra(kind, rng), rng)


def synth_render(strokes: list[np.ndarray], rng: np.random.Generator, size: int = 40) -> np.ndarray:
    """Unit-square strokes with the synthesiser's pens and paper, grid remnants at the border."""
    cell = paper((size, size), rng)
    pen = Pen.random(rng, size * 0.6)
    mask = ink_mask((size, size), [np.asarray(s) * size for s in strokes], pen, rng)
    cell = np.clip(cell * (1.0 - pen.darkness * mask), 0, 255).astype(np.uint8)
    return add_grid_remnants(cell, rng, probability=0.3)


def draw_set(
    n: int,
    seed: int,
    positive_share: float = 0.4,
    hands: dict[str, list[list[np.ndarray]]] | None = None,
    real_share: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """`n` cells (uint8 (n, 40, 40)), their labels (1: whole symbol) and sources; a third of
    them on sheets cut by the board reader, a third alone in a cell, a third synthesised.
    `real_share` of the positives are `hands`' real drawings."""
    rng = np.random.default_rng([seed, 77])

    def positive() -> str:
        if hands and rng.random() < real_share:
            return str(rng.choice(REAL_SOURCES))
        return str(rng.choice(POSITIVE_SOURCES))

    sources = [
        positive() if rng.random() < positive_share else str(rng.choice(NEGATIVE_SOURCES))
        for _ in range(n)
    ]
    renders = [RENDERS[i % 3] for i in range(n)]
    cells = np.zeros((n, 40, 40), np.uint8)
    on_sheet = [i for i, r in enumerate(renders) if r == "sheet"]
    for first in range(0, len(on_sheet), 9):
        part = on_sheet[first : first + 9]
        sheet = Sheet(int(rng.integers(2**31)))
        for cell, i in zip(CELL_NAMES, part, strict=False):
            width = int(rng.integers(3, 9)) if rng.random() < 0.7 else 5
            for points in strokes_of(sources[i], rng, hands):
                sheet.stroke(unit_to_canvas(cell, points), width)
        try:
            cut = cut_board(sheet.image)[0]
        except OxbotError:  # a drawing that hides the grid: draw these alone
            cut = np.stack([cell_image(strokes_of(sources[i], rng, hands), rng) for i in part])
            cells[part] = cut[: len(part)]
            continue
        cells[part] = cut[: len(part)]
    for i, r in enumerate(renders):
        if r == "cell":
            cells[i] = cell_image(strokes_of(sources[i], rng, hands), rng)
        elif r == "synth":
            cells[i] = synth_render(strokes_of(sources[i], rng, hands), rng)
    labels = np.array([s in POSITIVE_SOURCES or s in REAL_SOURCES for s in sources], np.float32)
    return cells, labels, [f"{s}|{r}" for s, r in zip(sources, renders, strict=True)]
