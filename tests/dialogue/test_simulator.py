import numpy as np
import pytest

from oxbot.dialogue.domain import SILENCE, load_domain
from oxbot.dialogue.simulator import UserSimulator
from oxbot.errors import OpponentError
from oxbot.game.board import EMPTY_BOARD, play

DOMAIN = load_domain()


def simulator(**kwargs) -> UserSimulator:
    return UserSimulator(DOMAIN, rng=np.random.default_rng(0), **kwargs)


def test_without_noise_every_word_is_heard_with_full_confidence():
    heard = simulator(asr_noise=0.0).recognize(["yes", "let's", "go"])
    assert heard == (("yes", 1.0), ("let's", 1.0), ("go", 1.0))


@pytest.mark.parametrize("noise", [0.2, 0.6])
def test_noise_drops_substitutes_and_lowers_confidence_at_the_configured_level(noise):
    words = ["pick"] * 4000
    heard = simulator(asr_noise=noise).recognize(words)
    dropped = 1 - len(heard) / len(words)
    assert dropped == pytest.approx(noise / 4, abs=0.03)
    substituted = [c for w, c in heard if w != "pick"]
    assert len(substituted) / len(words) == pytest.approx(noise / 4 * 37 / 38, abs=0.03)
    assert all(0.1 <= c <= 0.6 for c in substituted)
    kept = [c for w, c in heard if w == "pick"]  # (a few are substitutions that hit "pick")
    assert np.quantile(kept, 0.02) >= 1 - noise - 0.01 and max(kept) <= 1.0
    assert np.mean(kept) == pytest.approx(1 - noise / 2, abs=0.03)
    assert all(w in DOMAIN.vocabulary for w, _ in heard)


def test_the_person_sometimes_declines_the_first_invitation_only():
    declined = 0
    for seed in range(200):
        person = UserSimulator(DOMAIN, rng=np.random.default_rng(seed), decline_probability=0.3)
        first = person.respond("Request(playGame)", EMPTY_BOARD, False)
        second = person.respond("Request(playGame)", EMPTY_BOARD, False)
        declined += first.act == "Reject(playGame=no)"
        assert second.act == "Confirm(playGame=yes)"
    assert 40 <= declined <= 80


def test_the_person_sometimes_answers_out_of_turn_instead_of_drawing():
    person = simulator(out_of_turn_probability=0.5)
    answers = [person.respond("Request(userGameMove)", EMPTY_BOARD, True) for _ in range(200)]
    small_talk = [a for a in answers if a.cell is None]
    assert 70 <= len(small_talk) <= 130
    assert {a.act for a in small_talk} <= {"Salutation(greeting)", "Acknowledge"}


def test_the_person_draws_only_on_empty_cells_when_asked_and_it_is_their_turn():
    person = simulator()
    board = EMPTY_BOARD
    for cell in (0, 4, 8, 2):
        board = play(board, cell, 1)
    for _ in range(100):
        answer = person.respond("Request(userGameMove)", board, True)
        if answer.cell is not None:
            assert board[answer.cell] == 0
            assert answer.act == f"GameMove(gridloc={answer.text.split('where=')[1][:-1]})"
    assert person.respond("Request(userGameMove)", board, False).act == SILENCE


@pytest.mark.parametrize(
    "bad,message", [(4, "middle \\(cell 4\\), which is already taken"), (9, "returned 9")]
)
def test_an_opponent_naming_a_taken_or_missing_cell_is_an_opponent_error(bad, message):
    person = UserSimulator(
        DOMAIN, opponent=lambda board: bad, rng=np.random.default_rng(0), out_of_turn_probability=0
    )
    with pytest.raises(OpponentError, match=message):
        person.respond("Request(userGameMove)", play(EMPTY_BOARD, 4, 1), True)
