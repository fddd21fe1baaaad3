"""Cells that must never read as a move, drawn independently of the training synthesiser.

The acceptance sets for such cells. Nothing here imports `oxbot.perception`: the shapes come
straight from OpenCV's drawing primitives with their own randomness, so that a classifier which
learnt the synthesiser's quirks cannot pass by recognising them.

    partial_cell(kind, rng)  ink that is not a whole symbol: PARTIAL_KINDS
    empty_cell(kind, rng)    a blank cell of a used sheet: EMPTY_KINDS

Both give uint8 (40, 40) dark ink on light paper.
"""

from __future__ import annotations

import cv2
import numpy as np

SIZE = 40
_UP = 8  # drawn 8x larger, then shrunk: smooth edges without relying on LINE_AA alone

PARTIAL_KINDS = ("arc", "semicircle", "three_quarters", "plus", "stroke", "tick", "scribble")
"""Half-drawn and wrong shapes: arcs of 45-270 degrees, semicircles, three quarters of a
circle (255-275 degrees), plus signs with long arms, single strokes, ticks, scribbles."""
EMPTY_KINDS = ("squared", "dotted", "ruled", "ghost", "remnants", "smudge")
"""Blank cells: squared, dotted or ruled paper; an erased mark; grid-line remnants at the
border; a smudge. Each on its own paper."""


def _sheet(rng: np.random.Generator) -> np.ndarray:
    """Paper: a tone with a gentle slope and grain, float32 at SIZE*_UP."""
    side = SIZE * _UP
    tone = rng.uniform(165, 240)
    slope = rng.uniform(-12, 12) * np.linspace(-1, 1, side, dtype=np.float32)
    sheet = np.full((side, side), tone, np.float32) + (
        slope if rng.random() < 0.5 else slope[:, None]
    )
    return sheet


def _finish(sheet: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Shrink to SIZE, blur a little, add sensor noise."""
    cell = cv2.resize(sheet, (SIZE, SIZE), interpolation=cv2.INTER_AREA)
    if rng.random() < 0.5:
        cell = cv2.GaussianBlur(cell, (3, 3), rng.uniform(0.3, 0.9))
    cell = cell + rng.normal(0, rng.uniform(0.5, 4.0), cell.shape)
    return np.clip(cell, 0, 255).astype(np.uint8)


def _ink(sheet: np.ndarray, mask: np.ndarray, darkness: float) -> np.ndarray:
    """Darken `sheet` by `darkness` where `mask` (uint8 0/255) is set."""
    return sheet * (1.0 - darkness * mask.astype(np.float32) / 255.0)


def _pt(x: float, y: float) -> tuple[int, int]:
    return round(x * _UP), round(y * _UP)


def partial_cell(kind: str, rng: np.random.Generator) -> np.ndarray:
    """One cell holding ink that is not a whole symbol, of `kind` (one of PARTIAL_KINDS)."""
    sheet = _sheet(rng)
    mask = np.zeros(sheet.shape, np.uint8)
    thick = max(1, round(rng.uniform(1.0, 3.5) * _UP))
    cx, cy = SIZE / 2 + rng.uniform(-4, 4), SIZE / 2 + rng.uniform(-4, 4)
    r = rng.uniform(8, 15)
    if kind in ("arc", "semicircle", "three_quarters"):
        sweep = {"arc": (45, 270), "semicircle": (170, 190), "three_quarters": (255, 275)}[kind]
        span = rng.uniform(*sweep)
        start = rng.uniform(0, 360)
        axes = _pt(r, r * rng.uniform(0.7, 1.0))
        cv2.ellipse(mask, _pt(cx, cy), axes, rng.uniform(0, 180), start, start + span, 255, thick)
    elif kind == "plus":
        tilt = np.deg2rad(rng.uniform(-10, 10))
        for a in (tilt, tilt + np.pi / 2):
            arm = rng.uniform(11, 16)
            dx, dy = np.cos(a) * arm, np.sin(a) * arm
            cv2.line(mask, _pt(cx - dx, cy - dy), _pt(cx + dx, cy + dy), 255, thick)
    elif kind == "stroke":
        a = rng.uniform(0, np.pi)
        half = rng.uniform(8, 16)
        dx, dy = np.cos(a) * half, np.sin(a) * half
        cv2.line(mask, _pt(cx - dx, cy - dy), _pt(cx + dx, cy + dy), 255, thick)
    elif kind == "tick":
        s = rng.uniform(0.7, 1.2)
        pts = np.array([[-9, -1], [-3, 7], [11, -11]], np.float64) * s + [cx, cy]
        pts[:, 1] += rng.normal(0, 1, 3)
        cv2.polylines(mask, [np.array([_pt(*p) for p in pts], np.int32)], False, 255, thick)
    elif kind == "scribble":
        n = int(rng.integers(5, 10))
        pts = np.stack([cx + rng.uniform(-11, 11, n), cy + rng.uniform(-8, 8, n)], axis=1)
        cv2.polylines(mask, [np.array([_pt(*p) for p in pts], np.int32)], False, 255, thick)
    else:
        raise ValueError(f"unknown partial kind {kind!r}; kinds are {PARTIAL_KINDS}")
    return _finish(_ink(sheet, mask, rng.uniform(0.45, 0.9)), rng)


def empty_cell(kind: str, rng: np.random.Generator) -> np.ndarray:
    """One blank cell of a used sheet, of `kind` (one of EMPTY_KINDS)."""
    sheet = _sheet(rng)
    side = sheet.shape[0]
    mask = np.zeros(sheet.shape, np.uint8)
    if kind in ("squared", "dotted", "ruled"):
        step = rng.uniform(4.5, 10.0) * _UP
        offset = rng.uniform(0, step, 2)
        lines = np.arange(-step, side + step, step)
        width = max(1, round(rng.uniform(0.4, 1.0) * _UP))
        if kind == "dotted":
            for x in lines + offset[0]:
                for y in lines + offset[1]:
                    cv2.circle(mask, (int(x), int(y)), width, 255, -1)
        else:
            for y in lines + offset[1]:
                cv2.line(mask, (0, int(y)), (side, int(y)), 255, width)
            if kind == "squared":
                for x in lines + offset[0]:
                    cv2.line(mask, (int(x), 0), (int(x), side), 255, width)
        darkness = rng.uniform(0.05, 0.25)
    elif kind == "ghost":  # a circle or a cross rubbed out: faint, soft, broken
        cx, cy = SIZE / 2 + rng.uniform(-3, 3), SIZE / 2 + rng.uniform(-3, 3)
        thick = max(1, round(rng.uniform(1.5, 3.5) * _UP))
        if rng.random() < 0.5:
            r = rng.uniform(9, 15)
            cv2.ellipse(mask, _pt(cx, cy), _pt(r, r * 0.9), 0, 0, 360, 255, thick)
        else:
            h = rng.uniform(8, 14)
            cv2.line(mask, _pt(cx - h, cy - h), _pt(cx + h, cy + h), 255, thick)
            cv2.line(mask, _pt(cx + h, cy - h), _pt(cx - h, cy + h), 255, thick)
        holes = rng.random((SIZE, SIZE)) < rng.uniform(0.1, 0.5)
        mask[
            cv2.resize(holes.astype(np.uint8), (side, side), interpolation=cv2.INTER_NEAREST) > 0
        ] = 0
        mask = cv2.GaussianBlur(mask, (0, 0), rng.uniform(0.8, 2.0) * _UP)
        darkness = rng.uniform(0.04, 0.15)
    elif kind == "remnants":  # what grid removal leaves: bits of line within 3 px of an edge
        width = max(1, round(rng.uniform(0.8, 2.5) * _UP))
        for edge in rng.choice(4, size=int(rng.integers(1, 3)), replace=False):
            depth = rng.uniform(0, 3) * _UP
            a, b = sorted(rng.uniform(0, side, 2))
            b = max(b, a + 0.3 * side)
            at = depth if edge in (0, 2) else side - 1 - depth
            tilt = rng.uniform(-1.5, 1.5) * _UP
            if edge < 2:
                cv2.line(mask, (int(a), int(at)), (int(b), int(at + tilt)), 255, width)
            else:
                cv2.line(mask, (int(at), int(a)), (int(at + tilt), int(b)), 255, width)
        darkness = rng.uniform(0.3, 0.8)
    elif kind == "smudge":
        for _ in range(int(rng.integers(1, 3))):
            centre = (int(rng.uniform(0, side)), int(rng.uniform(0, side)))
            axes = (int(rng.uniform(3, 12) * _UP), int(rng.uniform(2, 8) * _UP))
            cv2.ellipse(mask, centre, axes, rng.uniform(0, 180), 0, 360, 255, -1)
        mask = cv2.GaussianBlur(mask, (0, 0), rng.uniform(2, 5) * _UP)
        darkness = rng.uniform(0.05, 0.2)
    else:
        raise ValueError(f"unknown empty kind {kind!r}; kinds are {EMPTY_KINDS}")
    return _finish(_ink(sheet, mask, darkness), rng)


def odd_cells(
    n: int, rng: np.random.Generator, kinds: tuple[str, ...], draw: object
) -> tuple[np.ndarray, list[str]]:
    """`n` cells of the given kinds in turn, drawn by `draw(kind, rng)`; with their kinds."""
    names = [kinds[i % len(kinds)] for i in range(n)]
    return np.stack([draw(kind, rng) for kind in names]), names  # type: ignore[operator]
