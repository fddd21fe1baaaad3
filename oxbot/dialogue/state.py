"""The dialogue state: everything the interaction manager knows of one dialogue so far.

The training environment, the robot's interaction manager, the action model's seed dialogues
and the evaluations all drive the same `DialogueState` through the same three events — the
robot says an act, the robot's act could not be done, the person says or draws something —
and read it the same two ways: `encode()`, the feature vector the Q-network and the action
model see (`oxbot.dialogue.features`), and `offered()`, Pr(a|s) and the action mask. They differ
only in where the person's answers come from: a simulated person in the environment, the
recogniser and the camera on the robot.

    state = DialogueState(layout, robot_starts=True, action_model=model)
    state.robot_says(GREETING, "Hello!")
    state.person_says(GREETING, "Hi!", heard=(("hi", 0.9),))
    obs = state.encode()
    probs, mask = state.offered()
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

import numpy as np

from oxbot.dialogue.domain import (
    ACCEPT,
    ACTION_INDEX,
    ANSWERS_ABOUT_PLAYING,
    ANSWERS_TO_PLAY,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    GRANT_REFUSAL,
    GRANT_STOP,
    INVITATION,
    MOVE_REQUEST,
    REFUSALS,
    STOP,
    SURE_NO,
    SYSTEM_ACTS,
    Turn,
    acts_on_an_answer,
    game_move_cell,
    is_feedback,
    plays,
    starts_game,
    words_of,
)
from oxbot.dialogue.wellformed import as_heard, ignores_the_person
from oxbot.errors import IllegalMoveError
from oxbot.game.board import (
    EMPTY,
    EMPTY_BOARD,
    ROBOT,
    USER,
    Board,
    Ending,
    Outcome,
    outcome,
    play,
    to_move,
)

_PLAYING = np.array([plays(act) for act in SYSTEM_ACTS])
"""The acts that play, as a mask: "let's play" and the moves."""
_STARTING = np.array([starts_game(act) for act in SYSTEM_ACTS])
"""The acts that start a game before it is on: those and "your turn"."""

_GRANTS = (
    (ACTION_INDEX[GRANT_REFUSAL], frozenset(REFUSALS)),
    (ACTION_INDEX[GRANT_STOP], frozenset({STOP})),
)
"""The acknowledgements and the answers each acts on ("Okay, maybe another time." a no)."""
_LEAVING = np.array([act in (GRANT_REFUSAL, CLOSING) for act in SYSTEM_ACTS])
"""What lets a person go before a game: acknowledging a no, the goodbye."""

if TYPE_CHECKING:
    from oxbot.dialogue.features import FeatureLayout

Heard = tuple[tuple[str, float], ...]
"""Words as the recogniser heard them, each with its confidence in [0, 1]."""
ASKING_TO_PLAY = frozenset({INVITATION, ASK_AGAIN})

_NO_OR_STOP = frozenset({STOP, *REFUSALS})
_CLOSING = ACTION_INDEX[CLOSING]
_ANSWERING = np.array([act in (*ASKING_TO_PLAY, CLOSING, MOVE_REQUEST) for act in SYSTEM_ACTS])
"""The acts that can break a rule about a no or a stop heard: asking to play, the goodbye,
asking for a move."""


class OffersActs(Protocol):
    """What offers acts in a state: Pr(a|s) and the action mask (paper §2.2). The Naive Bayes
    `oxbot.dialogue.action_model.ActionModel` is one; it learns from replayed states, so it sits
    above this module and is named here only by what it does."""

    def offered(
        self, state: np.ndarray, board: Board, robot_to_move: bool
    ) -> tuple[np.ndarray, np.ndarray]: ...


class DialogueState:
    """The board, who started, the acts said, the last words on both sides, the transcript.

    `layout` turns the state into features; `action_model`, when given, says which acts are
    offered in it (the seed dialogues that train the action model are replayed without one).
    """

    def __init__(
        self,
        layout: FeatureLayout,
        robot_starts: bool = True,
        action_model: OffersActs | None = None,
    ) -> None:
        self.layout = layout
        self.action_model = action_model
        self.robot_starts = bool(robot_starts)
        self.board: Board = EMPTY_BOARD
        self.said: set[str] = set()
        """Every act the robot has said in this dialogue."""
        self.last_act = ""
        """The robot's last act ("" before its first)."""
        self.system_words: Sequence[str] = ()
        """The words of the robot's last act (none after a turn it could not take)."""
        self.heard: Heard = ()
        """The person's words since the robot's last act, as heard."""
        self.understood: tuple[str, float] | None = None
        """The act the person's words since the robot's last act were understood as, with the
        understanding's score (None: nothing said)."""
        self.person_acts: list[str] = []
        """Every act the person's turns were understood as, in order."""
        self.answers_from = 0
        """Where in `person_acts` the answers that count begin: asking again ("Sorry, I didn't
        catch that.") makes every answer before it count for nothing."""
        self.acted_on_answer = False
        """Whether the robot has acted on the person's last answer or drawing
        (`domain.acts_on_an_answer`) and they have said nothing since: it may not say now that
        it did not catch it."""
        self.invitations = 0
        """How many times the robot has asked to play (invited, or asked again)."""
        self.refused_unasked = False
        """Whether the person said no before the robot first asked to play ("no thanks" to
        its greeting): the robot may then ask once, as after any no."""
        self.heard_a_no_or_stop = False
        """Whether the person was ever understood saying no or asking to stop."""
        self.stop_is_final = False
        """Whether asking for the person's move would not let their stop go: they asked to stop
        twice, or once clearly (`SURE_NO`), with no yes and no drawing since. Counted as
        `wellformed` counts it."""
        self._no_count = _NoCount()
        self._stops_in_a_row = 0
        self.transcript: list[Turn] = []
        self.understood_turns: list[str] = []
        """For each turn of the transcript, the act it was understood as (the robot's own turns
        and drawings: their act)."""
        self.understood_scores: list[float] = []
        """For each turn of the transcript, the understanding's score of `understood_turns`
        (1.0 for the robot's own turns and drawings)."""
        self._features: np.ndarray | None = None

    # --- the game ---------------------------------------------------------------------------

    @property
    def outcome(self) -> Outcome | None:
        """The game's result from the robot's side once it is over, else None."""
        return outcome(self.board)

    @property
    def ending(self) -> Ending | None:
        """How the dialogue stands as the robot sees it: the game's result once it is over,
        "stopped" once the person was understood asking to stop, "declined" once they were
        understood saying no and never yes; else None (unfinished)."""
        if self.outcome is not None:
            return self.outcome
        if STOP in self.person_acts:
            return "stopped"
        if REFUSALS.intersection(self.person_acts) and ACCEPT not in self.person_acts:
            return "declined"
        return None

    @property
    def robot_to_move(self) -> bool:
        """True while the game is on and it is the robot's turn to draw."""
        return self.outcome is None and to_move(self.board, self.robot_starts) == ROBOT

    @property
    def person_to_move(self) -> bool:
        """True while the game is on and it is the person's turn to draw."""
        return self.outcome is None and to_move(self.board, self.robot_starts) == USER

    def can_do(self, act: str) -> bool:
        """Whether the robot can do `act` now: a GameMove needs its turn and an empty cell."""
        cell = game_move_cell(act)
        return cell is None or (self.board[cell] == EMPTY and self.robot_to_move)

    # --- what happens -----------------------------------------------------------------------

    def robot_says(self, act: str, text: str) -> None:
        """The robot says `act` in the words `text` (and draws, for a GameMove)."""
        cell = game_move_cell(act)
        if cell is not None:
            if not self.can_do(act):
                raise IllegalMoveError(f"the robot cannot play {act} now")
            self.board = play(self.board, cell, ROBOT)
        self.said.add(act)
        self.last_act = act
        self.invitations += act in ASKING_TO_PLAY
        if act == ASK_AGAIN:
            self.answers_from = len(self.person_acts)
        self.acted_on_answer = self.acted_on_answer or acts_on_an_answer(act)
        self._no_count.robot(act)
        self.system_words = _words(text)
        self.heard, self.understood = (), None
        self._turn("sys", act, text)

    def robot_informs(self, act: str, text: str) -> None:
        """The robot says something outside the policy's acts (about an impossible drawing):
        in the transcript, not in what the policy sees."""
        self._no_count.robot(act)
        self._turn("sys", act, text)

    def person_informs(self, act: str, text: str, score: float = 1.0) -> None:
        """The person said something the robot answers outside the policy's acts (a move in
        words it asks about): in the transcript, as understood as `act` with `score`, not in
        what the policy sees."""
        self._count_answer(act, score, drew=game_move_cell(act) is not None)
        self._turn("usr", act, text, act, score)

    def robot_skips(self) -> None:
        """The robot's act could not be done (a GameMove out of turn): nothing said or heard."""
        self.system_words, self.heard, self.understood = (), (), None
        self._features = None

    def person_says(
        self,
        act: str,
        text: str,
        heard: Heard | None = None,
        understood: tuple[str, float] | None = None,
    ) -> None:
        """The person's turn: they meant `act` and said `text`, heard as `heard` and
        understood as `understood` (an act and its score) when they spoke; None keeps what was
        heard and understood before (a drawing makes no sound). A GameMove act on a cell also
        puts the person's mark there. The transcript keeps `act`."""
        cell = game_move_cell(act)
        if cell is not None:
            self.board = play(self.board, cell, USER)
            self.acted_on_answer = True  # a drawing is seen, not heard, and taken as a move
        elif understood is not None:
            self.acted_on_answer = False  # words the robot has not acted on yet
        if heard is not None:
            self.heard = tuple(heard)
        if understood is not None:
            self.understood = understood
            self.person_acts.append(understood[0])
            if understood[0] in REFUSALS and self.invitations == 0:
                self.refused_unasked = True
        heard_as, score = understood if understood is not None else (act, 1.0)
        self._count_answer(heard_as, score, drew=cell is not None)
        self._turn("usr", act, text, heard_as, score)

    def _count_answer(self, act: str, score: float, drew: bool) -> None:
        """Keep `no_is_final` and `stop_is_final` up to date with an answer understood as `act`
        with `score` (`drew`: the person drew on the sheet, whatever was heard)."""
        self._no_count.person(act, score >= SURE_NO)
        if act == ACCEPT or drew:
            self._stops_in_a_row, self.stop_is_final = 0, False
        elif act == STOP:
            self._stops_in_a_row += 1
            self.stop_is_final = self._stops_in_a_row >= 2 or score >= SURE_NO or self.stop_is_final

    def _turn(
        self, speaker: str, act: str, text: str, understood: str = "", score: float = 1.0
    ) -> None:
        if speaker == "usr":
            self.heard_a_no_or_stop |= (understood or act) in _NO_OR_STOP
        self.transcript.append({"speaker": speaker, "act": act, "text": text})
        self.understood_turns.append(understood or act)
        self.understood_scores.append(float(score))
        self._features = None

    # --- how the policy sees it -------------------------------------------------------------

    def encode(self) -> np.ndarray:
        """The state's feature vector (`FeatureLayout`); do not modify it in place."""
        if self._features is None:
            self._features = self.layout.encode(self)
        return self._features

    @property
    def _yes_heard_last(self) -> bool:
        """Whether the person's last answer about playing (a yes, a no, a stop) was understood
        as a yes, counted or not: leaving then walks away from someone who said they would play
        (`wellformed.blame` puts that on the policy)."""
        answers = [act for act in self.person_acts if act in ANSWERS_ABOUT_PLAYING]
        return bool(answers) and answers[-1] == ACCEPT

    @property
    def no_is_final(self) -> bool:
        """Whether asking to play now would not let the person's no go: they said a clear no
        to the question ("no thanks" understood at `SURE_NO` or more), or the robot already
        asked once more after a no and they answered that too. Counted as `wellformed` counts
        it."""
        return self._no_count.final

    @property
    def game_started(self) -> bool:
        """Whether the robot has said an act after which the game is on (`starts_game`)."""
        return any(starts_game(act) for act in self.said)

    @property
    def counted_answers(self) -> list[str]:
        """What the person was understood to say since the robot last asked again (all of it
        if it never did): the answers it asked again about count for nothing."""
        return self.person_acts[self.answers_from :]

    @property
    def agreed(self) -> bool:
        """Whether the person has drawn on the sheet, or their last answer about a game was
        understood as yes (`ACCEPT`: "one game", "can I start" and a change of mind are one in
        context), not a no or a "later" said after it, nor said before the robot last asked
        again (`counted_answers`)."""
        if USER in self.board:
            return True
        answers = [act for act in self.counted_answers if act == ACCEPT or act in REFUSALS]
        return bool(answers) and answers[-1] == ACCEPT

    def offered(self) -> tuple[np.ndarray, np.ndarray]:
        """Pr(a|s) of every act and the action mask (paper §2.2), from the action model.

        Until the person was understood saying yes (and no no since) or drew (`agreed`), "let's
        play" and moves are never offered, whatever the learnt model offers, and asking again
        is: the policy met people who greeted or complained after "Sorry, I didn't catch that.
        Shall we play?" too rarely in training and started a game nobody agreed to. (A yes
        misheard still starts one: the check of `wellformed` can fail there.) Likewise, until
        the robot has invited the person, inviting is offered instead: a yes heard before it
        asked ("Hi!" heard as a no, then "Yes, I want to play.") left only "let's play". Before
        the game is on, "your turn" starts it, and is held back the same way.

        The robot never acts on an answer it said it did not catch, and never says it did not
        catch an answer it acted on. Once it asked again, the answers before count for nothing
        (`counted_answers`): a yes before it agrees to nothing (above), and a no or a stop
        before it is not acknowledged, the robot asks about it again instead. Once it acted on
        the person's last answer or drawing (`acted_on_answer`), asking again is not offered
        until they say something new. Before a game, a person whose last answer about playing
        was understood as yes is not let go (a no acknowledged, the goodbye): the robot plays,
        or asks, as it heard. Once it heard a no or a stop, it never asks again after a clear
        no or two, nor says goodbye before acknowledging them (`_letting_them_go`). (The rules
        about the board live in `action_mask`.)"""
        if self.action_model is None:
            raise TypeError("this DialogueState has no action model to offer acts with")
        probs, mask = self.action_model.offered(self.encode(), self.board, self.robot_to_move)
        uninvited = INVITATION not in self.said
        if not self.agreed or uninvited:
            # where the model would start a game, the robot asks whether the person wants one
            starting = _PLAYING if self.game_started else _STARTING
            if (mask & starting).any():
                mask = mask & ~starting
                mask[ACTION_INDEX[ASK_AGAIN if not self.agreed else INVITATION]] = True
        counted = set(self.counted_answers)
        for grant, needed in _GRANTS:
            if mask[grant] and needed.isdisjoint(counted):
                mask = mask.copy()
                mask[grant], mask[ACTION_INDEX[ASK_AGAIN]] = False, True
        if self._yes_heard_last and not self.game_started and (mask & ~_LEAVING).any():
            mask = mask & ~_LEAVING
        if self.acted_on_answer and mask[ACTION_INDEX[ASK_AGAIN]]:
            mask = mask.copy()
            mask[ACTION_INDEX[ASK_AGAIN]] = False
        if self.heard_a_no_or_stop and (mask & _ANSWERING).any():
            mask = self._letting_them_go(mask)
        return probs, mask

    def _letting_them_go(self, mask: np.ndarray) -> np.ndarray:
        """`mask` without the questions, requests for a move and goodbyes that, said now, would
        not let a no or a stop go as the robot understood them (`wellformed.ignores_the_person`
        read as heard): asking again after a clear no or two, a goodbye before the no or the
        stop is acknowledged. The acknowledgement is offered instead where nothing else is
        left. The policy once asked a third time after two unsure noes, and said goodbye
        straight after a stop heard, in about one dialogue of 5,000 with people who decline
        often and are heard badly."""
        heard = as_heard(self.transcript, self.understood_turns)
        understood, scores = self.understood_turns, self.understood_scores
        if ignores_the_person(heard, understood, scores) is not None:
            return mask  # a rule already broken, by a mishearing: no act can mend it

        def breaks(*acts: str) -> bool:
            said = [{"speaker": "sys", "act": act, "text": ""} for act in acts]
            problem = ignores_the_person(
                [*heard, *said], [*understood, *acts], [*scores, *[1.0] * len(acts)]
            )
            return problem is not None

        kept = mask.copy()
        for index in np.flatnonzero(mask & _ANSWERING):
            kept[index] = not breaks(SYSTEM_ACTS[index])
        if kept[_CLOSING] == mask[_CLOSING] and kept.any():
            return kept
        # the goodbye held back, or nothing left: the acknowledgement the robot may say (of an
        # answer it did not ask again about) after which it may say goodbye, and not another
        # (said again and again, "Okay, maybe another time" let no stop go). None (a stop it
        # asked again about, heard long before): the policy's own choice, though it break a rule
        counted = set(self.counted_answers)
        useful = [
            grant
            for grant, needed in _GRANTS
            if not needed.isdisjoint(counted) and not breaks(SYSTEM_ACTS[grant], CLOSING)
        ]
        if not useful:
            return kept if kept.any() else mask
        for grant, _ in _GRANTS:
            kept[grant] = grant in useful
        return kept

    def at(self, board: Board) -> DialogueState:
        """A copy of this state with the game at `board` (walking the game tree)."""
        twin = self.copy()
        twin.board = board
        return twin

    def copy(self) -> DialogueState:
        """An independent copy (the layout and action model are shared)."""
        twin = copy.copy(self)
        twin.said = set(self.said)
        twin.person_acts = list(self.person_acts)
        twin.transcript = list(self.transcript)
        twin.understood_turns = list(self.understood_turns)
        twin.understood_scores = list(self.understood_scores)
        twin._no_count = copy.copy(self._no_count)
        twin._features = None
        return twin


class _NoCount:
    """Whether a question to play would no longer let the person's no go, counted turn by turn
    as `wellformed` reads a finished dialogue: after a no (any refusal understood), one more
    question is allowed; a question about silence or chatter does not count. A clear "no
    thanks" to a question is final at once; a no after the game's feedback that answers no
    question ("oh no") counts for nothing."""

    def __init__(self) -> None:
        self.refused = self.answered = self.asked = self.over = self.clear_no = False
        self.asked_after_no = 0

    @property
    def final(self) -> bool:
        """True if asking to play now would break the rule."""
        return self.clear_no or (self.asked_after_no >= 1 and self.refused and self.answered)

    def robot(self, act: str) -> None:
        """The robot said `act`."""
        self.asked = act in ASKING_TO_PLAY
        self.over = self.over or is_feedback(act)
        if self.asked and self.refused and self.answered:
            self.asked_after_no += 1
        if self.asked:
            self.answered = False

    def person(self, act: str, clear: bool) -> None:
        """The person was understood saying `act` (`clear`: at `SURE_NO` or more)."""
        if self.over and not self.asked and act in REFUSALS:
            return
        self.answered = self.answered or act in ANSWERS_TO_PLAY
        self.refused = self.refused or act in REFUSALS
        self.clear_no = self.clear_no or (self.asked and act == DECLINE and clear)


@functools.lru_cache(maxsize=4096)
def _words(text: str) -> tuple[str, ...]:
    # the same few template texts come back every turn; the environment runs 30,000 a second
    return tuple(words_of(text))
