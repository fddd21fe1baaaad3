"""The experimenter page's plots: one measure by condition, means with 95% intervals, as PNG."""

from __future__ import annotations

import io
from typing import Any

PLOTS = {
    "success": "Games played to the end (share)",
    "turns": "Turns per game",
    "sus": "SUS (0-100)",
    "likeability": "Godspeed likeability (1-5)",
    "intelligence": "Godspeed perceived intelligence (1-5)",
}
"""The measures plotted, with their axis labels."""


def plot_png(measure: str, summary: dict[str, dict[str, dict[str, Any]]]) -> bytes:
    """A bar per condition of `measure`'s mean, with its 95% interval, as PNG bytes."""
    import matplotlib

    matplotlib.use("Agg")  # no display: the server draws off screen
    from matplotlib.figure import Figure

    names = [c for c, m in summary.items() if m[measure]["mean"] is not None]
    means = [summary[c][measure]["mean"] for c in names]
    errors = [
        [
            m - (summary[c][measure]["low"] if summary[c][measure]["low"] is not None else m)
            for c, m in zip(names, means, strict=True)
        ],
        [
            (summary[c][measure]["high"] if summary[c][measure]["high"] is not None else m) - m
            for c, m in zip(names, means, strict=True)
        ],
    ]
    figure = Figure(figsize=(6, 3.2), dpi=100)
    axes = figure.subplots()
    if names:
        axes.bar(range(len(names)), means, yerr=errors, capsize=4, color="#4a7ab5")
        axes.set_xticks(range(len(names)), names, rotation=20, ha="right", fontsize=8)
        for i, c in enumerate(names):
            axes.annotate(
                f"n={summary[c][measure]['n']}",
                (i, 0),
                ha="center",
                va="bottom",
                fontsize=7,
                color="white",
            )
    else:
        axes.text(0.5, 0.5, "no data yet", ha="center", va="center", transform=axes.transAxes)
    axes.set_ylabel(PLOTS[measure], fontsize=8)
    axes.set_title(f"{PLOTS[measure]} by condition (95% intervals)", fontsize=9)
    figure.tight_layout()
    out = io.BytesIO()
    figure.savefig(out, format="png")
    return out.getvalue()
