"""The person's side of the interaction manager's turn: their words and drawings read into
the dialogue (`PersonInput`, mixed into oxbot.robot.manager.InteractionManagerComponent).

The manager is the authority on the game: a move that is not legal on its board (typed moves
bypass the tracker) is refused in words and never changes the board.

A move said or typed in words when it is the person's turn ("top left", "number five":
`oxbot.dialogue.cells_in_words`) is played as a typed move is, by a GameMove on the bus (which
the eyes read too, so that drawing it afterwards is no second move), when heard at least
`speech.min_move_confidence` surely; below that, or among other words ("I'll go in the middle
this time", when nothing else was understood), the robot asks which cell (`WHICH_CELL`, like
the problem sentences outside the policy's acts) and waits for the move as before; a taken cell
is refused in words. It never plays a cell the person did not name.

"New game" after the outcome starts another game once this dialogue has said goodbye; said
mid-game, where the simulated people never say it, it is taken as a stop (the policy lets go,
"Okay, let's stop here") followed by another game.

A yes to playing said while a game is on is no news: it is kept from the policy (which said
"Great, let's play." mid-game) and answered, on the person's turn, with whose turn it is. Words
heard as a stop too unsurely for the policy, which would ask for the move instead, are asked
about ("Do you want to stop?": the manager's `_ask_whether_to_stop`): a yes is the stop again, a
no is the person playing on. A yes to "Shall we play?" heard too unsurely to start a game on
(`UserAct.unsure`), but surely enough to be no sneeze (`MIN_UNSURE_YES`), is asked about once
("Sorry, was that a yes?"), rather than the whole question again: a yes then plays, a no is the
person's no.

Drawings the tracker finds impossible and the camera's guidance come here too (`BoardProblem`),
and are said as the problem sentences of oxbot.robot.sentences.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Callable, Sequence

from oxbot.config import OxbotConfig
from oxbot.dialogue.asides import (
    ASIDE_ACTS,
    MIN_CONFIDENCE,
    OFF_TOPIC,
    aside_question,
    off_topic,
)
from oxbot.dialogue.cells_in_words import MoveHeard, move_in_words, read_cell
from oxbot.dialogue.domain import (
    ACCEPT,
    ACKNOWLEDGE,
    ANSWER,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    GAME_MOVE_TEMPLATE,
    GRANT_REFUSAL,
    INVITATION,
    LETS_PLAY,
    MOVE_REQUEST,
    NEW_GAME,
    REFUSALS,
    SILENCE,
    STOP,
    SURE_NO,
    THANKS,
    UNKNOWN,
    draw_tag,
    game_move,
    is_game_move,
    words_of,
)
from oxbot.dialogue.state import DialogueState
from oxbot.dialogue.understanding import UserAct, polarity
from oxbot.game.board import CELL_NAMES, EMPTY, USER, cell_index, symbol_of
from oxbot.robot.bus import Bus
from oxbot.robot.messages import GameMove, NewGame, SpeechHypotheses
from oxbot.robot.sentences import (
    AFTER_GOODBYE,
    GUIDANCE_SENTENCES,
    OFF_TOPIC_SENTENCE,
    PROBLEM_SENTENCES,
    TAKEN_IN_WORDS,
    WHICH_CELL,
    cell_in_words,
    symbol_names,
)
from oxbot.speech.keywords import answer_to
from oxbot.speech.nbest import Hypothesis

AGREEING = frozenset(
    {
        *("okay", "ok", "sure", "all", "right", "alright", "fine", "cool", "good", "great"),
        *("sounds", "no", "problem", "thanks", "thank", "you", "then", "oh", "well", "that's"),
    }
)
"""Words that, after the robot let a no go ("Okay, maybe another time."), only agree that it is
for another time: "okay", "sure", "all right then". A yes with any other word ("yes", "yes
please", "oh go on then") may take the no back, and is asked about."""
MIN_UNSURE_YES = 0.35
"""A yes to "Shall we play?" heard less surely than the understanding starts a game on, but at
least this surely, is asked about ("Sorry, was that a yes?"); below it, it is no answer. Above
the development sneezes heard as "okay", "nice" and "let's go" (0.11-0.30, docs/robot.md)."""
TAKEN_BACK = ("changed my mind", "change my mind", "second thought", "second thoughts")
"""Words that take a no back whatever else is said ("hang on, I changed my mind"), which the
understanding reads as nothing of the game."""

Understand = Callable[[Sequence[tuple[str, float]], str], UserAct]
"""Reads what the person said (an N-best list) in the context of the robot's last act as
their dialogue act with a score (`UserActClassifier.intent_of`)."""


class Phase(enum.Enum):
    """Where the interaction manager is in its turn."""

    IDLE = "idle"
    SPEAKING = "speaking"
    DRAWING = "drawing"
    LISTENING = "listening"
    DONE = "done"


class PersonInput:
    """What the person says and draws, read into the interaction manager's dialogue.

    A mixin of `InteractionManagerComponent`, which owns the attributes below and the robot's
    side of the turn: `_decide` (choose and say the next act), `_aside` and `_tell` (say a
    sentence outside the policy's acts, now or after the robot's act), `_publish_turn` and
    `_publish_game` (announce a turn, the board).
    """

    bus: Bus
    config: OxbotConfig
    state: DialogueState
    phase: Phase
    _understand: Understand
    _moved_since: bool
    _spoke_since: bool
    _heard_act: str
    _rematch: bool
    _agreed_words: str
    _offering: bool
    _offers: int
    _asking_after_all: bool
    _asking_to_stop: bool
    _asking_whether_yes: bool
    _asked_whether_yes: bool
    _broken: bool
    _early_answer: SpeechHypotheses | None
    _move_in_words: tuple[MoveHeard, Sequence[tuple[str, float]]] | None
    _unanswered_in_a_row: int

    def _decide(self) -> None:
        raise NotImplementedError

    def _aside(self, sentence: str) -> None:
        raise NotImplementedError

    def _tell(self, sentence: str) -> None:
        raise NotImplementedError

    def _publish_turn(self, speaker: str, act: str, text: str) -> None:
        raise NotImplementedError

    def _publish_game(self) -> None:
        raise NotImplementedError

    def _aside_answer(self, question: str) -> str | None:
        raise NotImplementedError

    def _whose_turn(self) -> str:
        raise NotImplementedError

    def _offer(self) -> None:
        raise NotImplementedError

    def _ask_after_all(self) -> None:
        raise NotImplementedError

    def _ask_whether_yes(self) -> None:
        raise NotImplementedError

    def _play_again(self, words: str) -> None:
        raise NotImplementedError

    def _carried(self, words: str) -> tuple[tuple[str, str, str], ...]:
        raise NotImplementedError

    def _words_need_an_answer(self) -> bool:
        """Whether words heard while the robot was busy are answered now: always, except while
        it waits for a move, where only a stop, a no or a goodbye is ("stop" over "Your move");
        chatter then needs no second request for the move."""
        if not self._expects_move():
            return True
        return self._heard_act in (STOP, CLOSING) or self._heard_act in REFUSALS

    def _expects_move(self) -> bool:
        return (
            self.state.last_act == MOVE_REQUEST
            and not self._moved_since
            and self.state.person_to_move
        )

    def _heard(self, message: SpeechHypotheses) -> None:
        if not message.nbest:
            return  # the recogniser heard nothing: as if nobody spoke
        nbest, words = message.nbest, message.words
        # the answer to a yes/no question: a "hi" the keyword model is sure was "no" is a no
        heard = [Hypothesis(t, c) for t, c in nbest]
        read = answer_to(self.state.last_act, heard, message.keywords)
        if read is not heard:
            nbest, words = tuple((h.text, h.confidence) for h in read), read[0].words
        text, confidence = nbest[0]
        # per-word confidences when the recogniser gives them (paper §2.2), else the utterance's
        words = words or tuple((w, confidence) for w in words_of(text))
        if self._answered_in_passing(text, confidence):
            return
        if self._offering:
            self._heard_about_another_game(nbest, text)
            return
        if self._asking_after_all and self._plays_after_all(nbest, text, words):
            return
        if self._asking_to_stop and self._answered_whether_to_stop(nbest, text, words):
            return
        if self._asking_whether_yes and self._answered_whether_yes(nbest, text, words):
            return
        if self._persons_turn():
            move = move_in_words(nbest)
            if move is not None:  # "top left": the person's move, said instead of drawn
                self._moved_in_words(move, words)
                return
        reading = self._understand(nbest, self.state.last_act)
        if self._unsure_yes(reading, confidence):
            self._informed(UNKNOWN, text, 0.0)
            self._ask_whether_yes()
            return
        if self._bare_yes_after_letting_go(nbest, text, reading):
            # "yes" to "Okay, maybe another time.": another time, or the no taken back?
            self._informed(reading.act, text, reading.score)
            self._ask_after_all()
            return
        if (
            self._persons_turn()
            and reading.act in (UNKNOWN, GAME_MOVE_TEMPLATE)
            and read_cell(text) is not None
        ):
            # a cell among other words ("I'll go in the middle this time"): which one, if any?
            self._ask_which_cell(UNKNOWN, text)
            return
        if (
            reading.act == UNKNOWN
            and confidence >= MIN_CONFIDENCE
            and off_topic(text)
            and not self._expects_move()  # chatter over "Your move" needs no answer
        ):
            # "are you a robot?": answered, not "Sorry, I didn't catch that", and waited on
            self._informed(ASIDE_ACTS[OFF_TOPIC], text, confidence)
            self._aside(OFF_TOPIC_SENTENCE, ANSWER)
            return
        if self._keen_while_playing(reading, text):
            return
        if (
            (reading.act in (ACCEPT, STOP, CLOSING) or reading.act in REFUSALS)
            and not self.state.invitations
            and not self.state.game_started
        ):
            # "yes, let's play", "no thanks" or "bye" to the greeting: kept until the robot has
            # asked, then taken as the answer (the policy never met an answer to a question it
            # had not asked: a yes was met with "Pardon?", a no or a goodbye ignored and the
            # question asked three times)
            self._early_answer = message
            if self.phase is Phase.LISTENING:
                self._decide()  # what it would say had the person kept quiet: go on to ask
            return
        reading = dataclasses.replace(reading, act=_unless_refused(reading.act, text))
        if reading.act == NEW_GAME and (self.state.game_started or self.state.outcome is not None):
            self._rematch, self._agreed_words = True, text  # after this dialogue, another game
            if self.state.outcome is None:  # mid-game: this one stops first (a stop it knows)
                reading = dataclasses.replace(reading, act=STOP)
        self.state.person_says(reading.act, text, words, (reading.act, reading.score))
        self._publish_turn("usr", reading.act, text)
        self._spoke_since, self._heard_act = True, reading.act
        self._unanswered_in_a_row = 0
        if self.phase is Phase.LISTENING and not (
            self._expects_move() and is_game_move(reading.act)
        ):
            self._decide()

    def _keen_while_playing(self, reading: UserAct, text: str) -> bool:
        """Whether the person said yes to playing ("let's play!") while a game is on: nothing
        to agree to, so it is kept out of what the policy sees (which answered it with "Great,
        let's play." mid-game), and told whose turn it is when it is theirs."""
        state = self.state
        playing = state.last_act in (LETS_PLAY, MOVE_REQUEST) or is_game_move(state.last_act)
        if reading.act != ACCEPT or not playing or state.outcome is not None:
            return False  # after "Okay, let's stop here." a yes takes the stop back
        self._informed(reading.act, text, reading.score)
        if self._expects_move() and self.phase is Phase.LISTENING:
            self._aside(self._whose_turn(), ANSWER)
        return True

    def _bare_yes_after_letting_go(
        self, nbest: Sequence[tuple[str, float]], text: str, reading: UserAct
    ) -> bool:
        """Whether the person answered the robot's letting a no go ("Okay, maybe another time.")
        with words that may take the no back: a yes that is more than agreement ("yes", "oh go
        on then"), read there as an acknowledgement but a yes to playing had the robot asked,
        or words of a changed mind ("I changed my mind"). A yes with "play", "actually"... is
        a change of mind already, and plays."""
        if self.state.last_act != GRANT_REFUSAL:
            return False
        words = words_of(text)
        if any(f" {cue} " in f" {' '.join(words)} " for cue in TAKEN_BACK):
            return True
        return (
            reading.act == ACKNOWLEDGE
            and not set(words) <= AGREEING
            and self._understand(nbest, INVITATION).act == ACCEPT
        )

    def _plays_after_all(
        self, nbest: Sequence[tuple[str, float]], text: str, words: Sequence[tuple[str, float]]
    ) -> bool:
        """The answer to "Do you want to play after all?": a yes is the person's yes to playing,
        which the policy answers (True); anything else is read as it would have been after
        "Okay, maybe another time." (False)."""
        self._asking_after_all = False
        reading = self._understand(nbest, INVITATION)
        if reading.act != ACCEPT:
            return False
        self._answered(ACCEPT, text, words, reading.score)
        return True

    def _unsure_yes(self, reading: UserAct, confidence: float) -> bool:
        """Whether the answer to "Shall we play?" was a yes heard too unsurely to start a game
        on, surely enough to be speech, and not yet asked about since the robot's question."""
        return (
            reading.act == UNKNOWN
            and reading.unsure == ACCEPT
            and confidence >= MIN_UNSURE_YES
            and self.state.last_act in (INVITATION, ASK_AGAIN)
            and not self._asked_whether_yes
        )

    def _answered_whether_yes(
        self, nbest: Sequence[tuple[str, float]], text: str, words: Sequence[tuple[str, float]]
    ) -> bool:
        """The answer to "Sorry, was that a yes?": a yes is the person's yes to playing, a no
        (or a later) their answer to the invitation, both given to the policy (True). Anything
        else is read as the answer to the invitation it was (False)."""
        self._asking_whether_yes = False
        reading = self._understand(nbest, INVITATION)
        if reading.act != ACCEPT and reading.act not in REFUSALS:
            return False
        self._answered(reading.act, text, words, reading.score)
        return True

    def _answered_whether_to_stop(
        self, nbest: Sequence[tuple[str, float]], text: str, words: Sequence[tuple[str, float]]
    ) -> bool:
        """The answer to "Do you want to stop?": a yes (or a stop) is the stop said again, which
        the policy answers; a no is their yes to playing on, told whose turn it is (True).
        Anything else is read as it would have been (False)."""
        self._asking_to_stop = False
        reading = self._understand(nbest, INVITATION)
        heard_as = self._understand(nbest, "")
        if reading.act == ACCEPT or heard_as.act == STOP:
            score = heard_as.score if heard_as.act == STOP else reading.score
            self._answered(STOP, text, words, score)
            return True
        if reading.act not in REFUSALS:
            return False
        self._informed(ACCEPT, text, reading.score)  # no stop: they play on
        self._aside(self._whose_turn(), ANSWER)
        return True

    def _informed(self, act: str, text: str, score: float) -> None:
        """The person's words, read as `act` with `score`, in the transcript and the page's log
        but not in what the policy sees (the robot answers them itself)."""
        self.state.person_informs(act, text, score)
        self._publish_turn("usr", act, text)
        self._unanswered_in_a_row = 0

    def _answered(
        self, act: str, text: str, words: Sequence[tuple[str, float]], score: float
    ) -> None:
        """The answer to a question the robot asked around the policy, given to the policy as
        `act` with `score`; it decides now if the robot is listening, else once its act is
        over."""
        self.state.person_says(act, text, words, (act, score))
        self._publish_turn("usr", act, text)
        self._spoke_since, self._heard_act = True, act
        self._unanswered_in_a_row = 0
        if self.phase is Phase.LISTENING:
            self._decide()

    def _heard_after_goodbye(self, message: SpeechHypotheses) -> None:
        """After the goodbye the robot listens for a new game ("again!", "new game"), and
        answers questions asked in passing."""
        if not message.nbest:
            return
        text, confidence = message.nbest[0]
        if self._answered_in_passing(text, confidence):
            return
        if self._broken:
            return
        # after "Would you like another game?", a late yes is one too
        act = self._understand(message.nbest, INVITATION if self._offers else "").act
        act = _unless_refused(act, text)
        if act != SILENCE:  # the person sees what was made of their words, as in a game
            self._publish_turn("usr", act, text)
        if act == NEW_GAME or (self._offers and act == ACCEPT):
            carried = self._carried(text)
            self.bus.publish(NewGame(robot_starts=self.state.robot_starts, carried=carried))
        elif act not in (CLOSING, STOP, THANKS, ACKNOWLEDGE, SILENCE, *REFUSALS) and (
            polarity(text) != "no"  # "not again" needs no reply either
        ):
            self._tell(AFTER_GOODBYE)  # not a word lost without a reply

    def _answered_in_passing(self, text: str, confidence: float) -> bool:
        """Whether `text` is a question asked in passing ("who starts?"; oxbot.dialogue.asides),
        now answered: in the transcript, not in what the policy sees, and the robot goes on
        waiting for what it waited for."""
        question = aside_question(text) if confidence >= MIN_CONFIDENCE else None
        answer = self._aside_answer(question) if question is not None else None
        if question is None or answer is None:
            return False
        self._informed(ASIDE_ACTS[question], text, confidence)
        self._aside(answer, ANSWER)
        return True

    def _heard_about_another_game(self, nbest: Sequence[tuple[str, float]], text: str) -> None:
        """The answer to "Would you like another game?": a yes starts it, a no or a goodbye
        lets the robot say its goodbye, anything else is asked about once more."""
        reading = self._understand(nbest, INVITATION)
        heard_as = _unless_refused(self._understand(nbest, "").act, text)
        act = ACCEPT if heard_as == NEW_GAME else reading.act
        if heard_as == DECLINE and reading.act not in REFUSALS:
            act = DECLINE  # "not again": its nearest phrasing, "again", is no yes
        if act == ACCEPT and heard_as in (ACKNOWLEDGE, THANKS):
            act = heard_as  # "good game", "thanks for the game": the outcome acknowledged late
        elif act == ACCEPT and heard_as != NEW_GAME and reading.score < SURE_NO:
            act = UNKNOWN  # "well played" is nearest "well okay" (0.5): no clear yes
        self._informed(act, text, reading.score)
        if act == ACCEPT:
            self._play_again(text)
        elif act in REFUSALS or act in (CLOSING, STOP):
            self._offering = False
            self._spoke_since, self._heard_act = True, act
            if self.phase is Phase.LISTENING:
                self._decide()  # its goodbye
        elif self._offers < 2 and self.phase is Phase.LISTENING:
            self._offer()

    def _moved(self, message: GameMove) -> None:
        if message.who != "usr":
            return
        cell = cell_index(message.where)
        said, self._move_in_words = self._move_in_words, None
        if said is not None and said[0].cell != cell:
            said = None  # a drawing, or a typed move, came first: the words wait no longer
        problem = self._illegal(cell, message.symbol)
        if problem is not None:
            if said is not None and problem == "occupied_cell":
                self._aside(TAKEN_IN_WORDS.format(cell=cell_in_words(cell).capitalize()))
            else:
                self._problem(problem)
            return
        self._moved_since = True
        self._unanswered_in_a_row = 0
        text = draw_tag("usr", cell)
        if said is None:
            self.state.person_says(game_move(cell), text)  # heard words stay
        else:  # heard as the simulated people's drawings are, with their words
            move, words = said
            text = move.words  # as heard, like every answer (the recorder links the two)
            self.state.person_says(game_move(cell), text, words, (GAME_MOVE_TEMPLATE, move.score))
        self._publish_turn("usr", game_move(cell), text)
        self._publish_game()
        if self.phase is Phase.LISTENING:
            self._decide()

    def _persons_turn(self) -> bool:
        """Whether the game is on and waits for the person's move."""
        return self.state.game_started and self.state.person_to_move

    def _moved_in_words(self, move: MoveHeard, words: Sequence[tuple[str, float]]) -> None:
        """A move said in words: played, through the path of a typed move (a GameMove on the
        bus, which the eyes also learn from), when heard surely enough; else asked about."""
        self._unanswered_in_a_row = 0
        if not move.played_at(self.config.speech.min_move_confidence):
            self._ask_which_cell(GAME_MOVE_TEMPLATE, move.words, move.score)
            return
        self._move_in_words = (move, words)
        symbol = symbol_of(USER, self.state.robot_starts)
        self.bus.publish(
            GameMove(who="usr", what="draw", where=CELL_NAMES[move.cell], symbol=symbol)
        )

    def _ask_which_cell(self, act: str, text: str, score: float = 0.0) -> None:
        """The person seemed to name a cell, not surely: in the transcript, not in what the
        policy sees, and the robot asks which cell (it waits for the move as before)."""
        self._informed(act, text, score)
        self._aside(WHICH_CELL)

    def _illegal(self, cell: int, symbol: str) -> str | None:
        """Why the person may not draw `symbol` in `cell` now, as a problem kind, or None."""
        state = self.state
        if not self.state.game_started:
            return "not_started"  # a drawing before the person agreed is no move
        if state.outcome is not None:
            return "game_over"
        if state.board[cell] != EMPTY:
            return "occupied_cell"
        if not state.person_to_move:
            return "out_of_turn"
        if symbol != symbol_of(USER, state.robot_starts):
            return "wrong_symbol"
        return None

    def _problem(self, kind: str, cells: tuple[str, ...] = ()) -> None:
        if kind in GUIDANCE_SENTENCES:
            if self.phase is Phase.LISTENING and self._expects_move():
                self._tell(GUIDANCE_SENTENCES[kind])
            return
        self._unanswered_in_a_row = 0  # someone is drawing
        if kind == "out_of_turn" and not self.state.game_started:
            kind = "not_started"  # "it is my turn" is wrong before anyone agreed to play
        sentence = PROBLEM_SENTENCES.get(kind, "Something is wrong on the sheet.").format(
            **symbol_names(self.state.robot_starts),
            cell=cell_in_words(CELL_NAMES.index(cells[0])) if cells else "a cell",
        )
        self._aside(sentence)


def _unless_refused(act: str, text: str) -> str:
    """`act`, or a no where words heard as a request for another game say no ("not again", "no
    rematch", "never again"): the understanding reads them by their nearest phrasing, "again"."""
    return DECLINE if act == NEW_GAME and polarity(text) == "no" else act
