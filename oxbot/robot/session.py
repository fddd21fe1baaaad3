"""The whole robot: every component on one bus, and the ways a person reaches it.

    from oxbot.robot.session import Robot
    with Robot() as robot:                   # starts; the robot greets
        events = robot.bus.subscribe()       # every message, in order
        robot.say("yes let's play")          # typed words
        robot.hear(wav_bytes)                # a push-to-talk recording
        robot.show(frame)                    # the sheet, as a camera sees it
        robot.draw("middle")                 # a typed move (no camera)
        robot.paper(True)                    # real paper under a camera: the robot says
                                             # where it plays

`Robot(config)` takes its settings from an `OxbotConfig` (`[game]` who starts, `[robot]` the
waits, speed, arm and head, `[speech]` the recogniser and voice, `[tracker]` the camera's
rate). The terminal (`oxbot play --terminal`), the web page (`oxbot play`) and the tests build
the same Robot; each browser tab has its own. The Robot talks to its components only through
messages on its bus, and learns the board and the dialogue from them too. Components that load
models (the classifier, the recogniser, the policy) share one copy per process. `[robot] manager`
picks the policy: the trained DQN, or the rules or the script it is compared with; `[robot]
policy` another trained one, and `[dialogue] domain` another domain (docs/extending.md).

The components run under a `Supervisor` (oxbot.robot.bus, with the `[robot]` restart budget and
hang deadline): a part that fails is restarted, a hung one replaced, and one lost for good is
said out loud (see oxbot.robot.manager); if the lost part is the interaction manager itself,
the Robot says the goodbye in its place. `stop` returns within about two seconds whatever the
components do: a thread still hung then is left behind as a daemon, told to stop, unable to
publish, and holding nothing of the robot's.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import logging
import os
import threading
import time
from collections.abc import Callable, Sequence

import numpy as np

from oxbot.config import DialogueConfig, OxbotConfig, RewardConfig, RobotConfig
from oxbot.dialogue.domain import Domain, Turn, load_domain, words_of
from oxbot.dialogue.policy import Policy
from oxbot.dialogue.situated import PHRASINGS
from oxbot.errors import InvalidInputError, OxbotError, SpeechUnavailable
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY_BOARD,
    N_CELLS,
    USER,
    Board,
    cell_index,
    outcome,
    symbol_of,
)
from oxbot.perception.sources import FrameSource
from oxbot.robot.arm import ArmComponent
from oxbot.robot.bus import Bus, Component, LocalBus, Supervisor
from oxbot.robot.frames import frame_message
from oxbot.robot.game_moves import GameMoveComponent
from oxbot.robot.head_movement import HeadMovementComponent
from oxbot.robot.head_tracking import HeadTracker, HeadTrackingComponent
from oxbot.robot.manager import (
    GUIDANCE_SENTENCES,
    LOST_SENTENCES,
    NOBODY_SENTENCE,
    PAPER_MOVE,
    STOPPED_SENTENCE,
    TAKEN_IN_WORDS,
    WHICH_CELL,
    InteractionManagerComponent,
    cell_in_words,
    say_goodbye,
    spoken,
)
from oxbot.robot.messages import (
    DialogueAct,
    DialogueEnded,
    GameMove,
    GameState,
    NewGame,
    PersonFrame,
    SheetMode,
    SourceEnded,
    SpeechAudio,
    SpeechHypotheses,
)
from oxbot.robot.sentences import (
    AFTER_ALL_SENTENCE,
    AFTER_GOODBYE,
    HOLD_SENTENCE,
    OFF_TOPIC_SENTENCE,
    OFFER_SENTENCES,
    PROBLEM_SENTENCES,
    RULES_SENTENCE,
    STOP_QUESTION_SENTENCE,
    WHO_STARTS_SENTENCES,
    YES_QUESTION_SENTENCE,
    symbol_names,
)
from oxbot.robot.voice import SpeechRecognitionComponent, SpeechSynthesisComponent
from oxbot.speech.audio import read_wav
from oxbot.speech.piper import PiperVoice
from oxbot.speech.recognition import Recognizer, load_recognizer
from oxbot.speech.synthesis import robot_voice

log = logging.getLogger(__name__)


def shared_policy(manager: str = "dqn", config: OxbotConfig | None = None) -> Policy:
    """The policy `manager` names (the trained policy, the rules or the script) for `config`'s
    `[robot] policy` and `[dialogue] domain` (`oxbot.peers.load_robot_policy`), loaded once
    per process."""
    config = config if config is not None else OxbotConfig()
    # the folder too: `policy` and `[dialogue] domain` may be paths relative to it
    where = os.getcwd()
    return _loaded_policy(manager, config.robot.policy, config.dialogue, config.reward, where)


@functools.cache
def _loaded_policy(
    manager: str, policy: str, dialogue: DialogueConfig, reward: RewardConfig, where: str
) -> Policy:
    from oxbot.peers import load_robot_policy

    config = OxbotConfig(dialogue=dialogue, reward=reward, robot=RobotConfig(policy=policy))
    return load_robot_policy(config, manager)


@functools.cache
def warm_up(config: OxbotConfig | None = None) -> None:
    """Load the shared models once (policy, understanding, classifier, voice, recogniser: a few
    seconds), so that the first game does not wait for them mid-sentence. A recogniser the config
    names but that cannot be built is a ConfigError here; one that is not installed only a
    warning."""
    from oxbot.dialogue.model import build_dialogue_model
    from oxbot.perception.board import default_reader

    config = config if config is not None else OxbotConfig()
    shared_policy(config.robot.manager, config)
    understanding = build_dialogue_model(config).understanding  # trained at first use (0.4 s)
    understanding.intent_of([("yes", 1.0)])
    default_reader(config.perception)
    robot_voice(config.speech)
    try:
        load_recognizer(config.speech)
    except SpeechUnavailable as exc:
        log.warning("speech recognition is off, type your answers instead: %s", exc)


ESSENTIAL_PARTS = ("voice", "arm", "eyes", "mind")
"""The parts a game cannot go on without, as the robot's goodbye names them."""


def robot_sentences(domain: Domain | None = None) -> list[str]:
    """Every distinct sentence the robot can say, the greetings first: each template's words
    (`domain`'s, the shipped by default), the interaction manager's own sentences with every
    cell and part name and its guidance about the camera, and the words it says about a move
    (`oxbot.dialogue.situated`, each a sentence of its own)."""
    domain = domain if domain is not None else load_domain()
    sentences = [spoken(t) for act in domain.templates for t in domain.templates_for(act)]
    cells = [cell_in_words(c) for c in range(N_CELLS)]
    sentences += [PAPER_MOVE.format(cell=c) for c in cells]
    sentences += [TAKEN_IN_WORDS.format(cell=c[0].upper() + c[1:]) for c in cells]
    sentences += [STOPPED_SENTENCE.format(part=p) for p in ESSENTIAL_PARTS]
    sentences += [*GUIDANCE_SENTENCES.values(), *LOST_SENTENCES.values()]
    sentences += [NOBODY_SENTENCE, WHICH_CELL, AFTER_GOODBYE, HOLD_SENTENCE, *OFFER_SENTENCES]
    sentences += [AFTER_ALL_SENTENCE, STOP_QUESTION_SENTENCE, YES_QUESTION_SENTENCE]
    sentences += [OFF_TOPIC_SENTENCE]
    sentences += [phrase for phrases in PHRASINGS.values() for phrase in phrases]
    for robot_starts in (True, False):
        names = symbol_names(robot_starts)
        starter = "robot" if robot_starts else "person"
        sentences += [
            WHO_STARTS_SENTENCES[kind].format(**names) for kind in (starter, "your_turn", "my_turn")
        ]
        sentences += [s.format(**names, cell=c) for s in PROBLEM_SENTENCES.values() for c in cells]
        sentences.append(RULES_SENTENCE.format(**names))
    return list(dict.fromkeys(s for s in sentences if s.strip()))


def _yield_to_games() -> None:
    """Lower the calling thread's CPU priority (Linux gives each thread its own nice value), so
    that sentences made ahead never slow a game that is being played meanwhile."""
    with contextlib.suppress(AttributeError, OSError):  # not Linux, or not allowed: as it is
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 19)


def prepare_voice(config: OxbotConfig) -> threading.Thread | None:
    """Load the robot's voice and make every sentence it can say with Piper in a background
    thread, greetings first (the voice keeps them), so that no sentence of a game waits for
    the network; None when the config chooses espeak-ng, which needs no preparing. When the
    process ends first, the thread stops after the sentence in hand."""
    if config.speech.voice != "piper":
        return None
    stop = threading.Event()

    def prepare() -> None:
        voice = robot_voice(config.speech)  # the one load the robots share
        if not isinstance(voice, PiperVoice):
            return  # espeak-ng, after robot_voice's warning
        _yield_to_games()
        started = time.perf_counter()
        try:
            domain = load_domain(config.dialogue.domain or None)  # --domain's templates
            made = voice.prepare(robot_sentences(domain), stop)
        except OxbotError as exc:  # Ctrl-C stops espeak-ng too; a game makes its sentences itself
            log.info("the robot's sentences were not all prepared: %s", exc)
            return
        log.info("%d sentences prepared in %.1f s", made, time.perf_counter() - started)

    def finish() -> None:  # ONNX Runtime aborts the process if it ends under a load or a run
        stop.set()
        thread.join(timeout=30)

    thread = threading.Thread(target=prepare, name="oxbot-voice-prepare", daemon=True)
    thread.start()
    atexit.register(finish)
    return thread


class Robot:
    """One robot: its components running on their own bus (see the module docstring).

    `sheet_camera` / `head_camera` are frame sources the robot reads itself; without them it
    sees only what `show` / `look` hand over. `recognizer` and `policy` replace the ones the
    config names (the shipped ones; `policy` is any `oxbot.dialogue.policy.Policy`); `seed`
    fixes the choice among templates and the arm's hand.
    `joining` makes more components on the robot's bus, each from the bus: a
    `oxbot.recording.Recorder` that keeps the games, say (`oxbot.recording.recorder.joining`).
    """

    def __init__(
        self,
        config: OxbotConfig | None = None,
        *,
        sheet_camera: FrameSource | None = None,
        head_camera: FrameSource | None = None,
        recognizer: Recognizer | None = None,
        policy: Policy | None = None,
        seed: int | None = None,
        joining: Sequence[Callable[[Bus], Component]] = (),
    ) -> None:
        self.config = config if config is not None else OxbotConfig()
        self.bus: Bus = LocalBus()
        body = self.config.robot
        manager_seed, arm_seed = np.random.default_rng(seed).integers(2**32, size=2)
        self._watching_sheet = sheet_camera is not None
        components: list[Component] = [
            InteractionManagerComponent(
                self.bus,
                policy=policy if policy is not None else shared_policy(body.manager, self.config),
                config=self.config,
                rng=np.random.default_rng(manager_seed),
            ),
            vision := GameMoveComponent(
                self.bus,
                self.config.game.robot_starts,
                source=sheet_camera,
                config=self.config.tracker,
                perception=self.config.perception,
            ),
            SpeechRecognitionComponent(self.bus, recognizer, self.config.speech),
            SpeechSynthesisComponent(
                self.bus, robot_voice(self.config.speech), speed_factor=body.speed_factor
            ),
            ArmComponent(
                self.bus,
                body.arm,
                rng=np.random.default_rng(arm_seed),
                speed_factor=body.speed_factor,
            ),
            HeadTrackingComponent(self.bus, HeadTracker(body.head), source=head_camera),
            HeadMovementComponent(self.bus),
        ]
        components.extend(make(self.bus) for make in joining)
        self._vision = vision.name
        self.supervisor = Supervisor(components, self.bus, body, on_lost=self._lost)
        self._follow_games()

    def _follow_games(self) -> None:
        """Subscribe to what `board`, `transcript` and `finished` are read from, and start from
        a game that has not begun."""
        self._events = self.bus.subscribe(
            NewGame, GameState, DialogueAct, DialogueEnded, SourceEnded
        )
        self._lock = threading.Lock()
        self._board: Board = EMPTY_BOARD
        self._robot_starts = self.config.game.robot_starts
        self._transcript: list[Turn] = []
        self._ended = False
        self._started = False

    # --- lifecycle ---

    def start(self) -> Robot:
        """Start every component and the first game: the robot begins to talk."""
        if not self._started:
            warm_up(self.config)
            self.supervisor.start()
            self._started = True
            if self._watching_sheet:  # a camera over real paper, where no arm reaches
                self.paper(True)
            self.new_game()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop every component within about `timeout` seconds (a sentence or a drawing under
        way is cut off; a hung thread is abandoned)."""
        self.supervisor.stop(timeout)
        self._events.close()
        self._started = False

    @property
    def components(self) -> list[Component]:
        """The components running now (a hung one's replacement in its place)."""
        return list(self.supervisor.components)

    def _lost(self, component: Component) -> None:
        """The supervisor gave up on `component`: with the manager gone, say goodbye for it."""
        if not isinstance(component, InteractionManagerComponent) or self.finished:
            return
        say_goodbye(self.bus, component.part, outcome(self.board))

    def __enter__(self) -> Robot:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def new_game(self, robot_starts: bool | None = None) -> None:
        """A clean sheet and a new dialogue; who starts is the config's unless given."""
        starts = self.config.game.robot_starts if robot_starts is None else robot_starts
        if self._started:
            # parts lost for good in the last game get another chance; before NewGame, so the
            # fresh ones hear it
            for name in self.supervisor.revive():
                log.info("%s starts afresh for the new game", name)
        self.bus.publish(NewGame(robot_starts=starts))

    # --- the person ---

    def say(self, text: str) -> None:
        """Typed words: heard with confidence 1."""
        if not isinstance(text, str) or not text.strip():
            raise InvalidInputError("say() needs some words; an empty answer is silence")
        words = tuple((w, 1.0) for w in words_of(text))
        self.bus.publish(SpeechHypotheses(nbest=((text, 1.0),), source="text", words=words))

    def hear(self, wav: bytes) -> None:
        """A push-to-talk recording (any WAV; resampled to 16 kHz mono) for the recogniser."""
        if not isinstance(wav, bytes):
            raise InvalidInputError(f"hear() takes the bytes of a WAV file, not {type(wav)}")
        read_wav(wav)  # a bad recording fails here, in the caller's thread, not the recogniser's
        self.bus.publish(SpeechAudio(audio=wav))

    def show(self, frame: np.ndarray) -> None:
        """The sheet as a camera sees it now (uint8 RGB or gray); read at 10 Hz."""
        self.bus.publish(frame_message(frame))

    def look(self, frame: np.ndarray) -> None:
        """A webcam frame of the person, for head tracking."""
        self.bus.publish(frame_message(frame, PersonFrame))

    def paper(self, on: bool) -> None:
        """Play on real paper under a camera (`on`), or on a drawn sheet: on paper the robot
        says where it plays, and says what to do when the camera cannot show the board."""
        self.bus.publish(SheetMode(paper=bool(on)))

    def draw(self, where: str | int) -> None:
        """A move typed instead of drawn (no camera): the person's symbol in `where`."""
        cell = cell_index(where) if isinstance(where, str) else where
        if not isinstance(cell, int) or not 0 <= cell < N_CELLS:
            raise InvalidInputError(f"{where!r} is not a cell; cells are {', '.join(CELL_NAMES)}")
        symbol = symbol_of(USER, self.robot_starts)
        self.bus.publish(GameMove(who="usr", what="draw", where=CELL_NAMES[cell], symbol=symbol))

    # --- what the bus has said so far ---

    @property
    def board(self) -> Board:
        """The board as the interaction manager last announced it."""
        self._catch_up()
        return self._board

    @property
    def robot_starts(self) -> bool:
        """Who started the current game."""
        self._catch_up()
        return self._robot_starts

    @property
    def transcript(self) -> list[Turn]:
        """The current game's dialogue so far, `{"speaker", "act", "text"}` per turn."""
        self._catch_up()
        return list(self._transcript)

    @property
    def watching_sheet(self) -> bool:
        """True while a camera watches the sheet (until it fails or ends): moves are drawn,
        not typed."""
        self._catch_up()
        return self._watching_sheet

    @property
    def finished(self) -> bool:
        """True once the robot has said goodbye in the current game."""
        self._catch_up()
        return self._ended

    def _catch_up(self) -> None:
        with self._lock:  # the web server asks from several threads
            for message in self._events.drain():  # in publish order
                if isinstance(message, NewGame):  # asked for: goodbyes before it are old
                    self._robot_starts, self._ended = message.robot_starts, False
                elif isinstance(message, GameState):
                    if message.board == EMPTY_BOARD:  # the manager's new game: turns after it
                        self._transcript = []
                    self._board = message.board
                elif isinstance(message, DialogueAct):
                    turn = {"speaker": message.speaker, "act": message.act, "text": message.text}
                    self._transcript.append(turn)
                elif isinstance(message, DialogueEnded):
                    self._ended = True
                elif isinstance(message, SourceEnded) and message.component == self._vision:
                    self._watching_sheet = False
