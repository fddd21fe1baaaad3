import numpy as np
import pytest

from oxbot.dialogue.domain import (
    ACCEPT,
    DECLINE,
    FEEDBACK_WIN,
    GREETING,
    INVITATION,
    N_ACTIONS,
    STOP,
    SYSTEM_ACTS,
    UNKNOWN,
)
from oxbot.dialogue.features import DIALOGUE_FLAGS, HEARD_ACTS, FeatureLayout, board_symmetries
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.dialogue.state import DialogueState
from oxbot.errors import DataError
from oxbot.game.board import EMPTY_BOARD, play


def state_of(layout, robot_starts=True) -> DialogueState:
    return DialogueState(layout, robot_starts)


def test_layout_is_words_cells_game_flags_heard_acts_last_acts_then_dialogue_flags():
    layout = shipped_dialogue_model().layout
    n = len(layout.vocabulary)
    assert layout.n_features == n + 18 + 4 + len(HEARD_ACTS) + N_ACTIONS + len(DIALOGUE_FLAGS)
    assert layout.names[:n] == tuple(f"word:{w}" for w in layout.vocabulary)
    assert layout.names[n] == "robot:upperleft" and layout.names[n + 9] == "person:upperleft"
    assert layout.names[layout.flags] == (
        "game:robot_to_move",
        "game:robot_won",
        "game:person_won",
        "game:draw",
    )
    assert layout.names[layout.heard_acts][0] == "heard:Salutation(greeting)"
    assert layout.names[layout.last_acts] == tuple(f"last:{a}" for a in SYSTEM_ACTS)
    assert layout.names[layout.dialogue_flags][:4] == (
        "dialogue:greeted",
        "dialogue:introduced",
        "dialogue:invited",
        "dialogue:gave_feedback",
    )
    assert layout.context == slice(layout.flags.start, layout.n_features)


def test_user_words_carry_confidence_and_override_system_words():
    layout = FeatureLayout(("yes", "i", "won", "okay"))
    state = state_of(layout)
    state.robot_says(FEEDBACK_WIN, "Yes, I won.")
    state.person_says(ACCEPT, "yes okay", (("yes", 0.4), ("okay", 0.9)), (ACCEPT, 0.7))
    vector = state.encode()
    assert vector[:4].tolist() == pytest.approx([0.4, 1.0, 1.0, 0.9])
    assert vector[layout.heard_index[ACCEPT]] == pytest.approx(0.7)  # the understanding's score
    assert vector[layout.last_index[FEEDBACK_WIN]] == 1


def test_what_was_not_understood_is_heard_as_unknown_whatever_its_score():
    layout = FeatureLayout(("hello",))
    state = state_of(layout)
    state.person_says(UNKNOWN, "purple elephants", (("purple", 0.9),), (UNKNOWN, 0.0))
    assert state.encode()[layout.heard_index[UNKNOWN]] == 1


def test_game_features_keep_the_board_and_its_result():
    layout = FeatureLayout(("hello",))
    state = state_of(layout)
    for cell, player in ((0, 1), (4, 2), (1, 1), (8, 2), (2, 1)):
        state.board = play(state.board, cell, player)
    state.robot_says(FEEDBACK_WIN, "Yes, I won.")
    vector = state.encode()
    assert vector[layout.robot_cells].tolist() == [1, 1, 1, 0, 0, 0, 0, 0, 0]
    assert vector[layout.person_cells].tolist() == [0, 0, 0, 0, 1, 0, 0, 0, 1]
    assert vector[layout.flags].tolist() == [0, 1, 0, 0]  # robot won, nobody to move
    assert vector[layout.dialogue_flags][:4].tolist() == [0, 0, 0, 1]
    assert state_of(layout, robot_starts=False).encode()[layout.flags.start] == 0
    assert state_of(layout, robot_starts=True).encode()[layout.flags.start] == 1


def test_the_dialogue_flags_remember_invitations_and_what_the_person_said():
    layout = FeatureLayout(("hello",))
    flags = dict.fromkeys(DIALOGUE_FLAGS)
    state = state_of(layout)
    state.robot_says(GREETING, "Hello!")
    state.robot_says(INVITATION, "Would you like to play?")
    state.person_says(DECLINE, "no", (("no", 1.0),), (DECLINE, 0.9))
    read = dict(zip(flags, state.encode()[layout.dialogue_flags].tolist(), strict=True))
    assert read["dialogue:greeted"] == read["dialogue:invited"] == read["person:refused"] == 1
    assert read["dialogue:asked_twice"] == read["person:agreed"] == read["person:stopped"] == 0
    state.robot_says(INVITATION, "Shall we play noughts and crosses?")
    state.person_says(STOP, "stop", (("stop", 1.0),), (STOP, 0.9))
    read = dict(zip(flags, state.encode()[layout.dialogue_flags].tolist(), strict=True))
    assert read["dialogue:asked_twice"] == read["person:stopped"] == 1


def test_a_no_before_the_first_invitation_counts_as_one_asking():
    layout = FeatureLayout(("hello",))
    asked_twice = layout.dialogue_flags.start + DIALOGUE_FLAGS.index("dialogue:asked_twice")
    state = state_of(layout)
    state.robot_says(GREETING, "Hello!")
    state.person_says(DECLINE, "no thanks", (("no", 1.0), ("thanks", 1.0)), (DECLINE, 0.9))
    assert state.encode()[asked_twice] == 0
    state.robot_says(INVITATION, "Would you like to play?")
    assert state.encode()[asked_twice] == 1  # "no thanks", then asked: as after one no
    answered = state_of(layout)
    answered.robot_says(GREETING, "Hello!")
    answered.robot_says(INVITATION, "Would you like to play?")
    answered.person_says(DECLINE, "no", (("no", 1.0),), (DECLINE, 0.9))
    assert answered.encode()[asked_twice] == 0  # a no to the invitation is no asking


def test_symmetries_move_cells_and_game_moves_together():
    layout = shipped_dialogue_model().layout
    features, actions = layout.symmetry_permutations()
    assert len({tuple(p) for p in board_symmetries()}) == 8
    state = state_of(layout)
    state.board = play(EMPTY_BOARD, 0, 1)  # robot in the upper left corner
    vector = state.encode()
    for k in range(8):
        moved = vector[features[k]]
        corner = int(np.flatnonzero(moved[layout.robot_cells])[0])
        assert corner == actions[k][0]  # "draw in the upper left" became "draw there"
        assert corner in (0, 2, 6, 8)
        assert moved.sum() == vector.sum()


def test_an_empty_vocabulary_is_refused():
    with pytest.raises(DataError, match="vocabulary is empty"):
        FeatureLayout(())
