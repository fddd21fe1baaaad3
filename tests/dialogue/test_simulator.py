from collections import Counter

import numpy as np
import pytest

from oxbot.dialogue.domain import (
    ACCEPT,
    DECLINE,
    FEEDBACK_WIN,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
    NEW_GAME,
    POSTPONE,
    REFUSALS,
    SILENCE,
    STOP,
    UNKNOWN,
    load_domain,
)
from oxbot.dialogue.model import shipped_dialogue_model
from oxbot.dialogue.simulator import UserSimulator
from oxbot.errors import OpponentError
from oxbot.game.board import EMPTY_BOARD, play

DOMAIN = load_domain()
UNDERSTANDING = shipped_dialogue_model().understanding


def simulator(seed: int = 0, **kwargs) -> UserSimulator:
    kwargs.setdefault("understanding", UNDERSTANDING)
    return UserSimulator(DOMAIN, rng=np.random.default_rng(seed), **kwargs)


def agreed(person: UserSimulator) -> UserSimulator:
    while person.respond(INVITATION, EMPTY_BOARD, False).act != ACCEPT:
        pass
    return person


def test_without_noise_every_word_is_heard_with_full_confidence():
    heard = simulator(asr_noise=0.0).recognize(["yes", "let's", "go"])
    assert heard == (("yes", 1.0), ("let's", 1.0), ("go", 1.0))


@pytest.mark.parametrize("noise", [0.2, 0.6])
def test_noise_drops_substitutes_and_lowers_confidence_at_the_configured_level(noise):
    words = ["pick"] * 4000
    person = simulator(asr_noise=noise)
    heard = person.recognize(words)
    dropped = 1 - len(heard) / len(words)
    assert dropped == pytest.approx(noise / 4, abs=0.03)
    substituted = [c for w, c in heard if w != "pick"]
    assert len(substituted) / len(words) == pytest.approx(noise / 4, abs=0.03)
    assert all(0.1 <= c <= 0.6 for c in substituted)
    kept = [c for w, c in heard if w == "pick"]  # (a few are substitutions that hit "pick")
    assert np.quantile(kept, 0.02) >= 1 - noise - 0.01 and max(kept) <= 1.0
    assert np.mean(kept) == pytest.approx(1 - noise / 2, abs=0.03)
    phrase_words = {w for text, _ in DOMAIN.user_phrases() for w in text.split()}
    assert {w for w, _ in heard} <= phrase_words  # the recogniser hears the phrasings' words


def test_the_person_says_things_in_many_ways_and_is_understood_as_the_robot_would():
    person = simulator(asr_noise=0.0, decline_probability=0.0)
    answers = [person.respond(INVITATION, EMPTY_BOARD, False) for _ in range(60)]
    assert len({a.text for a in answers}) >= 30  # the phrasings, not one sentence
    for answer in answers:
        assert answer.act == ACCEPT
        reading = UNDERSTANDING.read(answer.text, INVITATION)
        expected = 1.0 if reading.act == UNKNOWN else reading.score
        assert answer.understood == (reading.act, pytest.approx(expected))
    understood = Counter(a.understood[0] for a in answers)
    assert understood[ACCEPT] >= 50 and understood[DECLINE] == 0  # no flips


def test_the_person_declines_once_or_for_good_as_configured():
    kinds, firsts = Counter(), Counter()
    for seed in range(300):
        person = simulator(seed, decline_probability=0.3, refuse_probability=0.2)
        first = person.respond(INVITATION, EMPTY_BOARD, False).act
        second = person.respond(INVITATION, EMPTY_BOARD, False).act
        kinds[person.kind] += 1
        firsts[first in REFUSALS] += 1
        if person.kind == "refuses":
            assert first in REFUSALS and second in REFUSALS
        elif person.kind == "declines once":
            assert first in (DECLINE, POSTPONE) and second == ACCEPT
        else:
            assert first == second == ACCEPT
    assert 40 <= kinds["refuses"] <= 80 and 70 <= kinds["declines once"] <= 110
    assert firsts[True] == kinds["refuses"] + kinds["declines once"]


def test_a_person_who_declines_may_say_no_before_being_asked_and_that_no_counts():
    early = Counter()
    for seed in range(300):
        person = simulator(
            seed, decline_probability=0.3, refuse_probability=0.2, early_refusal_probability=0.5
        )
        greeted = person.respond(GREETING, EMPTY_BOARD, False).act
        introduced = person.respond(INTRODUCTION, EMPTY_BOARD, False).act
        asked = person.respond(INVITATION, EMPTY_BOARD, False).act
        said = [act for act in (greeted, introduced) if act in REFUSALS]
        if person.kind == "agrees":
            assert not said and asked == ACCEPT
            continue
        assert len(said) <= 1  # one no before being asked
        early[bool(said)] += 1
        # for good: "no thanks"; for now: "maybe later"
        no = DECLINE if person.kind == "refuses" else POSTPONE
        assert set(said) <= {no}
        if person.kind == "declines once" and said:
            assert asked == ACCEPT  # the early no was their one no
        else:
            assert asked == no
    assert early[True] == pytest.approx(early[False], abs=0.25 * sum(early.values()))


def test_a_cooperative_person_always_agrees_and_plays():
    for seed in range(50):
        person = simulator(
            seed,
            cooperative=True,
            refuse_probability=1.0,
            stop_probability=1.0,
            nonsense_probability=1.0,
            silence_probability=1.0,
            early_refusal_probability=1.0,
            out_of_turn_probability=0.0,
        )
        assert person.respond(GREETING, EMPTY_BOARD, False).act != DECLINE
        assert person.respond(INVITATION, EMPTY_BOARD, False).act == ACCEPT
        assert person.respond(MOVE_REQUEST, EMPTY_BOARD, True).cell is not None


def test_the_person_may_stop_mid_game_and_asks_to_stop_when_nobody_asked_them():
    person = agreed(simulator(stop_probability=1.0, out_of_turn_probability=0))
    acts = [person.respond(MOVE_REQUEST, EMPTY_BOARD, True).act for _ in range(4)]
    assert STOP in acts and acts[acts.index(STOP) :] == [STOP] * (4 - acts.index(STOP))
    assert person.kind == "stops"
    unasked = simulator(out_of_turn_probability=0)
    assert unasked.respond(MOVE_REQUEST, EMPTY_BOARD, True).act == STOP


def test_a_person_heard_saying_no_or_stop_says_yes_when_the_robot_lets_them_go():
    """Told "Okay, maybe another time" after a yes misheard as a no (or "Okay, let's stop here"
    after a drawing misheard as a stop), a person who wants to play says so; one who said no or
    stop does not."""
    board = play(EMPTY_BOARD, 4, 1)
    for seed in range(20):
        wants = agreed(simulator(seed, asr_noise=0, out_of_turn_probability=0))
        answer = wants.respond(GRANT_REFUSAL, EMPTY_BOARD, False)
        assert answer.act == ACCEPT and answer.understood[0] == ACCEPT, answer
        assert wants.respond(GRANT_STOP, board, True).understood[0] == ACCEPT
        not_asked_yet = simulator(seed, asr_noise=0, decline_probability=0.0)
        assert not_asked_yet.respond(GRANT_REFUSAL, EMPTY_BOARD, False).act == ACCEPT

        refuses = simulator(seed, asr_noise=0, refuse_probability=1.0)
        refuses.respond(INVITATION, EMPTY_BOARD, False)
        assert refuses.respond(GRANT_REFUSAL, EMPTY_BOARD, False).act != ACCEPT
        later = simulator(seed, asr_noise=0, decline_probability=1.0)
        assert later.respond(INVITATION, EMPTY_BOARD, False).act == POSTPONE
        assert later.respond(GRANT_REFUSAL, EMPTY_BOARD, False).act != ACCEPT

        stops = agreed(simulator(seed, asr_noise=0, stop_probability=1.0))
        while stops.respond(MOVE_REQUEST, board, True).act != STOP:
            pass
        assert stops.respond(GRANT_STOP, board, True).act != ACCEPT
        assert wants.respond(GRANT_STOP, EMPTY_BOARD, True).act != ACCEPT  # no game yet


def test_the_person_may_say_nonsense_or_nothing_and_ask_for_a_rematch():
    person = simulator(nonsense_probability=0.5, silence_probability=0.3, rematch_probability=1)
    answers = Counter(person.respond(INVITATION, EMPTY_BOARD, False).act for _ in range(300))
    assert 60 <= answers[SILENCE] <= 120 and 80 <= answers[UNKNOWN] <= 130
    assert person.respond(FEEDBACK_WIN, EMPTY_BOARD, False).act == NEW_GAME


def test_the_person_sometimes_answers_out_of_turn_instead_of_drawing():
    person = agreed(simulator(out_of_turn_probability=0.5))
    answers = [person.respond(MOVE_REQUEST, EMPTY_BOARD, True) for _ in range(200)]
    small_talk = [a for a in answers if a.cell is None]
    assert 70 <= len(small_talk) <= 130
    assert {a.act for a in small_talk} <= {"Salutation(greeting)", "Acknowledge"}


def test_the_person_draws_only_on_empty_cells_when_asked_and_it_is_their_turn():
    person = agreed(simulator())
    board = EMPTY_BOARD
    for cell in (0, 4, 8, 2):
        board = play(board, cell, 1)
    for _ in range(100):
        answer = person.respond(MOVE_REQUEST, board, True)
        if answer.cell is not None:
            assert board[answer.cell] == 0
            assert answer.act == f"GameMove(gridloc={answer.text.split('where=')[1][:-1]})"
    assert person.respond(MOVE_REQUEST, board, False).act == SILENCE


@pytest.mark.parametrize(
    "bad,message", [(4, "middle \\(cell 4\\), which is already taken"), (9, "returned 9")]
)
def test_an_opponent_naming_a_taken_or_missing_cell_is_an_opponent_error(bad, message):
    person = agreed(simulator(opponent=lambda board: bad, out_of_turn_probability=0))
    with pytest.raises(OpponentError, match=message):
        person.respond(MOVE_REQUEST, play(EMPTY_BOARD, 4, 1), True)
