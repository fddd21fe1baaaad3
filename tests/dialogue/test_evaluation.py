import numpy as np
import pytest

from oxbot.config import load_config
from oxbot.dialogue.agent import load_policy
from oxbot.dialogue.evaluation import (
    KEPT_OWN_FAULTS,
    OUTCOMES,
    EvaluationResult,
    check_dialogue,
    evaluate,
    heard_cleanly,
    losing_positions,
    misread_wills,
    wins_against_random,
)
from oxbot.dialogue.wellformed import blame
from oxbot.game import win_probability_vs_random
from oxbot.game.board import EMPTY_BOARD, ROBOT


def sys(act: str, text: str = "") -> dict[str, str]:
    return {"speaker": "sys", "act": act, "text": text}


def usr(act: str, text: str = "") -> dict[str, str]:
    return {"speaker": "usr", "act": act, "text": text}


FIGURE_1 = [
    sys("Salutation(greeting)"),
    sys("Provide(name)"),
    sys("Request(playGame)"),
    usr("Confirm(playGame=yes)"),
    sys("Reply(playGame=yes)"),
    sys("GameMove(gridloc=lowermiddle)"),
    sys("Request(userGameMove)"),
    usr("GameMove(gridloc=middleleft)"),
    sys("GameMove(gridloc=lowerright)"),
    sys("Request(userGameMove)"),
    usr("GameMove(gridloc=middle)"),
    sys("GameMove(gridloc=lowerleft)"),
    sys("Provide(feedback=win)"),
    sys("Salutation(closing)"),
]


def test_the_papers_figure_1_is_well_formed():
    assert check_dialogue(FIGURE_1, "win") is None


@pytest.mark.parametrize(
    "edit,outcome,problem",
    [
        (lambda t: t[1:], "win", "does not greet first"),
        (lambda t: [t[0], *t[2:]], "win", "does not introduce itself"),
        (lambda t: [*t[:2], *t[3:]], "win", "does not invite"),
        (lambda t: [*t[:6], *t[7:]], "win", "does not ask for the person's move"),
        (lambda t: t, "draw", "says Provide(feedback=win) but the outcome is a draw"),
        (lambda t: [*t[:12], *t[13:]], "win", "gives 0 feedback acts"),
        (lambda t: t[:-1], "win", "does not close"),
    ],
)
def test_each_broken_rule_is_caught(edit, outcome, problem):
    assert problem in check_dialogue(edit(FIGURE_1), outcome)


GREETED = [sys("Salutation(greeting)"), sys("Provide(name)"), sys("Request(playGame)")]


@pytest.mark.parametrize(
    "transcript,outcome,problem",
    [
        # let a no go: acknowledge it, say goodbye, play nothing
        (
            [
                *GREETED,
                usr("Reject(playGame=no)"),
                sys("Acknowledge(playGame=no)"),
                sys("Salutation(closing)"),
            ],
            "declined",
            None,
        ),
        (
            [*GREETED, usr("Reject(playGame=no)"), sys("Salutation(closing)")],
            "declined",
            "says goodbye to a no without acknowledging it",
        ),
        # "oh no" after the game answers nothing: the goodbye lets it go (the action model
        # offers nothing but the goodbye there)
        ([*FIGURE_1[:-1], usr("Reject(playGame=no)"), FIGURE_1[-1]], "win", None),
        # but a no to its question after the game is a no like any other
        (
            [
                *FIGURE_1[:-1],
                sys("Request(playGame)"),
                usr("Reject(playGame=no)"),
                FIGURE_1[-1],
            ],
            "win",
            "says goodbye to a no without acknowledging it",
        ),
        (
            [
                *GREETED,
                usr("Reject(playGame=later)"),
                sys("Reply(playGame=yes)"),
                sys("Salutation(closing)"),
            ],
            "declined",
            "starts a game nobody agreed to",
        ),
        # a clear "no thanks" to the question is final
        (
            [
                *GREETED,
                usr("Reject(playGame=no)"),
                sys("Request(repeat)"),
                usr("Reject(playGame=no)"),
                sys("Acknowledge(playGame=no)"),
                sys("Salutation(closing)"),
            ],
            "declined",
            "asks to play again after a clear no",
        ),
        # after a "later", ask once more, never twice
        (
            [
                *GREETED,
                usr("Reject(playGame=later)"),
                sys("Request(playGame)"),
                usr("Confirm(playGame=yes)"),
                *FIGURE_1[4:],
            ],
            "win",
            None,
        ),
        (
            [
                *GREETED,
                usr("Reject(playGame=later)"),
                sys("Request(playGame)"),
                usr("Reject(playGame=later)"),
                sys("Request(repeat)"),
                usr("Reject(playGame=later)"),
                sys("Acknowledge(playGame=no)"),
                sys("Salutation(closing)"),
            ],
            "declined",
            "asks to play again after being told no twice",
        ),
        # a no before being asked: one invitation may follow
        (
            [
                sys("Salutation(greeting)"),
                usr("Reject(playGame=no)"),
                sys("Provide(name)"),
                sys("Request(playGame)"),
                usr("Reject(playGame=no)"),
                sys("Acknowledge(playGame=no)"),
                sys("Salutation(closing)"),
            ],
            "declined",
            None,
        ),
        # asking again about an answer it could not make out does not count
        (
            [
                *GREETED,
                usr("Reject(playGame=later)"),
                sys("Request(playGame)"),
                usr("Unknown"),
                sys("Request(repeat)"),
                sys("Request(repeat)"),
                usr("Confirm(playGame=yes)"),
                *FIGURE_1[4:],
            ],
            "win",
            None,
        ),
        # a "thank you" answers nothing: asking again about it does not count either
        (
            [
                *GREETED,
                usr("Reject(playGame=later)"),
                sys("Request(playGame)"),
                usr("Thank"),
                sys("Request(playGame)"),
                usr("Confirm(playGame=yes)"),
                *FIGURE_1[4:],
            ],
            "win",
            None,
        ),
        # a no acknowledged: the goodbye may follow a further "later"
        (
            [
                *GREETED,
                usr("Reject(playGame=no)"),
                sys("Acknowledge(playGame=no)"),
                usr("Reject(playGame=later)"),
                sys("Salutation(closing)"),
            ],
            "declined",
            None,
        ),
        # ... but not a no said after a yes took the first back
        (
            [
                *GREETED,
                usr("Reject(playGame=later)"),
                sys("Acknowledge(playGame=no)"),
                usr("Confirm(playGame=yes)"),
                sys("Request(repeat)"),
                usr("Reject(playGame=no)"),
                sys("Salutation(closing)"),
            ],
            "declined",
            "says goodbye to a no without acknowledging it",
        ),
        # a game nobody agreed to: the answer was not understood
        (
            [*GREETED, usr("Unknown"), sys("Reply(playGame=yes)"), sys("Salutation(closing)")],
            "loss",
            "starts a game nobody agreed to",
        ),
        # a stop is a stop
        (
            [
                *FIGURE_1[:8],
                usr("Request(stop)"),
                sys("Acknowledge(stop)"),
                sys("Salutation(closing)"),
            ],
            "stopped",
            None,
        ),
        (
            [
                *FIGURE_1[:8],
                usr("Request(stop)"),
                sys("Request(userGameMove)"),
                usr("Request(stop)"),
                sys("Request(userGameMove)"),
                sys("Salutation(closing)"),
            ],
            "stopped",
            "asks for a move again after a clear stop",
        ),
        # never walk away from a person who wanted to play
        (
            [*GREETED, usr("Confirm(playGame=yes)"), sys("Salutation(closing)")],
            "abandoned",
            "walks away from a person who wanted to play",
        ),
        (
            [*FIGURE_1[:8], sys("Salutation(closing)")],
            "abandoned",
            "walks away from an unfinished game",
        ),
    ],
)
def test_the_rules_for_people_who_say_no_stop_or_are_not_understood(transcript, outcome, problem):
    found = check_dialogue(transcript, outcome)
    if problem is None:
        assert found is None
    else:
        assert found is not None and problem in found, found


def test_an_unsure_no_or_stop_may_be_checked_once():
    """Understood with a low score, a no or a stop may be asked about once; twice it is final."""
    no_twice = [
        *GREETED,
        usr("Reject(playGame=no)"),
        sys("Request(repeat)"),
        usr("Reject(playGame=no)"),
        sys("Acknowledge(playGame=no)"),
        sys("Salutation(closing)"),
    ]
    unsure = [1.0] * len(no_twice)
    unsure[3] = 0.4
    assert check_dialogue(no_twice, "declined", scores=unsure) is None
    assert "after a clear no" in check_dialogue(no_twice, "declined", scores=[1.0] * len(no_twice))
    asked_thrice = [*no_twice[:6], sys("Request(repeat)"), *no_twice[6:]]
    unsure_twice = [0.4 if t["speaker"] == "usr" else 1.0 for t in asked_thrice]
    problem = check_dialogue(asked_thrice, "declined", scores=unsure_twice)
    assert "after being told no twice" in problem
    stop = [
        *FIGURE_1[:8],
        usr("Request(stop)"),
        sys("Request(userGameMove)"),
        usr("Request(stop)"),
        sys("Request(userGameMove)"),
        sys("Salutation(closing)"),
    ]
    scores = [0.3 if t["speaker"] == "usr" else 1.0 for t in stop]
    assert "after being asked to stop twice" in check_dialogue(stop, "stopped", scores=scores)
    checked_once = [*stop[:10], sys("Acknowledge(stop)"), sys("Salutation(closing)")]
    assert check_dialogue(checked_once, "stopped", scores=scores[:12]) is None


def test_a_no_or_a_stop_taken_back_with_a_yes_lets_the_game_go_on():
    no_then_yes = [
        *GREETED,
        usr("Reject(playGame=no)"),
        sys("Acknowledge(playGame=no)"),
        usr("Confirm(playGame=yes)"),
        *FIGURE_1[4:],
    ]
    assert check_dialogue(no_then_yes, "win") is None
    asks_instead = [*no_then_yes[:6], sys("Request(playGame)")]
    assert "after a clear no" in check_dialogue(asks_instead, None)
    # "Hi!" heard as "no thanks" before it asked, then "Yes, I want to play": the rule still
    # asks for an invitation before the first move (docs/dialogue.md, "A no or a stop taken back")
    unasked = [*GREETED[:2], usr("Salutation(greeting)"), *no_then_yes[4:]]
    assert "does not invite" in check_dialogue(unasked, "win")

    stop_then_yes = [
        *FIGURE_1[:8],
        usr("Request(stop)"),
        sys("Acknowledge(stop)"),
        usr("Confirm(playGame=yes)"),
        sys("GameMove(gridloc=lowerright)"),
        *FIGURE_1[9:],
    ]
    assert check_dialogue(stop_then_yes, "win") is None
    silent = [*stop_then_yes[:10], *stop_then_yes[11:]]
    assert "goes on playing after the person asked to stop" in check_dialogue(silent, "win")
    # a stop misheard as a yes: going on is against the person's will, and the hearing's fault
    understood = [t["act"] for t in stop_then_yes]
    meant = [*stop_then_yes[:10], usr("Request(stop)"), *stop_then_yes[11:]]
    scores = [1.0] * len(meant)
    problem = check_dialogue(meant, "win", understood, scores)
    assert "goes on playing after the person asked to stop" in problem
    assert blame(problem, meant, understood, scores) == "hearing"


def test_a_move_drawn_after_a_stop_takes_the_stop_back():
    """The drawing on the paper outweighs the words heard with it or before it."""
    drawn_on = [
        *FIGURE_1[:8],
        usr("Request(stop)"),
        sys("Acknowledge(stop)"),
        usr("GameMove(gridloc=middle)"),
        sys("GameMove(gridloc=lowerright)"),
        sys("Request(userGameMove)"),
        usr("GameMove(gridloc=upperleft)"),
        sys("GameMove(gridloc=lowerleft)"),
        sys("Provide(feedback=win)"),
        sys("Salutation(closing)"),
    ]
    assert check_dialogue(drawn_on, "win") is None
    # the words said with the drawing heard as a clear stop: the drawing still wins
    understood = [t["act"] for t in drawn_on]
    understood[10] = "Request(stop)"
    assert check_dialogue(drawn_on, "win", understood, [1.0] * len(drawn_on)) is None
    # without the drawing, asking for a move after the clear stop is a fault
    not_drawn = [*drawn_on[:10], usr("Request(stop)"), *drawn_on[11:]]
    problem = check_dialogue(not_drawn, "win", understood, [1.0] * len(drawn_on))
    assert problem is not None and "stop" in problem


def test_a_drawing_heard_as_a_stop_does_not_turn_a_mishearing_into_the_policys_fault():
    """Read as heard, a drawing stays a drawing: only its words were misheard."""
    meant = [*FIGURE_1[:3], usr("Reject(playGame=no)"), *FIGURE_1[4:]]
    understood = [t["act"] for t in meant]
    understood[3] = "Confirm(playGame=yes)"  # the no heard as a yes: a game nobody agreed to
    understood[7] = "Request(stop)"  # the drawing's words heard as a clear stop
    scores = [1.0] * len(meant)
    problem = check_dialogue(meant, "win", understood, scores)
    assert "starts a game nobody agreed to" in problem
    assert blame(problem, meant, understood, scores) == "hearing"


def test_a_fault_is_blamed_on_hearing_only_when_what_was_understood_excuses_it():
    invited = [sys("Salutation(greeting)"), sys("Provide(name)"), sys("Request(playGame)")]
    later_taken_for_yes = [
        *invited,
        usr("Reject(playGame=later)", "later please"),
        sys("Reply(playGame=yes)"),
    ]
    understood = ["", "", "", "Confirm(playGame=yes)", ""]
    problem = check_dialogue(later_taken_for_yes, None, understood, [1, 1, 1, 0.8, 1])
    assert problem.startswith("starts a game nobody agreed to")
    assert blame(problem, later_taken_for_yes, understood, [1, 1, 1, 0.8, 1]) == "hearing"

    # the same "later", understood as it was meant: starting the game is the policy's mistake
    understood = ["", "", "", "Reject(playGame=later)", ""]
    problem = check_dialogue(later_taken_for_yes, None, understood, [1, 1, 1, 0.8, 1])
    assert blame(problem, later_taken_for_yes, understood, [1, 1, 1, 0.8, 1]) == "policy"

    yes_taken_for_no = [
        *invited,
        usr("Confirm(playGame=yes)", "yes"),
        sys("Acknowledge(playGame=no)"),
        sys("Salutation(closing)"),
    ]
    understood = ["", "", "", "Reject(playGame=no)", "", ""]
    scores = [1, 1, 1, 0.9, 1, 1]
    problem = check_dialogue(yes_taken_for_no, "abandoned", understood, scores)
    assert problem == "walks away from a person who wanted to play"
    assert blame(problem, yes_taken_for_no, understood, scores) == "hearing"

    # asking again after the clear no it understood: its own mistake, whatever was meant
    asks_again = [*yes_taken_for_no[:4], sys("Request(playGame)")]
    problem = check_dialogue(asks_again, None, understood[:5], scores[:5])
    assert "after a clear no" in problem
    assert blame(problem, asks_again, understood[:5], scores[:5]) == "policy"

    # it took the yes for a no, and then heard the yes said again: leaving is its own mistake
    said_again = [*yes_taken_for_no[:5], usr("Confirm(playGame=yes)"), sys("Salutation(closing)")]
    understood = [*understood[:5], "Confirm(playGame=yes)", ""]
    scores = [*scores[:5], 0.9, 1]
    problem = check_dialogue(said_again, "abandoned", understood, scores)
    assert problem == "walks away from a person who wanted to play"
    assert blame(problem, said_again, understood, scores) == "policy"

    # a "take care" after the goodbye heard as a yes came too late to act on
    too_late = [*yes_taken_for_no, usr("Salutation(closing)", "take care")]
    understood = ["", "", "", "Reject(playGame=no)", "", "", "Confirm(playGame=yes)"]
    scores = [1, 1, 1, 0.9, 1, 1, 0.44]
    problem = check_dialogue(too_late, "abandoned", understood, scores)
    assert problem == "walks away from a person who wanted to play"
    assert blame(problem, too_late, understood, scores) == "hearing"

    # a game played badly is never the hearing's fault
    no_feedback = [*FIGURE_1[:12], sys("Salutation(closing)")]
    problem = check_dialogue(no_feedback, "win")
    assert "feedback" in problem
    heard = [t["act"] for t in no_feedback]
    assert blame(problem, no_feedback, heard, [1.0] * len(heard)) == "policy"


def test_the_shipped_policy_never_loses_and_wins_near_the_optimum(ten_thousand_games):
    """Game play, against people who always play a whole game, heard through the noisy ASR:
    the 10,000 games of each condition that the acceptance test below measures."""
    for (opponent, robot_starts), r in ten_thousand_games.items():
        assert r.loss_rate == 0, (opponent, robot_starts, r.summary())
        # Misheard, "well done" can sound like a stop and "oh no" after the game like a
        # refusal to acknowledge: measured 99.5-99.9% well formed.
        assert r.well_formed >= 0.98, r.problems
        assert r.truncated == 0
        if opponent == "random":
            optimum = win_probability_vs_random(EMPTY_BOARD, ROBOT, robot_starts)
            assert r.win_rate >= optimum - 0.02


@pytest.mark.parametrize("cooperative", [True, False])
def test_the_shipped_policy_is_well_formed_when_it_hears_right(cooperative):
    """Every rule kept, with every kind of person, when nothing is misheard."""
    config = load_config(None, ["dialogue.asr_noise=0"])
    policy = load_policy()
    for opponent in ("random", "blocker", "minimax"):
        for robot_starts in (True, False):
            r = evaluate(
                policy.act_batch, opponent, robot_starts, 300, config, 7, cooperative=cooperative
            )
            assert r.loss_rate == 0, (opponent, robot_starts, r.summary())
            assert r.well_formed == 1.0, r.problems


@pytest.mark.parametrize(
    ("kind", "outcomes"),
    [("refuse", {"declined"}), ("stop", {"stopped"}), ("decline", {"win", "draw"})],
)
def test_the_shipped_policy_does_what_the_person_wants(kind, outcomes):
    """Heard cleanly: a person who says "no thanks" is let go, never made to play; one who
    asks to stop is let go; one who says "maybe later" and yes when asked again gets a game."""
    config = heard_cleanly(load_config(), kind)
    policy = load_policy()
    for robot_starts in (True, False):
        r = evaluate(policy.act_batch, "minimax", robot_starts, 200, config, seed=11)
        assert r.well_formed == 1.0, r.problems
        assert r.task_success == 1.0
        got = {k for k in OUTCOMES if getattr(r, f"{k}_rate") > 0}
        assert got <= outcomes, got


def _ten_thousand_games(condition: tuple[str, bool]) -> EvaluationResult:
    import torch

    torch.set_num_threads(1)
    opponent, robot_starts = condition
    policy = load_policy()
    return evaluate(policy.act_batch, opponent, robot_starts, 10_000, seed=2026, cooperative=True)


@pytest.fixture(scope="module")
def ten_thousand_games() -> dict[tuple[str, bool], EvaluationResult]:
    """The shipped policy's 10,000 games against each opponent, from both starts (SPEC §3's
    test), played once for every test that reads them."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    conditions = [(o, s) for o in ("random", "blocker", "minimax") for s in (True, False)]
    # two processes, one a core: the six conditions are independent, the results the same
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        return dict(zip(conditions, pool.map(_ten_thousand_games, conditions), strict=True))


@pytest.mark.slow
def test_acceptance_ten_thousand_games_per_condition(ten_thousand_games):
    for (opponent, robot_starts), r in ten_thousand_games.items():
        assert r.games == 10_000
        assert r.loss_rate == 0, (opponent, robot_starts, r.summary())
        assert r.well_formed >= 0.99, r.problems
        if opponent == "random":
            # within SPEC §3's 1 point of the optimum over 10,000 games (the sampling error
            # is about 0.28 points). The shipped policy's goal, 0.3 points over 20,000 games,
            # is measured outside the suite (docs/dialogue.md): at seed 2026, 0.23 below when
            # the person starts, 0.02 above when the robot does; over these 10,000, 0.33 below.
            optimum = win_probability_vs_random(EMPTY_BOARD, ROBOT, robot_starts)
            assert r.win_rate >= optimum - 0.01, r.summary()


@pytest.mark.parametrize("robot_starts", [True, False])
def test_no_person_can_beat_the_shipped_policy(robot_starts):
    """Every reply to every move, each utterance heard cleanly and through the noisy ASR."""
    policy = load_policy()
    assert losing_positions(policy.act_batch, robot_starts, noisy_variants=20, seed=1) == 0


def test_the_tree_check_finds_a_policy_that_can_be_beaten():
    def first_empty_cell(states, masks):  # offered act with the lowest index: a poor player
        return masks.argmax(axis=1)

    assert losing_positions(first_empty_cell, True, noisy_variants=0) > 0


@pytest.mark.parametrize("robot_starts", [True, False])
def test_the_exact_wins_against_random_reach_the_optimum_only_for_the_solver(robot_starts):
    from oxbot.dialogue.baselines import scripted_policy
    from oxbot.dialogue.model import build_dialogue_model

    optimum = win_probability_vs_random(EMPTY_BOARD, ROBOT, robot_starts)
    solver = scripted_policy(build_dialogue_model(load_config()))
    assert wins_against_random(solver, robot_starts) == pytest.approx(optimum, abs=1e-12)

    def first_empty_cell(states, masks):
        return masks.argmax(axis=1)

    assert wins_against_random(first_empty_cell, robot_starts) < optimum - 0.1


def script_that_asks_instead_of_letting_go(config):
    """The script, but it asks to play where it would let a no go: the mask no longer offers
    asking again after a clear no, so this breaks the rule on purpose."""
    from oxbot.dialogue.baselines import scripted_policy
    from oxbot.dialogue.domain import ACTION_INDEX, GRANT_REFUSAL, INVITATION
    from oxbot.dialogue.model import build_dialogue_model

    script = scripted_policy(build_dialogue_model(config))

    def policy(states, masks):
        acts = script(states, masks)
        return np.where(acts == ACTION_INDEX[GRANT_REFUSAL], ACTION_INDEX[INVITATION], acts)

    return policy


def test_misread_wills_catches_a_script_that_asks_again_after_no_thanks():
    config = load_config()
    assert misread_wills(script_that_asks_instead_of_letting_go(config), config, 50) > 0


def test_the_policys_own_faults_are_kept_whole_to_read():
    config = load_config()
    policy = script_that_asks_instead_of_letting_go(config)
    r = evaluate(policy, "random", True, 60, heard_cleanly(config, "refuse"), seed=0)
    assert r.policy_faults > 0
    assert len(r.own_faults) == min(r.policy_faults, KEPT_OWN_FAULTS)
    fault = r.own_faults[0]
    assert "asks to play again" in fault["problem"] and fault["person"] == "refuses"
    assert len(fault["understood"]) == len(fault["scores"]) == len(fault["transcript"])
    assert "own_faults" not in r.summary() and "transcripts" not in r.summary()


def test_the_times_asked_again_and_the_rewards_spread_are_counted_per_dialogue():
    from oxbot.dialogue.baselines import load_manager

    config = load_config(None, ["dialogue.asr_noise=0.6"])
    manager = load_manager("rules", config)
    result = evaluate(manager.act_batch, "random", True, 60, config, seed=3, keep_transcripts=60)
    asked = [
        sum(t["speaker"] == "sys" and t["act"] == "Request(repeat)" for t in transcript)
        for transcript in result.transcripts
    ]
    assert len(asked) == 60 and sum(asked) > 0  # at this much mishearing it does ask again
    assert result.asked_again == pytest.approx(sum(asked) / 60)
    assert result.reward_std > 0
