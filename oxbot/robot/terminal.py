"""The whole robot in a terminal: `oxbot play --terminal`.

The person types answers, or says them (`talk`: push-to-talk until Enter; `listen`: hands-free,
each utterance cut by the VAD, until an empty line), and types cells to draw in — or draws on
real paper under a webcam (`--camera 0`). The robot's turns are printed the
way the paper's Figure 1 prints them, `Rob: Your turn. [Request(userGameMove)]`, and spoken
through the speakers when there are any. Without a microphone, speakers, espeak-ng or a camera
the game goes on in text, after one clear warning each.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import shutil
import subprocess
import threading
import time
from collections.abc import Iterator, Sequence

import numpy as np
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
from oxbot.robot.listening import HandsFreeListener
from oxbot.robot.messages import (
    BoardProblem,
    ComponentFailed,
    ComponentLost,
    DialogueAct,
    DialogueEnded,
    GameState,
    Message,
    SpeakingContinued,
    SpeakingStarted,
    SpeechHypotheses,
    StopSpeaking,
)
from oxbot.robot.session import Robot, warm_up
from oxbot.speech.audio import RATE, Audio, to_wav_bytes
from oxbot.speech.vad import first_speech

log = logging.getLogger(__name__)

HELP = (
    f"Answer by typing (Enter sends), 'talk' to speak into the microphone (until Enter), "
    f"'listen' to talk hands-free, {CELL_HELP} to draw in it (or say it: top left), 'new' for "
    "a new game, 'quit' to leave."
)


class _Quit(Exception):
    """The person quit while the robot listened hands-free."""


class Speakers:
    """Plays WAVs with sox's `play`, one after another in the order given (a sentence waits for
    the one before); off after one warning if it cannot."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled and self._available()
        self._queue: queue.Queue[bytes] = queue.Queue()
        self._player: threading.Thread | None = None
        self._playing: subprocess.Popen[bytes] | None = None
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
        self._queue.put(wav)
        with self._lock:
            if self._player is None:
                self._player = threading.Thread(target=self._play_queued, daemon=True)
                self._player.start()

    def _play_queued(self) -> None:
        while True:
            self._play(self._queue.get())

    def _play(self, wav: bytes) -> None:
        if not self.enabled:
            return
        process = subprocess.Popen(
            ["play", "-q", "-t", "wav", "-"],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        with self._lock:
            self._playing = process
        try:
            _, errors = process.communicate(wav)
        except BrokenPipeError:  # cut short before it read the whole sentence
            errors = b""
            process.wait()
        with self._lock:
            self._playing = None
            cut = process.returncode < 0
        if process.returncode != 0 and not cut and self.enabled:
            self.enabled = False
            lines = errors.decode(errors="replace").strip().splitlines()
            log.warning(
                "no sound output (%s); the robot's speech is text only",
                lines[-1] if lines else "play failed",
            )

    def stop(self) -> None:
        """The person talked over the robot: what plays stops, what waits is dropped."""
        while True:
            try:
                self._queue.get_nowait()
            except queue.Empty:
                break
        with self._lock:
            if self._playing is not None:
                self._playing.kill()


class Microphone:
    """The person's microphone through sox's `rec`: 16 kHz mono 16-bit PCM on a pipe.

    `opened()` starts `rec` and returns only once its first samples arrive (the device is
    really open), so nobody is told to speak before anything records; `read` and `take` then
    give the samples recorded since. `rec` failing, or giving nothing within `open_timeout`
    seconds, is an InvalidInputError saying so, and the microphone is off from then on.
    """

    COMMAND = ("rec", "-q", "-t", "raw", "-r", str(RATE), "-e", "signed-integer", "-b", "16")
    COMMAND += ("-L", "-c", "1", "-")

    def __init__(self, command: Sequence[str] = COMMAND, open_timeout: float = 5.0) -> None:
        self.command = tuple(command)
        self.open_timeout = open_timeout
        self.available = shutil.which(self.command[0]) is not None
        self._process: subprocess.Popen[bytes] | None = None
        self._samples: queue.SimpleQueue[np.ndarray] = queue.SimpleQueue()
        self._receiving = threading.Event()
        self._reader: threading.Thread | None = None

    @property
    def receiving(self) -> bool:
        """Whether samples have arrived since the microphone was opened."""
        return self._receiving.is_set()

    @contextlib.contextmanager
    def opened(self) -> Iterator[Microphone]:
        """The microphone open, samples arriving; closed on leaving."""
        self.open()
        try:
            yield self
        finally:
            self.close()

    def open(self) -> None:
        if not self.available:
            raise InvalidInputError(
                f"there is no microphone recorder (sox's `{self.command[0]}`); type instead"
            )
        self._samples = queue.SimpleQueue()
        self._receiving.clear()
        self._process = subprocess.Popen(
            self.command, stdout=subprocess.PIPE, stderr=subprocess.PIPE
        )
        self._reader = threading.Thread(
            target=self._read_all, args=(self._process,), name="oxbot-microphone", daemon=True
        )
        self._reader.start()
        deadline = time.monotonic() + self.open_timeout
        while not self._receiving.wait(0.02):
            if self._process.poll() is not None or time.monotonic() > deadline:
                self._fail()

    def _fail(self) -> None:
        process = self._stop()
        err = process.stderr.read().decode(errors="replace") if process and process.stderr else ""
        lines = err.strip().splitlines()
        self.available = False
        raise InvalidInputError(
            f"no microphone could be opened ({lines[-1] if lines else 'no audio'}); "
            "type your answers instead"
        )

    def _read_all(self, process: subprocess.Popen[bytes]) -> None:
        assert process.stdout is not None
        odd = b""
        while chunk := process.stdout.read1(3200):  # 0.1 s at most
            data, odd = odd + chunk, b""
            if len(data) % 2:
                data, odd = data[:-1], data[-1:]
            if data:
                self._samples.put(np.frombuffer(data, dtype="<i2").astype(np.int16))
                self._receiving.set()

    def read(self, timeout: float = 0.1) -> np.ndarray | None:
        """The next samples, or None after `timeout` seconds without any."""
        try:
            return self._samples.get(timeout=timeout)
        except queue.Empty:
            return None

    def take(self) -> np.ndarray:
        """Every sample waiting now."""
        chunks = []
        while (chunk := self.read(timeout=0)) is not None:
            chunks.append(chunk)
        return np.concatenate(chunks) if chunks else np.zeros(0, np.int16)

    @property
    def running(self) -> bool:
        return self._process is not None and self._process.poll() is None

    def close(self) -> None:
        """Stop recording; what was recorded stays for `take`."""
        self._stop()

    def _stop(self) -> subprocess.Popen[bytes] | None:
        process, self._process = self._process, None
        if process is None:
            return None
        if process.poll() is None:
            process.terminate()
            try:
                process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        if self._reader is not None:
            self._reader.join(2)
        return process


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
            DialogueAct,
            GameState,
            BoardProblem,
            DialogueEnded,
            ComponentFailed,
            ComponentLost,
            SpeakingStarted,
            SpeakingContinued,
            StopSpeaking,
            SpeechHypotheses,
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
        except _Quit:
            return
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
            elif line.lower() == "listen":
                self._listen()
            elif self.typed_moves and is_cell(line):
                self.robot.draw(line)
            elif self.typed_moves and line.isdigit():  # "10" is no answer: a cell mistyped
                raise InvalidInputError(f"there is no cell {line}; type {CELL_HELP}")
            else:
                self.robot.say(line)
        except OxbotError as exc:
            self.console.print(f"[red]{escape(str(exc))}[/]")

    @property
    def typed_moves(self) -> bool:
        """Cells are typed unless a camera watches the sheet (and works)."""
        return not self.robot.watching_sheet

    def _talk(self) -> None:
        """Push-to-talk: from the moment `rec` really records until Enter."""
        with self.microphone.opened():
            self.read_line("recording... press Enter to stop ")
        samples = self.microphone.take()
        if len(samples) < RATE // 10:
            raise InvalidInputError("the recording is shorter than 0.1 s; talk, then press Enter")
        listening = self.robot.config.speech.listening
        start = first_speech(samples, listening)  # None: no speech found, keep it all
        self.robot.hear(to_wav_bytes(Audio(samples[start or 0 :], RATE)))

    def _listen(self) -> None:
        """Hands-free: the robot hears each utterance (not its own voice) until an empty line;
        typed lines are taken as usual meanwhile."""
        stop = threading.Event()
        with self.microphone.opened():
            listener = HandsFreeListener(self.robot, self.robot.config.speech.listening)
            feeder = threading.Thread(
                target=self._feed, args=(listener, stop), name="oxbot-terminal-listen", daemon=True
            )
            feeder.start()
            self.console.print("[dim]Listening: just speak. An empty line stops listening.[/]")
            try:
                while line := self.read_line("").strip():
                    if line.lower() in QUIT_WORDS:
                        raise _Quit
                    if line.lower() in ("talk", "listen"):
                        self.console.print("[dim]Already listening: just speak.[/]")
                        continue
                    self._take(line)
            except EOFError:
                raise _Quit from None
            finally:
                stop.set()
                feeder.join(2)
                listener.close()
        self.console.print("[dim]Stopped listening.[/]")

    def _feed(self, listener: HandsFreeListener, stop: threading.Event) -> None:
        while not stop.is_set():
            samples = self.microphone.read(timeout=0.1)
            if samples is not None:
                listener.feed(samples)
            elif not self.microphone.running:
                log.warning("the microphone stopped; press Enter, then type your answers")
                return

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
        elif isinstance(message, SpeechHypotheses) and message.source == "microphone":
            c.print(f"[dim]{escape(heard_line(message.nbest))}[/]")
        elif isinstance(message, SpeakingStarted | SpeakingContinued):
            self.speakers.play(message.audio)
        elif isinstance(message, StopSpeaking):
            self.speakers.stop()
        elif isinstance(message, ComponentFailed):
            c.print(f"[red]{escape(message.component)} failed ({escape(message.error)})[/]")
        elif isinstance(message, ComponentLost):
            c.print(f"[red]{escape(message.component)} is off until a new game[/]")
        elif isinstance(message, DialogueEnded):
            print_game_over(c, message.outcome)


def heard_line(nbest: Sequence[tuple[str, float]]) -> str:
    """What the recogniser heard in a recording, as the terminal shows it: the best hypothesis
    with its confidence (and the next two), or that nothing was heard."""
    if not nbest:
        return "(heard nothing: noise or silence)"
    shown = [f'"{text}" {confidence:.0%}' for text, confidence in nbest[:3]]
    return "(heard " + shown[0] + (f"; or {', '.join(shown[1:])}" if shown[1:] else "") + ")"
