"""The report's table cells: a figure written as a percentage, seconds, yes/no, win/draw/loss or
a ratio, and one row of the paper's figures table."""

from __future__ import annotations

from typing import Any


def _pct(x: float | None, digits: int = 2) -> str:
    return "not measured" if x is None else f"{100 * x:.{digits}f}%"


def _seconds(s: float | None) -> str:
    if s is None:
        return "none"
    return f"{s:.0f} s" if s >= 10 else f"{s:.1f} s"


def _yes(ok: bool) -> str:
    return "yes" if ok else "**no**"


def _wdl(r: dict[str, Any]) -> str:
    return f"{_pct(r['win_rate'])} / {_pct(r['draw_rate'])} / {_pct(r['loss_rate'])}"


def _ratio(peer: float | None, ours: float | None, budget: float) -> str:
    if ours is None:
        return "oxbot had losses to the end"
    if peer is None:
        return f"> {budget / ours:.1f}x (none within {budget:.0f} s)"
    return f"{peer / ours:.1f}x"


def _error_ratio(peer: float, ours: float) -> str:
    if ours >= 1.0:
        return "against none in" if peer < 1.0 else "equal to"
    return f"{(1 - peer) / (1 - ours):.0f} times"


def _row(measured: str, paper: str, ours: str, shipped: str, goal: str, met: str) -> str:
    """One row of the paper's figures table."""
    return f"| {measured} | {paper} | {ours} | {shipped} | {goal} | {met} |"


def _met(run_ok: bool, shipped_ok: bool) -> str:
    return f"{_yes(run_ok)} / {_yes(shipped_ok)}"
