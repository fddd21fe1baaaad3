import numpy as np
import pytest

from oxbot.dialogue.action_model import ActionModel, act_class, action_mask, seed_examples
from oxbot.dialogue.domain import (
    ACCEPT,
    ACTION_INDEX,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    GAME_MOVE_TEMPLATE,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    LETS_PLAY,
    MOVE_REQUEST,
    N_ACTIONS,
    STOP,
    SYSTEM_ACTS,
    UNKNOWN,
)
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.game.board import EMPTY_BOARD, play


def state_after(acts_and_answers, board=EMPTY_BOARD, robot_starts=True):
    """A dialogue state after the robot's acts and the person's understood answers."""
    state = shipped_dialogue_model().new_state(robot_starts)
    for act, answer in acts_and_answers:
        state.robot_says(act, shipped_dialogue_model().domain.templates_for(act)[0])
        if answer is not None:
            # an answer, or (answer, the score it was understood with)
            answer, score = answer if isinstance(answer, tuple) else (answer, 1.0)
            state.person_says(answer, answer, (("x", score),), (answer, score))
    state.board = board
    state._features = None
    return state


def test_probabilities_are_scikit_learns_naive_bayes():
    m = shipped_dialogue_model()
    domain, layout, model = m.domain, m.layout, m.action_model
    states, _ = seed_examples(domain, layout)
    ours = model.class_proba(states)
    sklearn = model.classifier_.predict_proba(states[:, model.columns])
    assert ours == pytest.approx(sklearn, abs=1e-9)


def test_the_model_reproduces_the_seed_dialogues():
    m = shipped_dialogue_model()
    domain, layout, model = m.domain, m.layout, m.action_model
    states, labels = seed_examples(domain, layout)
    predicted = model.classifier_.classes_[model.class_proba(states).argmax(axis=1)]
    differ = {(str(p), q) for p, q in zip(predicted, labels, strict=True) if p != q}
    # the choices the seeds disagree on, left to the policy: after a first "no" ask once more
    # or let the person go; after a yes or a stop it was not sure of, ask again or go on;
    # after "let's stop here" heard a yes (a stop misheard or taken back), go on or close
    choices = [
        {"Acknowledge(playGame=no)", "Request(playGame)#again"},
        {"Reply(playGame=yes)", "Request(repeat)"},
        {"Acknowledge(stop)", "Request(userGameMove)#again"},
        {"Request(userGameMove)", "Salutation(closing)"},
    ]
    assert all({p, q} in choices for p, q in differ), differ
    assert "Request(playGame)#again" in labels  # asking again after a "no" is learned apart
    assert act_class("GameMove(gridloc=middle)") == "GameMove"


def test_a_game_move_on_an_occupied_cell_has_probability_zero():
    m = shipped_dialogue_model()
    model = m.action_model
    board = play(play(EMPTY_BOARD, 4, 1), 0, 2)
    steps = [(GREETING, None), (INTRODUCTION, None), (INVITATION, ACCEPT), (LETS_PLAY, None)]
    state = state_after([*steps, (MOVE_REQUEST, GAME_MOVE_TEMPLATE)], board).encode()
    probs = model.predict_proba(state)[0]
    assert probs[4] == 0 and probs[0] == 0
    assert probs[1] > 0.5  # the robot's turn: a move is likely, on any empty cell alike
    assert np.allclose(probs[[1, 2, 3, 5, 6, 7, 8]], probs[1])


def test_mask_offers_all_valid_moves_when_one_is_offered_and_never_an_occupied_cell():
    board = play(play(EMPTY_BOARD, 4, 1), 0, 2)
    probs = np.zeros(N_ACTIONS)
    probs[2] = 0.5  # one GameMove passes the threshold
    probs[SYSTEM_ACTS.index("Request(userGameMove)")] = 0.0005  # below 0.001: not offered
    probs[SYSTEM_ACTS.index("Provide(name)")] = 0.002
    mask = action_mask(probs, board, robot_to_move=True, threshold=0.001)
    assert mask[:9].tolist() == [False, True, True, True, False, True, True, True, True]
    assert mask[SYSTEM_ACTS.index("Provide(name)")]
    assert not mask[SYSTEM_ACTS.index("Request(userGameMove)")]
    assert not action_mask(probs, board, robot_to_move=False, threshold=0.001)[:9].any()


def test_mask_is_never_empty():
    probs = np.full(N_ACTIONS, 1e-6)
    probs[SYSTEM_ACTS.index("Salutation(closing)")] = 2e-6
    mask = action_mask(probs, EMPTY_BOARD, robot_to_move=False, threshold=0.001)
    assert mask.sum() == 1 and mask[SYSTEM_ACTS.index("Salutation(closing)")]


def test_threshold_follows_the_paper():
    m = shipped_dialogue_model()
    model = m.action_model
    probs = model.predict_proba(m.new_state(True).encode())[0]
    mask = action_mask(probs, EMPTY_BOARD, True, 0.001)
    assert mask.tolist() == (probs > 0.001).tolist()
    assert SYSTEM_ACTS[int(np.argmax(probs))] == "Salutation(greeting)"
    assert isinstance(model, ActionModel)


def test_the_memoised_mask_is_the_same_as_computing_it():
    from oxbot.dialogue.env import InteractiveGameEnv

    env = InteractiveGameEnv(opponent="blocker")
    m = shipped_dialogue_model()
    layout, model = m.layout, m.action_model
    obs, info = env.reset(seed=4)
    rng = np.random.default_rng(0)
    for _ in range(300):
        probs = model.predict_proba(obs)[0]
        robot_to_move = bool(obs[layout.flags.start])
        assert np.allclose(env.action_probabilities, probs)
        memoised = model.offered(obs, env.board, robot_to_move)[1]
        assert (memoised == action_mask(probs, env.board, robot_to_move, 0.001)).all()
        obs, _, terminated, truncated, info = env.step(
            int(rng.choice(np.flatnonzero(info["action_mask"])))
        )
        if terminated or truncated:
            obs, info = env.reset()


def test_after_a_first_unsure_no_the_mask_offers_asking_once_more_and_letting_go():
    m = shipped_dialogue_model()
    state = state_after(
        [(GREETING, None), (INTRODUCTION, None), (INVITATION, ("Reject(playGame=no)", 0.44))]
    )
    _, mask = state.offered()
    offered = {SYSTEM_ACTS[i] for i in np.flatnonzero(mask)}
    assert {"Request(playGame)", "Acknowledge(playGame=no)"} <= offered
    # a clear no is final: only letting go
    clear = state_after(
        [(GREETING, None), (INTRODUCTION, None), (INVITATION, ("Reject(playGame=no)", 0.9))]
    )
    assert offered_acts(clear.offered()[1]) == {"Acknowledge(playGame=no)"}
    assert "Reply(playGame=yes)" not in offered and not mask[:9].any()
    assert m.action_model.threshold == 0.001


def test_a_no_heard_after_a_yes_means_no_game_is_offered_until_another_yes():
    """Found in the simulator: a yes heard unsure, asked again, then "later": the policy drew
    (`DialogueState.agreed` took any yes ever heard)."""
    asked = [(GREETING, None), (INTRODUCTION, None), (INVITATION, ACCEPT)]
    state = state_after([*asked, ("Request(repeat)", "Reject(playGame=later)")])
    _, mask = state.offered()
    assert not state.agreed
    assert not mask[:9].any() and not mask[ACTION_INDEX[LETS_PLAY]]
    state = state_after([*asked, ("Request(repeat)", ACCEPT)])
    assert state.agreed and state.offered()[1][ACTION_INDEX[LETS_PLAY]]


def test_a_yes_heard_before_the_invitation_is_met_with_the_invitation():
    """ "Hi!" heard as a no, then "Yes, I want to play.": the learnt mask offered only "let's
    play", and the game began without the invitation the rules ask for."""
    state = state_after([(GREETING, "Reject(playGame=no)"), ("Acknowledge(playGame=no)", ACCEPT)])
    offered = {SYSTEM_ACTS[i] for i in np.flatnonzero(state.offered()[1])}
    assert offered == {INVITATION}
    invited = state_after([(GREETING, None), (INTRODUCTION, None), (INVITATION, ACCEPT)])
    assert invited.offered()[1][ACTION_INDEX[LETS_PLAY]]
    # the person starts: "your turn" would start the game uninvited just the same
    early = state_after([(GREETING, None), (INTRODUCTION, ACCEPT)], robot_starts=False)
    assert not early.offered()[1][ACTION_INDEX[MOVE_REQUEST]]
    assert early.offered()[1][ACTION_INDEX[INVITATION]]


def test_after_a_no_or_stop_taken_back_the_mask_offers_to_play_on():
    let_go = [(GREETING, None), (INTRODUCTION, None), (INVITATION, "Reject(playGame=no)")]
    state = state_after([*let_go, ("Acknowledge(playGame=no)", ACCEPT)])
    offered = {SYSTEM_ACTS[i] for i in np.flatnonzero(state.offered()[1])}
    assert "Reply(playGame=yes)" in offered

    board = play(play(EMPTY_BOARD, 4, 1), 0, 2)
    playing = [(GREETING, None), (INTRODUCTION, None), (INVITATION, ACCEPT), (LETS_PLAY, None)]
    playing += [("GameMove(gridloc=middle)", None), (MOVE_REQUEST, "Request(stop)")]
    state = state_after([*playing, ("Acknowledge(stop)", ACCEPT)], board)
    offered = {SYSTEM_ACTS[i] for i in np.flatnonzero(state.offered()[1])}
    # playing on is the robot's move here (its turn), or the goodbye
    assert "Salutation(closing)" in offered and MOVE_REQUEST not in offered, offered
    assert any(act.startswith("GameMove") for act in offered), offered


def test_answers_the_robot_asked_again_about_count_for_nothing():
    """ "Go for it" understood unsure, "Pardon?", silence: the robot started the game on the
    answer it had just said it did not catch. A no or a stop it asked again about is not
    acknowledged either: the robot asks again."""
    asked = [(GREETING, None), (INTRODUCTION, None)]
    state = state_after([*asked, (INVITATION, ACCEPT), (ASK_AGAIN, None)])
    _, mask = state.offered()
    assert not state.agreed and state.counted_answers == []
    assert not mask[:9].any() and not mask[ACTION_INDEX[LETS_PLAY]]
    assert not mask[ACTION_INDEX[MOVE_REQUEST]] and mask[ACTION_INDEX[ASK_AGAIN]]
    # a new yes after it counts
    state = state_after([*asked, (INVITATION, ACCEPT), (ASK_AGAIN, ACCEPT)])
    assert state.agreed and state.offered()[1][ACTION_INDEX[LETS_PLAY]]

    refused = state_after([*asked, (INVITATION, DECLINE)])
    assert refused.offered()[1][ACTION_INDEX[GRANT_REFUSAL]]  # the no itself is let go
    state = state_after([*asked, (INVITATION, DECLINE), (ASK_AGAIN, None)])
    assert not state.offered()[1][ACTION_INDEX[GRANT_REFUSAL]]

    board = play(play(EMPTY_BOARD, 4, 1), 0, 2)
    playing = [*asked, (INVITATION, ACCEPT), (LETS_PLAY, None), ("GameMove(gridloc=middle)", None)]
    stopped = state_after([*playing, (MOVE_REQUEST, STOP)], board)
    assert stopped.offered()[1][ACTION_INDEX[GRANT_STOP]]
    state = state_after([*playing, (MOVE_REQUEST, STOP), (ASK_AGAIN, None)], board)
    assert not state.offered()[1][ACTION_INDEX[GRANT_STOP]]


def test_after_acting_on_an_answer_asking_again_is_not_offered_until_the_person_speaks():
    """Found in the simulator: the person drew, with words heard as nothing it knew, and the
    robot said "Sorry, I didn't catch that. Shall we play?" about a move it had taken."""
    m = shipped_dialogue_model()
    asked = [(GREETING, None), (INTRODUCTION, None), (INVITATION, ACCEPT), (LETS_PLAY, None)]
    state = state_after([*asked, (MOVE_REQUEST, None)], robot_starts=False)
    state.person_says("GameMove(gridloc=upperleft)", "over to you", (("over", 1.0),), (UNKNOWN, 1))
    learnt = m.action_model.offered(state.encode(), state.board, state.robot_to_move)[1]
    assert learnt[ACTION_INDEX[ASK_AGAIN]]  # what the learnt mask alone offered
    assert state.acted_on_answer and not state.offered()[1][ACTION_INDEX[ASK_AGAIN]]
    state.person_says(UNKNOWN, "what time is it", (("what", 1.0),), (UNKNOWN, 1.0))
    assert not state.acted_on_answer  # words it has not acted on: it may ask about them


def offered_acts(mask: np.ndarray) -> set[str]:
    return {SYSTEM_ACTS[i] for i in np.flatnonzero(mask)}


def test_a_no_or_a_stop_heard_is_let_go_as_the_robot_understood_it():
    """Found with people who decline often and are heard badly, about one dialogue in 5,000: a
    third "Pardon?" after two unsure noes, and a goodbye straight after a stop heard."""
    greeted = [(GREETING, None), (INTRODUCTION, None)]
    twice = state_after([*greeted, (INVITATION, (DECLINE, 0.44)), (ASK_AGAIN, (DECLINE, 0.38))])
    learnt = twice.action_model.offered(twice.encode(), twice.board, twice.robot_to_move)[1]
    assert learnt[ACTION_INDEX[INVITATION]]  # what the learnt mask alone offered
    offered = offered_acts(twice.offered()[1])
    assert ASK_AGAIN not in offered and INVITATION not in offered, offered
    assert GRANT_REFUSAL in offered
    once = state_after([*greeted, (INVITATION, (DECLINE, 0.44))])  # one unsure no: ask once more
    assert {ASK_AGAIN, INVITATION} & offered_acts(once.offered()[1])

    stopped = state_after([*greeted, (INVITATION, (DECLINE, 0.9)), (GRANT_REFUSAL, (STOP, 0.3))])
    learnt = stopped.action_model.offered(stopped.encode(), stopped.board, False)[1]
    assert learnt[ACTION_INDEX[CLOSING]]
    assert offered_acts(stopped.offered()[1]) == {GRANT_STOP}
    # acknowledged, the goodbye may follow
    state = state_after([*greeted, (INVITATION, (DECLINE, 0.9)), (GRANT_REFUSAL, (STOP, 0.3))])
    state.robot_says(GRANT_STOP, "Okay.")
    assert CLOSING in offered_acts(state.offered()[1])
