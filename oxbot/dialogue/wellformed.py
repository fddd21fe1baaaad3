"""What makes a dialogue well formed: the rules a finished dialogue is checked against.

The environment pays no end-of-dialogue reward for a dialogue that breaks them (`end_reward`);
a simulated person the robot ignores (`ignores_the_person`) walks away at once; the
evaluations count how many dialogues break them (`oxbot.dialogue.evaluation`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from oxbot.dialogue.domain import (
    ACCEPT,
    ANSWERS_ABOUT_PLAYING,
    ANSWERS_TO_PLAY,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    FEEDBACK_ACTS,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    LETS_PLAY,
    MOVE_REQUEST,
    NEW_GAME,
    PROBLEM,
    REFUSALS,
    SAID_OUTSIDE_THE_POLICY,
    STOP,
    SURE_NO,
    Turn,
    acts_on_an_answer,
    game_move_cell,
    is_feedback,
    is_game_move,
    plays,
    starts_game,
)
from oxbot.game.board import EMPTY_BOARD, ROBOT, USER, Board, play
from oxbot.game.board import outcome as game_outcome

_ASKING = (INVITATION, ASK_AGAIN)
_ANSWERS = ANSWERS_TO_PLAY


def check_dialogue(
    transcript: list[Turn],
    outcome: str | None,
    understood: Sequence[str] | None = None,
    scores: Sequence[float] | None = None,
) -> str | None:
    """Why a finished dialogue is not well formed, or None if it is.

    Well formed: it greets first and closes last, once. It plays only with a person who agreed
    (never a game nobody agreed to) and lets a person who declines or asks to stop go: it
    acknowledges (`Acknowledge(playGame=no)`, `Acknowledge(stop)`) and says goodbye, with no
    move after a stop. A clear no to its question ("no thanks", understood with a score of at
    least `SURE_NO`) is final, unless the person takes it back ("Yes, I want to play": the
    robot may play, not ask again); after a "later", an unsure no or a no said before it asked, it
    may ask once more; asking again about an answer it could not make out (silence, chatter, a
    "thank you") does not count; once it acknowledged a no, the goodbye may follow further noes
    ("catch you later") until a yes; a no after the game's feedback that answers no question
    ("oh no") needs no acknowledgement, the goodbye lets it go. A clear stop is final too: no
    request for a move after it, nor after two stops, until the person takes it back with a yes
    ("I want to play") or by drawing their move (the drawing outweighs the words heard with it,
    as in `DialogueState.agreed`). A game it
    plays, it plays properly: introduction and invitation before the first move, the person
    asked for their move after each robot move until the game is over, and exactly one feedback
    act, the one of the real outcome. It never walks away from a person who wanted to play. It
    never acts on an answer it said it did not catch, nor says it did not catch an answer it
    acted on (`acts_on_what_it_did_not_catch`).
    The person's turns are read as the acts they meant (the environment's transcript) or, where
    `understood` gives one per turn, as the acts the robot understood, with `scores` the
    understanding's scores (none given: every turn clear). The sentences the interaction
    manager says around the policy's acts (`SAID_OUTSIDE_THE_POLICY`: a problem on the sheet,
    an answer to a question asked in passing, the offer of another game) are no act of the
    policy and are read past; a game played out may end, instead of with a goodbye, with the
    person's yes to another game, which the next dialogue takes up.
    """
    transcript, understood, scores = _policy_turns(transcript, understood, scores)
    sys_acts = [t["act"] for t in transcript if t["speaker"] == "sys"]
    if not sys_acts or sys_acts[0] != GREETING:
        return "does not greet first"
    problem = ignores_the_person(transcript, understood, scores) or acts_on_what_it_did_not_catch(
        transcript, understood
    )
    if problem is not None:
        return problem
    plays_again = CLOSING not in sys_acts and _plays_again(transcript, outcome, understood)
    if not plays_again and (sys_acts[-1] != CLOSING or sys_acts.count(CLOSING) != 1):
        return "does not close with a goodbye"
    if outcome in ("declined", "stopped"):
        return None
    return _played_properly(transcript, outcome)


def _policy_turns(
    transcript: list[Turn], understood: Sequence[str] | None, scores: Sequence[float] | None
) -> tuple[list[Turn], Sequence[str] | None, Sequence[float] | None]:
    """`transcript` (and `understood`, `scores`, one per turn) without the robot's sentences
    outside the policy's acts."""
    keep = [
        i
        for i, t in enumerate(transcript)
        if t["speaker"] != "sys" or t["act"] not in SAID_OUTSIDE_THE_POLICY
    ]
    return (
        [transcript[i] for i in keep],
        [understood[i] for i in keep] if understood is not None else None,
        [scores[i] for i in keep] if scores is not None else None,
    )


def _plays_again(
    transcript: list[Turn], outcome: str | None, understood: Sequence[str] | None
) -> bool:
    """Whether a game played out ends with the person's yes to another game (or their asking
    for one), their last turn, after the robot's last act."""
    if outcome not in FEEDBACK_ACTS or not transcript or transcript[-1]["speaker"] != "usr":
        return False
    last = understood[-1] if understood is not None else transcript[-1]["act"]
    return last in (ACCEPT, NEW_GAME)


def ignores_the_person(
    transcript: list[Turn],
    understood: Sequence[str] | None = None,
    scores: Sequence[float] | None = None,
) -> str | None:
    """The first rule about the person's will the dialogue so far breaks, or None: a game
    nobody agreed to, a no or a stop not let go. Each is decided as soon as the robot says the
    act that breaks it, so the simulated person can walk away there (`InteractiveGameEnv`)."""
    heard = list(understood) if understood is not None else [t["act"] for t in transcript]
    sure = [score >= SURE_NO for score in scores] if scores is not None else [True] * len(heard)
    return (
        _agreed_before_playing(transcript)
        or _lets_a_no_go(transcript, heard, sure)
        or _lets_a_stop_go(transcript, heard, sure)
    )


def acts_on_what_it_did_not_catch(
    transcript: list[Turn], understood: Sequence[str] | None = None
) -> str | None:
    """The first turn at which the robot acts on an answer it said it did not catch, or says it
    did not catch an answer it acted on; None if there is none.

    Once the robot asks again (`Request(repeat)`: "Sorry, I didn't catch that. Shall we
    play?"), every answer before it counts for nothing: starting a game needs a yes said after
    it (or a drawing), acknowledging a no a no said after it, acknowledging a stop a stop said
    after it. And once the robot has acted on the person's last answer or drawing
    (`domain.acts_on_an_answer`), it does not ask again until they say something new. The
    person's turns are read as the robot understood them (`understood`, one per turn; none
    given: as the transcript's acts); the robot's `Inform(problem)` sentences are no act of its
    policy and do not count."""
    heard = list(understood) if understood is not None else [t["act"] for t in transcript]
    counted: list[str] = []  # the answers since the robot last asked again
    voided: list[str] = []  # the answers it asked again about
    drew = started = acted = False
    for turn, act in zip(transcript, heard, strict=True):
        if turn["speaker"] == "usr":
            if game_move_cell(turn["act"]) is not None:  # a drawing is seen, not heard
                drew = acted = True
            else:
                counted.append(act)
                acted = False
            continue
        said = turn["act"]
        if said == PROBLEM:
            continue
        if said == ASK_AGAIN:
            if acted:
                return "asks again about an answer it acted on"
            voided, counted = voided + counted, []
            continue
        needs = _needed_answer(said, started, drew)
        if needs is not None and not needs(counted) and needs(voided):
            return f"acts on an answer it said it did not catch ({said})"
        started = started or starts_game(said)
        acted = acted or acts_on_an_answer(said)
    return None


def _needed_answer(act: str, started: bool, drew: bool) -> Callable[[Sequence[str]], bool] | None:
    """What `act` needs the person to have answered, as a test of a list of answers (None:
    nothing): a "let's play", or a game started, needs their last yes or no to be a yes (unless
    they drew, which agrees as well)."""
    if (act == LETS_PLAY or (starts_game(act) and not started)) and not drew:
        return _last_says_yes
    if act == GRANT_REFUSAL:
        return lambda answers: any(a in REFUSALS for a in answers)
    if act == GRANT_STOP:
        return lambda answers: STOP in answers
    return None


def _last_says_yes(answers: Sequence[str]) -> bool:
    said = [a for a in answers if a == ACCEPT or a in REFUSALS]
    return bool(said) and said[-1] == ACCEPT


def blame(
    problem: str, transcript: list[Turn], understood: Sequence[str], scores: Sequence[float]
) -> str:
    """Who made a dialogue ill formed (`problem`, from `check_dialogue`): "hearing" when read
    as the robot understood it (each answer taken as the act it was understood as, with its
    score) it breaks no rule about the person's will, and the problem is one of those or a
    walk-away: "later" taken for a yes at 0.8, a yes taken for a clear no. Otherwise "policy"
    (walking away after it understood a yes last, too): a mistake the robot made about what it
    understood, or in playing (training can remove these; the others only better hearing, or
    asking about every answer, can)."""
    walks_away = problem.startswith("walks away")
    # what the person said after the robot's last word came too late to act on
    spoke = [i for i, turn in enumerate(transcript) if turn["speaker"] == "sys"]
    last_word = spoke[-1] if spoke else len(transcript)
    if walks_away and _last_answer(transcript[:last_word], understood[:last_word]) == ACCEPT:
        return "policy"  # it heard a yes last, and left
    about_the_person = walks_away or problem == ignores_the_person(transcript, understood, scores)
    if (
        about_the_person
        and ignores_the_person(as_heard(transcript, understood), understood, scores) is None
    ):
        return "hearing"
    return "policy"


def as_heard(transcript: list[Turn], understood: Sequence[str]) -> list[Turn]:
    """`transcript` with each of the person's turns the act the robot understood (one per turn
    in `understood`); a drawing is seen, not heard: it stays a drawing."""
    return [
        {**turn, "act": act} if turn["speaker"] == "usr" and not is_game_move(turn["act"]) else turn
        for turn, act in zip(transcript, understood, strict=True)
    ]


def _last_answer(transcript: list[Turn], understood: Sequence[str]) -> str | None:
    """The last yes, no or stop the person was understood to say, or None."""
    return next(
        (
            act
            for turn, act in zip(reversed(transcript), reversed(understood), strict=True)
            if turn["speaker"] == "usr" and act in ANSWERS_ABOUT_PLAYING
        ),
        None,
    )


def _agreed_before_playing(transcript: list[Turn]) -> str | None:
    agreed = False
    for turn in transcript:
        if turn["speaker"] == "usr":
            agreed = agreed or turn["act"] == ACCEPT
        elif plays(turn["act"]) and not agreed:
            return f"starts a game nobody agreed to ({turn['act']})"
    return None


def _lets_a_no_go(transcript: list[Turn], heard: list[str], sure: list[bool]) -> str | None:
    refused = final = asked = over = acknowledged = False
    asked_after = 0
    last_answer = ""  # the last yes or no understood
    answered = False  # whether the person said anything it made out since it last asked
    for turn, understood, clear in zip(transcript, heard, sure, strict=True):
        act = turn["act"]
        if turn["speaker"] == "usr":
            if over and not asked and understood in REFUSALS:
                continue  # "oh no" after the game answers nothing: the goodbye lets it go
            answered = answered or understood in _ANSWERS
            if understood in REFUSALS or understood == ACCEPT:
                refused = refused or understood in REFUSALS
                acknowledged = acknowledged and understood != ACCEPT
                final = final or (asked and understood == DECLINE and clear)
                last_answer = understood
            continue
        asked = act in _ASKING
        over = over or is_feedback(act)
        if asked and final:
            return "asks to play again after a clear no"
        if asked and refused and answered:  # asking about silence or chatter does not count
            asked_after += 1
            if asked_after > 1:
                return "asks to play again after being told no twice"
        elif last_answer in REFUSALS:
            if plays(act):
                return "plays with a person who said no"
            if act == CLOSING and not acknowledged:
                return "says goodbye to a no without acknowledging it"
            if act == GRANT_REFUSAL:
                last_answer, acknowledged = "", True  # the goodbye may follow
        if asked:
            answered = False
    return None


def _lets_a_stop_go(transcript: list[Turn], heard: list[str], sure: list[bool]) -> str | None:
    stops = understood_stops = 0
    clear_stop = acknowledged = False
    for turn, understood, clear in zip(transcript, heard, sure, strict=True):
        act = turn["act"]
        if turn["speaker"] == "usr":
            # a yes after a stop ("I want to play") or a drawn move takes it back; meant and
            # understood apart, so that a stop misheard as a yes still counts against going on
            drew = is_game_move(act)  # seen on the paper, whatever the words were heard as
            stops = 0 if act == ACCEPT or drew else stops + (act == STOP)
            if understood == ACCEPT or drew:
                understood_stops, clear_stop, acknowledged = 0, False, False
                continue
            understood_stops += understood == STOP
            clear_stop = clear_stop or (understood == STOP and clear)
        elif stops and is_game_move(act):
            return f"goes on playing after the person asked to stop ({act})"
        elif clear_stop and act == MOVE_REQUEST:
            return "asks for a move again after a clear stop"
        elif understood_stops >= 2 and act == MOVE_REQUEST:
            return "asks for a move again after being asked to stop twice"
        elif stops and act == GRANT_STOP:
            acknowledged = True
        elif stops and act == CLOSING and not acknowledged:
            return "says goodbye to a stop without acknowledging it"
    return None


def _played_properly(transcript: list[Turn], outcome: str | None) -> str | None:
    sys_acts = [t["act"] for t in transcript if t["speaker"] == "sys"]
    first_move = next((i for i, t in enumerate(transcript) if is_game_move(t["act"])), None)
    if first_move is None:
        return "walks away from a person who wanted to play"
    before = {t["act"] for t in transcript[:first_move] if t["speaker"] == "sys"}
    if INTRODUCTION not in before:
        return "does not introduce itself before the first move"
    if INVITATION not in before:
        return "does not invite the person before the first move"
    board: Board = EMPTY_BOARD
    sys_index = -1
    for turn in transcript:
        if turn["speaker"] == "sys":
            sys_index += 1
        cell = game_move_cell(turn["act"])
        if cell is None:
            continue
        board = play(board, cell, ROBOT if turn["speaker"] == "sys" else USER)
        if turn["speaker"] == "sys" and game_outcome(board) is None:
            following = sys_acts[sys_index + 1] if sys_index + 1 < len(sys_acts) else None
            if following != MOVE_REQUEST:
                return f"does not ask for the person's move after its move {turn['act']}"
    if outcome is None or game_outcome(board) is None:
        return "walks away from an unfinished game"
    feedback = [a for a in sys_acts if is_feedback(a)]
    if len(feedback) != 1:
        return f"gives {len(feedback)} feedback acts instead of one"
    if feedback[0] != FEEDBACK_ACTS[outcome]:
        return f"says {feedback[0]} but the outcome is a {outcome}"
    return None
