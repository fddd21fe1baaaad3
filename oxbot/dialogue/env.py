"""The interactive game as a Gymnasium environment: the robot talks and draws, a person answers.

## Description

One episode is one dialogue between the robot (the agent) and a simulated person
(`UserSimulator`): greeting, introduction, invitation, the game of noughts and crosses with
"I take this one" / "Your turn", feedback and goodbye, as in the paper's Figure 1. Each step is
one system act; the person then answers (or stays silent) and may draw.

## Action Space

`Discrete(18)`: the paper's 18 acts in `oxbot.dialogue.domain.SYSTEM_ACTS`, 0-8 being
`GameMove(gridloc=...)` on the cells row-major from the upper left. `info["action_mask"]` (bool,
18) says which acts are offered (Pr(a|s) > 0.001 from the action model, all valid GameMoves if
any is, never an occupied cell). An act outside the mask is still said; a GameMove that cannot
be drawn (occupied cell, not the robot's turn) is a wasted turn: nothing happens but -DL.

## Observation Space

`Box(0, 1, (57,), float32)`, the layout in `oxbot.dialogue.features`: word features of the last
system and user responses, and game-move features that keep the board.

## Rewards

R(s,a,s') = BR*w + DR*(1-w) - DL (`oxbot.dialogue.reward`), plus 0 at the end of the dialogue if
the robot lost and 5 otherwise.

## Episode End

Terminated when the robot says goodbye (`Salutation(closing)`): `info["outcome"]` is the game's
result from the robot's side ("win", "draw", "loss"; a game left unfinished counts as a loss)
and `info["transcript"]` the dialogue as `{"speaker", "act", "text"}` dicts. Truncated after
`max_turns` system acts (`info["outcome"]` is then the result so far, or None).

## Arguments

`opponent`: the person's game strategy, a SPEC §5 callable `f(board) -> cell` or a name
(`random`, `blocker`, `minimax`; default random, seeded by `reset`). `robot_starts`: who draws
first (with circles). `config`: the `OxbotConfig` (reward, dialogue). `reset(options=...)` may
change both for one episode: `{"opponent": ..., "robot_starts": ...}`.

## Version History

- v0: the first version (oxbot issue 5).
"""

from __future__ import annotations

import functools
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from oxbot.config import DialogueConfig, OxbotConfig
from oxbot.dialogue.action_model import ActionModel
from oxbot.dialogue.domain import SYSTEM_ACTS, Domain, load_domain, words_of
from oxbot.dialogue.features import FeatureLayout
from oxbot.dialogue.reward import end_reward, step_reward
from oxbot.dialogue.simulator import SILENCE, UserSimulator
from oxbot.errors import ConfigError
from oxbot.game.board import (
    EMPTY,
    EMPTY_BOARD,
    ROBOT,
    USER,
    Board,
    outcome,
    play,
    render,
    to_move,
)
from oxbot.game.opponents import Opponent, make_opponent

CLOSING = SYSTEM_ACTS.index("Salutation(closing)")


@functools.cache
def shipped_components(
    nb_alpha: float = 0.01, nb_binarize: float = 0.5, nb_flag_weight: int = 4
) -> tuple[Domain, FeatureLayout, ActionModel]:
    """The shipped domain, its feature layout and its action model (built once per process)."""
    domain = load_domain()
    layout = FeatureLayout(domain.vocabulary)
    model = ActionModel.from_domain(
        domain, layout, alpha=nb_alpha, binarize=nb_binarize, flag_weight=nb_flag_weight
    )
    return domain, layout, model


def build_components(
    config: DialogueConfig, domain: Domain | None = None
) -> tuple[Domain, FeatureLayout, ActionModel]:
    """Domain, feature layout and action model: the shipped ones unless `domain` is given."""
    if domain is None:
        return shipped_components(config.nb_alpha, config.nb_binarize, config.nb_flag_weight)
    layout = FeatureLayout(domain.vocabulary)
    model = ActionModel.from_domain(
        domain,
        layout,
        alpha=config.nb_alpha,
        binarize=config.nb_binarize,
        flag_weight=config.nb_flag_weight,
    )
    return domain, layout, model


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
    ) -> None:
        self.config = config if config is not None else OxbotConfig()
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode {render_mode!r} is not supported; use 'ansi' or None")
        self.render_mode = render_mode
        self.domain, self.layout, self.action_model = build_components(self.config.dialogue, domain)
        self.opponent = opponent
        self.robot_starts = bool(robot_starts)
        self.observation_space = spaces.Box(
            0.0, 1.0, shape=(self.layout.n_features,), dtype=np.float32
        )
        self.action_space = spaces.Discrete(len(SYSTEM_ACTS))
        self._templates = {act: self.domain.templates_for(act) for act in SYSTEM_ACTS}
        self._template_words = {
            act: [words_of(t) for t in texts] for act, texts in self._templates.items()
        }
        self._simulator: UserSimulator | None = None
        self._board: Board = EMPTY_BOARD
        self._transcript: list[dict[str, str]] = []
        self._done = True

    # --- the Gymnasium contract -------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start a dialogue; `options` may set `opponent` and `robot_starts` for this episode."""
        super().reset(seed=seed)
        options = options or {}
        self._episode_robot_starts = bool(options.get("robot_starts", self.robot_starts))
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
            )
        self._simulator.opponent = opponent
        self._simulator.reset()
        self._board = EMPTY_BOARD
        self._transcript = []
        self._said: set[str] = set()
        self._turns = 0
        self._done = False
        obs = self.layout.encode((), (), self._board, self._episode_robot_starts)
        return obs, self._info(obs)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Say (and draw) one system act, then hear the person's answer."""
        if self._done:
            raise gym.error.ResetNeeded("the dialogue is over; call reset() first")
        action = int(action)
        if not self.action_space.contains(action):
            raise ConfigError(f"action {action!r} is not one of the 18 acts (0-17)")
        rcfg = self.config.reward
        board = self._board
        starts = self._episode_robot_starts
        act = SYSTEM_ACTS[action]
        probability = float(self._probs[action])
        system_words: list[str] = []
        invalid = False

        # the robot's turn: say the act (and draw), rewarded before the board changes
        if action < 9 and not (
            board[action] == EMPTY and outcome(board) is None and to_move(board, starts) == ROBOT
        ):
            invalid = True
            reward = -rcfg.length_penalty
        else:
            reward = step_reward(board, action, probability, rcfg)
            k = int(self.np_random.integers(len(self._templates[act])))
            system_words = self._template_words[act][k]
            self._transcript.append({"speaker": "sys", "act": act, "text": self._templates[act][k]})
            self._said.add(act)
            if action < 9:
                board = play(board, action, ROBOT)

        terminated = action == CLOSING
        result = outcome(board)
        if terminated:
            result = result or "loss"  # a game left unfinished: the robot walked away from it
            reward += end_reward(result, rcfg)

        # the person's turn: answer, perhaps draw
        heard: tuple[tuple[str, float], ...] = ()
        if not invalid:
            person_to_move = outcome(board) is None and to_move(board, starts) == USER
            answer = self._simulator.respond(act, board, person_to_move)
            if answer.act != SILENCE:
                self._transcript.append({"speaker": "usr", "act": answer.act, "text": answer.text})
                heard = answer.heard
                if answer.cell is not None:
                    board = play(board, answer.cell, USER)

        self._board = board
        self._turns += 1
        truncated = not terminated and self._turns >= self.config.dialogue.max_turns
        self._done = terminated or truncated
        obs = self.layout.encode(system_words, heard, board, starts, self._said)
        info = self._info(obs)
        if invalid:
            info["invalid_action"] = True
        if self._done:
            info["outcome"] = result if terminated else outcome(board)
            info["transcript"] = list(self._transcript)
        return obs, float(reward), terminated, truncated, info

    def render(self) -> str | None:
        """The dialogue so far and the board, as text (render_mode "ansi")."""
        if self.render_mode != "ansi":
            return None
        lines = [format_turn(turn) for turn in self._transcript]
        return "\n".join([*lines, render(self._board, self._episode_robot_starts)]) + "\n"

    # --- internals ---------------------------------------------------------------------------

    def _info(self, obs: np.ndarray) -> dict[str, Any]:
        robot_to_move = bool(obs[self.layout.flags.start] > 0)
        self._probs, mask = self.action_model.offered(
            obs, self._board, robot_to_move, self.config.reward.mask_threshold
        )
        return {"action_mask": mask}

    @property
    def board(self) -> Board:
        """The board now (0 empty, 1 robot, 2 person)."""
        return self._board

    @property
    def action_probabilities(self) -> np.ndarray:
        """Pr(a|s) of the 18 acts in the current state, from the action model."""
        return self._probs.copy()


def format_turn(turn: dict[str, str]) -> str:
    """One transcript entry as a line like the paper's Figure 1: `Rob: Hello!`."""
    who = "Rob" if turn["speaker"] == "sys" else "Usr"
    return f"{who}: {turn['text']}"
