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
- not at all after acts nobody answers (only silence answers them, e.g. "Nice, let's play");
- `answer_timeout` seconds after acts a person may or may not answer (silence is one of the
  answers, e.g. "Hello!");
- `question_timeout` seconds after questions (silence is not an answer: "Would you like to
  play?"), and `move_timeout` seconds to draw after "Your turn". After `give_up_after` of
  these in a row waited out with no word or drawing, nobody is there: the robot says goodbye.
Words or a drawing that arrive while the robot is still talking or drawing count for the next
turn. The robot never talks while its arm moves: the act's words come first, then the arm,
and anything the robot has to say meanwhile (an impossible drawing) waits for ArmDone.

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
import dataclasses
import enum
import logging
import time
from collections.abc import Callable, Sequence

import numpy as np

from oxbot.config import OxbotConfig, RobotConfig
from oxbot.dialogue.cells_in_words import MoveHeard, move_in_words, read_cell
from oxbot.dialogue.domain import (
    ACCEPT,
    CLOSING,
    GAME_MOVE_TEMPLATE,
    MOVE_REQUEST,
    NEW_GAME,
    PROBLEM,
    REFUSALS,
    SILENCE,
    STOP,
    SYSTEM_ACTS,
    UNKNOWN,
    draw_tag,
    game_move,
    game_move_cell,
    is_game_move,
    words_of,
)
from oxbot.dialogue.model import build_dialogue_model
from oxbot.dialogue.policy import Policy, choose
from oxbot.dialogue.state import DialogueState, Turn
from oxbot.dialogue.understanding import UserAct
from oxbot.game.board import (
    CELL_NAMES,
    COLUMN_NAMES,
    EMPTY,
    PLURALS,
    ROBOT,
    ROW_NAMES,
    SIZE,
    USER,
    Board,
    Ending,
    cell_index,
    symbol_of,
)
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
    SheetMode,
    SpeakingFinished,
    SpeechHypotheses,
    Utterance,
)
from oxbot.speech.keywords import answer_to
from oxbot.speech.nbest import Hypothesis

log = logging.getLogger(__name__)

PROBLEM_SENTENCES = {
    "occupied_cell": "That cell is already taken. Please draw in an empty one.",
    "two_new_symbols": "I see two new symbols at once. Please draw one at a time.",
    "wrong_symbol": "You draw {person} and I draw {robot}.",
    "out_of_turn": "Please wait, it is my turn.",
    "not_started": "We have not started a game yet.",
    "game_over": "The game is over.",
    "unclear_symbol": "I cannot tell what is in {cell}. If it is your move, please draw a "
    "whole {shape}.",
}
"""What the robot says (as the act PROBLEM, not one the policy chooses) about an impossible
drawing, by the tracker's or the manager's problem kind."""
SHAPES = {"cross": "cross, two strokes crossing like an X", "circle": "circle, one closed loop"}
"""The person's symbol as `unclear_symbol` describes it: a plus or an arc is not one."""
GUIDANCE_SENTENCES = {
    "no_grid": "I cannot see the grid. Please hold the camera over the whole sheet.",
    "off_edge": "I can see only part of the sheet. Please move the camera so that I see all of it.",
    "too_close": "The camera is too close. Please hold it a little higher.",
    "too_dark": "It is too dark for me to see the sheet. Please turn on a light.",
    "blurred": "The picture is blurred. Please hold the camera still.",
    "hand": "A hand is in the way. Please take it off the sheet.",
}
"""What the robot says when its camera cannot show it the board (by the guidance's kind,
`oxbot.perception.guidance`), only while it waits for the person's drawing: at other times the
page shows it, and a stale instruction is worse than none."""
PAPER_MOVE = "I take {cell}."
"""What the robot says for its GameMove on real paper, where nobody sees an arm point."""
STOPPED_SENTENCE = "Sorry, my {part} stopped working, so we have to stop here. Goodbye."
"""The robot's goodbye when a part the game needs is lost for good (as the act CLOSING)."""
NOBODY_SENTENCE = "Nobody seems to be there, so I'll stop here. Goodbye."
"""The robot's goodbye (as the act CLOSING) after `give_up_after` unanswered questions."""
LOST_SENTENCES = {"hearing": "Sorry, my hearing has stopped working. Please type your answers."}
"""What the robot tells the person when a part the game can do without is lost, by part."""
WHICH_CELL = "Which cell do you mean? Say it like top left, the middle, or number five."
"""What the robot asks (as the act PROBLEM) when the person seems to name their cell in words
but not surely enough to play it (`speech.min_move_confidence`), or among other words."""
RESUMED_DRAWING_SECONDS = 8.0
"""How long a manager that took up a game mid-drawing (`resume`) waits for the arm's ArmDone,
at speed factor 1: the drawing's end may have gone with its predecessor process."""
TAKEN_IN_WORDS = "{cell} is already taken. Please pick an empty cell."
"""What the robot says (as the act PROBLEM) to a move in words on an occupied cell."""


def say_goodbye(bus: Bus, part: str, result: Ending | None) -> None:
    """The game ends in words because `part`, which the game needs, stopped for good."""
    sentence = STOPPED_SENTENCE.format(part=part)
    bus.publish(DialogueAct(speaker="sys", act=CLOSING, text=sentence))
    bus.publish(Utterance(text=sentence, act=CLOSING))
    bus.publish(DialogueEnded(outcome=result))


Understand = Callable[[Sequence[tuple[str, float]], str], UserAct]
"""Reads what the person said (an N-best list) in the context of the robot's last act as
their dialogue act with a score (`UserActClassifier.intent_of`)."""


def cell_in_words(cell: int) -> str:
    """A cell as a person says it: "the upper left", "the middle"."""
    row, column = ROW_NAMES[cell // SIZE], COLUMN_NAMES[cell % SIZE]
    return "the middle" if row == column == "middle" else f"the {row} {column}"


class Phase(enum.Enum):
    IDLE = "idle"
    SPEAKING = "speaking"
    DRAWING = "drawing"
    LISTENING = "listening"
    DONE = "done"


def spoken(text: str) -> str:
    """A template's words without its bracketed drawing tag: what the voice says."""
    return " ".join(text.split("[", 1)[0].split())


class InteractionManagerComponent(Component):
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
        elif isinstance(message, NewGame):
            self._reset(message.robot_starts)
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
            "_unanswered_in_a_row",
            "_early_answer",
            "_move_in_words",
        ):
            setattr(self, name, getattr(old, name))
        self._deadline, self._drawing_until = old._deadline, old._drawing_until

    def resume(self, game: Sequence[Message]) -> None:
        """Take up the game under way that a predecessor process left (oxbot.robot.resync):
        the dialogue replayed from `game`, then on from the robot's last act as if it had just
        been said. Its move is drawn if the arm had not started it; nothing said yet, it
        greets."""
        from oxbot.robot.resync import arm_started, replay_dialogue

        starts = [m.robot_starts for m in game if isinstance(m, (NewGame, GameState))]
        self._reset(starts[-1] if starts else True, publish=False)
        replay_dialogue(self.state, game)
        said = [t["text"] for t in self.state.transcript if t["speaker"] == "sys"]
        if not said:
            self._decide()
            return
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
        self._arm_cell: int | None = None
        self._rematch = False
        self._early_answer: SpeechHypotheses | None = None  # a yes or no before "Shall we play?"
        self._move_in_words: tuple[MoveHeard, Sequence[tuple[str, float]]] | None = None
        self._deferred: list[str] = []
        self._deadline = 0.0
        self._drawing_until = float("inf")  # only a resumed drawing has an end of its own
        self._unanswered_in_a_row = 0
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
        self._moved_since, self._spoke_since = False, False
        self._say(SYSTEM_ACTS[action])

    def _say(self, act: str, text: str | None = None) -> None:
        text = text if text is not None else self.model.template(act, self.rng)
        self.state.robot_says(act, text)
        self._arm_cell = game_move_cell(act)
        self._speaking = spoken(text)
        if self.paper and self._arm_cell is not None:
            # the policy keeps the template's words (above); the person hears the cell
            self._speaking = PAPER_MOVE.format(cell=cell_in_words(self._arm_cell))
            text = f"{self._speaking} [{text.split('[', 1)[1]}" if "[" in text else self._speaking
        self._publish_turn("sys", act, text)
        if self._arm_cell is not None:
            self._publish_game()
        self.phase = Phase.SPEAKING
        self.bus.publish(Utterance(text=self._speaking, act=act))

    def _last_sentence(self) -> str:
        robot = [t["text"] for t in self.state.transcript if t["speaker"] == "sys"]
        return robot[-1] if robot else ""

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
                self.bus.publish(NewGame(robot_starts=self.state.robot_starts))
            return
        self.phase = Phase.LISTENING
        for sentence in self._deferred:
            self._tell(sentence)
        self._deferred.clear()
        if self._early_answer is not None and self.state.invitations:
            early, self._early_answer = self._early_answer, None
            self._heard(early)  # now it answers the question
            return
        if self._expects_move():
            wait = self.timing.move_timeout
        elif last_act in self._unanswered:
            wait = 0.0
        elif last_act in self._questions:
            wait = self.timing.question_timeout
        else:
            wait = self.timing.answer_timeout
        self._deadline = time.monotonic() + wait / self.timing.speed_factor
        if self._moved_since or (self._spoke_since and self._words_need_an_answer()):
            self._decide()  # the answer came while the robot was still busy

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

    # --- the person ---

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
        if self._persons_turn():
            move = move_in_words(nbest)
            if move is not None:  # "top left": the person's move, said instead of drawn
                self._moved_in_words(move, words)
                return
        reading = self._understand(nbest, self.state.last_act)
        if (
            self._persons_turn()
            and reading.act in (UNKNOWN, GAME_MOVE_TEMPLATE)
            and read_cell(text) is not None
        ):
            # a cell among other words ("I'll go in the middle this time"): which one, if any?
            self._ask_which_cell(UNKNOWN, text)
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
        if reading.act == NEW_GAME and (self.state.game_started or self.state.outcome is not None):
            self._rematch = True  # after this dialogue's goodbye, another game
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

    def _heard_after_goodbye(self, message: SpeechHypotheses) -> None:
        """After the goodbye the robot only listens for a new game ("again!", "new game")."""
        if (
            message.nbest
            and not self._broken
            and self._understand(message.nbest, "").act == NEW_GAME
        ):
            self.bus.publish(NewGame(robot_starts=self.state.robot_starts))

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
        self._unanswered_in_a_row = 0
        self.state.person_informs(act, text, score)
        self._publish_turn("usr", act, text)
        self._aside(WHICH_CELL)

    def _aside(self, sentence: str) -> None:
        """Say `sentence` (as PROBLEM) now if the robot is listening, else after its act."""
        if self.phase is Phase.LISTENING:
            self._tell(sentence)
        else:
            self._deferred.append(sentence)  # never over the robot's own words or arm

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
        starts = self.state.robot_starts
        sentence = PROBLEM_SENTENCES.get(kind, "Something is wrong on the sheet.").format(
            person=PLURALS[symbol_of(USER, starts)],
            robot=PLURALS[symbol_of(ROBOT, starts)],
            shape=SHAPES[symbol_of(USER, starts)],
            cell=cell_in_words(CELL_NAMES.index(cells[0])) if cells else "a cell",
        )
        self._aside(sentence)

    def _lost(self, message: ComponentLost) -> None:
        """A part is gone for good: say goodbye now if the game needs it, else tell the person."""
        if message.component == self.name:
            return
        if not message.essential:
            sentence = LOST_SENTENCES.get(message.part)
            if sentence is not None and self.phase is Phase.LISTENING:
                self._tell(sentence)
            elif sentence is not None:
                self._deferred.append(sentence)
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

    def _tell(self, sentence: str) -> None:
        self.state.robot_informs(PROBLEM, sentence)
        self._publish_turn("sys", PROBLEM, sentence)
        self.bus.publish(Utterance(text=sentence, act=PROBLEM))

    def _publish_turn(self, speaker: str, act: str, text: str) -> None:
        self.bus.publish(DialogueAct(speaker=speaker, act=act, text=text))

    def _publish_game(self) -> None:
        state = self.state
        self.bus.publish(GameState(board=state.board, robot_starts=state.robot_starts))
