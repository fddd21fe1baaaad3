import numpy as np
import pytest

from oxbot.dialogue.action_model import ActionModel, act_class, action_mask, seed_examples
from oxbot.dialogue.domain import SYSTEM_ACTS
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.game.board import EMPTY_BOARD, play


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
    assert predicted.tolist() == labels
    assert "Request(playGame)#again" in labels  # asking again after a "no" is learned apart
    assert act_class("GameMove(gridloc=middle)") == "GameMove"


def test_a_game_move_on_an_occupied_cell_has_probability_zero():
    m = shipped_dialogue_model()
    layout, model = m.layout, m.action_model
    board = play(play(EMPTY_BOARD, 4, 1), 0, 2)
    said = ["Salutation(greeting)", "Provide(name)", "Request(playGame)"]
    state = layout.encode(["your", "turn"], [("i", 1.0), ("pick", 1.0)], board, True, said)
    probs = model.predict_proba(state)[0]
    assert probs[4] == 0 and probs[0] == 0
    assert probs[1] > 0.5  # the robot's turn: a move is likely, on any empty cell alike
    assert np.allclose(probs[[1, 2, 3, 5, 6, 7, 8]], probs[1])


def test_mask_offers_all_valid_moves_when_one_is_offered_and_never_an_occupied_cell():
    board = play(play(EMPTY_BOARD, 4, 1), 0, 2)
    probs = np.zeros(18)
    probs[2] = 0.5  # one GameMove passes the threshold
    probs[SYSTEM_ACTS.index("Request(userGameMove)")] = 0.0005  # below 0.001: not offered
    probs[SYSTEM_ACTS.index("Provide(name)")] = 0.002
    mask = action_mask(probs, board, robot_to_move=True, threshold=0.001)
    assert mask[:9].tolist() == [False, True, True, True, False, True, True, True, True]
    assert mask[SYSTEM_ACTS.index("Provide(name)")]
    assert not mask[SYSTEM_ACTS.index("Request(userGameMove)")]
    assert not action_mask(probs, board, robot_to_move=False, threshold=0.001)[:9].any()


def test_mask_is_never_empty():
    probs = np.full(18, 1e-6)
    probs[SYSTEM_ACTS.index("Salutation(closing)")] = 2e-6
    mask = action_mask(probs, EMPTY_BOARD, robot_to_move=False, threshold=0.001)
    assert mask.sum() == 1 and mask[SYSTEM_ACTS.index("Salutation(closing)")]


def test_threshold_follows_the_paper():
    m = shipped_dialogue_model()
    layout, model = m.layout, m.action_model
    state = layout.encode([], [], EMPTY_BOARD, True)
    probs = model.predict_proba(state)[0]
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
        assert (info["action_mask"] == action_mask(probs, env.board, robot_to_move, 0.001)).all()
        obs, _, terminated, truncated, info = env.step(
            int(rng.choice(np.flatnonzero(info["action_mask"])))
        )
        if terminated or truncated:
            obs, info = env.reset()
