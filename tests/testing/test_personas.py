"""The pieces of the whole-conversation harness (bench/bench_conversations.py): its phrasings
are not the project's own, each persona answers as its kind of person would, the judge finds
every way a conversation can go against the person, and a room mixes at the SNR it says."""

from pathlib import Path

import numpy as np
import pytest

from oxbot.dialogue.domain import (
    ACCEPT,
    AFTER_ALL,
    ANSWER,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    GRANT_REFUSAL,
    INVITATION,
    MOVE_REQUEST,
    OFFER_ANOTHER,
    STOP,
    STOP_QUESTION,
    YES_QUESTION,
    load_domain,
    words_of,
)
from oxbot.errors import DataError
from oxbot.speech.audio import RATE
from oxbot.testing.personas import (
    FAMILIES,
    PERSONAS,
    YES,
    Conversation,
    Game,
    Persona,
    Reply,
    judge,
    read_phrasings,
)
from oxbot.testing.rooms import SPEECH_DBFS, Room, level_dbfs

PHRASINGS = Path(__file__).resolve().parents[2] / "bench" / "data" / "conversation_phrasings.csv"


PLAIN = {family: (family,) for family in FAMILIES}


@pytest.fixture(scope="module")
def phrasings():
    return read_phrasings(PHRASINGS)


def person(kind, phrasings, **kwargs):
    return Persona(kind, phrasings, np.random.default_rng(0), **kwargs)


def test_every_family_has_twenty_phrasings_the_domain_does_not_hold(phrasings):
    known = {words for words, _ in load_domain().user_phrases()}
    assert set(phrasings) == set(FAMILIES)
    for family, texts in phrasings.items():
        fresh = {" ".join(words_of(text)) for text in texts} - known
        assert len(fresh) == len(texts) >= 20, family


def test_a_bad_phrasings_file_says_what_is_wrong(tmp_path):
    bad = tmp_path / "phrasings.csv"
    bad.write_text("family,phrasing\nshrug,whatever\n")
    with pytest.raises(DataError, match="shrug"):
        read_phrasings(bad)
    with pytest.raises(DataError, match="cannot read"):
        read_phrasings(tmp_path / "missing.csv")


def test_who_declines_never_agrees_to_anything(phrasings):
    someone = person("declines", phrasings)
    said = [someone.reply(act) for act in (INVITATION, ASK_AGAIN, AFTER_ALL, MOVE_REQUEST)]
    assert {reply.family for reply in said} == {"decline"}
    assert not someone.consented


def test_the_hesitant_and_the_mind_changer_say_no_then_take_it_back(phrasings):
    for kind, first in (("hesitant", "postpone"), ("changes_mind", "decline")):
        someone = person(kind, phrasings)
        assert someone.reply(INVITATION).family == first
        assert not someone.consented
        assert someone.reply(GRANT_REFUSAL).family == "take_back"
        assert someone.consented
        assert someone.reply(AFTER_ALL).family == "accept"
        assert someone.reply(MOVE_REQUEST) is None  # they draw


def test_was_that_a_yes_is_answered_with_what_the_person_means():
    assert person("keen", PLAIN).reply(YES_QUESTION).family == "accept"
    assert person("declines", PLAIN).reply(YES_QUESTION).family == "decline"
    hesitant = person("hesitant", PLAIN)
    hesitant.reply(INVITATION)
    assert hesitant.reply(YES_QUESTION).family == "postpone"
    asks = person("asks", PLAIN)
    asks.reply(INVITATION)  # a question heard as an unsure yes
    assert asks.reply(YES_QUESTION).family == "accept"


def test_the_stopper_stops_at_their_move_and_confirms_it(phrasings):
    someone = person("stopper", phrasings, stop_at=2)
    assert someone.reply(INVITATION).family == "accept"
    assert someone.reply(MOVE_REQUEST) is None
    assert someone.reply(MOVE_REQUEST).family == "stop"
    assert someone.reply(STOP_QUESTION).family == "confirm_yes"
    assert someone.reply(MOVE_REQUEST).family == "stop"  # asked again: stops again
    keen = person("keen", phrasings)
    keen.reply(INVITATION)
    assert keen.reply(STOP_QUESTION).family == "carry_on"  # a misheard stop


def test_the_keen_play_again_once_when_they_want_a_rematch(phrasings):
    again = person("keen", phrasings, rematch=True)
    assert again.reply(INVITATION).family == "accept"
    assert again.reply(OFFER_ANOTHER).family == "rematch"
    assert again.reply(OFFER_ANOTHER).family == "farewell"
    assert person("keen", phrasings).reply(OFFER_ANOTHER).family == "farewell"


def test_who_asks_asks_first_then_answers_the_question_again(phrasings):
    kinds = set()
    for seed in range(8):
        someone = Persona("asks", phrasings, np.random.default_rng(seed))
        kinds.add(someone.reply(INVITATION).family)
        assert someone.reply(ANSWER).family == "accept"  # the aside answered: the question stands
    assert kinds == {"repeat", "off_topic"}


def test_the_silent_only_make_noise_or_nothing(phrasings):
    someone = person("silent", phrasings)
    families = {someone.reply(act).family for act in (INVITATION, ASK_AGAIN) * 10}
    assert families == {"noise", "silence"}
    assert someone.reply(CLOSING) is None


def played(persona="keen", moves=(("rob", "middle"), ("usr", "upperleft"))) -> Conversation:
    c = Conversation(persona, said=[Reply("accept", "go on then")], goodbye=True, outcome="win")
    for who, cell in moves:
        if who == "usr":
            c.game.drawn.append(cell)
            c.game.person_moved(cell)
        else:
            c.game.robot_moved(cell)
    return c


WON = (
    ("rob", "middle"),
    ("usr", "upperleft"),
    ("rob", "upperright"),
    ("usr", "lowerright"),
    ("rob", "lowerleft"),
)


def test_a_game_played_as_wanted_is_judged_so():
    c = played(moves=WON)
    c.game.feedback = "win"
    assert judge(c) == []


def test_the_judge_finds_every_way_it_went_wrong():
    c = played(moves=WON)
    c.game.feedback = "loss"
    assert any("named the outcome loss" in w for w in judge(c))
    c = played(moves=WON)
    c.game.feedback, c.goodbye = "win", False
    assert judge(c) == ["no goodbye"]
    c = played(moves=WON)
    c.game.feedback = "win"
    c.game.accepted.append("middleleft")
    assert any("did not draw" in w for w in judge(c))
    c = played(moves=WON)
    c.game.feedback, c.moves_without_consent, c.noise_answered = "win", 1, 2
    assert len(judge(c)) == 2
    assert "0 games played to the end, wanted 1" in judge(played())
    stopper = played("stopper")
    stopper.said.append(Reply("stop", "let's leave it there"))
    assert "the stop was not honoured (ended win)" in judge(stopper)
    stopper.outcome = "stopped"
    assert judge(stopper) == []
    declined = Conversation("declines", goodbye=True, outcome="declined")
    assert judge(declined) == []
    declined.games.append(Game(robot_moves=1))
    assert "a game was played with a person who did not want one" in judge(declined)


def test_a_stopper_whose_game_ended_before_their_stop_wanted_that_game():
    c = played("stopper", moves=WON)
    c.game.feedback = "win"
    assert judge(c) == []  # they never said stop: nothing to honour
    c.outcome = "declined"
    c.games = [Game()]
    assert "0 games played to the end, wanted 1" in judge(c)


def test_a_rematch_asked_for_is_a_second_game_wanted():
    c = played(moves=WON)
    c.game.feedback = "win"
    c.said.append(Reply("rematch", "that was fun let's have another go"))
    assert "1 games played to the end, wanted 2" in judge(c)


def test_flips_are_answers_understood_as_their_opposite():
    c = Conversation("keen")
    c.understood = [("accept", DECLINE), ("decline", ACCEPT), ("accept", ACCEPT), ("stop", STOP)]
    c.understood += [("confirm_yes", ACCEPT), ("repeat", ASK_AGAIN)]
    assert c.flips() == 2
    assert {"accept", "take_back", "rematch"} == YES


def test_every_persona_is_known_and_an_unknown_one_is_refused(phrasings):
    for kind in PERSONAS:
        person(kind, phrasings)
    with pytest.raises(ValueError, match="unknown persona"):
        person("grumpy", phrasings)


@pytest.mark.parametrize("snr", [20.0, 10.0])
def test_a_room_sits_its_snr_below_the_speech(snr):
    rng = np.random.default_rng(1)
    recording = (rng.normal(0, 3000, 3 * RATE)).astype(np.int16)
    speech = (np.sin(np.arange(RATE) / 7) * 9000).astype(np.int16)
    room = Room("test", recording, snr, rng)
    heard = room.around(speech, before=0.5, after=0.5)
    assert len(heard) == 2 * RATE
    room_alone = level_dbfs(heard[: RATE // 2])
    assert room_alone == pytest.approx(SPEECH_DBFS - snr, abs=0.5)
    both = 10 * np.log10(10 ** (SPEECH_DBFS / 10) * (1 + 10 ** (-snr / 10)))  # powers add
    assert level_dbfs(heard[RATE // 2 : RATE // 2 + RATE]) == pytest.approx(both, abs=0.5)


def test_a_quiet_room_is_a_faint_hiss_and_a_loud_one_needs_a_recording():
    quiet = Room("quiet", None, None, np.random.default_rng(0))
    assert level_dbfs(quiet.noise(1.0)) < -60
    with pytest.raises(ValueError, match="needs a recording"):
        Room("10 dB", None, 10.0, np.random.default_rng(0))
