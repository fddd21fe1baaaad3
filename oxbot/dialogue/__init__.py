"""Learning to interact: the dialogue domain, the simulated person, the environment, the DQN.

    from oxbot.dialogue import InteractiveGameEnv, load_policy
    env = InteractiveGameEnv(opponent=f, robot_starts=True)
    obs, info = env.reset(seed=0)
    policy = load_policy()
    a = policy.act(obs, info["action_mask"])
    obs, reward, terminated, truncated, info = env.step(a)

Importing this package registers the environment as `oxbot/NoughtsAndCrosses-v0`. PyTorch is
imported only when a policy is loaded or trained.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import gymnasium

from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.policy import Policy

if TYPE_CHECKING:
    from oxbot.dialogue.agent import DQNPolicy, load_policy

ENV_ID = "oxbot/NoughtsAndCrosses-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="oxbot.dialogue.env:InteractiveGameEnv")

__all__ = ["ENV_ID", "DQNPolicy", "InteractiveGameEnv", "Policy", "load_policy"]


def __getattr__(name: str) -> Any:
    if name in ("load_policy", "DQNPolicy"):
        from oxbot.dialogue import agent

        return getattr(agent, name)
    raise AttributeError(f"module 'oxbot.dialogue' has no attribute {name!r}")
