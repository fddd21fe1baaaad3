"""Simulated people for whole spoken conversations: who they are, what they say to each of the
robot's questions, and whether the conversation went as they wanted.

A `Persona` answers the robot's acts (`reply`) as one kind of person would (`PERSONAS`), in
words drawn from phrasings the project's phrase files do not hold (`read_phrasings`).
`judge` reads what the robot did (a `Conversation`, filled by `bench/bench_conversations.py`
from the page's WebSocket) and says whether it went as the person wanted, and why not:

    persona = Persona("hesitant", read_phrasings(PHRASINGS), np.random.default_rng(0))
    persona.reply(INVITATION)      # Reply("postpone", "can we do it after lunch")
    judge(conversation)            # [] when it went as wanted, else what went wrong
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from oxbot.dialogue.domain import (
    ACCEPT,
    AFTER_ALL,
    ANSWER,
    ASK_AGAIN,
    DECLINE,
    GRANT_REFUSAL,
    INVITATION,
    MOVE_REQUEST,
    NEW_GAME,
    OFFER_ANOTHER,
    POSTPONE,
    SILENCE,
    STOP,
    STOP_QUESTION,
    UNKNOWN,
    YES_QUESTION,
)
from oxbot.errors import DataError
from oxbot.game.board import EMPTY_BOARD, ROBOT, USER, Board, cell_index, outcome, play

FAMILIES: tuple[str, ...] = (
    "accept",
    "decline",
    "postpone",
    "take_back",
    "stop",
    "repeat",
    "off_topic",
    "rematch",
    "farewell",
    "confirm_yes",
)
"""What a person means by a phrasing, in the situation the robot's question sets."""
CARRY_ON: tuple[str, ...] = ("no keep going", "no i want to finish", "no carry on", "not yet")
"""A person's no to "Do you want to stop?" when they never asked to stop (a misheard word did)."""
PERSONAS: tuple[str, ...] = (
    "keen",
    "declines",
    "hesitant",
    "changes_mind",
    "stopper",
    "asks",
    "silent",
)
"""keen: plays, then a rematch or a goodbye. declines: no, for good. hesitant: later, then yes.
changes_mind: no, then takes it back. stopper: plays, then stops mid-game. asks: asks to hear the
question again or asks something off the topic, then plays. silent: says nothing, or only
noise reaches the microphone."""
WANTS_A_GAME = frozenset({"keen", "hesitant", "changes_mind", "stopper", "asks"})
YES = frozenset({"accept", "take_back", "rematch"})
"""The families that agree to a game: a game the robot starts before one of them is unwanted."""
AGREEING_ACTS = frozenset({ACCEPT, NEW_GAME})
REFUSING_ACTS = frozenset({DECLINE, POSTPONE, STOP})
QUESTIONS = frozenset(
    {INVITATION, ASK_AGAIN, AFTER_ALL, STOP_QUESTION, OFFER_ANOTHER, YES_QUESTION}
)
"""The robot's acts that wait for the person's answer (a move request waits for a drawing)."""


def read_phrasings(path: str | Path) -> dict[str, tuple[str, ...]]:
    """family -> its phrasings, from a CSV with the columns `family,phrasing`.

    Raises DataError naming the file when it is missing, has an unknown family or a family
    with no phrasing."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
    except OSError as exc:
        raise DataError(f"cannot read the phrasings {path}: {exc.strerror}") from None
    found: dict[str, list[str]] = {family: [] for family in FAMILIES}
    for number, row in enumerate(rows, start=2):
        family, phrasing = row.get("family"), (row.get("phrasing") or "").strip()
        if family not in found or not phrasing:
            raise DataError(
                f"{path}:{number}: expected `family,phrasing` with a family of "
                f"{', '.join(FAMILIES)}; got {row}"
            )
        found[family].append(phrasing)
    empty = [family for family, phrasings in found.items() if not phrasings]
    if empty:
        raise DataError(f"{path} has no phrasing for {', '.join(empty)}")
    return {family: tuple(phrasings) for family, phrasings in found.items()}


@dataclass(frozen=True)
class Reply:
    """What the person does in answer: say a phrasing of `family`, make a noise, or stay quiet.

    `family` is one of FAMILIES, "carry_on", "noise" (a non-speech sound reaches the
    microphone) or "silence" (nothing at all)."""

    family: str
    text: str = ""


class Persona:
    """One simulated person's answers, in order, to the robot's acts.

    `rematch`: a keen person's yes to another game (else a goodbye); `stop_at`: the stopper's
    move request (1 = the first) at which they ask to stop instead of drawing."""

    def __init__(
        self,
        kind: str,
        phrasings: dict[str, tuple[str, ...]],
        rng: np.random.Generator,
        rematch: bool = False,
        stop_at: int = 2,
    ) -> None:
        if kind not in PERSONAS:
            raise ValueError(f"unknown persona {kind!r}; known: {', '.join(PERSONAS)}")
        self.kind, self.phrasings, self.rng = kind, phrasings, rng
        self.rematch, self.stop_at = rematch, stop_at
        self.asked = 0  # invitations answered
        self.move_requests = 0
        self.games_finished = 0
        self.stopping = False
        self.consented = False
        """Whether the person has said yes to the game now on (or about to start)."""
        self.question: str | None = None
        """The robot's last question, answered again when the robot answers an aside."""

    @property
    def wants_a_game(self) -> bool:
        return self.kind in WANTS_A_GAME

    def say(self, family: str) -> Reply:
        options = CARRY_ON if family == "carry_on" else self.phrasings[family]
        reply = Reply(family, str(options[int(self.rng.integers(len(options)))]))
        if family in YES:
            self.consented = True
        return reply

    def reply(self, act: str) -> Reply | None:
        """What the person answers to the robot's `act`; None when it needs no answer."""
        if act in QUESTIONS:
            self.question = act
        elif act == ANSWER and self.question is not None:
            act = self.question  # the robot answered an aside: its question stands
        elif act not in (GRANT_REFUSAL, MOVE_REQUEST):
            return None
        if self.kind == "silent":
            return Reply("noise") if self.rng.random() < 0.5 else Reply("silence")
        if act in (INVITATION, ASK_AGAIN):
            return self._invited()
        if act == GRANT_REFUSAL:  # "Okay, maybe another time."
            if self.kind in ("hesitant", "changes_mind") and not self.consented:
                return self.say("take_back")
            return None
        if act == YES_QUESTION:  # "Sorry, was that a yes?": what they mean, said again
            return self.say(self._stance())
        if act == AFTER_ALL:
            return self.say("accept" if self.wants_a_game else "decline")
        if act == STOP_QUESTION:
            return self.say("confirm_yes" if self.stopping else "carry_on")
        if act == OFFER_ANOTHER:
            self.games_finished += 1
            self.consented = False
            if self.kind == "keen" and self.rematch and self.games_finished == 1:
                return self.say("rematch")
            return self.say("farewell")
        return self._asked_to_move()

    def _invited(self) -> Reply:
        self.asked += 1
        if self.kind == "asks" and self.asked == 1:
            return self.say("repeat" if self.rng.random() < 0.5 else "off_topic")
        return self.say(self._stance())

    def _stance(self) -> str:
        """What the person means to answer to the invitation now."""
        if self.kind == "declines":
            return "decline"
        if self.kind == "hesitant" and self.asked == 1:
            return "postpone"
        if self.kind == "changes_mind" and self.asked == 1:
            return "decline"
        return "accept"

    def _asked_to_move(self) -> Reply | None:
        """None: the person draws their move. A stopper asks to stop instead at `stop_at`, and
        again at every move request after; a person who never agreed to play says no."""
        self.move_requests += 1
        if not self.consented and not self.stopping:
            return self.say("decline")
        if self.kind == "stopper" and (self.stopping or self.move_requests >= self.stop_at):
            self.stopping = True
            return self.say("stop")
        return None


@dataclass
class Game:
    """One game of a conversation, as the robot's messages showed it."""

    board: Board = EMPTY_BOARD
    drawn: list[str] = field(default_factory=list)
    """The cells the person drew in."""
    accepted: list[str] = field(default_factory=list)
    """The cells the robot took as the person's moves (GameMove who=usr)."""
    robot_moves: int = 0
    feedback: str | None = None
    """The outcome the robot named (win, draw or loss, from its side), if it named one."""

    def robot_moved(self, cell: str) -> None:
        self.board = play(self.board, cell_index(cell), ROBOT)
        self.robot_moves += 1

    def person_moved(self, cell: str) -> None:
        self.accepted.append(cell)
        self.board = play(self.board, cell_index(cell), USER)


@dataclass
class Conversation:
    """What happened in one conversation between a persona and the robot."""

    persona: str
    games: list[Game] = field(default_factory=lambda: [Game()])
    turns: list[tuple[str, str, str]] = field(default_factory=list)
    """(speaker, act, text) of every DialogueAct, in order."""
    said: list[Reply] = field(default_factory=list)
    """What the person said or did, in order (noise and silence included)."""
    understood: list[tuple[str, str]] = field(default_factory=list)
    """(what the person meant: a Reply's family, the act the robot understood) per answer."""
    moves_without_consent: int = 0
    """Robot moves made, and moves asked of the person, while they had not agreed to play."""
    moves_after_stop: int = 0
    noise_answered: int = 0
    """Noise or silence understood as an answer (any act but Silence and Unknown)."""
    heard: list[tuple[str, float]] = field(default_factory=list)
    """The recogniser's best hypothesis and its confidence, per recording ("" when none)."""
    latencies: list[float] = field(default_factory=list)
    """Seconds from an answer's audio leaving the client to the recogniser's hypotheses."""
    outcome: str | None = None
    """DialogueEnded's outcome (None until the dialogue ended)."""
    goodbye: bool = False
    problems: list[str] = field(default_factory=list)
    """Errors and failures the robot reported, and the harness's own time-out."""

    @property
    def game(self) -> Game:
        return self.games[-1]

    def asked_again(self) -> int:
        return sum(1 for speaker, act, _ in self.turns if speaker == "sys" and act == ASK_AGAIN)

    def confirmations(self) -> int:
        """The robot's questions about what it heard: "Sorry, was that a yes?", "Do you want to
        stop?" and "Do you want to play after all?"."""
        asked = (YES_QUESTION, STOP_QUESTION, AFTER_ALL)
        return sum(1 for speaker, act, _ in self.turns if speaker == "sys" and act in asked)

    def flips(self) -> int:
        """Answers understood as their opposite: a yes the person did not mean, or a no, later
        or stop where they meant yes."""
        return sum(
            (act in REFUSING_ACTS) if meant in YES else (act in AGREEING_ACTS)
            for meant, act in self.understood
            if meant != "confirm_yes"
        )


def judge(conversation: Conversation) -> list[str]:
    """What went against the person's wishes in `conversation`; empty when it went as they
    wanted: the games they wanted played to the end and named as the board shows, no game or
    move they did not agree to, a stop honoured, noise never an answer, and a goodbye."""
    c, wrong = conversation, list(conversation.problems)
    finished = [game for game in c.games if outcome(game.board) is not None]
    for game in c.games:
        truth = outcome(game.board)
        if truth is not None and game.feedback != truth:
            wrong.append(f"named the outcome {game.feedback}, the board shows {truth}")
        if any(cell not in game.drawn for cell in game.accepted):
            wrong.append(f"took a move the person did not draw ({game.accepted} of {game.drawn})")
    if c.moves_without_consent:
        wrong.append(f"{c.moves_without_consent} moves without the person's consent")
    if c.moves_after_stop:
        wrong.append(f"{c.moves_after_stop} robot moves after the person asked to stop")
    if c.noise_answered:
        wrong.append(f"{c.noise_answered} noises taken as an answer")
    if not c.goodbye:
        wrong.append("no goodbye")
    wanted_games = 0 if c.persona in ("declines", "silent") else 1
    if c.persona == "keen" and any(r.family == "rematch" for r in c.said):
        wanted_games = 2
    if c.persona == "stopper" and any(reply.family == "stop" for reply in c.said):
        if c.outcome != "stopped":
            wrong.append(f"the stop was not honoured (ended {c.outcome})")
    elif len(finished) != wanted_games:
        wrong.append(f"{len(finished)} games played to the end, wanted {wanted_games}")
    if c.persona in ("declines", "silent") and any(game.robot_moves for game in c.games):
        wrong.append("a game was played with a person who did not want one")
    return wrong


def understood_as_answer(act: str) -> bool:
    """Whether the robot took what it heard for an answer (anything but silence or nonsense)."""
    return act not in (SILENCE, UNKNOWN)


__all__ = [
    "CARRY_ON",
    "FAMILIES",
    "PERSONAS",
    "QUESTIONS",
    "Conversation",
    "Game",
    "Persona",
    "Reply",
    "judge",
    "read_phrasings",
    "understood_as_answer",
]
