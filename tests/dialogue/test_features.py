import numpy as np
import pytest

from oxbot.dialogue.features import FeatureLayout, board_symmetries
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.errors import DataError
from oxbot.game.board import EMPTY_BOARD, play


def test_layout_is_words_then_cells_then_flags():
    layout = shipped_dialogue_model().layout
    assert layout.n_features == 61 == len(layout.names)
    assert layout.names[:35] == tuple(f"word:{w}" for w in layout.vocabulary)
    assert layout.names[35] == "robot:upperleft" and layout.names[44] == "person:upperleft"
    assert layout.names[53:57] == (
        "game:robot_to_move",
        "game:robot_won",
        "game:person_won",
        "game:draw",
    )
    assert layout.names[57:] == (
        "dialogue:greeted",
        "dialogue:introduced",
        "dialogue:invited",
        "dialogue:gave_feedback",
    )


def test_user_words_carry_confidence_and_override_system_words():
    layout = FeatureLayout(("yes", "i", "won", "okay"))
    state = layout.encode(["yes", "i", "won"], [("yes", 0.4), ("okay", 0.9)], EMPTY_BOARD, True)
    assert state[:4].tolist() == pytest.approx([0.4, 1.0, 1.0, 0.9])


def test_game_features_keep_the_board_and_its_result():
    layout = FeatureLayout(("hello",))
    board = EMPTY_BOARD
    for cell, player in ((0, 1), (4, 2), (1, 1), (8, 2), (2, 1)):
        board = play(board, cell, player)
    state = layout.encode([], [], board, robot_starts=True, said=["Provide(feedback=win)"])
    assert state[layout.robot_cells].tolist() == [1, 1, 1, 0, 0, 0, 0, 0, 0]
    assert state[layout.person_cells].tolist() == [0, 0, 0, 0, 1, 0, 0, 0, 1]
    assert state[layout.flags].tolist() == [0, 1, 0, 0]  # robot won, nobody to move
    assert state[layout.dialogue_flags].tolist() == [0, 0, 0, 1]
    person_first = layout.encode([], [], EMPTY_BOARD, robot_starts=False)
    assert person_first[layout.flags.start] == 0
    assert layout.encode([], [], EMPTY_BOARD, robot_starts=True)[layout.flags.start] == 1


def test_symmetries_move_cells_and_game_moves_together():
    layout = shipped_dialogue_model().layout
    features, actions = layout.symmetry_permutations()
    assert len({tuple(p) for p in board_symmetries()}) == 8
    board = play(EMPTY_BOARD, 0, 1)  # robot in the upper left corner
    state = layout.encode([], [], board, True)
    for k in range(8):
        moved = state[features[k]]
        corner = int(np.flatnonzero(moved[layout.robot_cells])[0])
        assert corner == actions[k][0]  # "draw in the upper left" became "draw there"
        assert corner in (0, 2, 6, 8)
        assert moved.sum() == state.sum()


def test_an_empty_vocabulary_is_refused():
    with pytest.raises(DataError, match="vocabulary is empty"):
        FeatureLayout(())
