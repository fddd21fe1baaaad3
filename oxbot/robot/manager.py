"""The interaction manager as a component: the trained policy talking and drawing for real.

Paper §3.1: the interaction manager (SimpleDS) takes the latest speech and game moves, builds
the state, acts greedily with the trained policy among the acts the Naive Bayes mask offers,
and verbalises the act through the templates; a GameMove also moves the arm, and the next
utterance waits until the arm is done. The policy is any `oxbot.dialogue.policy.Policy`:
`[robot] policy` (`oxbot play --policy`) names another trained one (an oxbot policy file, an
SB3 model), and `[robot] manager` (`oxbot play --manager`) may put the baselines the policy is
compared with in its place (`oxbot.dialogue.baselines`: the rules, the script), their scores in
the Q-values' place.

One turn here is what one environment step is in training (`oxbot.dialogue.env`): the robot
says an act (and for a GameMove then draws it), then listens for the person's answer — their
words, their drawing, or silence — and decides again. How long it listens follows the domain's
user responses:
- not at all after acts nobody answers (only silence answers them, e.g. "Nice, let's play"),
  unless the person began to speak over it (barge-in, `oxbot.robot.listening`);
- `answer_timeout` seconds after acts a person may or may not answer (silence is one of the
  answers, e.g. "Hello!");
- `question_timeout` seconds after questions (silence is not an answer: "Would you like to
  play?"), and `move_timeout` seconds to draw after "Your turn". After `give_up_after` of
  these in a row waited out with no word or drawing, nobody is there: the robot says goodbye.
After an act a person may or may not answer, the robot pauses `pause_timeout` seconds and goes
on, unless the person begins to answer meanwhile (PersonAnswering: speech starting,
push-to-talk, a key in the answer box), when it waits `answer_timeout` for their words.
Words or a drawing that arrive while the robot is still talking or drawing count for the next
turn. The robot never talks while its arm moves: the act's words come first, then the arm,
and anything the robot has to say meanwhile (an impossible drawing) waits for ArmDone.

The person's side of a turn (their words and drawings read into the dialogue, moves said in
words, "new game", the problem sentences) is `oxbot.robot.person_input.PersonInput`, mixed in
here.

Around the games, the visit's conversation (`oxbot.dialogue.asides`):
- the robot greets and introduces itself once a visit: every later dialogue takes those turns
  up unsaid (`NewGame.carried`), and so does a manager process respawned mid-visit;
- who starts, its name, and "say that again" are answered in any state, outside the policy's
  acts, and the dialogue goes on where it was;
- after a game played out, it offers another (`robot.offer_another_game`): a clear yes ends
  this dialogue without a goodbye and starts the next, which takes up the question and the
  yes; a no or a goodbye gets the closing; anything else gets the offer once more;
- after its goodbye, a late yes still plays, and other words get `AFTER_GOODBYE`;
- when "Okay, maybe another time." is answered with a bare yes ("yes", "yeah"), it asks "Do
  you want to play after all?": a yes then is the person's yes to playing, which the policy
  answers; anything else, or silence, is read as after "maybe another time".

On real paper (SheetMode) the robot has no arm that reaches the sheet: it says where
it plays ("I take the upper left.") instead of "I take this one"; the policy still sees the
template's words, as in training, and the simulated arm still "draws" (the page shows its
strokes over the video). When the camera cannot show the board while the robot waits for the
person's drawing, it says why and what to do (the eyes' guidance, `GUIDANCE_SENTENCES`).

When a part fails (see `oxbot.robot.bus`), the game goes on if it can:
- the manager itself raising is restarted with its dialogue state as it was (the game on the
  board, the turns so far) and decides again; hanging, it is replaced by a fresh manager that
  takes over a copy of that state and decides again (and reads the messages its predecessor
  had not read); a NewGame it failed on is handled again;
- the voice and the arm handle again the sentence or the drawing they failed on, since the
  manager waits for them;
- a part the game needs (voice, arm, eyes) that is lost for good (its restart budget spent) makes
  the robot say so in words ("Sorry, my arm stopped working, so we have to stop here.
  Goodbye.") and end the dialogue at once, without waiting for a voice or arm that may be gone;
  when the manager is the lost part, `oxbot.robot.session.Robot` says it instead;
- lost hearing is told ("please type your answers"), and the game goes on; a lost head goes
  unsaid. Words a failing recogniser loses are silence for that turn, which the dialogue
  handles as it always does (it asks again).
"""

from __future__ import annotations

import copy
import logging
import time
from collections.abc import Sequence

import numpy as np

from oxbot.config import OxbotConfig, RobotConfig
from oxbot.dialogue.asides import HOLD, NAME, REPEAT, RULES
from oxbot.dialogue.cells_in_words import MoveHeard
from oxbot.dialogue.domain import (
    ACCEPT,
    AFTER_ALL,
    CLOSING,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
    OFFER_ANOTHER,
    PROBLEM,
    REFUSALS,
    SILENCE,
    STOP,
    STOP_QUESTION,
    SYSTEM_ACTS,
    YES_QUESTION,
    game_move_cell,
    is_feedback,
)
from oxbot.dialogue.model import build_dialogue_model
from oxbot.dialogue.policy import Policy, choose
from oxbot.dialogue.situated import situated_sentence
from oxbot.dialogue.state import DialogueState, Turn
from oxbot.game.board import CELL_NAMES, ROBOT, Board, symbol_of
from oxbot.peers import load_robot_policy
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import (
    ArmCommand,
    ArmDone,
    BoardProblem,
    ComponentJoined,
    ComponentLost,
    Decision,
    DialogueAct,
    DialogueEnded,
    GameMove,
    GameState,
    Message,
    NewGame,
    PersonAnswering,
    SheetMode,
    SpeakingFinished,
    SpeechHypotheses,
    Utterance,
)
from oxbot.robot.person_input import PersonInput, Phase, Understand
from oxbot.robot.resync import replay_dialogue
from oxbot.robot.sentences import (
    AFTER_ALL_SENTENCE,
    GUIDANCE_SENTENCES,
    HOLD_SENTENCE,
    LOST_SENTENCES,
    NOBODY_SENTENCE,
    OFFER_SENTENCES,
    PAPER_MOVE,
    PROBLEM_SENTENCES,
    RULES_SENTENCE,
    SHAPES,
    STOP_QUESTION_SENTENCE,
    STOPPED_SENTENCE,
    TAKEN_IN_WORDS,
    WHICH_CELL,
    WHO_STARTS_SENTENCES,
    YES_QUESTION_SENTENCE,
    cell_in_words,
    say_goodbye,
    spoken,
    symbol_names,
)

__all__ = [  # with the names of the modules split from this one, importable from here as before
    "GUIDANCE_SENTENCES",
    "LOST_SENTENCES",
    "NOBODY_SENTENCE",
    "PAPER_MOVE",
    "PROBLEM_SENTENCES",
    "RESUMED_DRAWING_SECONDS",
    "SHAPES",
    "STOPPED_SENTENCE",
    "TAKEN_IN_WORDS",
    "WHICH_CELL",
    "InteractionManagerComponent",
    "Phase",
    "Understand",
    "cell_in_words",
    "say_goodbye",
    "spoken",
]

log = logging.getLogger(__name__)

RESUMED_DRAWING_SECONDS = 8.0
"""How long a manager that took up a game mid-drawing (`resume`) waits for the arm's ArmDone,
at speed factor 1: the drawing's end may have gone with its predecessor process."""


class InteractionManagerComponent(PersonInput, Component):
    """Greedy dialogue and game policy of the robot; starts a dialogue on NewGame.

    Its `state` is a `DialogueState`, driven as the training environment drives it; only the
    person's answers differ: here they come from the recogniser, the keyboard and the camera.
    Others learn of the dialogue through the bus: DialogueAct for each turn, GameState for
    each change of the board, Decision for each choice.
    """

    listens_to = (
        NewGame,
        SpeechHypotheses,
        GameMove,
        SpeakingFinished,
        ArmDone,
        BoardProblem,
        ComponentLost,
        ComponentJoined,
        SheetMode,
        PersonAnswering,
    )
    retries = (NewGame,)  # else it restarts deciding again from the dialogue so far
    period = 0.02
    part = "mind"

    def __init__(
        self,
        bus: Bus,
        policy: Policy | None = None,
        config: OxbotConfig | None = None,
        understand: Understand | None = None,
        rng: np.random.Generator | None = None,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        self.config = config if config is not None else OxbotConfig()
        self.model = build_dialogue_model(self.config)
        self.policy = policy if policy is not None else load_robot_policy(self.config)
        self.rng = rng if rng is not None else np.random.default_rng()
        self._understand = understand or self.model.understanding.intent_of
        domain = self.model.domain
        answers = {act: {u.act for u in domain.responses_to(act)} for act in SYSTEM_ACTS}
        self._unanswered = {act for act, a in answers.items() if a <= {SILENCE}}
        self._questions = {act for act, a in answers.items() if a and SILENCE not in a}
        self.phase = Phase.IDLE
        self.paper = False
        """Whether the sheet is real paper under a camera (SheetMode)."""
        self._introductions: tuple[tuple[str, str, str], ...] = ()
        """The greeting and introduction the robot said in this visit: said once, taken up
        by every dialogue after (`NewGame.carried`)."""
        self._reset(True, publish=False)  # a replacement must not announce an empty board

    @property
    def timing(self) -> RobotConfig:
        """The waits (`answer_timeout`, `question_timeout`, `move_timeout`, `speed_factor`)."""
        return self.config.robot

    # --- what others may read (the bus carries the same) ---

    @property
    def board(self) -> Board:
        return self.state.board

    @property
    def robot_starts(self) -> bool:
        return self.state.robot_starts

    @property
    def transcript(self) -> list[Turn]:
        """The dialogue so far as `{"speaker", "act", "text"}` dicts, like the environment's."""
        return list(self.state.transcript)

    # --- messages ---

    def handle(self, message: Message) -> None:
        if isinstance(message, SheetMode):
            self.paper = message.paper
        elif isinstance(message, PersonAnswering):
            self._person_answering()
        elif isinstance(message, NewGame):
            self._reset(message.robot_starts)
            self._take_up(message.carried)
            self._decide()
        elif self.phase is Phase.DONE and isinstance(message, SpeechHypotheses):
            self._heard_after_goodbye(message)
        elif self.phase in (Phase.IDLE, Phase.DONE):
            if isinstance(message, ComponentLost) and message.essential:
                self._broken = True  # between games: no spoken rematch with the part gone
            return
        elif isinstance(message, SpeechHypotheses):
            self._heard(message)
        elif isinstance(message, GameMove):
            self._moved(message)
        elif isinstance(message, BoardProblem):
            self._problem(message.kind, message.cells)
        elif isinstance(message, ComponentLost):
            self._lost(message)
        elif isinstance(message, ComponentJoined):
            self._rejoined(message)
        elif isinstance(message, SpeakingFinished):
            if self.phase is Phase.SPEAKING and message.text == self._speaking:
                self._spoke()
        elif isinstance(message, ArmDone) and self.phase is Phase.DRAWING:
            self._listen()

    def tick(self) -> None:
        if self.phase is Phase.DRAWING and time.monotonic() >= self._drawing_until:
            self._listen()  # a resumed drawing whose end went with the predecessor process
            return
        if self.phase is Phase.LISTENING and time.monotonic() >= self._deadline:
            # nothing came since the robot's act, or it would have decided already
            self._unanswered_in_a_row += (
                self._expects_move() or self.state.last_act in self._questions
            )
            give_up = self.timing.give_up_after
            if give_up and self._unanswered_in_a_row >= give_up:
                self._say(CLOSING, NOBODY_SENTENCE)  # nobody there: no more questions to the room
            else:
                self._decide()

    def restart(self) -> None:
        # Carry on from the board and dialogue so far: decide again at the next tick.
        if self.phase not in (Phase.IDLE, Phase.DONE):
            self.phase, self._deadline = Phase.LISTENING, 0.0

    def take_over(self, old: Component) -> None:
        assert isinstance(old, InteractionManagerComponent)
        # A copy, so the hung thread cannot change this game should it wake; the models it
        # points to are read-only and stay shared.
        state = old.state
        keep = {id(state.layout): state.layout, id(state.action_model): state.action_model}
        self.state = copy.deepcopy(state, keep)
        self.rng, self.phase, self._deferred = old.rng, old.phase, list(old._deferred)
        self.paper = old.paper
        for name in (
            "_moved_since",
            "_spoke_since",
            "_heard_act",
            "_speaking",
            "_arm_cell",
            "_rematch",
            "_agreed_words",
            "_unanswered_in_a_row",
            "_early_answer",
            "_move_in_words",
            "_introductions",
            "_offers",
            "_offering",
            "_asking_after_all",
            "_after_all_due",
            "_asking_to_stop",
            "_asking_whether_yes",
            "_asked_whether_yes",
            "_answering",
            "_pausing",
        ):
            setattr(self, name, getattr(old, name))
        self._deadline, self._drawing_until = old._deadline, old._drawing_until

    def resume(self, game: Sequence[Message]) -> None:
        """Take up the game under way that a predecessor process left (oxbot.robot.resync):
        the dialogue replayed from `game`, then on from the robot's last act as if it had just
        been said. Its move is drawn if the arm had not started it; nothing said yet in this
        dialogue, it decides its first act (a greeting only if the visit had none)."""
        from oxbot.robot.resync import arm_started

        starts = [m.robot_starts for m in game if isinstance(m, (NewGame, GameState))]
        self._reset(starts[-1] if starts else True, publish=False)
        carried = [m.carried for m in game if isinstance(m, NewGame)]
        taken_up = carried[-1] if carried else ()
        acts = [m.act for m in game if isinstance(m, DialogueAct) and m.speaker == "sys"]
        if not taken_up and acts and acts[0] != GREETING:
            # the dialogue took up the visit's greeting unsaid, from its predecessor's memory
            taken_up = tuple(
                ("sys", act, self.model.template(act, self.rng)) for act in (GREETING, INTRODUCTION)
            )
        self._take_up(taken_up)
        replay_dialogue(self.state, game, self.model.domain.templates_for)
        if not acts:  # the dialogue's first act unheard by anyone, or none yet: (re)decide it
            self._decide()
            return
        said = [t["text"] for t in self.state.transcript if t["speaker"] == "sys"]
        self._speaking = spoken(said[-1])
        self._arm_cell = game_move_cell(self.state.last_act)
        if self._arm_cell is None or self.state.board[self._arm_cell] != ROBOT:
            self._arm_cell = None
            self._listen()
            return
        self.phase = Phase.DRAWING
        # its ArmDone may be gone with the predecessor: wait for the arm only so long
        self._drawing_until = time.monotonic() + RESUMED_DRAWING_SECONDS / self.timing.speed_factor
        if not arm_started(game, self._arm_cell):
            symbol = symbol_of(ROBOT, self.state.robot_starts)
            self.bus.publish(ArmCommand(where=CELL_NAMES[self._arm_cell], symbol=symbol))

    # --- the turn ---

    def _reset(self, robot_starts: bool, publish: bool = True) -> None:
        self.state: DialogueState = self.model.new_state(robot_starts)
        self._moved_since = False
        self._spoke_since = False
        self._heard_act = ""  # the act of the person's last words
        self._speaking = ""
        self._spoken_last = ""  # the robot's last sentence as said, never said twice in a row
        self._arm_cell: int | None = None
        self._rematch = False
        self._agreed_words = "yes"  # how the person asked for another game, when they did
        self._early_answer: SpeechHypotheses | None = None  # a yes or no before "Shall we play?"
        self._move_in_words: tuple[MoveHeard, Sequence[tuple[str, float]]] | None = None
        self._deferred: list[tuple[str, str]] = []  # (act, sentence) to say after the act
        self._offers = 0  # times another game was offered after this one
        self._offering = False  # the robot waits for the answer to its offer
        self._asking_after_all = False  # ... or to "Do you want to play after all?"
        self._after_all_due = False  # that question, once the robot's act is over
        self._asking_to_stop = False  # ... or to "Do you want to stop?"
        self._asking_whether_yes = False  # ... or to "Sorry, was that a yes?"
        self._asked_whether_yes = False  # asked since the policy's last act (once is enough)
        self._deadline = 0.0
        self._drawing_until = float("inf")  # only a resumed drawing has an end of its own
        self._unanswered_in_a_row = 0
        self._answering = False  # the person began to answer since the robot's last act
        self._pausing = False  # the robot waits a pause, not for an answer
        self._broken = False  # a part was lost: only Robot.new_game, which revives it, replays
        if publish:
            self._publish_game()

    def _decide(self) -> None:
        """Choose the next act greedily among the offered ones, and start saying it."""
        obs = self.state.encode()
        _, mask = self.state.offered()
        action, q = choose(self.policy, obs, mask)
        self.bus.publish(
            Decision(
                offered=tuple(a for a, m in zip(SYSTEM_ACTS, mask, strict=True) if m),
                q_values=tuple(round(float(v), 4) for v in q),
                chosen=SYSTEM_ACTS[action],
            )
        )
        unsure_stop = self._spoke_since and self._heard_act == STOP
        self._moved_since, self._spoke_since = False, False
        self._offering, self._answering, self._pausing = False, False, False
        self._asking_after_all, self._after_all_due = False, False
        self._asking_to_stop = False
        self._asking_whether_yes, self._asked_whether_yes = False, False
        act = SYSTEM_ACTS[action]
        if act == MOVE_REQUEST and unsure_stop:
            self._ask_whether_to_stop()  # rather than "Your move" to someone who said stop
            return
        if act == CLOSING and self.state.outcome is not None and not self._broken:
            if self._rematch:  # they asked for another game after this one: no goodbye
                self._play_again(self._agreed_words)
                return
            if self._may_offer():
                self._offer()
                return
        self._say(act)

    def _say(self, act: str, text: str | None = None) -> None:
        text = text if text is not None else self.model.template(act, self.rng, self._spoken_last)
        self.state.robot_says(act, text)
        self._arm_cell = game_move_cell(act)
        self._speaking = spoken(text)
        if self._arm_cell is not None:
            # the policy keeps the template's words (above); the person hears why it plays
            # there, and on paper, where no arm points, the cell too
            where = PAPER_MOVE.format(cell=cell_in_words(self._arm_cell)) if self.paper else ""
            self._speaking = situated_sentence(
                self.state.transcript,
                where or self._speaking,
                self.rng,
                self._spoken_last,
                says_where=self.paper,
            )
            text = f"{self._speaking} [{text.split('[', 1)[1]}" if "[" in text else self._speaking
        self._spoken_last = self._speaking
        if act in (GREETING, INTRODUCTION) and act not in {a for _, a, _ in self._introductions}:
            self._introductions += (("sys", act, text),)
        self._publish_turn("sys", act, text)
        if self._arm_cell is not None:
            self._publish_game()
        self.phase = Phase.SPEAKING
        self.bus.publish(Utterance(text=self._speaking, act=act))

    def _spoke(self) -> None:
        if self._arm_cell is None:
            self._listen()
            return
        self.phase, self._drawing_until = Phase.DRAWING, float("inf")
        symbol = symbol_of(ROBOT, self.state.robot_starts)
        self.bus.publish(ArmCommand(where=CELL_NAMES[self._arm_cell], symbol=symbol))

    def _listen(self) -> None:
        """The robot has finished its act: wait for the person, or end the dialogue."""
        last_act = self.state.last_act
        self._drawing_until = float("inf")
        if last_act == CLOSING:
            self.phase = Phase.DONE
            self.bus.publish(DialogueEnded(outcome=self.state.ending))
            if self._rematch:
                carried = self._carried(self._agreed_words)
                self.bus.publish(NewGame(robot_starts=self.state.robot_starts, carried=carried))
            return
        self.phase = Phase.LISTENING
        for act, sentence in self._deferred:
            self._tell(sentence, act)
        self._deferred.clear()
        if self._after_all_due:  # a bare yes came over "Okay, maybe another time."
            self._ask_after_all()
            return
        if self._early_answer is not None and self.state.invitations:
            early, self._early_answer = self._early_answer, None
            self._heard(early)  # now it answers the question
            return
        if self._expects_move():
            wait = self.timing.move_timeout
        elif self._asking_around_the_policy():
            wait = self.timing.question_timeout
        elif last_act in self._unanswered:
            # nobody answers it, but a person who spoke over it is waited for
            wait = self.timing.answer_timeout if self._answering else 0.0
        elif last_act in self._questions:
            wait = self.timing.question_timeout
        elif self.timing.pause_timeout and not self._answering:
            wait, self._pausing = self.timing.pause_timeout, True  # on, unless they begin
        else:
            wait = self.timing.answer_timeout
        self._deadline = time.monotonic() + wait / self.timing.speed_factor
        if self._moved_since or (self._spoke_since and self._words_need_an_answer()):
            self._decide()  # the answer came while the robot was still busy

    def _person_answering(self) -> None:
        """The person began to answer: a pause after an act they may answer becomes a wait
        for their answer."""
        if self.phase in (Phase.IDLE, Phase.DONE):
            return
        self._answering = True
        if self.phase is Phase.LISTENING and self._pausing:
            self._pausing = False
            answer = self.timing.answer_timeout / self.timing.speed_factor
            self._deadline = max(self._deadline, time.monotonic() + answer)

    def _aside(self, sentence: str, act: str = PROBLEM) -> None:
        """Say `sentence` (as `act`, outside the policy's acts) now if the robot is listening,
        else after its act."""
        if self.phase is Phase.LISTENING:
            self._tell(sentence, act)
        else:
            self._deferred.append((act, sentence))  # never over the robot's own words or arm

    def _lost(self, message: ComponentLost) -> None:
        """A part is gone for good: say goodbye now if the game needs it, else tell the person."""
        if message.component == self.name:
            return
        if not message.essential:
            sentence = LOST_SENTENCES.get(message.part)
            if sentence is not None and self.phase is Phase.LISTENING:
                self._tell(sentence)
            elif sentence is not None:
                self._deferred.append((PROBLEM, sentence))
            return
        sentence = STOPPED_SENTENCE.format(part=message.part)
        self.state.robot_says(CLOSING, sentence)
        self._publish_turn("sys", CLOSING, sentence)
        self.bus.publish(Utterance(text=sentence, act=CLOSING))
        # no waiting for the voice or the arm to finish: either may be the part that is gone
        self.phase, self._broken, self._rematch = Phase.DONE, True, False
        self.bus.publish(DialogueEnded(outcome=self.state.ending))

    def _rejoined(self, message: ComponentJoined) -> None:
        """A part's process came back (oxbot.robot.zenoh_bus): what died with its predecessor,
        the sentence or drawing this manager waits for, is asked again."""
        if message.part == "voice" and self.phase is Phase.SPEAKING:
            self.bus.publish(Utterance(text=self._speaking, act=self.state.last_act))
        elif message.part == "arm" and self.phase is Phase.DRAWING and self._arm_cell is not None:
            symbol = symbol_of(ROBOT, self.state.robot_starts)
            self.bus.publish(ArmCommand(where=CELL_NAMES[self._arm_cell], symbol=symbol))

    def _tell(self, sentence: str, act: str = PROBLEM) -> None:
        self.state.robot_informs(act, sentence)
        self._spoken_last = sentence
        self._publish_turn("sys", act, sentence)
        self.bus.publish(Utterance(text=sentence, act=act))

    # --- the visit's conversation around the games ---

    def _take_up(self, carried: Sequence[tuple[str, str, str]]) -> None:
        """Put the turns a new dialogue takes up (`NewGame.carried`; none: the visit's greeting
        and introduction, if it had them) in its state, unsaid: the policy goes on from them."""
        said = carried or self._introductions
        turns = [DialogueAct(speaker=speaker, act=act, text=text) for speaker, act, text in said]
        replay_dialogue(self.state, turns)
        self._introductions = tuple(t for t in said if t[1] in (GREETING, INTRODUCTION))

    def _carried(self, words: str) -> tuple[tuple[str, str, str], ...]:
        """What the next dialogue takes up when the person agreed to it in `words`."""
        invitation = self.model.template(INVITATION, self.rng)
        return (*self._introductions, ("sys", INVITATION, invitation), ("usr", ACCEPT, words))

    def _may_offer(self) -> bool:
        """Whether the robot asks about another game before its goodbye: the game was played
        out, and the person has not taken their leave since the feedback."""
        if not self.timing.offer_another_game or self._offers:
            return False
        turns = self.state.transcript
        told = max((i for i, t in enumerate(turns) if is_feedback(t["act"])), default=len(turns))
        leaving = {CLOSING, STOP, *REFUSALS}
        after = self.state.understood_turns[told + 1 :]
        return not any(act in leaving for act in after)

    def _offer(self) -> None:
        self._offers += 1
        sentence = next(
            (s for s in self.rng.permutation(OFFER_SENTENCES) if s != self._spoken_last),
            OFFER_SENTENCES[0],
        )
        self._ask(str(sentence), OFFER_ANOTHER)
        self._offering = True

    def _ask_after_all(self) -> None:
        self._asking_after_all = True
        if self.phase is not Phase.LISTENING:
            self._after_all_due = True  # never over the robot's own words or arm
            return
        self._after_all_due = False
        self._ask(AFTER_ALL_SENTENCE, AFTER_ALL)

    def _asking_around_the_policy(self) -> bool:
        """Whether the robot waits for the answer to a question it asked around the policy."""
        return (
            self._offering
            or self._asking_after_all
            or self._asking_to_stop
            or self._asking_whether_yes
        )

    def _ask(self, sentence: str, act: str) -> None:
        """Say a question of its own (`act`, outside the policy's acts) and, unlike a problem
        told, wait for its answer once it is said."""
        self._tell(sentence, act)
        self._speaking, self._arm_cell = sentence, None
        self.phase = Phase.SPEAKING

    def _ask_whether_yes(self) -> None:
        self._asking_whether_yes, self._asked_whether_yes = True, True
        self._ask(YES_QUESTION_SENTENCE, YES_QUESTION)

    def _ask_whether_to_stop(self) -> None:
        self._asking_to_stop = True
        self._ask(STOP_QUESTION_SENTENCE, STOP_QUESTION)

    def _play_again(self, words: str) -> None:
        """The person agreed to another game in `words`: this dialogue ends without a goodbye,
        and the next takes up the conversation (no greeting, no introduction, no question)."""
        self._offering, self._rematch = False, False
        self.phase = Phase.DONE
        self.bus.publish(DialogueEnded(outcome=self.state.ending))
        self.bus.publish(
            NewGame(robot_starts=self.state.robot_starts, carried=self._carried(words))
        )

    def _aside_answer(self, question: str) -> str | None:
        """The robot's answer to a question asked in passing (oxbot.dialogue.asides)."""
        if question == NAME:
            return spoken(self.model.template(INTRODUCTION, self.rng, self._spoken_last))
        if question == REPEAT:
            return self._spoken_last or None  # nothing said yet: the understanding reads it
        if question == RULES:
            return RULES_SENTENCE.format(**symbol_names(self.state.robot_starts))
        if question == HOLD:  # they want time: waited for as for an answer to a question
            wait = self.timing.question_timeout / self.timing.speed_factor
            self._deadline = max(self._deadline, time.monotonic() + wait)
            return HOLD_SENTENCE
        return self._whose_turn()

    def _whose_turn(self) -> str:
        """Who will start and with which symbol; during a game, whose turn it is."""
        state = self.state
        if state.game_started and state.outcome is None:
            kind = "your_turn" if state.person_to_move else "my_turn"
        else:
            kind = "robot" if state.robot_starts else "person"
        return WHO_STARTS_SENTENCES[kind].format(**symbol_names(state.robot_starts))

    def _publish_turn(self, speaker: str, act: str, text: str) -> None:
        self.bus.publish(DialogueAct(speaker=speaker, act=act, text=text))

    def _publish_game(self) -> None:
        state = self.state
        self.bus.publish(GameState(board=state.board, robot_starts=state.robot_starts))
