import gymnasium as gym
import numpy as np
import pytest

from oxbot.config import OxbotConfig, load_config
from oxbot.errors import ConfigError
from oxbot.peers import (
    CONDITIONS,
    PixelSVM,
    TrainingConditions,
    make_peer_env,
    peer_batch_policy,
    train_peer_agent,
    zero_losses,
)
from oxbot.perception.augment import generate
from oxbot.perception.classifier import label_indices
from oxbot.perception.evaluation import evaluate, generated_test_set
from oxbot.perception.seeds import load_seeds


@pytest.fixture(scope="module")
def cells():
    seeds = load_seeds()
    x, y = generate(seeds, 300, np.random.default_rng(5), 40)
    test_x, test_y = generated_test_set(seeds, 300, seed=9)
    return x, label_indices(y), test_x, test_y


def test_pixel_svm_learns_raw_pixels_and_is_deterministic(cells):
    x, y, test_x, test_y = cells
    first = PixelSVM(max_iter=300).fit(x, y)
    second = PixelSVM(max_iter=300).fit(x, y)
    assert np.array_equal(first.decision_function(test_x), second.decision_function(test_x))
    # three labels: chance is a third; a linear SVM on pixels does clearly better
    assert evaluate(first, test_x, test_y).accuracy > 0.6


def test_pixel_svm_scores_follow_the_label_order_even_with_a_label_missing(cells):
    x, y, test_x, _ = cells
    keep = y != 1  # no crosses
    scores = PixelSVM(max_iter=300).fit(x[keep], y[keep]).decision_function(test_x)
    assert scores.shape == (len(test_x), 3)
    assert np.all(np.isneginf(scores[:, 1]))
    assert set(np.unique(scores.argmax(axis=1))) <= {0, 2}


def test_training_conditions_mix_opponents_and_starters_and_expose_the_mask():
    config = load_config(None, ["agent.opponents=random:1,minimax:1", "agent.robot_starts=both"])
    env = TrainingConditions(gym.make("oxbot/NoughtsAndCrosses-v0", config=config), config, 3)
    seen_opponents, seen_starts = set(), set()
    for _ in range(40):
        _, info = env.reset()
        assert np.array_equal(env.action_mask, info["action_mask"])
        seen_opponents.add(env.unwrapped._simulator.opponent)
        seen_starts.add(env.unwrapped.state.robot_starts)
        _, _, _, _, info = env.step(int(np.flatnonzero(info["action_mask"])[0]))
        assert np.array_equal(env.action_mask, info["action_mask"])
    assert len(seen_opponents) == 2
    assert seen_starts == {True, False}


def test_maskable_env_offers_the_environments_mask():
    env = make_peer_env("maskable_ppo", OxbotConfig(), seed=0)
    _, info = env.reset(seed=1)
    assert np.array_equal(env.action_masks(), info["action_mask"])
    _, _, _, _, info = env.step(int(np.flatnonzero(info["action_mask"])[0]))
    assert np.array_equal(env.action_masks(), info["action_mask"])


@pytest.mark.parametrize("algorithm", ["dqn", "maskable_ppo"])
def test_a_peer_trains_for_its_budget_and_is_evaluated_in_every_condition(algorithm):
    run = train_peer_agent(algorithm, OxbotConfig(), budget_s=1.5, eval_every_s=0.5, eval_games=4)
    assert run.steps > 100
    assert 1.5 <= run.train_s < 3.0
    times = [e["train_s"] for e in run.evaluations]
    if algorithm == "dqn":
        # SB3 calls back after every step: each evaluation comes at the first step past its
        # point (on a cold machine a first update once took until 0.9 s: [0.9, 1.0, 1.5])
        assert len(times) == 3 and times == sorted(times) and times[-1] == 1.5
        assert all(t >= point for t, point in zip(times, (0.5, 1.0, 1.5), strict=True)), times
    else:
        # PPO learns from 2,048 steps at a time, with no call back while it does: a point
        # that falls in there is evaluated at the next step, 1.0 here possibly at 1.5.
        assert times in ([0.5, 1.0, 1.5], [0.5, 1.5])
    last = run.evaluations[-1]["results"]
    assert set(last) == {f"{o}/{'robot' if s else 'person'}" for o, s in CONDITIONS}
    assert all(r["games"] == 4 for r in last.values())
    # time to zero losses is the first evaluation that has none, or None
    expected = next((e["train_s"] for e in run.evaluations if zero_losses(e["results"])), None)
    assert run.time_to_zero_losses == expected
    # the greedy peer only ever picks an offered act
    rng = np.random.default_rng(0)
    n_features, n_actions = run.model.observation_space.shape[0], run.model.action_space.n
    states = rng.random((64, n_features), dtype=np.float32)
    masks = rng.random((64, n_actions)) < 0.3
    masks[np.arange(64), rng.integers(n_actions, size=64)] = True
    acts = peer_batch_policy(algorithm, run.model)(states, masks)
    assert masks[np.arange(64), acts].all()


@pytest.mark.parametrize("algorithm", ["dqn", "maskable_ppo"])
def test_a_peer_trains_for_exactly_its_experiences_when_given_a_step_budget(algorithm):
    # PPO collects 2,048 steps a rollout: the budget cuts its rollout short
    progress = []
    run = train_peer_agent(
        algorithm,
        OxbotConfig(),
        eval_games=2,
        on_progress=progress.append,
        budget_steps=300,
        eval_every_steps=100,
    )
    assert run.steps == 300 and run.budget_steps == 300 and run.budget_s is None
    assert [e["steps"] for e in run.evaluations] == [100, 200, 300]
    assert progress == [100, 200, 300]
    assert run.to_dict()["budget_steps"] == 300


def test_peers_refuse_unknown_algorithms_and_empty_budgets():
    with pytest.raises(ConfigError, match="unknown peer"):
        train_peer_agent("a2c", OxbotConfig(), budget_s=1, eval_every_s=1, eval_games=1)
    with pytest.raises(ConfigError, match="positive"):
        train_peer_agent("dqn", OxbotConfig(), budget_s=0, eval_every_s=1, eval_games=1)
    with pytest.raises(ConfigError, match="one budget"):
        train_peer_agent("dqn", OxbotConfig(), budget_s=1, eval_every_s=1, budget_steps=10)
    with pytest.raises(ConfigError, match="positive"):
        train_peer_agent("dqn", OxbotConfig(), budget_steps=10, eval_every_s=1)
