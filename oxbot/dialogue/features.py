"""The state the interaction manager sees: word features plus game and dialogue context.

Layout (SPEC §3, paper §2.2 "State Space") with the shipped vocabulary of 35 words, 61 features:

    index  name                     value
    0-34   word:<w>, vocabulary     system words of the last response: 1 if present; user words
           order                    of the last answer: the recogniser's confidence in [0, 1],
                                    overriding the system's value on overlap
    35-43  robot:<cell>             1 if the robot's mark is on the cell (row-major, upper left
                                    first)
    44-52  person:<cell>            1 if the person's mark is on the cell
    53     game:robot_to_move       1 while the game is on and it is the robot's turn to draw
                                    (before the first move: 1 if the robot starts)
    54     game:robot_won           1 once the robot has three in a row
    55     game:person_won          1 once the person has three in a row
    56     game:draw                1 once the board is full with no line
    57     dialogue:greeted         1 once the robot has said Salutation(greeting)
    58     dialogue:introduced      1 once it has said Provide(name)
    59     dialogue:invited         1 once it has said Request(playGame)
    60     dialogue:gave_feedback   1 once it has said a Provide(feedback=...) act

The paper had 57 features (about 40 words plus game moves); the first 57 here are exactly that
kind (35 words, 18 cells, 4 game flags). The word features are reset every turn; the others keep
the history instead (paper: "we kept the game move features as to describe the game state rather
than resetting them at every turn"). oxbot adds the four dialogue flags for the same reason: the
last turn's words cannot tell whether the robot has already introduced itself or given feedback,
and without them no policy can be well formed every time (see docs/deviations.md).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from oxbot.dialogue.domain import (
    FEEDBACK_ACTS,
    GREETING,
    INTRODUCTION,
    INVITATION,
    N_ACTIONS,
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
DIALOGUE_FLAGS: dict[str, tuple[str, ...]] = {
    "dialogue:greeted": (GREETING,),
    "dialogue:introduced": (INTRODUCTION,),
    "dialogue:invited": (INVITATION,),
    "dialogue:gave_feedback": tuple(FEEDBACK_ACTS.values()),
}
"""Context features: 1 once the robot has said one of the acts."""
_FLAG_OF_ACT: dict[str, int] = {
    act: k for k, acts in enumerate(DIALOGUE_FLAGS.values()) for act in acts
}


def board_symmetries() -> np.ndarray:
    """The 8 rotations and reflections of the board, as (8, N_CELLS) cell permutations."""
    return np.array(symmetries(), dtype=np.int64)


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
        self.dialogue_flags = slice(self.flags.stop, self.flags.stop + len(DIALOGUE_FLAGS))
        self.names: tuple[str, ...] = (
            *(f"word:{w}" for w in self.vocabulary),
            *(f"robot:{c}" for c in CELL_NAMES),
            *(f"person:{c}" for c in CELL_NAMES),
            *GAME_FLAGS,
            *DIALOGUE_FLAGS,
        )
        self.n_features = len(self.names)
        self.n_words = n

    def encode(
        self,
        system_words: Iterable[str],
        user_words: Iterable[tuple[str, float]],
        board: Board,
        robot_starts: bool,
        said: Iterable[str] = (),
    ) -> np.ndarray:
        """The state vector after a system response and the user's (heard) response.

        `said` is every system act the robot has said so far in the dialogue.
        """
        state = np.zeros(self.n_features, dtype=np.float32)
        for word in system_words:
            i = self.word_index.get(word)
            if i is not None:
                state[i] = 1.0
        for word, confidence in user_words:  # the user's words override the system's
            i = self.word_index.get(word)
            if i is not None:
                state[i] = confidence
        self.encode_game(state, board, robot_starts)
        for act in said:
            k = _FLAG_OF_ACT.get(act)
            if k is not None:
                state[self.dialogue_flags.start + k] = 1.0
        return state

    def encode_game(self, state: np.ndarray, board: Board, robot_starts: bool) -> None:
        """Write the game-move features of `board` into `state` in place."""
        cells = np.asarray(board)
        state[self.robot_cells] = cells == ROBOT
        state[self.person_cells] = cells == USER
        w = winner(board)
        full = EMPTY not in board
        flags = state[self.flags]
        flags[0] = w == EMPTY and not full and to_move(board, robot_starts) == ROBOT
        flags[1] = w == ROBOT
        flags[2] = w == USER
        flags[3] = w == EMPTY and full

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
