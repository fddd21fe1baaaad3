"""The whole robot in a terminal: `oxbot play --terminal`.

The person types answers, or says them (`talk`, with a microphone), and types cells to draw
in — or draws on real paper under a webcam (`--camera 0`). The robot's turns are printed the
way the paper's Figure 1 prints them, `Rob: Your turn. [Request(userGameMove)]`, and spoken
through the speakers when there are any. Without a microphone, speakers, espeak-ng or a camera
the game goes on in text, after one clear warning each.
"""

from __future__ import annotations

import logging
import shutil
import subprocess
import threading

from rich.console import Console
from rich.markup import escape

from oxbot.errors import InvalidInputError, OxbotError
from oxbot.game.board import EMPTY_BOARD
from oxbot.game.terminal import (
    CELL_HELP,
    NEW_WORDS,
    QUIT_WORDS,
    ReadLine,
    is_cell,
    print_board,
    print_game_over,
    print_turn,
)
from oxbot.robot.messages import (
    BoardProblem,
    ComponentFailed,
    DialogueAct,
    DialogueEnded,
    GameState,
    Message,
    SpeakingStarted,
)
from oxbot.robot.session import Robot, warm_up

log = logging.getLogger(__name__)

HELP = (
    f"Answer by typing (Enter sends), 'talk' to speak into the microphone, {CELL_HELP} to draw "
    "in it, 'new' for a new game, 'quit' to leave."
)


class Speakers:
    """Plays WAVs with sox's `play`, one at a time; off after one warning if it cannot."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled and self._available()
        self._lock = threading.Lock()

    @staticmethod
    def _available() -> bool:
        if shutil.which("play") is None:
            log.warning("sox's `play` is not installed, so the robot's speech is text only")
            return False
        return True

    def play(self, wav: bytes) -> None:
        if not self.enabled or not wav:
            return
        threading.Thread(target=self._play, args=(wav,), daemon=True).start()

    def _play(self, wav: bytes) -> None:
        with self._lock:
            result = subprocess.run(
                ["play", "-q", "-t", "wav", "-"], input=wav, capture_output=True, check=False
            )
        if result.returncode != 0 and self.enabled:
            self.enabled = False
            lines = result.stderr.decode(errors="replace").strip().splitlines()
            log.warning(
                "no sound output (%s); the robot's speech is text only",
                lines[-1] if lines else "play failed",
            )


class Microphone:
    """Push-to-talk recordings with sox's `rec`: `start()`, then `stop()` returns the WAV."""

    def __init__(self) -> None:
        self.available = shutil.which("rec") is not None
        self._process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        if not self.available:
            raise InvalidInputError("there is no microphone recorder (sox's `rec`); type instead")
        self._process = subprocess.Popen(
            ["rec", "-q", "-r", "16000", "-c", "1", "-b", "16", "-t", "wav", "-"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )

    def stop(self) -> bytes:
        process, self._process = self._process, None
        if process is None:
            return b""
        if process.poll() is None:
            process.terminate()
        wav, err = process.communicate(timeout=5)
        if len(wav) <= 44:
            self.available = False
            message = err.decode(errors="replace").strip().splitlines()
            raise InvalidInputError(
                f"no microphone could be opened ({message[-1] if message else 'no audio'}); "
                "type your answers instead"
            )
        return wav


class TerminalRobot:
    """Runs a Robot with the terminal as its face, ears and (without a camera) the sheet."""

    def __init__(
        self,
        robot: Robot,
        read_line: ReadLine = input,
        console: Console | None = None,
        speakers: Speakers | None = None,
        microphone: Microphone | None = None,
    ) -> None:
        self.robot = robot
        self.read_line = read_line
        self.console = console if console is not None else Console(highlight=False)
        self.speakers = speakers if speakers is not None else Speakers()
        self.microphone = microphone if microphone is not None else Microphone()
        self._events = robot.bus.subscribe(
            DialogueAct, GameState, BoardProblem, DialogueEnded, ComponentFailed, SpeakingStarted
        )
        self._printer = threading.Thread(target=self._print_events, daemon=True)
        self._stopping = threading.Event()

    def run(self) -> None:
        """Play until the person quits or the input ends."""
        self.console.print(f"[dim]{escape(HELP)}[/]")
        self._printer.start()
        with self.console.status("Loading the robot's models..."):
            warm_up(self.robot.config)
        self.robot.start()
        try:
            while True:
                try:
                    line = self.read_line("").strip()
                except EOFError:
                    return
                if line.lower() in QUIT_WORDS:
                    return
                self._take(line)
        finally:
            self._stopping.set()
            self.robot.stop()
            self._printer.join(1)

    def _take(self, line: str) -> None:
        if not line:
            return
        try:
            if line.lower() in NEW_WORDS:
                self.robot.new_game()
            elif line.lower() == "talk":
                self._talk()
            elif self.typed_moves and is_cell(line):
                self.robot.draw(line)
            else:
                self.robot.say(line)
        except OxbotError as exc:
            self.console.print(f"[red]{escape(str(exc))}[/]")

    @property
    def typed_moves(self) -> bool:
        """Cells are typed unless a camera watches the sheet (and works)."""
        return not self.robot.watching_sheet

    def _talk(self) -> None:
        self.microphone.start()
        self.read_line("recording... press Enter to stop ")
        self.robot.hear(self.microphone.stop())

    def _print_events(self) -> None:
        while not self._stopping.is_set():
            message = self._events.get(timeout=0.1)
            if message is not None:
                self._show(message)

    def _show(self, message: Message) -> None:
        c = self.console
        if isinstance(message, DialogueAct):
            print_turn(c, message.speaker, message.text, message.act)
        elif isinstance(message, GameState) and message.board != EMPTY_BOARD:
            print_board(c, message.board, message.robot_starts)
        elif isinstance(message, BoardProblem):
            c.print(f"[yellow]On the sheet: {escape(message.reason)}[/]")
        elif isinstance(message, SpeakingStarted):
            self.speakers.play(message.audio)
        elif isinstance(message, ComponentFailed):
            c.print(
                f"[red]{escape(message.component)} failed ({escape(message.error)}); restarted[/]"
            )
        elif isinstance(message, DialogueEnded):
            print_game_over(c, message.outcome)
