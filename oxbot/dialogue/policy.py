"""The `Policy` protocol: whoever picks the robot's next act, as the robot drives it.

The interaction manager (`oxbot.robot.manager`) asks its policy for one act per turn:
`act(observation, mask) -> action`. The observation is the dialogue state's features
(`DialogueState.encode()`, in the feature layout of the domain played), the mask says which acts
the action model offers (bool, one per act of `SYSTEM_ACTS`), and the action is the index of an
offered act. The trained DQN (`oxbot.dialogue.agent.DQNPolicy`), the rules and the script
(`oxbot.dialogue.baselines`) are policies, and `oxbot.peers.SB3Policy` makes a
Stable-Baselines3 DQN or an sb3-contrib MaskablePPO model one. A policy that also has
`q_values(states)` has its scores shown on the page beside each choice.

>>> import numpy as np
>>> class FirstOffered:
...     def act(self, observation, mask):
...         return int(np.flatnonzero(mask)[0])
>>> isinstance(FirstOffered(), Policy)
True
>>> choose(FirstOffered(), np.zeros(3), np.array([False, True, True]))[0]
1
"""

from __future__ import annotations

import logging
from typing import Protocol, runtime_checkable

import numpy as np

log = logging.getLogger(__name__)


@runtime_checkable
class Policy(Protocol):
    """What the robot needs of a policy: the act to take in a state among the offered ones."""

    def act(self, observation: np.ndarray, mask: np.ndarray) -> int: ...


def choose(policy: Policy, observation: np.ndarray, mask: np.ndarray) -> tuple[int, np.ndarray]:
    """The act `policy` takes, and the scores the page shows beside it: the policy's
    `q_values` when it has them, else 1 for the chosen act and 0 for the others.

    An act outside the mask is never said on the robot (it may be an occupied cell): a warning,
    and the best-scored offered act instead."""
    mask = np.asarray(mask, dtype=bool)
    action = int(policy.act(observation, mask))
    q_values = getattr(policy, "q_values", None)
    if q_values is not None:
        scores = np.asarray(q_values(np.asarray(observation)[None])[0], dtype=float)
    else:
        scores = np.zeros(len(mask))
        if 0 <= action < len(mask):
            scores[action] = 1.0
    if not (0 <= action < len(mask) and mask[action]):
        offered = np.flatnonzero(mask)
        best = int(offered[np.argmax(scores[offered])])
        log.warning("the policy chose act %s, which is not offered; saying act %s", action, best)
        action = best
    return action, scores


def train_command(domain: str = "", out: str = "runs/agent") -> str:
    """The command that trains a policy for `domain` (a folder; "" the shipped one) into `out`."""
    where = f" --domain {domain}" if domain else ""
    return f".venv/bin/oxbot train agent{where} --out {out}"


def play_command(domain: str = "", policy: str = "runs/agent") -> str:
    """The command that plays `domain` with the policy at `policy`."""
    where = f" --domain {domain}" if domain else ""
    return f".venv/bin/oxbot play{where} --policy {policy}"


def retrain_advice(domain: str = "", out: str = "runs/agent") -> str:
    """What to do when no policy fits the domain: train one, then play with it."""
    return (
        f"train one for this domain with `{train_command(domain, out)}`, "
        f"then play with it: `{play_command(domain, out)}`"
    )
