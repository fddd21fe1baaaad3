"""What the learned interaction manager is measured against: rules, a script, tabular Q-learning.

- `rule_based_policy` (`RuleBasedManager`): the finite-state manager a dialogue engineer would
  write, with the same understanding, confidences, action mask and solver as the DQN. It greets,
  introduces itself and invites; plays on a sure yes, asks again once about an unsure one; lets
  a no or a stop go; asks once more after a "later"; gives feedback and says goodbye.
- `scripted_policy`: no learning at all. It says the action model's most probable offered act
  (the Naive Bayes classifier of the seed dialogues), and when that is a move it draws where
  the exact solver says: among the moves that never lose, the one most likely to win against a
  random person. If the DQN is worth learning, it has to beat this.
- `train_tabular_q`: Q-learning with a table, keyed on the state's features read as 0/1 (words
  and acts heard above 0.5, the board, the flags), epsilon-greedy among the offered acts, on the
  same environment and people as the DQN and for the same number of experiences.

All are batch policies for `oxbot.dialogue.evaluation.evaluate`; `load_manager` gives the robot
any of them, the DQN included, by name (`oxbot play --manager rules`).
"""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

from oxbot.config import MANAGERS, OxbotConfig, opponent_mix, who_starts
from oxbot.dialogue.agent import load_policy, masked_argmax
from oxbot.dialogue.domain import (
    ACCEPT,
    ACTION_INDEX,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    FEEDBACK_ACTS,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    LETS_PLAY,
    MOVE_ACT_TYPE,
    MOVE_REQUEST,
    N_ACTIONS,
    POSTPONE,
    REFUSALS,
    SILENCE,
    STOP,
    SYSTEM_ACTS,
    is_game_move,
)
from oxbot.dialogue.env import InteractiveGameEnv
from oxbot.dialogue.evaluation import Policy
from oxbot.dialogue.features import DIALOGUE_FLAGS, HEARD_ACTS, FeatureLayout
from oxbot.dialogue.model import DialogueModel, build_dialogue_model
from oxbot.dialogue.policy import retrain_advice
from oxbot.dialogue.wellformed import SURE_NO
from oxbot.errors import ConfigError
from oxbot.game.board import EMPTY, N_CELLS, ROBOT, USER, Board, outcome, play
from oxbot.game.opponents import make_opponent
from oxbot.game.solver import best_moves, win_probability_vs_random


def board_of(state: np.ndarray, layout: FeatureLayout) -> Board:
    """The board a state vector shows."""
    robot = state[layout.robot_cells] > 0.5
    person = state[layout.person_cells] > 0.5
    return tuple(ROBOT if r else USER if p else EMPTY for r, p in zip(robot, person, strict=True))


def solver_move(board: Board, offered: np.ndarray) -> int:
    """The offered cell that never loses and most often wins against a random person."""
    cells = [c for c in best_moves(board, ROBOT) if offered[c]] or list(np.flatnonzero(offered))
    return max(cells, key=lambda c: win_probability_vs_random(play(board, c, ROBOT), ROBOT, False))


class Manager(Protocol):
    """What the robot and the evaluations need of an interaction manager: a score for every act
    in a batch of states (the DQN's Q-values), and the best-scored offered act. `DQNPolicy`,
    `ScriptedManager` and `RuleBasedManager` are managers."""

    def q_values(self, states: np.ndarray) -> np.ndarray: ...

    def act(self, obs: np.ndarray, action_mask: np.ndarray) -> int: ...

    def act_batch(self, states: np.ndarray, masks: np.ndarray) -> np.ndarray: ...


class ScriptedManager:
    """The script as a manager: its scores are the action model's Pr(a|s), the moves folded
    onto the solver's cell (the others a point lower), so that the best-scored offered act is
    the most probable one, and for a move the solver's cell."""

    def __init__(self, model: DialogueModel) -> None:
        self.layout = model.layout
        self.action_model = model.action_model

    def q_values(self, states: np.ndarray) -> np.ndarray:
        """Scores of every act, (N, N_ACTIONS), from the states alone."""
        states = np.atleast_2d(states)
        scores = self.action_model.predict_proba(states)
        for i, state in enumerate(states):
            cell = self.solver_cell(state)
            if cell is not None:
                moves = scores[i, :N_CELLS]
                moves[np.arange(N_CELLS) != cell] -= 1.0
        return scores

    def solver_cell(self, state: np.ndarray) -> int | None:
        """The solver's cell on the state's board (`solver_move`), or None when the game is
        over."""
        board = board_of(state, self.layout)
        if outcome(board) is not None:
            return None
        return solver_move(board, np.array([c == EMPTY for c in board]))

    def act(self, obs: np.ndarray, action_mask: np.ndarray) -> int:
        """The best-scored act that `action_mask` offers."""
        return int(self.act_batch(np.asarray(obs)[None], np.asarray(action_mask)[None])[0])

    def act_batch(self, states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        """`act` for a batch of states and masks."""
        return masked_argmax(self.q_values(states), np.asarray(masks, dtype=bool))


def scripted_policy(model: DialogueModel) -> Policy:
    """The action model's most probable offered act; the exact solver's cell for a move."""
    return ScriptedManager(model).act_batch


SURE_YES = 0.7
"""A yes to "Shall we play?" understood with a score below this (the understanding's
probability times the recogniser's mean word confidence, `DialogueState.understood`) is asked
about once ("Sorry, I didn't catch that. Shall we play?") before the robot plays; a yes after
asking once is taken as heard. Too low, and a misheard answer starts a game nobody agreed to
(the person walks away); too high, and people are asked twice. To be tuned on development
people only (the simulated people at development seeds, the tuning voices), never on the
people or voices kept for independent evaluation. Chosen so on the default simulated people at
seed 1 (0.5 to 0.8 tried; docs/dialogue.md, "The hand-written baseline")."""
CLEAR_NO = SURE_NO
"""A "no thanks" to "Shall we play?" understood with a score of at least this is let go at
once ("Okay, maybe another time.", then the goodbye); below it the robot asks once. It may not
exceed `oxbot.dialogue.wellformed.SURE_NO`, above which a no is clear and asking again breaks
the rules; lower, more of the yeses misheard as a no are let go without a question (the person
may still take it back). To be tuned on development people only, as `SURE_YES`."""
CLEAR_STOP = 0.4
"""A stop mid-game understood with a score of at least this is let go at once ("Okay, let's
stop here.", then the goodbye); below it the robot asks for the move once more. At most
`wellformed.SURE_NO`, as `CLEAR_NO`. A second stop is let go whatever its score
(`person:stop_is_final`). To be tuned on development people only, as `SURE_YES` (and so
chosen: 0.2, 0.4 and 0.6 tried)."""
_ASKING = (INVITATION, ASK_AGAIN)


class RuleBasedManager(ScriptedManager):
    """The finite-state manager a dialogue engineer would write, over the DQN's state vector
    and action mask (a batch policy for `oxbot.dialogue.evaluation.evaluate`).

    It reads, as the DQN does, the act the person's last answer was understood as and its score,
    the robot's last act, the dialogue flags and the board (`FeatureLayout`):

    - it greets, introduces itself and invites the person to play, whatever they answer first
      (a no before it asked is taken up again by the invitation);
    - asked to play, on a yes understood at least `sure_yes` surely it says "Nice, let's play",
      below that it asks again once (`Request(repeat)`) and then takes the answer as heard;
      a clear "no thanks" (at least `clear_no`) it lets go ("Okay, maybe another time."), an
      unsure one it asks about once, and lets go a no once asking would not
      (`person:no_is_final`); after a "later" it invites once more; a no after it has
      asked twice (a no before it asked counts as one) it lets go; when it made nothing out
      (silence, chatter) it asks again, then invites again, never asking again twice in a row;
    - in the game it draws the exact solver's cell (`solver_move`, as the script) and asks
      for the person's move after each of its own; with no drawing it asks for the move again;
      a stop understood at least `clear_stop` surely it lets go ("Okay, let's stop here."), an
      unsure one it asks for the move once more, and lets the second go;
    - once the game is over, the feedback of its outcome, then the goodbye; after letting a no
      or a stop go, the goodbye, unless the person takes it back with a yes ("Yes, I want to
      play."): then it plays on.

    Only offered acts are said. Each rule names its acts best first; the policy says the first
    one the action mask offers, and when the mask offers none of them, the script's choice (the
    action model's most probable offered act, the solver's cell for a move), so the choice is
    always offered and deterministic. `q_values` gives the same order as scores (the rule's acts
    above 2, the script's below 1), so the robot's greedy choice over them is the same.
    """

    def __init__(
        self,
        model: DialogueModel,
        sure_yes: float = SURE_YES,
        clear_no: float = CLEAR_NO,
        clear_stop: float = CLEAR_STOP,
    ) -> None:
        super().__init__(model)
        if max(clear_no, clear_stop) > SURE_NO:
            raise ValueError(
                f"clear_no and clear_stop must not exceed wellformed.SURE_NO ({SURE_NO}): "
                "asking again after a clear no or stop breaks the rules"
            )
        self.sure_yes, self.clear_no, self.clear_stop = sure_yes, clear_no, clear_stop
        layout = self.layout
        self._flag = {
            name: layout.dialogue_flags.start + k for k, name in enumerate(DIALOGUE_FLAGS)
        }

    def q_values(self, states: np.ndarray) -> np.ndarray:
        """Scores of every act, (N, N_ACTIONS): the rule's acts, best first, from 2 + their
        number down to 3; every other act its script score (at most 1)."""
        states = np.atleast_2d(states)
        scores = super().q_values(states)
        for i, state in enumerate(states):
            preferred = self.preferences(state)
            for rank, action in enumerate(preferred):
                scores[i, action] = 2.0 + len(preferred) - rank
        return scores

    def preferences(self, state: np.ndarray) -> tuple[int, ...]:
        """The acts the rules would say in `state`, best first, as indices of SYSTEM_ACTS (a
        move: the solver's cell); empty where no rule applies (the script decides)."""
        preferred = []
        for act in self._rule(state):
            if act != MOVE_ACT_TYPE:
                preferred.append(ACTION_INDEX[act])
            elif (cell := self.solver_cell(state)) is not None:
                preferred.append(cell)
        return tuple(preferred)

    def _rule(self, state: np.ndarray) -> tuple[str, ...]:
        """The rule that applies to `state`: its acts, best first (`MOVE_ACT_TYPE`: a move)."""
        layout, flag = self.layout, self._flag
        said = {name: state[k] > 0.5 for name, k in flag.items()}
        if not said["dialogue:greeted"]:
            return (GREETING,)
        robot_to_move, robot_won, person_won, draw = state[layout.flags] > 0.5
        if robot_won or person_won or draw:
            if said["dialogue:gave_feedback"]:
                return (CLOSING,)
            ending = "win" if robot_won else "loss" if person_won else "draw"
            return (FEEDBACK_ACTS[ending],)
        heard, score = self._heard(state)
        last = self._last_act(state)
        play_on = (MOVE_ACT_TYPE,) if robot_to_move else (MOVE_REQUEST,)
        if last in (GRANT_REFUSAL, GRANT_STOP):  # a yes takes the no or the stop back
            if heard == ACCEPT:
                return (LETS_PLAY,) if last == GRANT_REFUSAL else play_on
            return (CLOSING,)
        if last in _ASKING:
            return self._answer_to_play(heard, score, last, said)
        if last == LETS_PLAY:
            return play_on
        if is_game_move(last):
            return (MOVE_REQUEST,)
        if last == MOVE_REQUEST:
            if robot_to_move:  # the person drew
                return (MOVE_ACT_TYPE,)
            if heard == STOP:
                final = score >= self.clear_stop or said["person:stop_is_final"]
                return (GRANT_STOP,) if final else (MOVE_REQUEST, GRANT_STOP)
            return (MOVE_REQUEST,)
        if not said["dialogue:introduced"]:
            return (INTRODUCTION,)
        if not said["dialogue:invited"]:
            return (INVITATION, GRANT_REFUSAL)
        return ()

    def _answer_to_play(
        self, heard: str, score: float, asked: str, said: dict[str, bool]
    ) -> tuple[str, ...]:
        """What to say to the answer to "Shall we play?" (`asked`: the invitation or asking
        again; `said`: the dialogue flags)."""
        again = asked == ASK_AGAIN
        if heard == ACCEPT:
            # after a no, this question was the one more the rules allow: no checking the yes
            sure = score >= self.sure_yes or again or said["person:refused"]
            return (LETS_PLAY,) if sure else (ASK_AGAIN, LETS_PLAY)
        if heard in REFUSALS:
            final = said["dialogue:asked_twice"] or said["person:no_is_final"]
            if final or (heard == DECLINE and score >= self.clear_no):
                # where the mask offers no acknowledgement (an unsure yes asked about, then a
                # no) the question once more: a goodbye to a no must acknowledge it
                return (GRANT_REFUSAL, ASK_AGAIN)
            if heard == POSTPONE:  # "maybe later": asked once more
                return (INVITATION, ASK_AGAIN, GRANT_REFUSAL)
            return (ASK_AGAIN, INVITATION, GRANT_REFUSAL)  # an unsure no, asked about once
        # nothing made out (silence, chatter): asked again, then the invitation again (or, where
        # the mask offers only asking again and the goodbye, asked again: a goodbye would leave
        # a person who may want to play)
        return (INVITATION, ASK_AGAIN) if again else (ASK_AGAIN, INVITATION)

    def _heard(self, state: np.ndarray) -> tuple[str, float]:
        """The act the person's last answer was understood as, and its score (Silence, 0)."""
        scores = state[self.layout.heard_acts]
        k = int(np.argmax(scores))
        return (HEARD_ACTS[k], float(scores[k])) if scores[k] > 0 else (SILENCE, 0.0)

    def _last_act(self, state: np.ndarray) -> str:
        """The robot's last act ("" before its first, or after a turn it could not take)."""
        last = state[self.layout.last_acts]
        k = int(np.argmax(last))
        return SYSTEM_ACTS[k] if last[k] > 0.5 else ""


def rule_based_policy(
    model: DialogueModel,
    sure_yes: float = SURE_YES,
    clear_no: float = CLEAR_NO,
    clear_stop: float = CLEAR_STOP,
) -> Policy:
    """The rule-based manager (`RuleBasedManager`) as a batch policy."""
    return RuleBasedManager(model, sure_yes, clear_no, clear_stop).act_batch


def load_manager(
    name: str = "dqn", config: OxbotConfig | None = None, policy_file: Path | None = None
) -> Manager:
    """An interaction manager by name (`oxbot.config.MANAGERS`): "dqn", the trained policy
    (the shipped one, or `policy_file`, checked against the feature layout of `config`'s
    domain); "rules", `RuleBasedManager`; "script", `ScriptedManager`; the last two over the
    dialogue model of `config`."""
    config = config if config is not None else OxbotConfig()
    if name == "dqn":
        names = build_dialogue_model(config).layout.names
        return load_policy(policy_file, names, retrain_advice(config.dialogue.domain))
    if name not in MANAGERS:
        raise ConfigError(f"unknown manager {name!r}; choose one of {', '.join(MANAGERS)}")
    model = build_dialogue_model(config)
    return RuleBasedManager(model) if name == "rules" else ScriptedManager(model)


@dataclass
class TabularQ:
    """A Q-table over states read as 0/1; unseen states act on zeros (the first offered act)."""

    table: dict[bytes, np.ndarray] = field(default_factory=dict)
    experiences: int = 0
    cpu_seconds: float = 0.0

    @staticmethod
    def key(state: np.ndarray) -> bytes:
        return np.packbits(state > 0.5).tobytes()

    def values(self, state: np.ndarray) -> np.ndarray:
        return self.table.get(self.key(state), _ZEROS)

    def act_batch(self, states: np.ndarray, masks: np.ndarray) -> np.ndarray:
        q = np.stack([self.values(s) for s in states])
        return masked_argmax(q, np.asarray(masks, dtype=bool))


_ZEROS = np.zeros(N_ACTIONS)
PROGRESS_EVERY = 1_000
"""Experiences between two progress reports of `train_tabular_q`."""


def train_tabular_q(
    config: OxbotConfig,
    experiences: int,
    learning_rate: float = 0.2,
    epsilon: tuple[float, float] = (1.0, 0.01),
    on_progress: Callable[[int], None] | None = None,
) -> TabularQ:
    """Q-learning for `experiences` steps in the DQN's training conditions (`config.agent`:
    seed, discount, opponents, who starts, `eval_every`; epsilon falling linearly over half
    the run), keeping the best evaluated table as the DQN keeps its best network
    (`oxbot.dialogue.checkpoint_evaluation.evaluate_checkpoint`); `on_progress` is told the
    experiences so far every `PROGRESS_EVERY` and at the end."""
    from oxbot.dialogue.checkpoint_evaluation import evaluate_checkpoint

    cfg = config.agent
    started = time.process_time()
    env = InteractiveGameEnv(config=config)
    rng = np.random.default_rng(cfg.seed)
    mix = opponent_mix(cfg.opponents)
    names, weights = list(mix), np.array(list(mix.values()))
    opponents = {name: make_opponent(name, rng) for name in names}
    starts = who_starts(cfg.robot_starts)
    table: dict[bytes, np.ndarray] = defaultdict(lambda: np.zeros(N_ACTIONS))
    best, best_score = TabularQ(), None

    def next_episode() -> dict:
        name = names[rng.choice(len(names), p=weights)]
        return {"opponent": opponents[name], "robot_starts": bool(rng.choice(starts))}

    obs, info = env.reset(seed=cfg.seed, options=next_episode())
    for step in range(experiences):
        eps = max(epsilon[1], epsilon[0] - (epsilon[0] - epsilon[1]) * step / (experiences / 2))
        mask = info["action_mask"]
        q = table[TabularQ.key(obs)]
        if rng.random() < eps:
            action = int(rng.choice(np.flatnonzero(mask)))
        else:
            action = int(masked_argmax(q, mask))
        next_obs, reward, terminated, truncated, info = env.step(action)
        target = reward
        if not terminated:
            following = table[TabularQ.key(next_obs)]
            target += cfg.discount * float(
                np.max(np.where(info["action_mask"], following, -np.inf))
            )
        q[action] += learning_rate * (target - q[action])
        obs = next_obs
        if terminated or truncated:
            obs, info = env.reset(options=next_episode())
        if on_progress is not None and (
            (step + 1) % PROGRESS_EVERY == 0 or step + 1 == experiences
        ):
            on_progress(step + 1)
        if cfg.eval_every and (step + 1) % cfg.eval_every == 0:
            candidate = TabularQ({k: v.copy() for k, v in table.items()}, step + 1)
            _, score = evaluate_checkpoint(config, candidate.act_batch, step + 1)
            if best_score is None or score >= best_score:
                best, best_score = candidate, score
    if not cfg.eval_every:
        best = TabularQ(dict(table), experiences)
    best.cpu_seconds = time.process_time() - started
    return best
