import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from oxbot.config import DialogueConfig, OxbotConfig, load_config
from oxbot.dialogue import ENV_ID, InteractiveGameEnv, load_policy
from oxbot.dialogue.domain import (
    ACTION_INDEX,
    CLOSING,
    GRANT_REFUSAL,
    GRANT_STOP,
    INTRODUCTION,
    INVITATION,
    LETS_PLAY,
    MOVE_REQUEST,
    N_ACTIONS,
    SYSTEM_ACTS,
)
from oxbot.dialogue.wellformed import SURE_NO, check_dialogue
from oxbot.errors import OpponentError

GREETING = SYSTEM_ACTS.index("Salutation(greeting)")


def say(env, *acts):
    """Step the env through `acts`; the last step's (reward, terminated, info)."""
    for act in acts:
        _, reward, terminated, _, info = env.step(ACTION_INDEX[act])
    return reward, terminated, info


def test_the_env_passes_gymnasiums_checker():
    check_env(InteractiveGameEnv(), skip_render_check=True)
    check_env(InteractiveGameEnv(robot_starts=False, render_mode="ansi"))


def test_the_registered_id_builds_the_same_env():
    env = gymnasium.make(ENV_ID)
    check_env(env.unwrapped)
    assert isinstance(env.unwrapped, InteractiveGameEnv)
    layout = env.unwrapped.layout
    assert env.observation_space.shape == (layout.n_features,)
    assert env.action_space.n == N_ACTIONS == 21


@pytest.mark.parametrize("robot_starts", [True, False])
def test_the_spec_interface_plays_a_whole_dialogue(robot_starts):
    env = InteractiveGameEnv(
        opponent=lambda board: board.index(0), robot_starts=robot_starts, cooperative=True
    )
    obs, info = env.reset(seed=0)
    assert info["action_mask"].dtype == bool and info["action_mask"].shape == (N_ACTIONS,)
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


def test_closing_early_abandons_the_person_with_no_end_reward():
    env = InteractiveGameEnv()
    env.reset(seed=0)
    _, reward, terminated, _, info = env.step(SYSTEM_ACTS.index("Salutation(closing)"))
    assert terminated and info["outcome"] == "abandoned"
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
    env = InteractiveGameEnv(opponent=lambda board: 42, robot_starts=False, cooperative=True)
    _obs, _info = env.reset(seed=0)
    with pytest.raises(OpponentError, match="returned 42"):
        say(env, "Salutation(greeting)", INTRODUCTION, INVITATION, LETS_PLAY, *[MOVE_REQUEST] * 3)


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


def test_a_person_who_declines_is_let_go_with_the_end_reward_of_a_refusal():
    config = load_config(None, ["dialogue.refuse_probability=1", "dialogue.asr_noise=0"])
    env = InteractiveGameEnv(config=config)
    env.reset(seed=0)
    reward, terminated, info = say(env, "Salutation(greeting)", INTRODUCTION, INVITATION)
    assert info.get("person") is None  # not over yet
    reward, terminated, info = say(env, GRANT_REFUSAL, CLOSING)
    assert terminated and info["outcome"] == "declined" and info["person"] == "refuses"
    assert reward > 2.5  # 3 at the end, well formed


def test_a_person_who_declined_walks_away_from_a_game_forced_on_them():
    config = load_config(None, ["dialogue.refuse_probability=1", "dialogue.asr_noise=0"])
    env = InteractiveGameEnv(config=config)
    env.reset(seed=0)
    say(env, "Salutation(greeting)", INTRODUCTION, INVITATION)
    reward, terminated, info = say(env, LETS_PLAY)
    assert terminated and info["outcome"] == "declined"
    assert "starts a game nobody agreed to" in info["walked_away"]
    assert reward < 1  # ill formed, so no end reward
    assert env.state.transcript[-1]["act"] == LETS_PLAY  # no answer: the person left
    problem = check_dialogue(info["transcript"], info["outcome"], info["understood"])
    assert problem is not None and "nobody agreed" in problem


def test_a_person_asked_again_after_a_clear_no_thanks_walks_away():
    quiet = [f"dialogue.{kind}_probability=0" for kind in ("nonsense", "silence", "out_of_turn")]
    config = load_config(None, ["dialogue.refuse_probability=1", "dialogue.asr_noise=0", *quiet])
    env = InteractiveGameEnv(config=config)
    env.reset(seed=0)
    say(env, "Salutation(greeting)", INTRODUCTION)
    _, terminated, _ = say(env, INVITATION)
    act, score = env.state.understood
    assert not terminated and act == "Reject(playGame=no)" and score >= SURE_NO
    _, terminated, info = say(env, INVITATION)
    assert terminated
    assert info["walked_away"] == "asks to play again after a clear no"


def test_a_person_who_says_maybe_later_may_be_asked_once_more_not_twice():
    quiet = [
        f"dialogue.{kind}_probability=0"
        for kind in ("nonsense", "silence", "out_of_turn", "refuse", "early_refusal")
    ]
    config = load_config(None, ["dialogue.decline_probability=1", "dialogue.asr_noise=0", *quiet])
    env = InteractiveGameEnv(config=config)
    env.reset(seed=0)
    say(env, "Salutation(greeting)", INTRODUCTION)
    _, terminated, _ = say(env, INVITATION)
    assert not terminated and env.state.understood[0] == "Reject(playGame=later)"
    _, terminated, _ = say(env, INVITATION)
    assert not terminated and env.state.understood[0] == "Confirm(playGame=yes)"


def test_a_person_who_asks_to_stop_ends_the_dialogue_as_stopped():
    config = load_config(
        None,
        [
            "dialogue.stop_probability=1",
            "dialogue.asr_noise=0",
            *(f"dialogue.{kind}_probability=0" for kind in ("decline", "refuse", "out_of_turn")),
            *(f"dialogue.{kind}_probability=0" for kind in ("nonsense", "silence")),
        ],
    )
    env = InteractiveGameEnv(config=config, robot_starts=False)
    env.reset(seed=0)
    say(env, "Salutation(greeting)", INTRODUCTION, INVITATION, LETS_PLAY)
    for _ in range(8):  # the person draws a few times, then asks to stop
        _, _, info = say(env, MOVE_REQUEST)
        if env.state.transcript[-1]["act"] == "Request(stop)":
            break
        free = [c for c in range(9) if env.board[c] == 0]
        say(env, SYSTEM_ACTS[free[0]])
    reward, _, info = say(env, GRANT_STOP, CLOSING)
    assert info["outcome"] == "stopped" and info["person"] == "stops" and reward > 2.5
