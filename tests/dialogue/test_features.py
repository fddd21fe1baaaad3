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
from oxbot.game.board import EMPTY_BOARD, ROBOT, USER, play


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


def test_the_final_flags_say_when_asking_again_would_break_the_rules():
    # random dialogues of questions, move requests, noes, stops, yeses and drawings: before
    # every question to play (request for a move) the flag says whether the checker will call
    # it a no (a stop) not let go
    from oxbot.dialogue.domain import (
        ASK_AGAIN,
        CLOSING,
        FEEDBACK_WIN,
        GRANT_REFUSAL,
        GRANT_STOP,
        LETS_PLAY,
        MOVE_REQUEST,
        POSTPONE,
        game_move,
    )
    from oxbot.dialogue.wellformed import ignores_the_person

    layout = shipped_dialogue_model().layout
    robot_acts = (INVITATION, ASK_AGAIN, MOVE_REQUEST, GRANT_REFUSAL, GRANT_STOP, FEEDBACK_WIN)
    answers = (ACCEPT, DECLINE, POSTPONE, STOP, UNKNOWN, CLOSING, "draw")
    rng = np.random.default_rng(0)
    checked = {"no": [0, 0], "stop": [0, 0]}
    for _ in range(3_000):
        state = state_of(layout)
        state.robot_says(GREETING, "Hello!")
        state.person_says(ACCEPT, "yes", understood=(ACCEPT, 0.9))
        state.robot_says(LETS_PLAY, "Let's play.")
        for _ in range(8):
            act = robot_acts[rng.integers(len(robot_acts))]
            flagged = {"no": state.no_is_final, "stop": state.stop_is_final}
            state.robot_says(act, "...")
            problem = ignores_the_person(
                state.transcript, state.understood_turns, state.understood_scores
            )
            kind = "no" if act in (INVITATION, ASK_AGAIN) else "stop" if act == MOVE_REQUEST else ""
            if kind:
                broke = problem is not None and (
                    ("no" in problem) if kind == "no" else ("stop" in problem)
                )
                assert broke == flagged[kind], (kind, problem, state.transcript)
                checked[kind][broke] += 1
            if problem is not None:
                break
            answer = answers[rng.integers(len(answers))]
            if answer == "draw":
                empty = [c for c in range(9) if state.board[c] == 0]
                if not empty or not state.person_to_move:
                    continue
                state.person_says(game_move(int(rng.choice(empty))), "(drawn)")
            else:
                state.person_says(answer, "...", understood=(answer, float(rng.random())))
    assert min(min(counts) for counts in checked.values()) >= 50, checked


def test_a_person_heard_saying_yes_last_is_not_let_go_before_a_game():
    from oxbot.dialogue.domain import ACTION_INDEX, CLOSING, GRANT_REFUSAL, INTRODUCTION, POSTPONE

    model = shipped_dialogue_model()
    state = DialogueState(model.layout, True, model.action_model)
    state.robot_says(GREETING, "Hello!")
    state.person_says(POSTPONE, "later thanks", understood=(POSTPONE, 0.8))
    state.robot_says(INTRODUCTION, "I am oxbot.")
    state.person_says(UNKNOWN, "oh well", understood=(UNKNOWN, 1.0))
    state.robot_says(INVITATION, "Would you like to play a game?")
    _, mask = state.offered()
    assert mask[ACTION_INDEX[GRANT_REFUSAL]]  # "later" was the last answer: it may be let go
    state.person_says(ACCEPT, "of course", understood=(ACCEPT, 0.24))
    _, mask = state.offered()
    assert not mask[ACTION_INDEX[GRANT_REFUSAL]] and not mask[ACTION_INDEX[CLOSING]]
    assert mask.any()


def test_the_feedback_says_the_real_outcome_and_only_once_the_game_is_over():
    from oxbot.dialogue.domain import (
        ACTION_INDEX,
        FEEDBACK_ACTS,
        GAME_MOVE_TEMPLATE,
        LETS_PLAY,
        MOVE_REQUEST,
        game_move,
    )

    model = shipped_dialogue_model()
    state = DialogueState(model.layout, False, model.action_model)
    state.robot_says(GREETING, "Hi!")
    state.person_says(ACCEPT, "yeah sure", understood=(ACCEPT, 0.62))
    state.robot_says(INVITATION, "Do you want to play a game with me?")
    state.person_says(ACCEPT, "yeah sure", understood=(ACCEPT, 0.62))
    state.robot_says(LETS_PLAY, "Nice, let's play.")
    for person, robot in ((0, 4), (8, 3)):
        state.robot_says(MOVE_REQUEST, "Your move.")
        state.person_says(game_move(person), "there", understood=(GAME_MOVE_TEMPLATE, 0.7))
        state.robot_says(game_move(robot), "Mine.")
    # words heard as a move with nothing drawn: the learnt model offers only "it's a draw"
    state.robot_says(MOVE_REQUEST, "Your turn.")
    state.person_says(GREETING, "hi there", understood=(GAME_MOVE_TEMPLATE, 0.67))
    _, mask = state.offered()
    feedback = [ACTION_INDEX[act] for act in FEEDBACK_ACTS.values()]
    assert not mask[feedback].any() and mask[ACTION_INDEX[MOVE_REQUEST]]
    # a win is a win, not a draw or a loss
    won = state.at((ROBOT, ROBOT, ROBOT, USER, USER, 0, 0, 0, 0))
    _, mask = won.offered()
    assert not mask[[ACTION_INDEX[FEEDBACK_ACTS[e]] for e in ("draw", "loss")]].any()
    assert not mask[ACTION_INDEX[MOVE_REQUEST]]  # a game won has no next move


def test_on_its_own_turn_the_robot_draws_and_does_not_ask_for_a_move():
    from oxbot.dialogue.domain import ACTION_INDEX, LETS_PLAY, MOVE_REQUEST, STOP, game_move

    model = shipped_dialogue_model()
    state = DialogueState(model.layout, True, model.action_model)
    state.robot_says(GREETING, "Hello there!")
    state.robot_says(INVITATION, "Do you want to play a game with me?")
    state.person_says(ACCEPT, "sure i'll play", understood=(ACCEPT, 0.89))
    state.robot_says(LETS_PLAY, "Great, let's play.")
    for robot, person in ((6, 1), (0, 2), (8, 5)):
        state.robot_says(game_move(robot), "Mine.")
        state.robot_says(MOVE_REQUEST, "Your turn.")
        heard = (STOP, 0.5) if person == 1 else (UNKNOWN, 1.0)  # a drawing heard as a stop
        state.person_says(game_move(person), "here", understood=heard)
    _, mask = state.offered()
    assert state.robot_to_move and not mask[ACTION_INDEX[MOVE_REQUEST]] and mask[:9].any()
