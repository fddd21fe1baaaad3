"""The whole robot, headless, against a scripted person who speaks and draws.

The person's answers are espeak-ng recordings fed through the real recogniser; their crosses
are drawn stroke by stroke on a rendered photo of a sheet, which a "camera" thread shows the
robot 10 times a second, and the real perception pipeline reads. The robot's circles appear
on the sheet when its arm has drawn them.
"""

import threading
import time

import numpy as np
import pytest

from oxbot.config import load_config
from oxbot.game.board import CELL_NAMES, EMPTY, outcome
from oxbot.robot.messages import (
    ArmCommand,
    ArmDone,
    BoardSeen,
    DialogueAct,
    DialogueEnded,
    GameMove,
    SpeakingFinished,
    SpeakingStarted,
)
from oxbot.robot.session import Robot
from oxbot.speech.synthesis import Voice, synthesize
from oxbot.testing.render import TUNING_STYLE, random_scene

pytestmark = pytest.mark.slow

ANSWERS = {
    "Salutation(greeting)": "Hello!",
    "Request(playGame)": "Yes, let's play.",
    # the outcome goes unanswered: an answer heard late on a loaded machine would answer the
    # robot's next question, "Would you like another game?"
    "Request(anotherGame)": "No thanks.",
    "Salutation(closing)": "Good bye!",
}
EXPECTED_ACTS = {
    "Salutation(greeting)": "Salutation(greeting)",
    "Request(playGame)": "Confirm(playGame=yes)",
    "Request(anotherGame)": "Reject(playGame=no)",
    "Salutation(closing)": "Salutation(closing)",
}
"""What the person means by the answer to each act."""


class Camera(threading.Thread):
    """Shows the robot a fresh photo of the current sheet every 100 ms (a webcam's view)."""

    def __init__(self, robot: Robot, seed: int) -> None:
        super().__init__(daemon=True)
        self.robot = robot
        self.rng = np.random.default_rng(seed)
        self.scene = random_scene(self.rng, TUNING_STYLE)
        self.drawing: dict[int, float] = {}  # cell -> strokes drawn so far
        self.lock = threading.Lock()
        self.stopped = threading.Event()

    def add(self, cell: int, label: str, strokes_drawn: float = 99.0) -> None:
        with self.lock:
            self.scene = self.scene.with_symbol(cell, label, self.rng)
            self.drawing[cell] = strokes_drawn

    def draw_on(self, cell: int) -> None:
        """The person's pen moves on: a stroke at a time, a quarter of a stroke per frame."""
        with self.lock:
            self.drawing[cell] = self.drawing.get(cell, 0.0) + 0.25

    def run(self) -> None:
        while not self.stopped.is_set():
            with self.lock:
                photo = self.scene.photo(self.rng, drawn=dict(self.drawing))
            self.robot.show(photo)
            self.stopped.wait(0.1)


def moved_cells(log: list) -> set[int]:
    """Every cell a GameMove on the bus has played so far, by either player."""
    return {CELL_NAMES.index(m.where) for m in log if isinstance(m, GameMove)}


def test_a_spoken_and_drawn_game_runs_to_the_goodbye():
    config = load_config(
        None,
        [
            "robot.speed_factor=8",
            "robot.answer_timeout=4",
            "robot.pause_timeout=0",  # the person answers the greeting once it is said
            "robot.move_timeout=60",
        ],
    )
    voice = Voice("en-us+m3")
    recordings = {act: synthesize(text, voice) for act, text in ANSWERS.items()}
    prefer = (4, 0, 2, 6, 8, 1, 3, 5, 7)
    log: list = []
    with Robot(config, seed=5) as robot:
        events = robot.bus.subscribe()
        camera = Camera(robot, seed=11)
        camera.start()
        drawing: int | None = None
        deadline = time.monotonic() + 150
        try:
            while time.monotonic() < deadline:
                message = events.get(0.05)
                if drawing is not None:
                    camera.draw_on(drawing)  # the person keeps drawing until it is accepted
                if message is None:
                    continue
                log.append(message)
                if isinstance(message, DialogueEnded):
                    break
                if isinstance(message, ArmDone):
                    camera.add(CELL_NAMES.index(message.where), "circle")
                if isinstance(message, GameMove) and message.who == "usr":
                    drawing = None
                if isinstance(message, DialogueAct) and message.speaker == "sys":
                    if message.act in recordings:
                        robot.hear(recordings[message.act])
                    if message.act == "Request(userGameMove)" and drawing is None:
                        # the moves on the bus so far, not only robot.board, which a loaded
                        # machine may show a move late
                        board, taken = robot.board, moved_cells(log)
                        drawing = next(c for c in prefer if board[c] == EMPTY and c not in taken)
                        camera.add(drawing, "cross", strokes_drawn=0.0)
        finally:
            camera.stopped.set()
            camera.join(1)
        transcript = robot.transcript
        board = robot.board

    text = "\n".join(f"{t['speaker']}: {t['text']} [{t['act']}]" for t in transcript)
    assert isinstance(log[-1], DialogueEnded), f"no goodbye:\n{text}"
    assert log[-1].outcome == outcome(board) is not None, text

    # The person's spoken answers were heard as what they meant, until the robot's goodbye (a
    # goodbye said after it answers nothing, and espeak's "good bye" is now and then heard as
    # "don't buy").
    closing = next((i for i, t in enumerate(transcript) if t["act"] == "Salutation(closing)"), None)
    spoken_acts = {
        t["act"]
        for t in transcript[:closing]
        if t["speaker"] == "usr" and not t["text"].startswith("[")
    }
    assert "Confirm(playGame=yes)" in spoken_acts, text
    assert spoken_acts <= set(EXPECTED_ACTS.values()), text
    # Every move of the person was accepted by the tracker after 3 agreeing readings, and
    # the manager acted on it only afterwards.
    person_moves = [i for i, m in enumerate(log) if isinstance(m, GameMove) and m.who == "usr"]
    assert person_moves, text
    for i in person_moves:
        seen = [m.agreeing for m in log[:i] if isinstance(m, BoardSeen)]
        assert seen[-3:] == [1, 2, 3], f"accepted without 3 agreeing readings: {seen[-5:]}"
        where = log[i].where
        acted = [
            j
            for j, m in enumerate(log)
            if isinstance(m, DialogueAct)
            and m.speaker == "usr"
            and m.act == f"GameMove(gridloc={where})"
        ]
        assert acted and acted[0] > i, [
            (j, type(m).__name__, getattr(m, "who", ""), getattr(m, "where", ""))
            for j, m in enumerate(log[max(0, i - 20) : i + 2], start=max(0, i - 20))
            if isinstance(m, GameMove | DialogueAct | BoardSeen)
        ]
    # The robot never spoke while its arm moved.
    busy = []
    for start, end in ((SpeakingStarted, SpeakingFinished), (ArmCommand, ArmDone)):
        opened = None
        for j, m in enumerate(log):
            if isinstance(m, start):
                opened = j
            elif isinstance(m, end) and opened is not None:
                busy.append((start.__name__, opened, j))
                opened = None
    arms = [(a, b) for name, a, b in busy if name == "ArmCommand"]
    talks = [(a, b) for name, a, b in busy if name == "SpeakingStarted"]
    assert arms
    for a0, a1 in arms:
        assert all(s1 < a0 or s0 > a1 for s0, s1 in talks), "spoke while drawing"
