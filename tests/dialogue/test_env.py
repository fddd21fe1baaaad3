import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from oxbot.config import DialogueConfig, OxbotConfig
from oxbot.dialogue import ENV_ID, InteractiveGameEnv, load_policy
from oxbot.dialogue.domain import SYSTEM_ACTS
from oxbot.errors import OpponentError

GREETING = SYSTEM_ACTS.index("Salutation(greeting)")


def test_the_env_passes_gymnasiums_checker():
    check_env(InteractiveGameEnv(), skip_render_check=True)
    check_env(InteractiveGameEnv(robot_starts=False, render_mode="ansi"))


def test_the_registered_id_builds_the_same_env():
    env = gymnasium.make(ENV_ID)
    check_env(env.unwrapped)
    assert isinstance(env.unwrapped, InteractiveGameEnv)
    assert env.observation_space.shape == (61,) and env.action_space.n == 18


@pytest.mark.parametrize("robot_starts", [True, False])
def test_the_spec_interface_plays_a_whole_dialogue(robot_starts):
    env = InteractiveGameEnv(opponent=lambda board: board.index(0), robot_starts=robot_starts)
    obs, info = env.reset(seed=0)
    assert info["action_mask"].dtype == bool and info["action_mask"].shape == (18,)
    policy = load_policy()
    terminated = truncated = False
    while not (terminated or truncated):
        a = policy.act(obs, info["action_mask"])
        assert info["action_mask"][a]
        obs, _reward, terminated, truncated, info = env.step(a)
        assert env.observation_space.contains(obs)
    assert terminated and info["outcome"] in {"win", "draw", "loss"}
    transcript = info["transcript"]
    assert all(set(t) == {"speaker", "act", "text"} for t in transcript)
    assert {t["speaker"] for t in transcript} == {"sys", "usr"}
    first_move = next(t for t in transcript if t["act"].startswith("GameMove"))
    assert first_move["speaker"] == ("sys" if robot_starts else "usr")
    assert transcript[-1]["act"] == "Salutation(closing)" or transcript[-2]["act"] == (
        "Salutation(closing)"
    )


def test_the_dialogue_is_capped():
    config = OxbotConfig(dialogue=DialogueConfig(max_turns=7))
    env = InteractiveGameEnv(config=config)
    env.reset(seed=1)
    for _turn in range(7):
        _, _, terminated, truncated, info = env.step(GREETING)  # greeting forever
        assert not terminated
    assert truncated and info["outcome"] is None and len(info["transcript"]) >= 7


def test_closing_early_abandons_the_game_as_a_loss_with_no_end_reward():
    env = InteractiveGameEnv()
    env.reset(seed=0)
    _, reward, terminated, _, info = env.step(SYSTEM_ACTS.index("Salutation(closing)"))
    assert terminated and info["outcome"] == "loss"
    assert reward == pytest.approx(0.5 * env_probability_of_closing_at_start() - 0.1)


def env_probability_of_closing_at_start() -> float:
    env = InteractiveGameEnv()
    env.reset(seed=0)
    return float(env.action_probabilities[SYSTEM_ACTS.index("Salutation(closing)")])


def test_a_move_that_cannot_be_drawn_wastes_the_turn():
    env = InteractiveGameEnv(robot_starts=False)
    env.reset(seed=0)
    _obs, reward, _, _, info = env.step(4)  # the person starts: not the robot's turn
    assert info.get("invalid_action") and reward == pytest.approx(-0.1)
    assert env.board == (0,) * 9


def test_a_bad_opponent_is_reported():
    env = InteractiveGameEnv(opponent=lambda board: 42, robot_starts=False)
    _obs, _info = env.reset(seed=0)
    with pytest.raises(OpponentError, match="returned 42"):
        for act in (
            "Salutation(greeting)",
            "Provide(name)",
            "Request(playGame)",
            "Request(playGame)",
            "Request(userGameMove)",
            "Request(userGameMove)",
            "Request(userGameMove)",
        ):
            env.step(SYSTEM_ACTS.index(act))


def test_the_same_seed_gives_the_same_dialogue():
    def run(seed):
        env = InteractiveGameEnv()
        _, info = env.reset(seed=seed)
        rng = np.random.default_rng(3)
        while True:
            a = int(rng.choice(np.flatnonzero(info["action_mask"])))
            _obs, _r, term, trunc, info = env.step(a)
            if term or trunc:
                return info["transcript"]

    assert run(5) == run(5)
    assert run(5) != run(6)
