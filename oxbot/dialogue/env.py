"""The interactive game as a Gymnasium environment: the robot talks and draws, a person answers.

## Description

One episode is one dialogue between the robot (the agent) and a simulated person
(`UserSimulator`): greeting, introduction, invitation, the game of noughts and crosses with
"I take this one" / "Your turn", feedback and goodbye, as in the paper's Figure 1. Each step is
one system act; the person then answers (or stays silent) and may draw.

## Action Space

`Discrete(N_ACTIONS)`: the 21 acts in `oxbot.dialogue.domain.SYSTEM_ACTS` (the paper's 18, then
ask again, acknowledge a refusal, acknowledge a stop), 0-8 being `GameMove(gridloc=...)` on the
cells row-major from the upper left. `info["action_mask"]`
(bool, one per act) says which acts are offered (Pr(a|s) > 0.001 from the action model, all
valid GameMoves if any is, never an occupied cell). An act outside the mask is still said; a
GameMove that cannot be drawn (occupied cell, not the robot's turn) is a wasted turn: nothing
happens but -DL.

## Observation Space

`Box(0, 1, (149,), float32)`, the layout in `oxbot.dialogue.features`: word features of the last
system and user responses, game-move features that keep the board, game flags, the act the
person's answer was understood as (with its score), the robot's last act and dialogue flags. The
state behind it is a `DialogueState` (`oxbot.dialogue.state`), the same the robot's
interaction manager keeps.

## Rewards

R(s,a,s') = BR*w + DR*(1-w) - DL (`oxbot.dialogue.reward`), plus at the end of the dialogue 0 if
the robot lost and 5 after any other game (the paper's); oxbot: 3 when the person declined to
play or asked to stop and the robot let them, and 0 for any dialogue that is not well formed
(`oxbot.dialogue.wellformed`: a game nobody agreed to, a no or a stop not let go, walking away).
A person the robot ignores — it starts a game they did not agree to, asks to play again after a
clear "no thanks" (or a third time after two noes), goes on after a stop — walks away there:
the dialogue ends at once, with no end reward (`info["walked_away"]` says why).

## Episode End

Terminated when the robot says goodbye (`Salutation(closing)`), or when the person walks away
(above): `info["outcome"]` is the game's
result from the robot's side ("win", "draw", "loss"), or "declined" (the person never agreed
to play), "stopped" (the person asked to stop mid-game) or "abandoned" (the robot left a person
who wanted to play; rewarded as a loss). `info["transcript"]` is the dialogue as
`{"speaker", "act", "text"}` dicts, the person's turns with the act they meant;
`info["understood"]` the act each turn was understood as and `info["understood_scores"]` with
what score; `info["person"]` the kind of person
(`UserSimulator.kind`). Truncated after `max_turns` system acts
(`info["outcome"]` is then the result so far, or None).

## Arguments

`opponent`: the person's game strategy, a callable `f(board) -> cell` or a name
(`random`, `blocker`, `minimax`; default random, seeded by `reset`). `robot_starts`: who draws
first (with circles). `config`: the `OxbotConfig` (reward, dialogue). `cooperative`: a person
who always agrees and plays a whole game (recognition noise still on), for measuring game play.
`reset(options=...)` may change opponent and starter for one episode: `{"opponent": ...,
"robot_starts": ...}`.

## Version History

- v0: the first version; later kept the id and grew the acts (21), the features (150), the
  people (who decline, stop, chatter, say nothing, walk away when ignored) and the outcomes
  ("declined", "stopped").
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from oxbot.config import OxbotConfig, phrasing_weights
from oxbot.dialogue.domain import CLOSING, SILENCE, SYSTEM_ACTS, Domain
from oxbot.dialogue.model import build_dialogue_model
from oxbot.dialogue.reward import end_reward, step_reward
from oxbot.dialogue.simulator import UserSimulator
from oxbot.dialogue.state import DialogueState, Turn
from oxbot.dialogue.wellformed import check_dialogue, ignores_the_person
from oxbot.errors import ConfigError, InvalidInputError
from oxbot.game.board import Board, render
from oxbot.game.opponents import Opponent, make_opponent


class InteractiveGameEnv(gym.Env):
    """The robot's dialogue and game with a simulated person (see the module docstring)."""

    metadata = {"render_modes": ["ansi"], "render_fps": 4}  # noqa: RUF012 (gymnasium's API)

    def __init__(
        self,
        opponent: Opponent | str | None = None,
        robot_starts: bool = True,
        config: OxbotConfig | None = None,
        domain: Domain | None = None,
        render_mode: str | None = None,
        cooperative: bool = False,
    ) -> None:
        self.config = config if config is not None else OxbotConfig()
        self.cooperative = cooperative
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode {render_mode!r} is not supported; use 'ansi' or None")
        self.render_mode = render_mode
        self.model = build_dialogue_model(self.config, domain)
        self.domain, self.layout = self.model.domain, self.model.layout
        self.opponent = opponent
        self.robot_starts = bool(robot_starts)
        self.observation_space = spaces.Box(
            0.0, 1.0, shape=(self.layout.n_features,), dtype=np.float32
        )
        self.action_space = spaces.Discrete(len(SYSTEM_ACTS))
        self._simulator: UserSimulator | None = None
        self.state: DialogueState = self.model.new_state(self.robot_starts)
        self._probs = np.zeros(len(SYSTEM_ACTS))
        self._done = True

    # --- the Gymnasium contract -------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start a dialogue; `options` may set `opponent` and `robot_starts` for this episode."""
        super().reset(seed=seed)
        options = options or {}
        opponent = options.get("opponent", self.opponent)
        if opponent is None or isinstance(opponent, str):
            opponent = make_opponent(opponent or "random", self.np_random)
        cfg = self.config.dialogue
        if self._simulator is None or seed is not None:
            self._simulator = UserSimulator(
                self.domain,
                opponent,
                self.np_random,
                asr_noise=cfg.asr_noise,
                decline_probability=cfg.decline_probability,
                out_of_turn_probability=cfg.out_of_turn_probability,
                refuse_probability=cfg.refuse_probability,
                stop_probability=cfg.stop_probability,
                nonsense_probability=cfg.nonsense_probability,
                silence_probability=cfg.silence_probability,
                rematch_probability=cfg.rematch_probability,
                early_refusal_probability=cfg.early_refusal_probability,
                cooperative=self.cooperative,
                understanding=self.model.understanding,
                phrasing_weights=phrasing_weights(cfg.phrasing_weights),
            )
        self._simulator.opponent = opponent
        self._simulator.reset()
        self.state = self.model.new_state(bool(options.get("robot_starts", self.robot_starts)))
        self._turns = 0
        self._done = False
        self._probs, mask = self.state.offered()
        return self.state.encode(), {"action_mask": mask}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Say (and draw) one system act, then hear the person's answer."""
        if self._done:
            raise gym.error.ResetNeeded("the dialogue is over; call reset() first")
        action = int(action)
        if not self.action_space.contains(action):
            raise InvalidInputError(
                f"action {action!r} is not one of the {len(SYSTEM_ACTS)} acts "
                f"(0-{len(SYSTEM_ACTS) - 1})"
            )
        rcfg = self.config.reward
        state = self.state
        act = SYSTEM_ACTS[action]

        # the robot's turn: say the act (and draw), rewarded before the board changes
        did = state.can_do(act)
        if did:
            reward = step_reward(state.board, action, float(self._probs[action]), rcfg)
            # never the robot's own last sentence again, whatever the person said between
            last = next(
                (t["text"] for t in reversed(state.transcript) if t["speaker"] == "sys"), ""
            )
            state.robot_says(act, self.model.template(act, self.np_random, last))
        else:  # a GameMove that cannot be drawn: a wasted turn
            reward = -rcfg.length_penalty
            state.robot_skips()

        ignored = (
            ignores_the_person(state.transcript, state.understood_turns, state.understood_scores)
            if did
            else None
        )
        terminated = act == CLOSING or ignored is not None
        result = self._closing_outcome() if terminated else state.outcome
        if terminated:  # no end reward for a dialogue that is not well formed
            problem = check_dialogue(
                state.transcript, result, state.understood_turns, state.understood_scores
            )
            well_formed = problem is None
            reward += end_reward(result if well_formed else "loss", rcfg)

        # the person's turn: answer, perhaps draw; or walk away from a robot that ignores them
        if did and ignored is None:
            answer = self._simulator.respond(act, state.board, state.person_to_move)
            if answer.act != SILENCE:
                state.person_says(answer.act, answer.text, answer.heard, answer.understood)

        self._turns += 1
        truncated = not terminated and self._turns >= self.config.dialogue.max_turns
        self._done = terminated or truncated
        self._probs, mask = state.offered()
        info: dict[str, Any] = {"action_mask": mask}
        if not did:
            info["invalid_action"] = True
        if ignored is not None:
            info["walked_away"] = ignored
        if self._done:
            info["outcome"] = result if terminated else state.outcome
            info["transcript"] = list(state.transcript)
            info["understood"] = list(state.understood_turns)
            info["understood_scores"] = list(state.understood_scores)
            info["person"] = self._simulator.kind
        return state.encode(), float(reward), terminated, truncated, info

    def _closing_outcome(self) -> str:
        """How the dialogue ended, when the robot says goodbye (see the module docstring)."""
        result = self.state.outcome
        if result is not None:
            return result
        person = self._simulator
        if person.refused and not person.agreed:
            return "declined"
        if person.asked_to_stop:
            return "stopped"
        return "abandoned"  # the robot walked away from a person who wanted to play

    def render(self) -> str | None:
        """The dialogue so far and the board, as text (render_mode "ansi")."""
        if self.render_mode != "ansi":
            return None
        lines = [format_turn(turn) for turn in self.state.transcript]
        return "\n".join([*lines, render(self.state.board, self.state.robot_starts)]) + "\n"

    @property
    def board(self) -> Board:
        """The board now (0 empty, 1 robot, 2 person)."""
        return self.state.board

    @property
    def action_probabilities(self) -> np.ndarray:
        """Pr(a|s) of every act in the current state, from the action model."""
        return self._probs.copy()


def format_turn(turn: Turn) -> str:
    """One transcript entry as a line like the paper's Figure 1: `Rob: Hello!`."""
    who = "Rob" if turn["speaker"] == "sys" else "Usr"
    return f"{who}: {turn['text']}"
