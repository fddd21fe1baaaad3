"""A conversation, not a form: questions asked in passing are answered in any state, the robot
offers another game after one, and plays it without greeting or introducing itself again."""

import time

import pytest

from oxbot.dialogue.domain import (
    ANSWER,
    CLOSING,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    LETS_PLAY,
    MOVE_REQUEST,
    OFFER_ANOTHER,
    REFUSALS,
    STOP_QUESTION,
    YES_QUESTION,
    is_feedback,
)
from oxbot.dialogue.wellformed import check_dialogue
from oxbot.game.board import EMPTY
from oxbot.robot.manager import Phase
from oxbot.robot.messages import DialogueAct
from oxbot.robot.sentences import (
    AFTER_ALL_SENTENCE,
    HOLD_SENTENCE,
    OFF_TOPIC_SENTENCE,
    STOP_QUESTION_SENTENCE,
    YES_QUESTION_SENTENCE,
)
from tests.robot.helpers import ManagerAtHand


def acts(hand: ManagerAtHand, speaker: str = "sys") -> list[str]:
    return [t["act"] for t in hand.manager.transcript if t["speaker"] == speaker]


def agree(hand: ManagerAtHand) -> None:
    """From the greeting to the game: the person keeps quiet until asked, then says yes."""
    while hand.last_act != INVITATION:
        hand.wait()
    hand.say("yes let's play")


def play_out(hand: ManagerAtHand) -> None:
    """The person draws in the first empty cell each time they are asked, to the end."""
    while not any(is_feedback(a) for a in acts(hand)):
        assert hand.last_act in (MOVE_REQUEST, LETS_PLAY) or hand.last_act.startswith("GameMove")
        if hand.last_act == MOVE_REQUEST:
            hand.draw(hand.manager.board.index(EMPTY))
        else:
            hand.wait()


def to_the_offer(seed: int, robot_starts: bool = True) -> ManagerAtHand:
    """A game agreed to and played out, the feedback unanswered: the robot offers another."""
    hand = ManagerAtHand(robot_starts=robot_starts, seed=seed)
    agree(hand)
    play_out(hand)
    hand.wait()
    assert acts(hand)[-1] == OFFER_ANOTHER and hand.said[-1].endswith("?")
    return hand


def test_the_name_who_starts_and_say_that_again_are_answered_and_the_robot_waits_on():
    hand = ManagerAtHand(robot_starts=False, seed=3)
    assert hand.last_act == GREETING
    hand.say("what's your name?")
    assert hand.said[-1] in ("I am oxbot.", "My name is oxbot.", hand.said[0].split("!")[0])
    assert acts(hand)[-1] == ANSWER and "oxbot" in hand.said[-1]
    assert hand.last_act == GREETING  # the policy's state did not move
    while hand.last_act != INVITATION:
        hand.wait()
    asked = hand.said[-1]
    hand.say("who starts?")
    # answered, and no consent: the robot still waits for the answer to its question
    assert hand.said[-1] == "You start this time: you draw circles, and I draw crosses."
    assert hand.last_act == INVITATION
    hand.say("can you repeat that")
    assert hand.said[-1] == hand.said[-2]  # the answer it just gave, again
    hand.say("yes")
    assert hand.last_act == LETS_PLAY
    hand.wait()
    assert hand.last_act == MOVE_REQUEST
    hand.say("whose turn is it")
    assert hand.said[-1] == "It's your turn: please draw a circle."
    hand.say("pardon?")
    assert hand.said[-1] == hand.said[-2]
    assert asked in hand.said
    # the transcript shows each question as the person's, each answer as the robot's
    person = acts(hand, "usr")
    assert {"Request(name)", "Request(whoStarts)", "Request(sayAgain)"} <= set(person)


def test_after_a_game_another_is_offered_and_a_yes_plays_it_on_a_clean_board_without_greetings():
    hand = to_the_offer(seed=5, robot_starts=False)
    assert not hand.done
    first, outcome = list(hand.manager.transcript), hand.manager.state.outcome
    offered = len(hand.said)
    hand.say("yes please")
    # the first dialogue ends with the yes, well formed without a goodbye
    yes = {"speaker": "usr", "act": "Confirm(playGame=yes)", "text": "yes please"}
    assert check_dialogue([*first, yes], outcome) is None
    assert check_dialogue(first, outcome) == "does not close with a goodbye"
    # a new dialogue on a clean board, which goes on from "let's play": nothing said again
    assert hand.manager.board.count(EMPTY) == 9 and hand.last_act == LETS_PLAY
    hand.wait()
    assert acts(hand) == [GREETING, INTRODUCTION, INVITATION, LETS_PLAY, MOVE_REQUEST]
    assert len(hand.said) == offered + 2  # "Nice, let's play." and "Your turn."
    assert CLOSING not in [t["act"] for t in first]
    play_out(hand)  # and it is played out
    assert any(is_feedback(a) for a in acts(hand))


@pytest.mark.parametrize("answer", ["no thanks", "bye"])
def test_a_no_to_another_game_gets_the_goodbye(answer):
    hand = to_the_offer(seed=7)
    hand.say(answer)
    assert hand.last_act == CLOSING and hand.done
    transcript = hand.manager.transcript
    assert check_dialogue(transcript, hand.manager.state.ending) is None, transcript


def test_silence_to_the_offer_gets_the_goodbye_and_a_button_game_asks_without_greeting():
    from oxbot.robot.messages import NewGame

    hand = to_the_offer(seed=11)
    hand.wait()
    assert hand.last_act == CLOSING and hand.done
    assert check_dialogue(hand.manager.transcript, hand.manager.state.ending) is None
    before = len(hand.said)
    hand.manager.handle(NewGame(robot_starts=True))  # the page's New game button
    hand._settle()
    assert acts(hand)[:3] == [GREETING, INTRODUCTION, INVITATION]
    assert hand.said[before:] == [hand.said[-1]] and hand.said[-1].endswith("?")


def test_after_a_greeting_the_robot_pauses_then_goes_on_unless_the_person_begins_to_answer():
    from oxbot.robot.messages import PersonAnswering

    pause = ("robot.pause_timeout=0.05", "robot.answer_timeout=30")
    quiet = ManagerAtHand(seed=2, settings=pause)
    assert quiet.last_act == GREETING
    time.sleep(0.1)
    quiet.wait()
    assert quiet.last_act == INTRODUCTION  # on after the pause, not 30 s later

    answering = ManagerAtHand(seed=2, settings=pause)
    answering.manager.handle(PersonAnswering(how="typing"))
    time.sleep(0.1)
    answering.wait()
    assert answering.last_act == GREETING  # it waits for the answer under way
    answering.say("hello")
    assert answering.last_act == INTRODUCTION
    assert acts(answering, "usr") == [GREETING]


def test_after_the_goodbye_a_late_yes_plays_again_and_other_words_get_a_reply():
    hand = to_the_offer(seed=13)
    hand.wait()  # too slow: the goodbye
    assert hand.last_act == CLOSING and hand.done
    hand.say("what time is it")
    assert hand.said[-1] == 'That game is over. Say "one more game" to play again.'
    said = len(hand.said)
    hand.say("bye")  # a goodbye to the goodbye needs no answer
    assert len(hand.said) == said
    hand.say("yes please")  # the late yes to the offer
    assert not hand.done and hand.last_act == LETS_PLAY
    assert acts(hand) == [GREETING, INTRODUCTION, INVITATION, LETS_PLAY]
    # the page's log shows each of those words with what was made of them
    shown = []
    while (message := hand.record.get(0)) is not None:
        if isinstance(message, DialogueAct) and message.speaker == "usr":
            shown.append(message.text)
    assert shown[-3:] == ["what time is it", "bye", "yes please"]


@pytest.mark.parametrize("late", ["Well played.", "Good game.", "Thanks for the game."])
def test_the_outcome_acknowledged_late_is_no_yes_to_another_game(late):
    hand = to_the_offer(seed=17)
    hand.say(late)  # meant for "I won", heard once the robot asks about another game
    assert acts(hand)[-1] == OFFER_ANOTHER and not hand.done  # asked once more
    hand.say("no thanks")
    assert hand.last_act == CLOSING and hand.done


def test_wait_said_over_the_robot_is_answered_and_the_robot_waits_longer():
    hand = ManagerAtHand(robot_starts=True, settings=("robot.question_timeout=30",))
    while hand.last_act != INVITATION:
        hand.wait()
    manager = hand.manager
    asked_until = manager._deadline
    hand.say("wait a second")
    assert hand.said[-1] == HOLD_SENTENCE and manager.phase is Phase.LISTENING
    assert manager.transcript[-2]["act"] == "Request(wait)"
    assert manager._deadline > asked_until  # time to think: a question's wait, not the pause
    hand.say("yes let's play")
    assert hand.last_act != INVITATION and "Confirm(playGame=yes)" in [
        t["act"] for t in manager.transcript
    ]


def let_go(seed: int) -> ManagerAtHand:
    """The person says no to the invitation, and the robot lets it go."""
    hand = ManagerAtHand(robot_starts=True, seed=seed)
    while hand.last_act != INVITATION:
        hand.wait()
    hand.say("no thanks")
    assert hand.last_act == GRANT_REFUSAL and not hand.done
    return hand


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_bare_yes_after_maybe_another_time_is_asked_about_and_a_yes_then_plays(seed):
    hand = let_go(seed)
    hand.say("yes")  # agreeing it is for another time, or taking the no back?
    assert hand.said[-1] == AFTER_ALL_SENTENCE and not hand.done
    hand.say("yes please")
    assert hand.last_act == LETS_PLAY
    hand.wait()
    play_out(hand)
    hand.say("no thanks")  # to the offer of another game
    transcript = hand.manager.transcript
    assert [t["text"] for t in transcript if t["speaker"] == "usr"][:3] == [
        "no thanks",
        "yes",
        "yes please",
    ]
    assert check_dialogue(transcript, hand.manager.state.outcome) is None


@pytest.mark.parametrize(("answer", "seed"), [("no", 0), ("no thanks", 1), ("", 2)])
def test_a_no_or_silence_after_play_after_all_gets_the_goodbye(answer, seed):
    hand = let_go(seed)
    hand.say("yeah")
    assert hand.said[-1] == AFTER_ALL_SENTENCE
    if answer:
        hand.say(answer)
    else:
        hand.wait()
    assert hand.last_act == CLOSING and hand.done
    assert not any(a.startswith("GameMove") for a in acts(hand))
    assert hand.ended.outcome == "declined"
    assert check_dialogue(hand.manager.transcript, hand.ended.outcome) is None


@pytest.mark.parametrize(
    "answer", ["okay", "all right", "sure", "okay then", "sounds good", "fine, thanks"]
)
def test_agreeing_that_it_is_for_another_time_gets_the_goodbye_without_a_question(answer):
    hand = let_go(seed=3)
    hand.say(answer)
    assert hand.last_act == CLOSING and hand.done
    assert AFTER_ALL_SENTENCE not in hand.said


def to_the_persons_move(seed: int) -> ManagerAtHand:
    """A game agreed to, the person asked for their first move."""
    hand = ManagerAtHand(robot_starts=False, seed=seed)
    agree(hand)
    while hand.last_act != MOVE_REQUEST:
        hand.wait()
    return hand


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lets_play_said_during_a_game_is_told_whose_turn_it_is_not_lets_play(seed):
    hand = to_the_persons_move(seed)
    for words in ("let's play", "yes let's play"):
        hand.say(words, 0.9)
        assert hand.said[-1] == "It's your turn: please draw a circle."
        assert acts(hand)[-1] == ANSWER and hand.last_act == MOVE_REQUEST
    assert LETS_PLAY not in acts(hand)[acts(hand).index(MOVE_REQUEST) :]
    play_out(hand)
    hand.say("no thanks")  # to the offer of another game
    assert check_dialogue(hand.manager.transcript, hand.manager.state.outcome) is None


def test_a_stop_taken_back_with_lets_play_plays_on():
    hand = to_the_persons_move(seed=0)
    hand.say("stop")
    assert hand.last_act == GRANT_STOP
    hand.say("actually let's play")
    assert hand.last_act == MOVE_REQUEST and not hand.done


@pytest.mark.parametrize(("answer", "seed"), [("yes", 0), ("yes please stop", 1), ("stop", 2)])
def test_an_unsure_stop_mid_game_is_asked_about_and_a_yes_stops(answer, seed):
    hand = to_the_persons_move(seed)
    hand.say("stop", 0.4)  # the policy would ask for the move, as if nothing was said
    assert hand.said[-1] == STOP_QUESTION_SENTENCE and acts(hand)[-1] == STOP_QUESTION
    hand.say(answer)
    assert hand.last_act == GRANT_STOP
    hand.wait()
    assert hand.done and hand.ended.outcome == "stopped"
    assert not any(a.startswith("GameMove") for a in acts(hand))
    assert check_dialogue(hand.manager.transcript, hand.ended.outcome) is None


@pytest.mark.parametrize("seed", [0, 1])
def test_a_no_to_do_you_want_to_stop_plays_on(seed):
    hand = to_the_persons_move(seed)
    hand.say("I want to stop", 0.45)
    assert hand.said[-1] == STOP_QUESTION_SENTENCE
    hand.say("no")
    assert hand.said[-1] == "It's your turn: please draw a circle."
    assert hand.last_act == MOVE_REQUEST and not hand.done
    play_out(hand)
    hand.say("no thanks")  # to the offer of another game
    assert hand.ended.outcome in ("win", "loss", "draw")
    assert check_dialogue(hand.manager.transcript, hand.ended.outcome) is None


def test_silence_after_do_you_want_to_stop_goes_on_and_a_sure_stop_is_not_asked_about():
    hand = to_the_persons_move(seed=3)
    hand.say("stop", 0.3)  # a noise heard as "stop" is asked about, not taken as one
    assert hand.said[-1] == STOP_QUESTION_SENTENCE
    hand.wait()
    assert hand.last_act == MOVE_REQUEST and not hand.done
    hand.say("stop")
    assert hand.last_act == GRANT_STOP and STOP_QUESTION_SENTENCE not in hand.said[-2:]


def invited(seed: int) -> ManagerAtHand:
    hand = ManagerAtHand(robot_starts=True, seed=seed)
    while hand.last_act != INVITATION:
        hand.wait()
    return hand


@pytest.mark.parametrize("seed", [0, 1])
def test_an_unsure_yes_is_asked_about_and_a_yes_then_plays(seed):
    """ "okay sure", a yes the domain lists, heard word for word at 0.5 was asked the whole
    question again, and again, until the person was told nobody seemed to be there."""
    hand = invited(seed)
    hand.say("okay sure", 0.5)  # too unsure to start a game on
    assert hand.said[-1] == YES_QUESTION_SENTENCE and acts(hand)[-1] == YES_QUESTION
    assert acts(hand, "usr")[-1] == "Unknown"  # no consent yet
    hand.say("yes")
    assert acts(hand, "usr")[-1] == "Confirm(playGame=yes)"
    play_out(hand)
    hand.say("no thanks")  # to the offer of another game
    assert hand.ended.outcome in ("win", "loss", "draw")
    assert check_dialogue(hand.manager.transcript, hand.ended.outcome) is None


def test_a_no_to_was_that_a_yes_is_the_persons_no():
    hand = invited(2)
    hand.say("okay sure", 0.5)
    assert hand.said[-1] == YES_QUESTION_SENTENCE
    hand.say("no")
    assert acts(hand, "usr")[-1] in REFUSALS
    assert hand.last_act == GRANT_REFUSAL
    assert not any(a.startswith("GameMove") for a in acts(hand))


def test_a_yes_is_asked_about_once_and_a_sneeze_heard_as_okay_not_at_all():
    hand = invited(3)
    hand.say("okay", 0.2)  # below MIN_UNSURE_YES: no answer at all
    assert YES_QUESTION_SENTENCE not in hand.said
    hand = invited(4)
    hand.say("okay sure", 0.5)
    hand.say("okay sure", 0.5)  # still unsure: the policy asks its question again
    assert hand.said.count(YES_QUESTION_SENTENCE) == 1
    assert hand.last_act != LETS_PLAY and not any(a.startswith("GameMove") for a in acts(hand))


def test_how_do_you_play_is_answered_with_the_rules_in_any_state_and_is_no_consent():
    hand = ManagerAtHand(robot_starts=True, seed=4)
    while hand.last_act != INVITATION:
        hand.wait()
    hand.say("how do you play?")
    rules = (
        "We take turns to draw in the grid: you draw crosses, I draw circles. Three in a row wins."
    )
    assert hand.said[-1] == rules and acts(hand)[-1] == ANSWER
    assert hand.last_act == INVITATION  # the question stays open: a question is no consent
    hand.say("ok let's play")
    while hand.last_act != MOVE_REQUEST:
        hand.wait()
    hand.say("sorry, what are the rules?")
    assert hand.said[-1] == rules and hand.last_act == MOVE_REQUEST


@pytest.mark.parametrize(
    ("answer", "seed"), [("not again", 0), ("no rematch", 1), ("never again", 2)]
)
def test_a_no_to_another_game_in_its_own_words_is_no_rematch(answer, seed):
    # the understanding reads these by their nearest phrasing, "again" or "rematch"
    hand = to_the_offer(seed)
    hand.say(answer)
    assert hand.done and hand.last_act == CLOSING
    assert hand.ended.outcome in ("win", "loss", "draw")
    said = len(hand.said)
    hand.say("not again")  # after the goodbye: no game, and nothing to answer
    assert hand.done and len(hand.said) == said
    hand.say("again")
    assert not hand.done  # a new game, as before


@pytest.mark.parametrize("question", ["are you a robot?", "how old are you", "can you play chess"])
def test_a_question_off_the_topic_is_answered_not_called_unheard_and_the_robot_waits_on(question):
    hand = ManagerAtHand(robot_starts=False, seed=5)
    while hand.last_act != INVITATION:
        hand.wait()
    hand.say(question, 0.95)
    assert hand.said[-1] == OFF_TOPIC_SENTENCE and acts(hand)[-1] == ANSWER
    assert hand.last_act == INVITATION and not hand.done  # still waiting for the answer
    hand.say("yes")
    assert hand.last_act == LETS_PLAY


@pytest.mark.parametrize(
    ("answer", "seed"),
    [("oh go on then", 0), ("hang on, I changed my mind", 1), ("on second thought, yes", 2)],
)
def test_a_no_taken_back_in_other_words_is_asked_about_and_a_yes_plays(answer, seed):
    hand = let_go(seed)
    hand.say(answer)  # once read as agreeing (or nothing), and the goodbye followed
    assert hand.said[-1] == AFTER_ALL_SENTENCE and not hand.done
    hand.say("yes")
    assert hand.last_act == LETS_PLAY
