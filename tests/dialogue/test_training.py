import json

import pytest

from oxbot.config import load_config
from oxbot.dialogue.agent import load_policy
from oxbot.dialogue.checkpoint_evaluation import evaluation_score
from oxbot.dialogue.training import epsilon_at, train_agent
from oxbot.errors import ModelFileError

TINY = [
    "agent.total_steps=3000",
    "agent.learning_starts=200",
    "agent.double_dqn=true",
    "agent.symmetries=true",
    "agent.opponents=random:2,minimax:1",
    "agent.robot_starts=both",
    "agent.eval_every=1500",
    "agent.eval_games=10",
]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("agent")
    result = train_agent(load_config(None, TINY), out, show_progress=False, checkpoint_every=1000)
    return out, result


def test_a_tiny_real_run_writes_policy_metrics_and_curves(trained):
    out, _result = trained
    assert {p.name for p in out.iterdir()} >= {
        "agent.pt",
        "agent_metrics.json",
        "agent_reward.png",
        "agent_win_draw.png",
        "checkpoint.pt",
    }
    assert not list(out.glob(".*.tmp"))
    metrics = json.loads((out / "agent_metrics.json").read_text())
    assert metrics["experiences"] == 3000 and metrics["updates"] == 2800
    assert metrics["seed"] == 0 and metrics["config"]["agent"]["double_dqn"] is True
    assert len(metrics["reward_curve"]) == 3 and len(metrics["evaluations"]) == 2
    for evaluation in metrics["evaluations"]:  # what checkpoints are ranked by, recorded
        assert 0 <= evaluation["misread_wills"] <= 3 * 2 * 10
        assert all(0 <= w <= 1 for w in evaluation["wins_against_random"])
    assert metrics["games"] > 100
    for png in ("agent_reward.png", "agent_win_draw.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    policy = load_policy(out / "agent.pt")
    assert policy.metadata["experiences"] == 3000


def test_training_resumes_from_its_checkpoint(trained):
    out, first = trained
    longer = load_config(None, [*TINY[1:], "agent.total_steps=4000"])
    result = train_agent(longer, out, show_progress=False, checkpoint_every=1000)
    assert result.metrics["experiences"] == 4000
    assert result.metrics["updates"] == first.metrics["updates"] + 1000
    assert result.metrics["games"] > first.metrics["games"]


def test_a_checkpoint_from_other_settings_is_refused(trained):
    out, _ = trained
    other = load_config(None, [*TINY, "agent.discount=0.5"])
    with pytest.raises(ModelFileError, match="other agent settings \\(discount\\)"):
        train_agent(other, out, show_progress=False)


def test_epsilon_falls_linearly_to_its_minimum():
    cfg = load_config(None, ["agent.total_steps=1000", "agent.exploration_fraction=0.5"])
    assert epsilon_at(0, cfg) == 1.0
    assert epsilon_at(250, cfg) == pytest.approx(0.505)
    assert epsilon_at(900, cfg) == 0.01


def test_misheard_words_are_absent_words_below_the_action_models_threshold():
    import numpy as np

    from oxbot.dialogue.model import shipped_dialogue_model
    from oxbot.dialogue.replay import add_misheard_words

    m = shipped_dialogue_model()
    layout, model = m.layout, m.action_model
    rng = np.random.default_rng(0)
    states = np.zeros((1000, layout.n_features), dtype=np.float32)
    states[:, 0] = 1.0  # a word the robot said
    heard = add_misheard_words(states, 0.5, layout.n_words, 0.5, rng)
    changed = heard != states
    assert 0.4 < changed.any(axis=1).mean() < 0.5  # half the rows, less the already-present word
    assert changed.sum(axis=1).max() == 1
    assert (heard[changed] >= 0.1).all() and (heard[changed] < 0.5).all()
    assert not changed[:, layout.n_words :].any() and (heard[:, 0] == 1.0).all()
    assert np.allclose(model.predict_proba(heard), model.predict_proba(states))


def test_checkpoints_are_ranked_by_what_is_sure_before_what_is_sampled():
    def results(losing, misread, exact, faults, wins):
        games = {"games": 100, "loss_rate": 0.0, "well_formed": 1 - faults / 100}
        return {
            "random/robot": {**games, "win_rate": wins},
            "losing_positions": losing,
            "misread_wills": misread,
            "wins_against_random": [exact, exact],
        }

    order = [
        results(losing=1, misread=0, exact=0.95, faults=0, wins=1.0),
        results(losing=0, misread=3, exact=0.95, faults=0, wins=1.0),
        results(losing=0, misread=0, exact=0.90, faults=0, wins=1.0),
        results(losing=0, misread=0, exact=0.95, faults=5, wins=1.0),
        results(losing=0, misread=0, exact=0.95, faults=0, wins=0.8),
        results(losing=0, misread=0, exact=0.95, faults=0, wins=0.9),
    ]
    scores = [evaluation_score(r) for r in order]
    assert scores == sorted(scores)


MANY_AT_ONCE = [
    "agent.total_steps=900",
    "agent.learning_starts=200",
    "agent.n_envs=8",
    "agent.opponents=random:2,minimax:1",
    "agent.robot_starts=both",
    "agent.eval_every=900",
    "agent.eval_games=4",
]


def test_many_dialogues_at_once_judged_beside_training_keep_the_policy_judged_here(tmp_path):
    import torch

    runs = {}
    for background in (True, False):
        config = load_config(None, [*MANY_AT_ONCE, f"agent.eval_in_background={background}"])
        out = tmp_path / str(background)
        runs[background] = train_agent(config, out, show_progress=False, checkpoint_every=0)
    beside, here = runs[True].metrics, runs[False].metrics
    assert beside["experiences"] == 900 and beside["updates"] == 700  # one per experience
    assert beside["games"] == here["games"] > 8  # dialogues reset as they end
    assert [e["step"] for e in beside["evaluations"]] == [900]
    drop = ("elapsed_s",)
    assert [{k: v for k, v in e.items() if k not in drop} for e in beside["evaluations"]] == [
        {k: v for k, v in e.items() if k not in drop} for e in here["evaluations"]
    ]
    weights = [r.policy.q_network.state_dict() for r in runs.values()]
    assert all(torch.equal(weights[0][k], weights[1][k]) for k in weights[0])


def test_each_training_dialogue_meets_the_next_person_of_the_mix():
    from oxbot.dialogue.vector_env import training_envs

    config = load_config(None, ["agent.opponents=random:1,minimax:1", "agent.robot_starts=both"])
    envs = training_envs(config, 2)
    starts, opponents = set(), set()
    for seed in range(12):
        envs.reset(seed=seed)
        for person in envs.envs:
            game = person.unwrapped
            starts.add(game.state.robot_starts)
            opponents.add(game._simulator.opponent.__name__)
    assert starts == {True, False} and len(opponents) == 2
    first = envs.reset(seed=3)[0].copy()
    assert (envs.reset(seed=3)[0] == first).all()  # seeded: the same people again


def test_the_replay_memory_stores_rows_in_order_and_wraps_around():
    import numpy as np

    from oxbot.dialogue.replay import ReplayBuffer

    replay = ReplayBuffer(capacity=5, n_features=2, n_actions=3)
    for first in (0, 3):  # 3 rows, then 3 more: the oldest one is overwritten
        rows = np.arange(first, first + 3)
        replay.add_batch(
            np.stack([rows, rows], axis=1).astype(np.float32),
            rows,
            rows.astype(np.float32),
            np.zeros((3, 2), np.float32),
            np.ones((3, 3), bool),
            np.zeros(3, bool),
        )
    assert replay.size == 5 and replay.position == 1
    assert replay.actions.tolist() == [5, 1, 2, 3, 4]
