"""The action model: a Naive Bayes classifier of Pr(a|s) learned from the seed dialogues.

Paper §2.2: "the action set was derived from the most likely actions, Pr(a|s) > 0.001, with
probabilities derived from a Naive Bayes classifier trained from example dialogues. In
addition, if a physical action was included in the action set, we included all valid physical
actions". The same probabilities are the DR term of the reward.

The classifier (scikit-learn's `BernoulliNB`) predicts the act *type*: the GameMoves are one
class, because a few seed games say nothing about which cell is good; every valid cell gets the
GameMove probability and an occupied cell gets 0. It reads the context features — the game
flags, the act the person's answer was understood as, the robot's last act, the dialogue flags
(`FeatureLayout.context`) — not the words and not the cells: the robot says each act in several
ways and people answer in hundreds, which a few seed dialogues cannot cover, and per-cell
features would let it veto acts on boards it has never seen. A feature counts above
`binarize`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sklearn.naive_bayes import BernoulliNB

from oxbot.dialogue.domain import (
    ACTION_INDEX,
    FEEDBACK_ACTS,
    GAME_MOVE_TEMPLATE,
    MOVE_ACT_TYPE,
    MOVE_REQUEST,
    N_ACTIONS,
    SILENCE,
    SYSTEM_ACTS,
    Domain,
    is_game_move,
)
from oxbot.dialogue.features import FeatureLayout
from oxbot.dialogue.state import DialogueState
from oxbot.game.board import EMPTY, N_CELLS, Board, outcome

GAME_MOVE_CLASS = MOVE_ACT_TYPE
"""The action model's one class for the moves: it says whether to draw; every empty cell is then
offered (paper §2.2)."""
REPEAT_SUFFIX = "#again"


def act_class(act: str, repeated: bool = False) -> str:
    """The classifier's label of a system act: `GameMove` for any cell, else the act itself.

    An act said right after itself (asking again after a "no" or an answer out of turn) is a
    class of its own, `Act#again`: its states look nothing like the first time's, and one Naive
    Bayes class cannot model both.
    """
    if is_game_move(act):
        return GAME_MOVE_CLASS
    return act + REPEAT_SUFFIX if repeated else act


def class_act(label: str) -> str:
    """The act (GameMove for the nine) a classifier label stands for."""
    return label.removesuffix(REPEAT_SUFFIX)


def seed_examples(domain: Domain, layout: FeatureLayout) -> tuple[np.ndarray, list[str]]:
    """Replay the seed dialogues: the state before each system act, and its class label.

    The states are the ones a dialogue reaches (`DialogueState`): the last system words (1),
    the words of the person's answer to them and the act they were understood as (confidence 1
    in the seeds; none if silent), the board, the acts said and heard so far.
    """
    states: list[np.ndarray] = []
    acts: list[str] = []
    for dialogue in domain.dialogues:
        first_move = next((u for u in dialogue if u.cell is not None), None)
        robot_starts = first_move is None or first_move.speaker == "SYS"
        state = DialogueState(layout, robot_starts)
        for utterance in dialogue:
            if utterance.speaker == "SYS":
                states.append(state.encode())
                acts.append(act_class(utterance.act, repeated=utterance.act == state.last_act))
                state.robot_says(utterance.act, utterance.text)
            else:
                heard = tuple((w, 1.0) for w in utterance.words)
                act = GAME_MOVE_TEMPLATE if is_game_move(utterance.act) else utterance.act
                understood = (act, 1.0) if heard else (SILENCE, 0.0)
                state.person_says(utterance.act, utterance.text, heard, understood)
    return np.stack(states), acts


class ActionModel:
    """Pr(a|s) over the system acts, from Bernoulli Naive Bayes on the dialogue features.

    Configured in `__init__`, learned by `fit`, and `predict_proba` takes a batch. Prediction is
    computed from the fitted log-probabilities with one matrix product (the same numbers as
    `BernoulliNB.predict_proba`, without its per-call overhead: the environment asks every step).
    """

    def __init__(
        self,
        layout: FeatureLayout,
        alpha: float = 0.01,
        binarize: float = 0.5,
        threshold: float = 0.001,
    ) -> None:
        self.layout = layout
        self.alpha = alpha
        self.binarize = binarize
        self.threshold = threshold
        # the context, not the words: the robot's own words vary with its templates and the
        # person's are read as acts (heard:*); seed dialogues cannot cover every phrasing
        self.columns = np.arange(layout.context.start, layout.context.stop)
        self._memo: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def fit(self, states: np.ndarray, labels: list[str]) -> ActionModel:
        """Learn from states (N, n_features) and the class label (`act_class`) of each act."""
        self.classifier_ = BernoulliNB(alpha=self.alpha, binarize=self.binarize)
        self.classifier_.fit(states[:, self.columns], labels)
        log_p = self.classifier_.feature_log_prob_
        log_not_p = np.log1p(-np.exp(log_p))
        self._weights = (log_p - log_not_p).T.astype(np.float64)  # (n_columns, n_classes)
        self._bias = log_not_p.sum(axis=1) + self.classifier_.class_log_prior_
        # where each class's probability goes among the acts (GameMove: each cell)
        self._memo.clear()
        self._to_actions = np.zeros((len(self.classifier_.classes_), N_ACTIONS))
        for k, label in enumerate(self.classifier_.classes_):
            for a, act in enumerate(SYSTEM_ACTS):
                if act_class(act) == class_act(str(label)):
                    self._to_actions[k, a] = 1.0
        return self

    @classmethod
    def from_domain(cls, domain: Domain, layout: FeatureLayout, **kwargs: Any) -> ActionModel:
        """The action model trained on the domain's seed dialogues."""
        states, acts = seed_examples(domain, layout)
        return cls(layout, **kwargs).fit(states, acts)

    def class_proba(self, states: np.ndarray) -> np.ndarray:
        """Pr(act type | s), (N, n_classes), in the order of `classifier_.classes_`."""
        x = (np.atleast_2d(states)[:, self.columns] > self.binarize).astype(np.float64)
        logits = x @ self._weights + self._bias
        logits -= logits.max(axis=1, keepdims=True)
        p = np.exp(logits)
        return p / p.sum(axis=1, keepdims=True)

    def offered(
        self, state: np.ndarray, board: Board, robot_to_move: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pr(a|s) and the action mask of one state (the same numbers as `predict_proba` and
        `action_mask`), memoised on the heard words and flags, which repeat a lot."""
        key = (state[self.columns] > self.binarize).tobytes()
        by_act = self._memo.get(key)
        if by_act is None:
            by_act = (self.class_proba(state) @ self._to_actions)[0]
            if len(self._memo) < 100_000:
                self._memo[key] = by_act
        probs = by_act.copy()
        for cell, mark in enumerate(board):
            if mark:
                probs[cell] = 0.0
        return probs, action_mask(probs, board, robot_to_move, self.threshold)

    def predict_proba(self, states: np.ndarray) -> np.ndarray:
        """Pr(a|s) of every act, (N, N_ACTIONS); a GameMove on an occupied cell has 0."""
        states = np.atleast_2d(states)
        probs = self.class_proba(states) @ self._to_actions
        occupied = (states[:, self.layout.robot_cells] + states[:, self.layout.person_cells]) > 0
        probs[:, :N_CELLS] = np.where(occupied, 0.0, probs[:, :N_CELLS])
        return probs


def action_mask(
    probs: np.ndarray, board: Board, robot_to_move: bool, threshold: float
) -> np.ndarray:
    """The actions offered in a state: Pr(a|s) > threshold, and all valid GameMoves if any is.

    A GameMove is valid only on an empty cell while it is the robot's turn; the person's move is
    asked for only on their turn (on its own the robot draws; a game won has no next move); the
    feedback says the game's real outcome, once it is over. Where the learnt model offered only
    acts these rules forbid, what carries the game on is offered instead: the robot's moves,
    asking for the person's, the right feedback (words heard as a move with nothing drawn once
    left only "it's a draw" mid-game). If nothing passes the threshold, the most likely act that
    can be done is offered, so the set is never empty.
    """
    offered = probs > threshold
    valid_moves = np.array([c == EMPTY for c in board]) & robot_to_move
    offered[:N_CELLS] = valid_moves if offered[:N_CELLS].any() else False
    ending = outcome(board)
    forbidden = _WRONG_FEEDBACK[ending].copy()
    forbidden[_ASKS_FOR_A_MOVE] = robot_to_move or ending is not None
    if (offered & forbidden).any():
        offered &= ~forbidden
        if not offered.any():
            offered[:N_CELLS] = valid_moves
            offered[_ASKS_FOR_A_MOVE] = ending is None and not robot_to_move
            if ending is not None:
                offered |= _FEEDBACK_FOR[ending]
    if not offered.any():
        can_do = np.r_[valid_moves, np.ones(N_ACTIONS - N_CELLS, dtype=bool)] & ~forbidden
        offered[int(np.argmax(np.where(can_do, probs, -1.0)))] = True
    return offered


_FEEDBACK_FOR = {
    ending: np.array([a == act for a in SYSTEM_ACTS]) for ending, act in FEEDBACK_ACTS.items()
}
_WRONG_FEEDBACK: dict[str | None, np.ndarray] = {
    ending: np.logical_or.reduce([f for e, f in _FEEDBACK_FOR.items() if e != ending])
    for ending in (None, *FEEDBACK_ACTS)
}
"""The feedback acts that would not say the game's real outcome (None: the game goes on)."""
_ASKS_FOR_A_MOVE = SYSTEM_ACTS.index(MOVE_REQUEST)


__all__ = ["ACTION_INDEX", "ActionModel", "act_class", "action_mask", "seed_examples"]
