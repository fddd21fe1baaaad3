"""The state the interaction manager sees: word features plus game and dialogue context.

Layout (paper §2.2 "State Space") with the shipped vocabulary of 81 words, 149 features:

    index    name                     value
    0-80     word:<w>, vocabulary     system words of the last response: 1 if present; user
             order                    words of the last answer: the recogniser's confidence in
                                      [0, 1], overriding the system's value on overlap
    81-89    robot:<cell>             1 if the robot's mark is on the cell (row-major)
    90-98    person:<cell>            1 if the person's mark is on the cell
    99       game:robot_to_move       1 while the game is on and it is the robot's turn to draw
                                      (before the first move: 1 if the robot starts)
    100      game:robot_won           1 once the robot has three in a row
    101      game:person_won          1 once the person has three in a row
    102      game:draw                1 once the board is full with no line
    103-116  heard:<user act>         the act the last answer was understood as
                                      (`UserActClassifier`): its score (1 for Unknown)
    117-137  last:<system act>        1 for the robot's last act
    138-141  dialogue:greeted, introduced, invited, gave_feedback
                                      1 once the robot has said that act (any feedback act)
    142      dialogue:acknowledged    1 once it has acknowledged a refusal or a stop
    143      dialogue:asked_twice     1 once it has asked to play (invited, asked again) twice,
                                      a no said before it first asked counting as once
    144-146  person:agreed, refused, stopped
                                      1 once an answer was understood as that (any refusal)
    147      person:no_is_final       1 while asking to play would not let a no go: a clear
                                      no to the question, or a no after asking once more
    148      person:stop_is_final     1 while asking for a move would not let a stop go: two
                                      stops, or one clear, with no yes or drawing since

The paper had 57 features (about 40 words plus game moves); the words, cells and game flags here
are exactly that kind. The word features are reset every turn; the others keep the history
instead (paper: "we kept the game move features as to describe the game state rather than
resetting them at every turn"). oxbot adds the rest for the same reason, and because people
answer in hundreds of ways the words alone cannot tell apart: the understood act and its score,
the robot's own last act (its words vary with its templates), and what the dialogue has been
through — whether the robot introduced itself, gave feedback, asked twice; whether the person
agreed, refused or asked to stop, and whether their no or stop is final, counted as the rules
of a well-formed dialogue count them (`oxbot.dialogue.wellformed`; see docs/deviations.md).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from oxbot.dialogue.domain import (
    ACCEPT,
    FEEDBACK_ACTS,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    N_ACTIONS,
    REFUSALS,
    SILENCE,
    STOP,
    SYSTEM_ACTS,
    UNKNOWN,
    USER_ACTS,
)
from oxbot.errors import DataError
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY,
    N_CELLS,
    ROBOT,
    USER,
    Board,
    symmetries,
    to_move,
    winner,
)

GAME_FLAGS: tuple[str, ...] = (
    "game:robot_to_move",
    "game:robot_won",
    "game:person_won",
    "game:draw",
)
HEARD_ACTS: tuple[str, ...] = tuple(act for act in USER_ACTS if act != SILENCE)
"""The acts the person's last answer can be understood as: one feature each, the
understanding's score for the act it chose (1 for Unknown)."""
SAID_FLAGS: dict[str, tuple[str, ...]] = {
    "dialogue:greeted": (GREETING,),
    "dialogue:introduced": (INTRODUCTION,),
    "dialogue:invited": (INVITATION,),
    "dialogue:gave_feedback": tuple(FEEDBACK_ACTS.values()),
    "dialogue:acknowledged": (GRANT_REFUSAL, GRANT_STOP),
}
"""Context features: 1 once the robot has said one of the acts."""
HEARD_FLAGS: dict[str, tuple[str, ...]] = {
    "person:agreed": (ACCEPT,),
    "person:refused": tuple(REFUSALS),
    "person:stopped": (STOP,),
}
"""Context features: 1 once the person's answer was understood as one of the acts."""
ASKED_TWICE = "dialogue:asked_twice"
"""1 once the robot has asked to play (invited or asked again) twice or more; a no the person
said before the robot first asked counts as one asking, so that a no to the greeting and a no to
the invitation look like two noes to two invitations (the rule: ask once more after a no)."""
FINAL_FLAGS: tuple[str, ...] = ("person:no_is_final", "person:stop_is_final")
"""1 while asking to play (asking for a move) would not let the person's no (stop) go: the
counts the rules of a well-formed dialogue keep, which the flags above cannot tell (one unsure
stop from two)."""
DIALOGUE_FLAGS: tuple[str, ...] = (*SAID_FLAGS, ASKED_TWICE, *HEARD_FLAGS, *FINAL_FLAGS)
_SAID: dict[str, int] = {act: k for k, acts in enumerate(SAID_FLAGS.values()) for act in acts}
_HEARD: dict[str, int] = {
    act: len(SAID_FLAGS) + 1 + k for k, acts in enumerate(HEARD_FLAGS.values()) for act in acts
}


def board_symmetries() -> np.ndarray:
    """The 8 rotations and reflections of the board, as (8, N_CELLS) cell permutations."""
    return np.array(symmetries(), dtype=np.int64)


class EncodableState(Protocol):
    """What `FeatureLayout.encode` reads of a dialogue state (`oxbot.dialogue.state.DialogueState`
    has it all; the layout sits below the state, so it names only what it reads)."""

    @property
    def system_words(self) -> Sequence[str]: ...
    @property
    def heard(self) -> Sequence[tuple[str, float]]: ...
    @property
    def board(self) -> Board: ...
    @property
    def robot_starts(self) -> bool: ...
    @property
    def understood(self) -> tuple[str, float] | None: ...
    @property
    def last_act(self) -> str: ...
    @property
    def said(self) -> set[str]: ...
    @property
    def invitations(self) -> int: ...
    @property
    def refused_unasked(self) -> bool: ...
    @property
    def person_acts(self) -> Sequence[str]: ...
    @property
    def no_is_final(self) -> bool: ...
    @property
    def stop_is_final(self) -> bool: ...


class FeatureLayout:
    """Names and positions of the state features for a given vocabulary."""

    def __init__(self, vocabulary: Sequence[str]) -> None:
        if not vocabulary:
            raise DataError("the vocabulary is empty; the state needs at least one word feature")
        if len(set(vocabulary)) != len(vocabulary):
            raise DataError("the vocabulary lists a word twice; each word is one feature")
        self.vocabulary: tuple[str, ...] = tuple(vocabulary)
        self.word_index: dict[str, int] = {w: i for i, w in enumerate(self.vocabulary)}
        n = len(self.vocabulary)
        self.robot_cells = slice(n, n + N_CELLS)
        self.person_cells = slice(n + N_CELLS, n + 2 * N_CELLS)
        self.flags = slice(self.person_cells.stop, self.person_cells.stop + len(GAME_FLAGS))
        self.heard_acts = slice(self.flags.stop, self.flags.stop + len(HEARD_ACTS))
        self.heard_index = {act: self.heard_acts.start + k for k, act in enumerate(HEARD_ACTS)}
        self.last_acts = slice(self.heard_acts.stop, self.heard_acts.stop + N_ACTIONS)
        self.last_index = {act: self.last_acts.start + k for k, act in enumerate(SYSTEM_ACTS)}
        end = self.last_acts.stop
        self.dialogue_flags = slice(end, end + len(DIALOGUE_FLAGS))
        self.board = slice(self.robot_cells.start, self.flags.stop)
        """The cells and the game flags: all the board says, whoever speaks."""
        self.context = slice(self.flags.start, self.dialogue_flags.stop)
        """Everything but the words and the cells: what the action model reads."""
        self.names: tuple[str, ...] = (
            *(f"word:{w}" for w in self.vocabulary),
            *(f"robot:{c}" for c in CELL_NAMES),
            *(f"person:{c}" for c in CELL_NAMES),
            *GAME_FLAGS,
            *(f"heard:{act}" for act in HEARD_ACTS),
            *(f"last:{act}" for act in SYSTEM_ACTS),
            *DIALOGUE_FLAGS,
        )
        self.n_features = len(self.names)
        self.n_words = n

    def encode(self, state: EncodableState) -> np.ndarray:
        """The feature vector of a dialogue state (see the module docstring)."""
        vector = np.zeros(self.n_features, dtype=np.float32)
        for word in state.system_words:
            i = self.word_index.get(word)
            if i is not None:
                vector[i] = 1.0
        for word, confidence in state.heard:  # the user's words override the system's
            i = self.word_index.get(word)
            if i is not None:
                vector[i] = confidence
        self.encode_game(vector, state.board, state.robot_starts)
        if state.understood is not None:
            act, score = state.understood
            i = self.heard_index.get(act)
            if i is not None:
                vector[i] = 1.0 if act == UNKNOWN else score
        if state.last_act in self.last_index and state.system_words:
            vector[self.last_index[state.last_act]] = 1.0
        flags = vector[self.dialogue_flags]
        for act in state.said:
            k = _SAID.get(act)
            if k is not None:
                flags[k] = 1.0
        flags[len(SAID_FLAGS)] = state.invitations + state.refused_unasked >= 2
        for act in state.person_acts:
            k = _HEARD.get(act)
            if k is not None:
                flags[k] = 1.0
        flags[-2:] = state.no_is_final, state.stop_is_final
        return vector

    def encode_game(self, state: np.ndarray, board: Board, robot_starts: bool) -> None:
        """Write the game-move features of `board` into `state` in place."""
        robot, person, flags = _game_features(tuple(board), bool(robot_starts))
        state[self.robot_cells] = robot
        state[self.person_cells] = person
        state[self.flags][:4] = flags

    def symmetry_permutations(self) -> tuple[np.ndarray, np.ndarray]:
        """(8, n_features) feature and (8, N_ACTIONS) action permutations for the symmetries.

        Under symmetry k a state becomes `state[features[k]]` and an act `a` becomes
        `actions[k][a]`; only the cell features and the GameMoves move.
        """
        cells = board_symmetries()
        features = np.tile(np.arange(self.n_features), (len(cells), 1))
        actions = np.tile(np.arange(N_ACTIONS), (len(cells), 1))
        for k, perm in enumerate(cells):
            features[k, self.robot_cells] = self.robot_cells.start + perm
            features[k, self.person_cells] = self.person_cells.start + perm
            inverse = np.argsort(perm)  # old cell c moves to position inverse[c]
            actions[k, :N_CELLS] = inverse  # the GameMoves are the first acts, one per cell
        return features, actions


@functools.lru_cache(maxsize=1 << 14)  # 3^9 boards x who starts, at most; asked every turn
def _game_features(board: Board, robot_starts: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The robot's cells, the person's cells and the game flags of `board`: the robot to move,
    the robot won, the person won, a draw."""
    cells = np.asarray(board)
    w = winner(board)
    full = EMPTY not in board
    flags = [
        w == EMPTY and not full and to_move(board, robot_starts) == ROBOT,
        w == ROBOT,
        w == USER,
        w == EMPTY and full,
    ]
    return cells == ROBOT, cells == USER, np.array(flags, dtype=np.float32)
