"""Reproducing the paper side by side: `oxbot reproduce` (issue 8).

One run, from a clean work folder: draw the 108 seed images, train the perceiver on 10K images
generated from them, train the interaction manager, evaluate both as the paper did (and as
SPEC §3 asks), train the peers (a linear SVM on raw pixels; Stable-Baselines3's DQN and
sb3-contrib's MaskablePPO for the same wall-clock time as oxbot's agent) and write
`REPORT.md` with its plots and `report.json` with every figure, seed, version and the machine.

    result = reproduce("reports", "runs/reproduce", train_config, eval_config, quick=True)
    result.report_path

Everything but the times is fixed by the seeds: the same seeds give the same numbers on the
same machine, except the SB3 peers', which learn for as many steps as fit in their time.
"""

from __future__ import annotations

import dataclasses
import datetime
import importlib.metadata
import json
import logging
import os
import platform
import shutil
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from oxbot import artifacts
from oxbot.atomic import atomic_write, save_figure, write_text_atomic
from oxbot.config import OxbotConfig, with_overrides
from oxbot.dialogue.evaluation import CONDITIONS, condition_key
from oxbot.errors import ConfigError, DataError
from oxbot.peers import (
    PEER_AGENTS,
    PixelSVM,
    evaluate_conditions,
    peer_batch_policy,
    peer_settings,
    train_peer_agent,
    zero_losses,
)

log = logging.getLogger(__name__)

MARKER = ".oxbot-reproduce"
"""A file in the work folder saying oxbot made it, so a rerun may clear it."""
WORK_PARTS = ("seeds", "perceiver", "agent", MARKER)

PAPER = "Cuayáhuitl et al. 2016, `seed/paper.tex`"
PAPER_FIGURES = {
    "accuracy": (0.999, "Experimental Results: 99.9% on 1000 randomly generated test images"),
    "train_time_10k_s": (360.0, "Experimental Results: 10K images in 6 minutes, Core i7 3.4 GHz"),
    "win_draw": (0.98, "abstract, Concluding Remarks: win/draw rate of 98%"),
    "agent_time_s": (3 * 3600.0, "Experimental Results: a reasonable policy after 3 hours"),
    "seed_images": (108, "Related Work and Limitations, Concluding Remarks"),
    "seed_dialogues": (10, "Experimental Results, Concluding Remarks"),
}
"""The paper's figures the report compares with, each with where paper.tex gives it."""
GOALS = {
    "accuracy": 0.999,
    "other_hand": 0.995,
    "train_time_10k_s": 30.0,
    "agent_time_s": 300.0,
    "win_random": {True: 0.9948, False: 0.9164},
}
"""SPEC §1 and §3: oxbot's goals (the optimum against a random person minus 1 point)."""


@dataclass(frozen=True)
class Budgets:
    """How much each learner gets; the full run is the one the shipped models came from."""

    perceiver_images: int | None
    """Training images generated from the seeds (None: the config's, 10K)."""
    agent_steps: int | None
    """Experiences of the interaction manager (None: the config's)."""
    agent_eval_every: int | None
    """Greedy evaluations during training every this many experiences (None: the config's)."""
    agent_eval_games: int | None
    """Games per condition of those evaluations (None: the config's)."""
    evaluation_games: int
    """Games per opponent and who-starts condition of the final evaluations (SPEC §3: 10,000)."""


FULL = Budgets(None, None, None, None, 10_000)
QUICK = Budgets(1_000, 4_000, 2_000, 100, 300)


@dataclass
class ReproduceResult:
    """What `reproduce` measured and where it wrote it."""

    figures: dict[str, Any]
    report_path: Path
    json_path: Path
    plots: list[Path]


def reproduce(
    out_dir: str | Path,
    work_dir: str | Path,
    train_config: OxbotConfig,
    eval_config: OxbotConfig,
    quick: bool = False,
    show_progress: bool = True,
    announce: Callable[[str], None] = log.info,
) -> ReproduceResult:
    """Make the seeds, train and evaluate both learners and their peers, write the report.

    `train_config` trains the learners (the shipped agent's: `oxbot/data/models/agent.toml`);
    `eval_config` is the simulated person they are measured against (the paper's defaults).
    `quick` uses the small `QUICK` budgets and says so in the report.
    """
    started = time.perf_counter()
    budgets = QUICK if quick else FULL
    out_dir, work_dir = Path(out_dir), Path(work_dir)
    _prepare_work_dir(work_dir)
    _check_out_dir(out_dir)
    figures: dict[str, Any] = {
        "mode": "quick" if quick else "full",
        "budgets": dataclasses.asdict(budgets),
        "started": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "environment": environment(),
    }

    announce("1/6 drawing the seed images")
    figures["data"] = _make_seed_data(work_dir, train_config)

    announce("2/6 training and evaluating the perceiver")
    figures["perceiver"] = _train_perceiver(work_dir, train_config, budgets, show_progress)

    announce("3/6 training the perception peer: a linear SVM on raw pixels")
    figures["perceiver_peer"] = train_pixel_svm_peer(
        work_dir / "seeds", train_config, budgets.perceiver_images
    )

    announce("4/6 training the interaction manager")
    agent_config = agent_config_for(train_config, budgets)
    figures["agent"] = train_and_evaluate_agent(
        work_dir, agent_config, eval_config, budgets, show_progress
    )

    announce("5/6 training the SB3 peers for the same time as oxbot's agent")
    figures["agent_peers"] = train_agent_peers(
        agent_config, eval_config, figures["agent"], budgets, announce, show_progress
    )

    announce("6/6 measuring the shipped models and writing the report")
    figures["shipped"] = measure_shipped(work_dir, train_config, eval_config, budgets)
    figures["shipped"]["agent"].update(
        _shipped_agent_against_run(figures["shipped"]["agent"], figures["agent"], agent_config)
    )
    figures["seeds"] = {
        "perception": train_config.perception.seed,
        "agent": agent_config.agent.seed,
        "evaluation": 0,
        "peers": agent_config.agent.seed,
    }
    figures["configs"] = {
        "train": dataclasses.asdict(agent_config),
        "evaluate": dataclasses.asdict(eval_config),
    }
    figures["wall_clock_s"] = round(time.perf_counter() - started, 1)
    plots = _write_plots(out_dir, work_dir, figures)
    json_path = out_dir / "report.json"
    write_text_atomic(json_path, json.dumps(_json_safe(figures), indent=2) + "\n")
    report_path = out_dir / "REPORT.md"
    write_text_atomic(report_path, render_report(figures))
    return ReproduceResult(figures, report_path, json_path, plots)


# --- the steps ---------------------------------------------------------------------------


def _prepare_work_dir(work_dir: Path) -> None:
    """A clean work folder: a previous run's parts are removed, anyone else's folder refused."""
    if work_dir.exists() and not work_dir.is_dir():
        raise ConfigError(f"work folder {work_dir} is a file; give a folder with --work")
    if work_dir.is_dir() and any(work_dir.iterdir()):
        if not (work_dir / MARKER).exists():
            raise ConfigError(
                f"work folder {work_dir} is not empty and was not made by `oxbot reproduce`; "
                "give an empty or new folder with --work"
            )
        for part in WORK_PARTS:
            path = work_dir / part
            if path.is_dir():
                shutil.rmtree(path)
            elif path.exists():
                path.unlink()
    work_dir.mkdir(parents=True, exist_ok=True)
    write_text_atomic(work_dir / MARKER, "made by oxbot reproduce; cleared by its next run\n")


def _check_out_dir(out_dir: Path) -> None:
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfigError(f"report folder {out_dir} is a file; give a folder with --out")
    out_dir.mkdir(parents=True, exist_ok=True)


def _make_seed_data(work_dir: Path, config: OxbotConfig) -> dict[str, Any]:
    from oxbot.dialogue.domain import load_domain
    from oxbot.perception.seeds import load_seeds, make_seeds

    p = config.perception
    written = make_seeds(work_dir / "seeds", p.seeds_per_class, p.seed, p.image_size)
    made, shipped = load_seeds(work_dir / "seeds", p.image_size), load_seeds(size=p.image_size)
    same = all(
        len(made.images[k]) == len(shipped.images[k])
        and all(
            np.array_equal(a, b) for a, b in zip(made.images[k], shipped.images[k], strict=True)
        )
        for k in made.images
    )
    domain = load_domain()
    return {
        "seed_images": len(written),
        "seed_images_per_label": {k: len(v) for k, v in made.images.items()},
        "seed_images_same_as_shipped": same,
        "seed_dialogues": len(domain.dialogues),
        "vocabulary": len(domain.vocabulary),
    }


def _train_perceiver(
    work_dir: Path, config: OxbotConfig, budgets: Budgets, show_progress: bool
) -> dict[str, Any]:

    from oxbot.perception.classifier import load_classifier
    from oxbot.perception.training import train_perceiver

    result = train_perceiver(
        config.perception,
        budgets.perceiver_images,
        work_dir / "seeds",
        work_dir / "perceiver" / "perceiver.pt",
        curve=True,
        show_progress=show_progress,
    )
    m = result.metrics
    timing = _time_perceiver_fit(work_dir, config, m["train_images"])
    same_weights = _same_weights(result.classifier.net, load_classifier().net)
    return {
        "train_images": m["train_images"],
        "generate_s": m["generate_seconds"],
        "fit_s": m["fit_seconds"],
        "train_s": round(m["generate_seconds"] + m["fit_seconds"], 3),
        "timed_refit": {
            **{k: v for k, v in timing.items() if k != "classifier"},
            "identical_weights": _same_weights(timing["classifier"].net, result.classifier.net),
        },
        "accuracy": m["test"]["accuracy"],
        "test_images": m["test"]["images"],
        "other_hand": m["fonts"].get("accuracy"),
        "other_hand_images": m["fonts"].get("images"),
        "other_hand_error": m["fonts"].get("error"),
        "learning_curve": m["learning_curve"],
        "same_as_shipped": same_weights,
        "curve_png": str(result.curve_path),
    }


def _time_perceiver_fit(work_dir: Path, config: OxbotConfig, images: int) -> dict[str, Any]:
    """Generate and fit once more, timed in wall-clock and CPU seconds.

    The machine may be shared: one torch thread's CPU time is what the same work takes on a
    core of its own. The refit must give the very same weights (a check of determinism).
    """
    from oxbot.perception.augment import generate
    from oxbot.perception.classifier import SymbolClassifier
    from oxbot.perception.evaluation import TRAIN_STREAM
    from oxbot.perception.seeds import load_seeds

    p = config.perception
    seeds = load_seeds(work_dir / "seeds", p.image_size)
    wall, cpu = time.perf_counter(), time.process_time()
    x, y = generate(seeds, images, np.random.default_rng([p.seed, TRAIN_STREAM]), p.image_size)
    generate_wall, generate_cpu = time.perf_counter() - wall, time.process_time() - cpu
    wall, cpu = time.perf_counter(), time.process_time()
    classifier = SymbolClassifier(p).fit(x, y)
    fit_wall, fit_cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {
        "generate_s": round(generate_wall, 2),
        "generate_cpu_s": round(generate_cpu, 2),
        "fit_s": round(fit_wall, 2),
        "fit_cpu_s": round(fit_cpu, 2),
        "train_s": round(generate_wall + fit_wall, 2),
        "train_cpu_s": round(generate_cpu + fit_cpu, 2),
        "classifier": classifier,
    }


def _same_weights(a: Any, b: Any) -> bool:
    """Whether two torch modules hold exactly the same parameters."""
    import torch

    sa, sb = a.state_dict(), b.state_dict()
    return list(sa) == list(sb) and all(
        sa[k].shape == sb[k].shape and torch.equal(sa[k], sb[k]) for k in sa
    )


def train_pixel_svm_peer(
    seeds_dir: str | Path | None, config: OxbotConfig, images: int | None = None
) -> dict[str, Any]:
    """Fit the pixel SVM on the CNN's training images (same seeds, seed and stream) and
    measure it on the CNN's test sets; `images` None means the config's 10K."""
    from oxbot.perception.augment import generate
    from oxbot.perception.classifier import label_indices
    from oxbot.perception.evaluation import (
        TRAIN_STREAM,
        evaluate,
        evaluate_fonts,
        generated_test_set,
    )
    from oxbot.perception.seeds import load_seeds

    p = config.perception
    n = images or p.train_images
    seeds = load_seeds(seeds_dir, p.image_size)
    x, y = generate(seeds, n, np.random.default_rng([p.seed, TRAIN_STREAM]), p.image_size)
    test_x, test_y = generated_test_set(seeds, p.test_images, p.seed, p.image_size)
    tick, cpu = time.perf_counter(), time.process_time()
    svm = PixelSVM(p.image_size, seed=p.seed).fit(x, label_indices(y))
    fit_s, fit_cpu = time.perf_counter() - tick, time.process_time() - cpu
    try:
        other_hand: float | None = evaluate_fonts(svm, seed=p.seed).accuracy
    except DataError as exc:  # no fonts installed: the CNN's row says so too
        log.warning("font set unavailable for the SVM: %s", exc)
        other_hand = None
    return {
        "train_images": n,
        "fit_s": round(fit_s, 3),
        "fit_cpu_s": round(fit_cpu, 3),
        "accuracy": evaluate(svm, test_x, test_y).accuracy,
        "other_hand": other_hand,
    }


def measure_shipped(
    work_dir: Path, config: OxbotConfig, eval_config: OxbotConfig, budgets: Budgets
) -> dict[str, Any]:
    """The shipped perceiver and agent on this run's test sets and games, and the training
    figures their own metrics files recorded."""
    from oxbot.dialogue.agent import load_policy, shipped_policy_path, training_budget
    from oxbot.perception.classifier import load_classifier, shipped_model_path
    from oxbot.perception.evaluation import evaluate_fonts, evaluate_generated
    from oxbot.perception.seeds import load_seeds
    from oxbot.perception.training import companion_paths

    p = config.perception
    classifier = load_classifier()
    seeds = load_seeds(work_dir / "seeds", p.image_size)
    try:
        other_hand: float | None = evaluate_fonts(classifier, seed=p.seed).accuracy
    except DataError:
        other_hand = None
    remedy = "re-download it from the oxbot repository"
    perceiver_metrics = artifacts.load_json(
        companion_paths(shipped_model_path())[0], "the shipped perceiver's metrics", remedy
    )
    agent_dir = shipped_policy_path().parent
    agent_metrics = artifacts.load_json(
        agent_dir / "agent_metrics.json", "the shipped agent's metrics", remedy
    )
    first_zero = next(
        (e for e in agent_metrics["evaluations"] if all(loss == 0 for loss in _losses(e).values())),
        None,
    )
    policy = load_policy()
    # a fine-tune's budget counts the runs it started from
    experiences, train_s = training_budget(agent_metrics)
    earlier_s = train_s - agent_metrics["wall_clock_s"]
    return {
        "perceiver": {
            "accuracy": evaluate_generated(classifier, seeds, p.test_images, p.seed).accuracy,
            "other_hand": other_hand,
            "train_images": perceiver_metrics["train_images"],
            "train_s": round(
                perceiver_metrics["generate_seconds"] + perceiver_metrics["fit_seconds"], 1
            ),
        },
        "agent": {
            "final": evaluate_conditions(
                policy.act_batch, budgets.evaluation_games, eval_config, seed=0, cooperative=True
            ),
            "people": evaluate_conditions(
                policy.act_batch, budgets.evaluation_games, eval_config, seed=0
            ),
            "train_s": round(train_s, 1),
            "experiences": experiences,
            "best_step": agent_metrics["best_step"],
            # a fine-tune's counts from the start of the runs before it
            "time_to_zero_losses_s": (first_zero["elapsed_s"] + earlier_s if first_zero else None),
            "config": agent_metrics["config"],
            "reward_curve": agent_metrics["reward_curve"],
        },
    }


def _shipped_agent_against_run(
    shipped: dict[str, Any], agent: dict[str, Any], agent_config: OxbotConfig
) -> dict[str, Any]:
    """Whether the shipped agent was trained with this run's config, and the first experience
    at which its average reward parts from this run's agent's (None if it never does)."""
    return {
        "same_config": shipped["config"] == _json_safe(dataclasses.asdict(agent_config)),
        "diverges_at": next(
            (
                ours[0]
                for ours, theirs in zip(
                    agent["reward_curve"], shipped["reward_curve"], strict=False
                )
                if ours != theirs
            ),
            None,
        ),
    }


def agent_config_for(config: OxbotConfig, budgets: Budgets) -> OxbotConfig:
    """`config` with the budgets' experiences and evaluations; evaluations are required."""
    changes = {
        name: value
        for name, value in (
            ("total_steps", budgets.agent_steps),
            ("eval_every", budgets.agent_eval_every),
            ("eval_games", budgets.agent_eval_games),
        )
        if value is not None
    }
    config = with_overrides(config, {"agent": changes}) if changes else config
    if not config.agent.eval_every:
        raise ConfigError(
            "agent.eval_every is 0: `oxbot reproduce` needs the agent's periodic evaluations "
            "to time its first run without a loss; set agent.eval_every"
        )
    return config


def _losses(evaluation: dict[str, Any]) -> dict[str, float]:
    """The loss rate of each game condition in a training evaluation's record."""
    keys = (condition_key(name, robot_starts) for name, robot_starts in CONDITIONS)
    return {k: evaluation[k][2] for k in keys if k in evaluation}


def train_and_evaluate_agent(
    work_dir: Path,
    config: OxbotConfig,
    eval_config: OxbotConfig,
    budgets: Budgets,
    show_progress: bool,
) -> dict[str, Any]:
    """Train oxbot's agent from scratch into `work_dir/agent`, time it, evaluate it greedily
    in the six conditions, and compare it with the shipped policy."""

    from oxbot.dialogue.agent import load_policy
    from oxbot.dialogue.training import train_agent

    cpu = time.process_time()
    result = train_agent(config, work_dir / "agent", resume=False, show_progress=show_progress)
    cpu = time.process_time() - cpu
    m = result.metrics
    policy = load_policy(work_dir / "agent" / "agent.pt")
    same = _same_weights(policy.q_network, load_policy().q_network)
    games = budgets.evaluation_games
    final = evaluate_conditions(policy.act_batch, games, eval_config, seed=0, cooperative=True)
    people = evaluate_conditions(policy.act_batch, games, eval_config, seed=0)
    evaluations = [
        {
            "train_s": e["elapsed_s"],
            "steps": e["step"],
            "losses": _losses(e),
        }
        for e in m["evaluations"]
    ]
    first_zero = next(
        (e for e in evaluations if all(loss == 0 for loss in e["losses"].values())), None
    )
    return {
        "experiences": m["experiences"],
        "games": m["games"],
        "train_s": m["wall_clock_s"],
        "cpu_s": round(cpu, 1),
        "best_step": m["best_step"],
        "reward_curve": m["reward_curve"],
        "time_to_zero_losses_s": first_zero["train_s"] if first_zero else None,
        "steps_to_zero_losses": first_zero["steps"] if first_zero else None,
        "evaluations": evaluations,
        "final": final,
        "people": people,
        "same_as_shipped": same,
        "reward_png": str(work_dir / "agent" / "agent_reward.png"),
        "win_draw_png": str(work_dir / "agent" / "agent_win_draw.png"),
    }


def train_agent_peers(
    config: OxbotConfig,
    eval_config: OxbotConfig,
    agent: dict[str, Any],
    budgets: Budgets,
    announce: Callable[[str], None],
    show_progress: bool,
) -> dict[str, Any]:
    """Train the SB3 peers for the agent's wall-clock time with as many evaluations, then
    evaluate their last policies as the agent was; `agent` is `train_and_evaluate_agent`'s."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    # The same budget and as many evaluations as oxbot's agent had, on as many games each.
    budget = float(agent["train_s"])
    n_evals = max(1, len(agent["evaluations"]))
    peers = {}
    for algorithm in PEER_AGENTS:
        announce(f"    {algorithm}: {budget:.0f} s of training, evaluated {n_evals} times")
        with Progress(
            TextColumn(f"[bold]{LEARNER_NAMES[algorithm]}[/]"),
            BarColumn(),
            TextColumn("{task.completed:.0f}/{task.total:.0f} s of training"),
            TimeElapsedColumn(),
            disable=not show_progress,
        ) as progress:
            task = progress.add_task(algorithm, total=budget)
            run = train_peer_agent(
                algorithm,
                config,
                budget_s=budget,
                eval_every_s=budget / n_evals,
                eval_games=config.agent.eval_games,
                seed=config.agent.seed,
                on_progress=lambda s, t=task: progress.update(t, completed=s),
            )
        final = evaluate_conditions(
            peer_batch_policy(algorithm, run.model),
            budgets.evaluation_games,
            eval_config,
            seed=0,
            cooperative=True,
        )
        peers[algorithm] = {
            **run.to_dict(),
            "evaluations": [
                {
                    "train_s": e["train_s"],
                    "steps": e["steps"],
                    "losses": {k: r["loss_rate"] for k, r in e["results"].items()},
                }
                for e in run.evaluations
            ],
            "zero_losses_at_end": zero_losses(final),
            "settings": peer_settings(algorithm, run.model),
            "final": final,
        }
    return peers


# --- the machine, versions and plots -------------------------------------------------------


def environment() -> dict[str, Any]:
    """The machine, Python packages and commit a run was made with."""
    packages = {}
    for name in (
        "oxbot",
        "torch",
        "numpy",
        "scikit-learn",
        "gymnasium",
        "stable-baselines3",
        "sb3-contrib",
        "opencv-python-headless",
        "matplotlib",
    ):
        try:
            packages[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            packages[name] = None
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "python": platform.python_version(),
        "packages": packages,
        "platform": platform.platform(),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "commit": _git_commit(),
    }


_NOT_CODE = ("--", ".", ":(exclude)reports")


def _git_commit() -> str | None:
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
        dirty = subprocess.run(
            # reports/ is this command's own output: rewriting it is not a change to the code
            [
                *("git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"),
                *_NOT_CODE,
            ],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{head}{' (with uncommitted changes)' if dirty else ''}"


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


def _json_safe(value: Any) -> Any:
    return json.loads(json.dumps(value, default=str))


# --- the report ----------------------------------------------------------------------------

SVM_NAME = "scikit-learn `LinearSVC` on raw pixels / 255 (C=1, primal, max_iter=5000)"
LEARNER_NAMES = {"dqn": "SB3 DQN", "maskable_ppo": "sb3-contrib MaskablePPO"}
OPPONENT_NAMES = {"random": "random", "blocker": "wins and blocks", "minimax": "perfect (minimax)"}


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


def render_report(f: dict[str, Any]) -> str:
    """REPORT.md from the figures `reproduce` measured, one function per section, in order."""
    sections = (
        _header_section,
        _paper_figures_section,
        _shipped_models_note,
        _learning_curves_section,
        _perception_peers_section,
        _agent_peers_section,
        _agent_peers_notes,
        _environment_section,
    )
    # each section's lines end with a blank one, so the report ends with a newline
    return "\n".join(line for section in sections for line in section(f))


def _header_section(f: dict[str, Any]) -> list[str]:
    """The title, a quick run's warning, the paper and how and when the report was made."""
    quick = f["mode"] == "quick"
    lines = ["# Reproducing the paper, side by side", ""]
    if quick:
        lines += [
            "> **Quick run (`oxbot reproduce --quick`)**: smaller budgets "
            f"({f['perceiver']['train_images']:,} training images, "
            f"{f['agent']['experiences']:,} experiences, "
            f"{f['budgets']['evaluation_games']:,} evaluation games per condition), so the "
            "figures below check the pipeline, not the paper. The full report is "
            "`oxbot reproduce` (reports/REPORT.md in the repository).",
            "",
        ]
    lines += [
        f"Paper: {PAPER}. Paper figures are quoted with the section of paper.tex that gives them;",
        "goals are oxbot's (SPEC §1, §3). Made by `oxbot reproduce"
        + (" --quick" if quick else "")
        + f"` in {f['wall_clock_s']:.0f} s, started {f['started']}.",
        "",
    ]
    return lines


def _paper_figures_section(f: dict[str, Any]) -> list[str]:
    """The table of the paper's figures, this run's, the shipped models' and the goals."""
    return [
        "## The paper's figures and oxbot's",
        "",
        "| measured | paper | oxbot, this run | oxbot, shipped model | goal | goal met: "
        "run / shipped |",
        "|---|---|---|---|---|---|",
        *_perceiver_rows(f),
        *_game_outcome_rows(f),
        *_interaction_manager_rows(f),
        *_seed_data_rows(f),
        "",
    ]


def _row(measured: str, paper: str, ours: str, shipped: str, goal: str, met: str) -> str:
    """One row of the paper's figures table."""
    return f"| {measured} | {paper} | {ours} | {shipped} | {goal} | {met} |"


def _met(run_ok: bool, shipped_ok: bool) -> str:
    return f"{_yes(run_ok)} / {_yes(shipped_ok)}"


def _perceiver_rows(f: dict[str, Any]) -> list[str]:
    """The perceiver's accuracy on generated images and on another hand, and its training time."""
    per, sp = f["perceiver"], f["shipped"]["perceiver"]
    n_images, timed = per["train_images"], per["timed_refit"]
    paper = PAPER_FIGURES
    time_label = "10K" if n_images == 10_000 else f"{n_images:,}"
    return [
        _row(
            f"classification accuracy, {per['test_images']:,} generated test images "
            "(same distribution)",
            f"{_pct(paper['accuracy'][0], 1)} ({paper['accuracy'][1]})",
            _pct(per["accuracy"], 1),
            _pct(sp["accuracy"], 1),
            "≥ 99.9%",
            _met(per["accuracy"] >= GOALS["accuracy"], sp["accuracy"] >= GOALS["accuracy"]),
        ),
        _row(
            f"classification accuracy, {per['other_hand_images'] or 0:,} cells from another "
            "hand (handwriting fonts, never trained on)",
            "not measured (pilot test with people only)",
            _pct(per["other_hand"], 1),
            _pct(sp["other_hand"], 1),
            "≥ 99.5%",
            _met(
                (per["other_hand"] or 0) >= GOALS["other_hand"],
                (sp["other_hand"] or 0) >= GOALS["other_hand"],
            ),
        ),
        _row(
            f"training time, {time_label} images",
            f"6 min ({paper['train_time_10k_s'][1]})",
            f"{_seconds(timed['train_cpu_s'])} of CPU time ({timed['generate_cpu_s']:.1f} s "
            f"generating, {timed['fit_cpu_s']:.1f} s fitting, one torch thread); wall-clock "
            f"{_seconds(timed['train_s'])}",
            "the same model: the same time"
            if per["same_as_shipped"]
            else f"{_seconds(sp['train_s'])} wall-clock for {sp['train_images']:,} images (its "
            "metrics file)",
            "≤ 30 s on 2 cores",
            _met(
                n_images == 10_000 and timed["train_cpu_s"] <= GOALS["train_time_10k_s"],
                n_images == 10_000 and timed["train_cpu_s"] <= GOALS["train_time_10k_s"]
                if per["same_as_shipped"]
                else sp["train_images"] == 10_000 and sp["train_s"] <= GOALS["train_time_10k_s"],
            ),
        ),
    ]


def _game_outcome_rows(f: dict[str, Any]) -> list[str]:
    """Win / draw / loss against each simulated person, robot or person starting."""
    agent, sa = f["agent"], f["shipped"]["agent"]
    rows = []
    for name, robot_starts in CONDITIONS:
        key = condition_key(name, robot_starts)
        r, rs = agent["final"][key], sa["final"][key]
        who = "robot starts" if robot_starts else "person starts"
        if name == "random" and robot_starts:
            paper_cell = f"98% win/draw ({PAPER_FIGURES['win_draw'][1]}; a semi-random person)"
        else:
            paper_cell = "not reported (a semi-random person; the robot starts in Figure 1)"
        goal_win = GOALS["win_random"][robot_starts] - 0.01
        rows.append(
            _row(
                f"win / draw / loss, {OPPONENT_NAMES[name]} person, {who}, {r['games']:,} games",
                paper_cell,
                f"{_wdl(r)} (win/draw {_pct(r['win_rate'] + r['draw_rate'])})",
                f"{_wdl(rs)} (win/draw {_pct(rs['win_rate'] + rs['draw_rate'])})",
                f"0 losses; wins ≥ {_pct(goal_win)}" if name == "random" else "0 losses",
                _met(_outcome_ok(r, name, goal_win), _outcome_ok(rs, name, goal_win)),
            )
        )
    return rows


def _outcome_ok(r: dict[str, Any], opponent: str, goal_win: float) -> bool:
    """No game lost and, against the random person, at least `goal_win` of them won."""
    return r["loss_rate"] == 0 and (opponent != "random" or r["win_rate"] >= goal_win)


def _interaction_manager_rows(f: dict[str, Any]) -> list[str]:
    """The agent's dialogues with the default simulated people (well formed, as they wanted),
    and its training time."""
    agent, sa = f["agent"], f["shipped"]["agent"]
    well_formed = min(r["well_formed"] for r in agent["people"].values())
    shipped_well_formed = min(r["well_formed"] for r in sa["people"].values())
    success = min(r["task_success"] for r in agent["people"].values())
    shipped_success = min(r["task_success"] for r in sa["people"].values())
    total_games = sum(r["games"] for r in agent["people"].values())
    people = "the default simulated people (some decline, stop, chatter or say nothing)"
    return [
        _row(
            "well-formed dialogues (docs/dialogue.md: greeting, a game only with a person who "
            f"agreed, a no or a stop let go, right feedback, goodbye), {people}, all "
            f"{total_games:,} dialogues, lowest condition",
            "not measured",
            _pct(well_formed),
            _pct(shipped_well_formed),
            "100%",
            _met(well_formed == 1.0, shipped_well_formed == 1.0),
        ),
        _row(
            f"task success (well formed and as the person wanted), {people}, lowest condition",
            "not measured",
            _pct(success),
            _pct(shipped_success),
            "—",
            "—",
        ),
        _row(
            "training time of the interaction manager",
            f"3 hours ({PAPER_FIGURES['agent_time_s'][1]})",
            f"{_seconds(agent['cpu_s'])} of CPU time, wall-clock {_seconds(agent['train_s'])}, "
            f"for {agent['experiences']:,} experiences ({agent['games']:,} games, evaluations "
            "included); "
            + (
                f"first evaluation without a loss after {_seconds(agent['time_to_zero_losses_s'])}"
                if agent["time_to_zero_losses_s"] is not None
                else "no evaluation without a loss"
            ),
            f"{_seconds(sa['train_s'])} wall-clock for {sa['experiences']:,} experiences "
            "(its metrics file); first evaluation without a loss after "
            f"{_seconds(sa['time_to_zero_losses_s'])}",
            "≤ 5 min on 2 cores",
            _met(agent["cpu_s"] <= GOALS["agent_time_s"], sa["train_s"] <= GOALS["agent_time_s"]),
        ),
    ]


def _seed_data_rows(f: dict[str, Any]) -> list[str]:
    """The seed images and seed dialogues everything is learned from."""
    data = f["data"]
    seeds_cell = (
        f"{data['seed_images']} ("
        + ", ".join(f"{v} {k}" for k, v in data["seed_images_per_label"].items())
        + "; drawn by oxbot's synthesiser)"
    )
    return [
        _row(
            "data: seed images",
            f"108 ({PAPER_FIGURES['seed_images'][1]})",
            seeds_cell,
            "the same 108 (`oxbot/data/seeds/`)"
            if data["seed_images_same_as_shipped"]
            else "108 others (`oxbot/data/seeds/`)",
            "—",
            "—",
        ),
        _row(
            "data: seed dialogues",
            f"10 ({PAPER_FIGURES['seed_dialogues'][1]})",
            f"{data['seed_dialogues']} (`oxbot/data/dialogue/dialogues.txt`)",
            f"the same {data['seed_dialogues']}",
            "—",
            "—",
        ),
    ]


def _shipped_models_note(f: dict[str, Any]) -> list[str]:
    """Under the paper's figures table: whether this run's models and seeds are the shipped
    ones, and how both columns were measured."""
    per, agent, data = f["perceiver"], f["agent"], f["data"]
    sa = f["shipped"]["agent"]
    return [
        "This run's models against the shipped ones (`oxbot/data/models/`): the perceiver is "
        + ("identical to" if per["same_as_shipped"] else "different from")
        + " `perceiver.pt`; the interaction manager (the best of its greedy evaluations, at "
        f"experience {agent['best_step']:,}) is "
        + ("identical to" if agent["same_as_shipped"] else "different from")
        + " `agent.pt`"
        + (
            ""
            if agent["same_as_shipped"]
            else f" (kept at experience {sa['best_step']:,} of an earlier run"
            + (
                " of the same config, whose `agent_metrics.json` parts from this run's "
                f"average reward by experience {sa['diverges_at']:,}: the code or packages "
                "it ran on were not quite these)"
                if sa.get("same_config") and sa.get("diverges_at") is not None
                else " with another config or budget)"
            )
        )
        + "; the seed images are "
        + ("identical to" if data["seed_images_same_as_shipped"] else "different from")
        + " `oxbot/data/seeds/`. Both columns are measured in this run on the same test "
        f"images and the same games: greedy, {f['budgets']['evaluation_games']:,} games per "
        "condition: game play against people who always play a whole game (as `oxbot evaluate "
        "agent --opponent all --robot-starts both --cooperative`), dialogues against the default "
        "simulated people, seed 0. The shipped models' training times are those their "
        "metrics files recorded.",
        "",
    ]


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


def _perception_peers_section(f: dict[str, Any]) -> list[str]:
    """The peers' heading, then the perception peers table: oxbot's CNN+SVM beside the SVM on
    raw pixels, and their accuracies compared."""
    per, svm = f["perceiver"], f["perceiver_peer"]
    timed = per["timed_refit"]
    return [
        "## Peers, measured in the same run",
        "",
        "### Learning to perceive",
        "",
        "| learner | training images | accuracy, generated test images | accuracy, other "
        "hand | training time (fit, CPU) | training-time ratio |",
        "|---|---|---|---|---|---|",
        f"| oxbot CNN+SVM | {per['train_images']:,} | {_pct(per['accuracy'], 1)} | "
        f"{_pct(per['other_hand'], 1)} | {timed['fit_cpu_s']:.1f} s "
        f"(wall-clock {timed['fit_s']:.1f} s) | 1.0x |",
        f"| {SVM_NAME} | {svm['train_images']:,} | {_pct(svm['accuracy'], 1)} | "
        f"{_pct(svm['other_hand'], 1)} | {svm['fit_cpu_s']:.1f} s "
        f"(wall-clock {svm['fit_s']:.1f} s) | {svm['fit_cpu_s'] / timed['fit_cpu_s']:.1f}x |",
        "",
        f"Accuracy: the SVM gets {_pct(svm['accuracy'], 1)} where the CNN gets "
        f"{_pct(per['accuracy'], 1)} (error {_error_ratio(svm['accuracy'], per['accuracy'])} "
        f"the CNN's), and {_pct(svm['other_hand'], 1)} against {_pct(per['other_hand'], 1)} "
        "on the other hand. Both learn from the same generated images (same seed and stream) "
        "and are measured on the same test sets.",
        "",
    ]


def _agent_peers_section(f: dict[str, Any]) -> list[str]:
    """The interaction peers table: oxbot's DQN beside SB3's DQN and MaskablePPO, the time to
    their first evaluation without a loss and their final games."""
    agent = f["agent"]
    budget, ours = agent["train_s"], agent["time_to_zero_losses_s"]
    header = "| learner | training (time, experiences) | first evaluation without a loss | "
    header += "ratio to oxbot | " + " | ".join(
        f"{OPPONENT_NAMES[n]}, {'robot' if s else 'person'} starts: W / D / L"
        for n, s in CONDITIONS
    )
    header += " | well formed |"
    lines = ["### Learning to interact", "", header, "|" + "---|" * (5 + len(CONDITIONS))]
    rows = [("oxbot DQN (`agent.toml`)", agent, ours)]
    rows += [(LEARNER_NAMES[k], p, p["time_to_zero_losses_s"]) for k, p in f["agent_peers"].items()]
    for name, run, t in rows:
        steps = run.get("experiences", run.get("steps"))
        cells = [
            name,
            f"{_seconds(run['train_s'])}, {steps:,}",
            _seconds(t) if t is not None else f"none within {budget:.0f} s",
            "1.0x" if run is agent else _ratio(t, ours, budget),
        ]
        cells += [_wdl(run["final"][condition_key(n, s)]) for n, s in CONDITIONS]
        cells.append(_pct(min(r["well_formed"] for r in run["final"].values())))
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    return lines


def _agent_peers_notes(f: dict[str, Any]) -> list[str]:
    """Under the interaction peers table: the losses plot, how the peers were trained and
    judged, and each peer's settings."""
    agent = f["agent"]
    lines = [
        "![losses against training time](losses_vs_time.png)",
        "",
        f"Each peer trains on `oxbot/NoughtsAndCrosses-v0` for oxbot's wall-clock time "
        f"({agent['train_s']:.0f} s, its evaluations not counted; oxbot's own time counts its "
        "evaluations), in oxbot's training conditions (the same opponent mix, both who-starts "
        "conditions, the same simulated person), with oxbot's network size and discount. "
        "Time without a loss: the first greedy evaluation "
        f"({len(agent['evaluations'])} along each run, every learner the same number, "
        f"{f['configs']['train']['agent']['eval_games']:,} games in each of the six "
        "conditions against the training person) with no game lost. Final columns: the last "
        f"policy of each peer and oxbot's kept one, {f['budgets']['evaluation_games']:,} games "
        "per condition against people who always play a whole game. DQN cannot mask its "
        "exploration, but it is "
        "judged like oxbot's agent, greedy over the offered acts; MaskablePPO gets the mask "
        "through sb3-contrib's `ActionMasker` and acts by its most likely act. Peer settings:",
        "",
    ]
    for k, p in f["agent_peers"].items():
        settings = ", ".join(f"{a}={b}" for a, b in p["settings"].items())
        lines.append(f"- {LEARNER_NAMES[k]}: {settings}; SB3 defaults otherwise.")
    lines.append("")
    return lines


def _environment_section(f: dict[str, Any]) -> list[str]:
    """Seeds, versions and machine: how times were judged, the seeds, commit, packages and
    machine."""
    env, seeds = f["environment"], f["seeds"]
    refit = f["perceiver"]["timed_refit"]
    return [
        "## Seeds, versions and machine",
        "",
        "- Times: the cores were shared with other jobs, so the time goals are judged on CPU "
        "time (the learners run on one torch thread: their CPU time is what they take on a "
        "core of their own), with wall-clock beside it. The perceiver's time is of a second, "
        "timed generation and fit after the curve's runs; it gave "
        + ("the very same" if refit["identical_weights"] else "**different**")
        + " weights. The SB3 peers' budget is oxbot's wall-clock time, all run one after "
        "the other on the same machine.",
        f"- Seeds: perception {seeds['perception']} (seed images, training and test "
        f"images, font set), agent {seeds['agent']} (training, its evaluations "
        f"10,000 + step), final evaluations {seeds['evaluation']}, peers "
        f"{seeds['peers']} (their evaluations 20,000 + seed). The same seeds give the "
        "same figures on the same machine, except times and the SB3 peers' figures, which "
        "depend on how many steps fit into their time.",
        f"- Commit: {env['commit'] or 'unknown'}",
        f"- Python {env['python']}; "
        + ", ".join(f"{k} {v}" for k, v in env["packages"].items() if v),
        f"- Machine: {env['cpu']}, {env['cores']} cores, {env['platform']}; load average "
        f"at the start {', '.join(str(x) for x in env['load_average'])} (other jobs shared "
        "the cores). Torch uses one thread for both learners.",
        "- Every figure, curve and the two configs (training, evaluation) are in "
        "`report.json` beside this file.",
        "",
    ]
