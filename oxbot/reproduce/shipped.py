"""The shipped models measured on this run's test images and games, beside the training figures
their metrics files recorded, and the note under the paper's figures table on how this run's
models compare with them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from oxbot import artifacts
from oxbot.config import OxbotConfig
from oxbot.errors import DataError
from oxbot.peers import evaluate_conditions
from oxbot.reproduce.agent import _losses
from oxbot.reproduce.budgets import Budgets


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
            "cpu_s": round(_cpu_seconds(agent_metrics), 1),
            "experiences": experiences,
            "best_step": agent_metrics["best_step"],
            # a fine-tune's counts from the start of the runs before it
            "time_to_zero_losses_s": (first_zero["elapsed_s"] + earlier_s if first_zero else None),
            "config": agent_metrics["config"],
            "reward_curve": agent_metrics["reward_curve"],
        },
    }


def _cpu_seconds(metadata: dict[str, Any]) -> float:
    """The CPU seconds a policy's training took, a fine-tune's together with the runs it started
    from (as `training_budget` counts experiences)."""
    seconds, step = 0.0, metadata
    while step:
        seconds += float(step.get("cpu_s", 0.0))
        step = step.get("init_from")
    return seconds


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
