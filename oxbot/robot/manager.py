"""The interaction manager as a component: the trained policy talking and drawing for real.

Paper §3.1: the interaction manager (SimpleDS) takes the latest speech and game moves, builds
the state, acts greedily with the trained policy among the acts the Naive Bayes mask offers,
and verbalises the act through the templates; a GameMove also moves the arm, and the next
utterance waits until the arm is done.

One turn here is what one environment step is in training (`oxbot.dialogue.env`): the robot
says an act (and for a GameMove then draws it), then listens for the person's answer — their
words, their drawing, or silence — and decides again. How long it listens follows the domain's
user responses:
- not at all after acts nobody answers (only silence answers them, e.g. "Nice, let's play");
- `answer_timeout` seconds after acts a person may or may not answer (silence is one of the
  answers, e.g. "Hello!");
- `question_timeout` seconds after questions (silence is not an answer: "Would you like to
  play?"), and `move_timeout` seconds to draw after "Your turn".
Words or a drawing that arrive while the robot is still talking or drawing count for the next
turn. The robot never talks while its arm moves: the act's words come first, then the arm,
and anything the robot has to say meanwhile (an impossible drawing) waits for ArmDone.

The manager is the authority on the game: a move that is not legal on its board (typed moves
bypass the tracker) is refused in words and never changes the board.
"""

from __future__ import annotations

import enum
import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from oxbot.config import OxbotConfig
from oxbot.dialogue.agent import DQNPolicy, load_policy, masked_argmax
from oxbot.dialogue.domain import SYSTEM_ACTS, game_move_cell, words_of
from oxbot.dialogue.env import CLOSING, build_components
from oxbot.errors import ConfigError
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY,
    EMPTY_BOARD,
    ROBOT,
    USER,
    Board,
    cell_index,
    outcome,
    play,
    symbol_of,
    to_move,
)
from oxbot.robot.bus import Bus, Component
from oxbot.robot.messages import (
    ArmCommand,
    ArmDone,
    BoardProblem,
    Decision,
    DialogueAct,
    DialogueEnded,
    GameMove,
    Message,
    NewGame,
    SpeakingFinished,
    SpeechHypotheses,
    Utterance,
)

log = logging.getLogger(__name__)

PROBLEM_ACT = "Inform(problem)"
"""The act of the fixed sentences about impossible drawings: not one of the 18 learned acts."""
PROBLEM_SENTENCES = {
    "occupied_cell": "That cell is already taken. Please draw in an empty one.",
    "two_new_symbols": "I see two new symbols at once. Please draw one at a time.",
    "wrong_symbol": "You draw {person}s and I draw {robot}s.",
    "out_of_turn": "Please wait, it is my turn.",
    "game_over": "The game is over.",
}
MOVE_REQUEST = SYSTEM_ACTS.index("Request(userGameMove)")
Understand = Callable[[Sequence[tuple[str, float]]], str]
"""Maps what the person said (an N-best list) to their dialogue act, for the log."""


@dataclass(frozen=True)
class ManagerTiming:
    """How long the robot waits for the person."""

    answer_timeout: float = 4.0
    """Seconds to wait for an optional answer (to a greeting, say) before taking silence."""
    question_timeout: float = 30.0
    """Seconds to wait for the answer to a question before taking silence."""
    move_timeout: float = 30.0
    """Seconds to wait for the person's drawing after "Your turn"; then the robot asks again."""
    speed_factor: float = 1.0
    """How many times faster than real time the waits run (tests use large values)."""

    def __post_init__(self) -> None:
        waits = (self.answer_timeout, self.question_timeout, self.move_timeout)
        if min(waits) < 0 or self.speed_factor <= 0:
            raise ConfigError("timeouts cannot be negative and speed_factor must be positive")


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
    """Greedy dialogue and game policy of the robot; starts a dialogue on NewGame."""

    listens_to = (NewGame, SpeechHypotheses, GameMove, SpeakingFinished, ArmDone, BoardProblem)
    period = 0.02

    def __init__(
        self,
        bus: Bus,
        policy: DQNPolicy | None = None,
        timing: ManagerTiming = ManagerTiming(),
        config: OxbotConfig | None = None,
        understand: Understand | None = None,
        rng: np.random.Generator | None = None,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        self.config = config if config is not None else OxbotConfig()
        self.domain, self.layout, self.action_model = build_components(self.config.dialogue)
        self.policy = policy if policy is not None else load_policy()
        self.timing = timing
        self.rng = rng if rng is not None else np.random.default_rng()
        self._understand = understand
        answers = {act: {u.act for u in self.domain.responses_to(act)} for act in SYSTEM_ACTS}
        self._unanswered = {act for act, a in answers.items() if a <= {"Silence"}}
        self._questions = {act for act, a in answers.items() if a and "Silence" not in a}
        self.phase = Phase.IDLE
        self._reset(True)

    # --- what others may read ---

    @property
    def transcript(self) -> list[dict[str, str]]:
        """The dialogue so far as `{"speaker", "act", "text"}` dicts, like the environment's."""
        return list(self._transcript)

    # --- messages ---

    def handle(self, message: Message) -> None:
        if isinstance(message, NewGame):
            self._reset(message.robot_starts)
            self._decide()
        elif self.phase in (Phase.IDLE, Phase.DONE):
            return
        elif isinstance(message, SpeechHypotheses):
            self._heard(message)
        elif isinstance(message, GameMove):
            self._moved(message)
        elif isinstance(message, BoardProblem):
            self._problem(message.kind)
        elif isinstance(message, SpeakingFinished):
            if self.phase is Phase.SPEAKING and message.text == self._speaking:
                self._spoke()
        elif isinstance(message, ArmDone) and self.phase is Phase.DRAWING:
            self._listen()

    def tick(self) -> None:
        if self.phase is Phase.LISTENING and time.monotonic() >= self._deadline:
            self._decide()

    def restart(self) -> None:
        # Carry on from the board and dialogue so far: decide again at the next tick.
        if self.phase not in (Phase.IDLE, Phase.DONE):
            self.phase, self._deadline = Phase.LISTENING, 0.0

    # --- the turn ---

    def _reset(self, robot_starts: bool) -> None:
        self.robot_starts = robot_starts
        self.board: Board = EMPTY_BOARD
        self._said: set[str] = set()
        self._system_words: list[str] = []
        self._heard_words: tuple[tuple[str, float], ...] = ()
        self._moved_since = False
        self._spoke_since = False
        self._last_act = ""
        self._speaking = ""
        self._arm_cell: int | None = None
        self._deferred: list[str] = []
        self._deadline = 0.0
        self._transcript: list[dict[str, str]] = []

    def _decide(self) -> None:
        """Choose the next act greedily among the offered ones, and start saying it."""
        obs = self.layout.encode(
            self._system_words, self._heard_words, self.board, self.robot_starts, self._said
        )
        robot_to_move = bool(obs[self.layout.flags.start] > 0)
        _, mask = self.action_model.offered(
            obs, self.board, robot_to_move, self.config.reward.mask_threshold
        )
        q = self.policy.q_values(obs[None])[0]
        action = int(masked_argmax(q[None], mask[None])[0])
        self.bus.publish(
            Decision(
                offered=tuple(a for a, m in zip(SYSTEM_ACTS, mask, strict=True) if m),
                q_values=tuple(round(float(v), 4) for v in q),
                chosen=SYSTEM_ACTS[action],
            )
        )
        self._heard_words, self._moved_since, self._spoke_since = (), False, False
        self._say(action)

    def _say(self, action: int) -> None:
        act = SYSTEM_ACTS[action]
        templates = self.domain.templates_for(act)
        cell = game_move_cell(act)
        text = templates[int(self.rng.integers(len(templates)))]
        if cell is not None:
            text = text.replace("$loc", CELL_NAMES[cell])
            self.board = play(self.board, cell, ROBOT)
        self._said.add(act)
        self._system_words = words_of(text)
        self._last_act, self._arm_cell = act, cell
        self._log("sys", act, text)
        self._speaking = spoken(text)
        self.phase = Phase.SPEAKING
        self.bus.publish(Utterance(text=self._speaking, act=act))

    def _spoke(self) -> None:
        if self._arm_cell is None:
            self._listen()
            return
        self.phase = Phase.DRAWING
        symbol = symbol_of(ROBOT, self.robot_starts)
        self.bus.publish(ArmCommand(where=CELL_NAMES[self._arm_cell], symbol=symbol))

    def _listen(self) -> None:
        """The robot has finished its act: wait for the person, or end the dialogue."""
        if self._last_act == SYSTEM_ACTS[CLOSING]:
            self.phase = Phase.DONE
            self.bus.publish(DialogueEnded(outcome=outcome(self.board)))
            return
        self.phase = Phase.LISTENING
        for sentence in self._deferred:
            self._tell(sentence)
        self._deferred.clear()
        if self._expects_move():
            wait = self.timing.move_timeout
        elif self._last_act in self._unanswered:
            wait = 0.0
        elif self._last_act in self._questions:
            wait = self.timing.question_timeout
        else:
            wait = self.timing.answer_timeout
        self._deadline = time.monotonic() + wait / self.timing.speed_factor
        if self._moved_since or (self._spoke_since and not self._expects_move()):
            self._decide()  # the answer came while the robot was still busy

    def _expects_move(self) -> bool:
        return (
            self._last_act == SYSTEM_ACTS[MOVE_REQUEST]
            and not self._moved_since
            and outcome(self.board) is None
            and to_move(self.board, self.robot_starts) == USER
        )

    # --- the person ---

    def _heard(self, message: SpeechHypotheses) -> None:
        if not message.nbest:
            return  # the recogniser heard nothing: as if nobody spoke
        text, confidence = message.nbest[0]
        words = message.words or tuple((w, confidence) for w in words_of(text))
        act = self._user_act(message.nbest)
        self._log("usr", act, text)
        self._heard_words, self._spoke_since = tuple(words), True
        if self.phase is Phase.LISTENING and not (
            self._expects_move() and act.startswith("GameMove")
        ):
            self._decide()

    def _moved(self, message: GameMove) -> None:
        if message.who != "usr":
            return
        cell = cell_index(message.where)
        problem = self._illegal(cell, message.symbol)
        if problem is not None:
            self._problem(problem)
            return
        self.board = play(self.board, cell, USER)
        self._moved_since = True
        where = CELL_NAMES[cell]
        self._log("usr", f"GameMove(gridloc={where})", f"[who=usr what=draw where={where}]")
        if self.phase is Phase.LISTENING:
            self._decide()

    def _illegal(self, cell: int, symbol: str) -> str | None:
        """Why the person may not draw `symbol` in `cell` now, as a problem kind, or None."""
        if outcome(self.board) is not None:
            return "game_over"
        if self.board[cell] != EMPTY:
            return "occupied_cell"
        if to_move(self.board, self.robot_starts) != USER:
            return "out_of_turn"
        if symbol != symbol_of(USER, self.robot_starts):
            return "wrong_symbol"
        return None

    def _problem(self, kind: str) -> None:
        sentence = PROBLEM_SENTENCES.get(kind, "Something is wrong on the sheet.").format(
            person=symbol_of(USER, self.robot_starts), robot=symbol_of(ROBOT, self.robot_starts)
        )
        if self.phase is Phase.LISTENING:
            self._tell(sentence)
        else:
            self._deferred.append(sentence)  # never over the robot's own words or arm

    def _tell(self, sentence: str) -> None:
        self._log("sys", PROBLEM_ACT, sentence)
        self.bus.publish(Utterance(text=sentence, act=PROBLEM_ACT))

    def _user_act(self, nbest: Sequence[tuple[str, float]]) -> str:
        if self._understand is None:
            from oxbot.dialogue.understanding import UserActClassifier

            classifier = UserActClassifier(self.domain)
            self._understand = lambda heard: classifier.intent_of(heard).act
        return self._understand(nbest)

    def _log(self, speaker: str, act: str, text: str) -> None:
        self._transcript.append({"speaker": speaker, "act": act, "text": text})
        self.bus.publish(DialogueAct(speaker=speaker, act=act, text=text))
