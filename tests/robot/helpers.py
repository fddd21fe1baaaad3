"""What several robot tests need: reading a bus subscription until a message comes, waiting
for a condition."""

import time


def collect(inbox, until, seconds=5.0):
    """Messages from `inbox` up to and including the first for which `until` is true."""
    got, deadline = [], time.monotonic() + seconds
    while time.monotonic() < deadline:
        message = inbox.get(timeout=0.05)
        if message is not None:
            got.append(message)
            if until(message):
                return got
    raise AssertionError(f"timed out after {got}")


def wait_for(predicate, seconds=3.0):
    """True as soon as `predicate()` is, False if it is not within `seconds`."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return False


class ManagerAtHand:
    """The interaction manager alone, driven in the test's own thread: its voice finishes each
    sentence and its arm each drawing at once, and every wait is over at once (`wait` is the
    person keeping quiet). The real policy, mask, understanding and manager code; no threads, no
    clock: a dialogue takes milliseconds."""

    def __init__(self, robot_starts: bool = True, seed: int = 0, settings: tuple = ()) -> None:
        import numpy as np

        from oxbot.config import load_config
        from oxbot.robot.bus import LocalBus
        from oxbot.robot.manager import InteractionManagerComponent
        from oxbot.robot.messages import (
            ArmCommand,
            DialogueAct,
            DialogueEnded,
            GameMove,
            GameState,
            NewGame,
            Utterance,
        )
        from oxbot.robot.session import shared_policy

        quick = [
            "robot.answer_timeout=0",
            "robot.pause_timeout=0",
            "robot.question_timeout=0",
            "robot.move_timeout=0",
        ]
        config = load_config(None, [*quick, *settings])
        self.bus = LocalBus()
        self.out = self.bus.subscribe(Utterance, ArmCommand, DialogueEnded, GameMove, NewGame)
        self.record = self.bus.subscribe(NewGame, GameState, DialogueAct, DialogueEnded)
        """What a component process would answer a state query with (the game so far)."""
        self.manager = InteractionManagerComponent(
            self.bus, policy=shared_policy(), config=config, rng=np.random.default_rng(seed)
        )
        self.ended = None
        self.said: list[str] = []
        """Everything the robot said, in order (its acts' words and its other sentences)."""
        self.manager.handle(NewGame(robot_starts=robot_starts))
        self._settle()

    def _settle(self) -> None:
        from oxbot.robot.messages import (
            ArmCommand,
            ArmDone,
            DialogueEnded,
            GameMove,
            NewGame,
            SpeakingFinished,
            Utterance,
        )

        while (message := self.out.get(0)) is not None:
            if isinstance(message, Utterance):
                self.said.append(message.text)
                self.manager.handle(SpeakingFinished(text=message.text))
            elif isinstance(message, ArmCommand):
                self.manager.handle(ArmDone(where=message.where))
            elif isinstance(message, GameMove):  # the bus brings the manager its own messages
                self.manager.handle(message)
            elif isinstance(message, DialogueEnded):
                self.ended = message
            elif isinstance(message, NewGame):  # asked for in words: the next dialogue
                self.ended = None
                self.manager.handle(message)

    @property
    def last_act(self) -> str:
        return self.manager.state.last_act

    @property
    def done(self) -> bool:
        return self.ended is not None

    def say(self, text: str, confidence: float = 1.0, *rivals: tuple[str, float]) -> None:
        """The person's words, heard with `confidence` (and other hypotheses after them)."""
        from oxbot.robot.messages import SpeechHypotheses

        self.manager.handle(SpeechHypotheses(nbest=((text, confidence), *rivals)))
        self._settle()

    def draw(self, cell: int) -> None:
        """The person's symbol in `cell`, as a camera or a typed move brings it."""
        from oxbot.game.board import CELL_NAMES, USER, symbol_of
        from oxbot.robot.messages import GameMove

        symbol = symbol_of(USER, self.manager.state.robot_starts)
        self.manager.handle(GameMove(who="usr", what="draw", where=CELL_NAMES[cell], symbol=symbol))
        self._settle()

    def wait(self) -> None:
        """The person says and draws nothing: the robot's wait is over."""
        self.manager.tick()
        self._settle()
