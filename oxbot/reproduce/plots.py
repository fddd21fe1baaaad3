"""The report's plots: the learners' curves copied beside it, the losses of oxbot's agent and its
peers against training time drawn, and the learning curves section (the paper's Figure
"plots")."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from oxbot.atomic import atomic_write, save_figure
from oxbot.reproduce.agent_peers import LEARNER_NAMES


def _write_plots(out_dir: Path, work_dir: Path, figures: dict[str, Any]) -> list[Path]:
    copies = {
        "perceiver_accuracy.png": figures["perceiver"]["curve_png"],
        "agent_reward.png": figures["agent"]["reward_png"],
        "agent_win_draw.png": figures["agent"]["win_draw_png"],
    }
    written = []
    for name, source in copies.items():
        with atomic_write(out_dir / name, "wb") as handle:
            handle.write(Path(source).read_bytes())
        written.append(out_dir / name)
    written.append(_plot_losses(out_dir / "losses_vs_time.png", figures))
    return written


def _plot_losses(path: Path, figures: dict[str, Any]) -> Path:
    """The worst condition's loss rate at each greedy evaluation against training seconds."""

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    series = {"oxbot DQN": figures["agent"]["evaluations"]}
    series.update({LEARNER_NAMES[k]: v["evaluations"] for k, v in figures["agent_peers"].items()})
    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=110)
    for (name, evaluations), style in zip(series.items(), ("o-", "s--", "^:"), strict=False):
        xs = [e["train_s"] for e in evaluations]
        ys = [100 * max(e["losses"].values()) for e in evaluations]
        ax.plot(xs, ys, style, label=name, markersize=4)
    ax.set_xlabel("training time (s)")
    ax.set_ylabel("loss rate, worst condition (%)")
    ax.set_title("Greedy evaluations while training: losses against time")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return save_figure(fig, path)


def _learning_curves_section(f: dict[str, Any]) -> list[str]:
    """The paper's Figure "plots": the three learning curves side by side."""
    return [
        '## Learning curves (the paper\'s Figure "plots")',
        "",
        "| classification accuracy against training images | average reward against "
        "experiences | win/draw rate against games |",
        "|---|---|---|",
        "| ![accuracy](perceiver_accuracy.png) | ![reward](agent_reward.png) | "
        "![win/draw](agent_win_draw.png) |",
        "",
        "Left: accuracy on the 1,000 test images after training on the first "
        + ", ".join(f"{p['images']:,}" for p in f["perceiver"]["learning_curve"])
        + " images (training time dotted). Middle and right: while training, exploring "
        "(epsilon-greedy), so below the greedy figures above.",
        "",
    ]
