"""The DQN interaction manager: the Q-network, the greedy policy, and its policy file.

Paper §2.2 "Model Architecture": a fully connected network with 57 inputs, two hidden layers of
60 ReLU units and 18 outputs (one Q-value per act), trained with deep Q-learning with experience
replay and a target network (Mnih et al. 2015); the defaults are in `AgentConfig`. At test time
the policy is greedy over the offered acts: argmax of Q(s, a) where `action_mask` is true.

oxbot's option (`agent.board_head`): the nine GameMoves' values are split, as in a dueling
network (Wang et al. 2016), into one value of moving now, from the whole state, and an advantage
per cell from a second tower that sees the board alone. Whether to draw or to talk still depends
on everything heard; which cell, only on the board, so a misheard word cannot change it.

A policy file (`torch.save` of plain types behind a checksummed header, `oxbot.artifacts`)
records the feature layout it was trained on and the network's shape; a file from another
layout (another vocabulary) or a damaged one is refused with a `ModelFileError`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from oxbot import artifacts
from oxbot.dialogue.domain import GAME_MOVES, N_ACTIONS, SYSTEM_ACTS
from oxbot.dialogue.policy import retrain_advice
from oxbot.errors import ModelFileError

POLICY_FORMAT = "oxbot-dqn-policy/1"
POLICY_KIND = "policy"
POLICY_VERSION = 2
"""2: the payload behind `oxbot.artifacts`' checksummed header; 1 had none."""
SHIPPED_POLICY = "agent.pt"


class QNetwork(nn.Module):
    """Q(s, ·): state features -> hidden ReLU layers -> one value per act (paper: 57-60-60-18).

    With `board_features` (start, stop) — the board's feature columns — the GameMoves (acts
    0-8) get Q = V_move(s) + A(board) - mean A(board): `net` gives the other acts and V_move,
    `board_net` (the same hidden sizes) the per-cell advantages A (see the module)."""

    def __init__(
        self,
        n_features: int,
        hidden_sizes: Sequence[int] = (60, 60),
        n_actions: int = N_ACTIONS,
        board_features: tuple[int, int] | None = None,
    ):
        super().__init__()
        self.n_features = n_features
        self.hidden_sizes = tuple(int(h) for h in hidden_sizes)
        self.board_features = tuple(board_features) if board_features is not None else None
        n_moves = len(GAME_MOVES)
        if self.board_features is None:
            self.net = _mlp(n_features, self.hidden_sizes, n_actions)
        else:
            start, stop = self.board_features
            self.net = _mlp(n_features, self.hidden_sizes, n_actions - n_moves + 1)
            self.board_net = _mlp(stop - start, self.hidden_sizes, n_moves)

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        if self.board_features is None:
            return self.net(states)
        start, stop = self.board_features
        out = self.net(states)
        advantage = self.board_net(states[..., start:stop])
        moves = out[..., :1] + advantage - advantage.mean(dim=-1, keepdim=True)
        return torch.cat([moves, out[..., 1:]], dim=-1)


def _mlp(n_in: int, hidden_sizes: Sequence[int], n_out: int) -> nn.Sequential:
    layers: list[nn.Module] = []
    size = n_in
    for hidden in hidden_sizes:
        layers += [nn.Linear(size, int(hidden)), nn.ReLU()]
        size = int(hidden)
    layers.append(nn.Linear(size, n_out))
    return nn.Sequential(*layers)


def masked_argmax(q_values: np.ndarray, masks: np.ndarray) -> np.ndarray:
    """The best offered act of each row (of the one row, for 1-D input): the greedy policy."""
    return np.argmax(np.where(masks, q_values, -np.inf), axis=-1)


def greedy_batch_policy(q_network: nn.Module) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A Q-network (states -> one value per act) as a greedy batch policy over offered acts."""

    def act(states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            q = q_network(torch.as_tensor(np.asarray(states, dtype=np.float32))).numpy()
        return masked_argmax(q, np.asarray(masks, dtype=bool))

    return act


class DQNPolicy:
    """The greedy interaction manager: the offered act with the highest Q-value."""

    def __init__(
        self,
        q_network: QNetwork,
        feature_names: Sequence[str],
        metadata: dict[str, Any] | None = None,
    ) -> None:
        self.q_network = q_network.eval()
        self.feature_names = tuple(feature_names)
        self.metadata = dict(metadata or {})

    def q_values(self, states: np.ndarray) -> np.ndarray:
        """Q(s, a) for a batch of states (N, n_features) -> (N, N_ACTIONS)."""
        with torch.inference_mode():
            x = torch.as_tensor(np.asarray(states, dtype=np.float32))
            return self.q_network(x).numpy()

    def act(self, obs: np.ndarray, action_mask: np.ndarray) -> int:
        """The act to take in state `obs` among those `action_mask` offers."""
        q = self.q_values(np.asarray(obs, dtype=np.float32)[None])[0]
        return int(masked_argmax(q, np.asarray(action_mask, dtype=bool)))

    def act_batch(self, states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        """`act` for a batch of states and masks."""
        return masked_argmax(self.q_values(states), np.asarray(masks, dtype=bool))

    def save(self, path: str | Path) -> None:
        """Write the policy file atomically (never half-written)."""
        payload = {
            "format": POLICY_FORMAT,
            "feature_names": list(self.feature_names),
            "action_names": list(SYSTEM_ACTS),
            "hidden_sizes": list(self.q_network.hidden_sizes),
            "board_features": self.q_network.board_features,
            "state_dict": self.q_network.state_dict(),
            "metadata": self.metadata,
        }
        artifacts.save(path, POLICY_KIND, POLICY_VERSION, payload)


def training_budget(metadata: dict[str, Any]) -> tuple[int, float]:
    """Experiences and wall-clock seconds a policy's training took, a fine-tune's together with
    the runs it started from (`init_from`, and back)."""
    experiences, seconds, step = 0, 0.0, metadata
    while step:
        experiences += int(step.get("experiences", 0))
        seconds += float(step.get("wall_clock_s", 0.0))
        step = step.get("init_from")
    return experiences, seconds


def shipped_policy_path() -> Path:
    """Where the shipped trained policy lives: `oxbot/data/models/agent.pt`."""
    return Path(str(resources.files("oxbot") / "data" / "models" / SHIPPED_POLICY))


def load_policy(
    path: str | Path | None = None,
    feature_names: Sequence[str] | None = None,
    advice: str | None = None,
) -> DQNPolicy:
    """The shipped trained policy, or the one at `path` (a file, or the folder `oxbot train
    agent --out` wrote it in); no training step.

    The file must have been trained on the same feature layout as the environment's (the
    shipped domain's unless `feature_names` is given); otherwise `ModelFileError`, saying
    `advice` (what to run; by default, how to train for the shipped domain).
    """
    path = Path(path) if path is not None else shipped_policy_path()
    if path.is_dir():
        path = path / SHIPPED_POLICY
    if feature_names is None:
        from oxbot.dialogue.model import shipped_dialogue_model

        feature_names = shipped_dialogue_model().layout.names
    what = "policy file"
    remedy = (
        "retrain it with `oxbot train agent`, or re-download oxbot/data/models/agent.pt "
        "from the oxbot repository"
    )
    payload = artifacts.load(path, POLICY_KIND, POLICY_VERSION, what, remedy, _is_legacy)
    if payload.get("format") != POLICY_FORMAT:
        raise ModelFileError(f"{path} is not an oxbot DQN policy file ({POLICY_FORMAT})")
    with artifacts.checked(path, what, remedy):
        saved = tuple(_strings(payload["feature_names"]))
        actions = tuple(_strings(payload["action_names"]))
        hidden = [int(h) for h in payload["hidden_sizes"]]
        board = payload.get("board_features")
        board = (int(board[0]), int(board[1])) if board else None
        metadata = dict(payload.get("metadata") or {})
    if saved != tuple(feature_names):
        missing = sorted(set(feature_names) - set(saved))[:5]
        extra = sorted(set(saved) - set(feature_names))[:5]
        raise ModelFileError(
            f"policy file {path} was trained on another feature layout ({len(saved)} features, "
            f"the domain has {len(feature_names)}; missing {missing}, unknown {extra}): "
            f"{advice or retrain_advice()}"
        )
    if actions != SYSTEM_ACTS:
        raise ModelFileError(f"policy file {path} was trained on other acts; retrain it")
    try:
        network = QNetwork(len(saved), hidden, len(SYSTEM_ACTS), board)
        network.load_state_dict(payload["state_dict"])
    except (RuntimeError, TypeError, ValueError, KeyError, AttributeError) as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise ModelFileError(f"policy file {path} does not match its network: {first}") from None
    return DQNPolicy(network, saved, metadata)


def _strings(values: Any) -> list[str]:
    if not isinstance(values, list | tuple) or not all(isinstance(v, str) for v in values):
        raise TypeError(f"expected a list of names, got {type(values).__name__}")
    return list(values)


def _is_legacy(payload: Any) -> bool:
    """A policy saved before files carried a checksum."""
    return isinstance(payload, dict) and payload.get("format") == POLICY_FORMAT
