import numpy as np
import pytest
import torch

from oxbot.dialogue.agent import DQNPolicy, QNetwork, load_policy, masked_argmax
from oxbot.dialogue.domain import GAME_MOVES, N_ACTIONS
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.errors import ModelFileError

LAYOUT = shipped_dialogue_model().layout


def test_the_network_is_the_papers_by_default():
    net = QNetwork(LAYOUT.n_features)
    shapes = [tuple(p.shape) for p in net.parameters()]
    # the paper's two hidden layers of 60; oxbot's 149 features and 21 acts (docs/deviations.md)
    assert shapes == [(60, 149), (60,), (60, 60), (60,), (21, 60), (21,)]
    assert isinstance(net.net[1], torch.nn.ReLU)


def test_save_and_load_round_trip(tmp_path):
    torch.manual_seed(0)
    policy = DQNPolicy(QNetwork(LAYOUT.n_features, (32, 16)), LAYOUT.names, {"seed": 7})
    path = tmp_path / "policy.pt"
    policy.save(path)
    loaded = load_policy(path)
    states = np.random.default_rng(0).random((20, LAYOUT.n_features), dtype=np.float32)
    assert np.array_equal(loaded.q_values(states), policy.q_values(states))
    assert loaded.metadata == {"seed": 7}
    assert loaded.q_network.hidden_sizes == (32, 16)
    assert not list(tmp_path.glob(".*.tmp"))  # written atomically, nothing left over


def test_with_a_board_head_the_cell_depends_on_the_board_alone(tmp_path):
    torch.manual_seed(0)
    board = (LAYOUT.board.start, LAYOUT.board.stop)
    policy = DQNPolicy(QNetwork(LAYOUT.n_features, (32, 16), board_features=board), LAYOUT.names)
    rng = np.random.default_rng(0)
    states = rng.random((50, LAYOUT.n_features), dtype=np.float32)
    heard_otherwise = rng.random((50, LAYOUT.n_features), dtype=np.float32)
    heard_otherwise[:, LAYOUT.board] = states[:, LAYOUT.board]  # same boards, other words
    moves = np.zeros((50, N_ACTIONS), dtype=bool)
    moves[:, : len(GAME_MOVES)] = True
    assert np.array_equal(policy.act_batch(states, moves), policy.act_batch(heard_otherwise, moves))
    q, q_other = policy.q_values(states), policy.q_values(heard_otherwise)
    assert not np.allclose(q[:, 0], q_other[:, 0])  # whether to move still hears the words
    policy.save(tmp_path / "p.pt")
    loaded = load_policy(tmp_path / "p.pt")
    assert loaded.q_network.board_features == board
    assert np.array_equal(loaded.q_values(states), q)


def test_the_greedy_act_is_the_best_offered_one():
    q = np.array([[5.0, 1.0, 3.0]])
    assert masked_argmax(q, np.array([[False, True, True]])).tolist() == [2]


def test_a_policy_from_another_feature_layout_is_refused(tmp_path):
    other = [*LAYOUT.names[:-1], "word:banana"]
    DQNPolicy(QNetwork(len(other)), other).save(tmp_path / "other.pt")
    with pytest.raises(ModelFileError, match=r"another feature layout.*word:banana"):
        load_policy(tmp_path / "other.pt")


def test_a_missing_truncated_or_foreign_file_is_refused(tmp_path):
    with pytest.raises(ModelFileError, match="does not exist"):
        load_policy(tmp_path / "nothing.pt")
    DQNPolicy(QNetwork(LAYOUT.n_features), LAYOUT.names).save(tmp_path / "p.pt")
    data = (tmp_path / "p.pt").read_bytes()
    (tmp_path / "cut.pt").write_bytes(data[: len(data) // 2])
    with pytest.raises(ModelFileError, match="is truncated"):
        load_policy(tmp_path / "cut.pt")
    torch.save({"weights": torch.zeros(3)}, tmp_path / "foreign.pt")
    with pytest.raises(ModelFileError, match="truncated or not a model file"):
        load_policy(tmp_path / "foreign.pt")


def test_the_shipped_policy_loads_without_training():
    policy = load_policy()
    assert policy.feature_names == LAYOUT.names
    assert policy.metadata["config"]["agent"]["seed"] == policy.metadata["seed"]
