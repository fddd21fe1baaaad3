"""The user simulator: a semi-random person built from the seed domain, heard through noisy ASR.

Paper §3.3: "we used user simulations that provide semi-randomly generated user responses ...
responses already chosen were not allowed. For example, drawing a symbol in the middle of the
grid was only allowed if the location was empty."

The simulated person answers each system act with one of its alternatives in
`user_responses.txt`, except that
- the first invitation to play is declined with probability `decline_probability`;
- asked for a move, with probability `out_of_turn_probability` the person answers out of turn,
  with small talk (an answer to the greeting or the introduction) and no drawing, so the robot
  has to ask again (seed dialogue 8);
- asked for a move, the person draws if it is their turn and the game is not over (a person who
  declined goes along once the robot starts playing); the cell comes from the opponent strategy
  (a SPEC §5 callable, default uniformly random), checked with `checked_move`.

What the robot hears goes through a speech recogniser model with noise level `asr_noise` = n:
each word is dropped with probability n/4, replaced by a random vocabulary word (confidence
uniform in [0.1, 0.6]) with probability n/4, and otherwise heard with a confidence uniform in
[1-n, 1].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from oxbot.dialogue.domain import (
    ACCEPT,
    DECLINE,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
    SILENCE,
    Domain,
    DomainLine,
    game_move,
)
from oxbot.game.board import CELL_NAMES, Board
from oxbot.game.opponents import Opponent, checked_move, random_opponent


@dataclass(frozen=True)
class UserTurn:
    """What the person did in answer to one system act."""

    act: str
    """The user act, e.g. `Confirm(playGame=yes)` or `GameMove(gridloc=middle)`; `Silence`."""
    text: str
    """What the person said, with the drawing in brackets; empty when silent."""
    heard: tuple[tuple[str, float], ...]
    """The recogniser's words with their confidences."""
    cell: int | None = None
    """The cell the person drew on, or None."""


class UserSimulator:
    """A semi-random person who talks and draws, heard through a noisy speech recogniser."""

    def __init__(
        self,
        domain: Domain,
        opponent: Opponent | None = None,
        rng: np.random.Generator | None = None,
        asr_noise: float = 0.2,
        decline_probability: float = 0.1,
        out_of_turn_probability: float = 0.05,
    ) -> None:
        self.domain = domain
        self.rng = rng if rng is not None else np.random.default_rng()
        self.opponent = opponent if opponent is not None else random_opponent(self.rng)
        self.asr_noise = asr_noise
        self.decline_probability = decline_probability
        self.out_of_turn_probability = out_of_turn_probability
        self._accept = tuple(u for u in domain.responses_to(INVITATION) if u.act == ACCEPT)
        self._decline = tuple(u for u in domain.responses_to(INVITATION) if u.act == DECLINE)
        self._small_talk = tuple(
            u
            for act in (GREETING, INTRODUCTION)
            for u in domain.responses_to(act)
            if u.act != SILENCE
        )
        self.reset()

    def reset(self) -> None:
        """Start a new dialogue with a person who has not yet agreed to play."""
        self.accepted = False
        self.asked = False

    def respond(self, system_act: str, board: Board, person_to_move: bool) -> UserTurn:
        """The person's answer to `system_act`, given the board and whether they may draw."""
        rng = self.rng
        if system_act == INVITATION and self._accept:
            first = not self.asked
            self.asked = True
            if first and self._decline and rng.random() < self.decline_probability:
                return self._say(self._decline[rng.integers(len(self._decline))])
            self.accepted = True
            return self._say(self._accept[rng.integers(len(self._accept))])
        alternatives = self.domain.responses_to(system_act)
        if system_act == MOVE_REQUEST:
            if self._small_talk and rng.random() < self.out_of_turn_probability:
                return self._say(self._small_talk[rng.integers(len(self._small_talk))])
            if not person_to_move:
                return UserTurn(SILENCE, "", ())
            cell = checked_move(self.opponent, board)
            choice = alternatives[rng.integers(len(alternatives))]
            return self._say(choice, cell)
        if not alternatives:
            return UserTurn(SILENCE, "", ())
        return self._say(alternatives[rng.integers(len(alternatives))])

    def _say(self, utterance: DomainLine, cell: int | None = None) -> UserTurn:
        act, text = utterance.act, utterance.text
        if act == SILENCE:
            return UserTurn(SILENCE, "", ())
        if cell is not None:  # a drawing: the template's $loc is the cell drawn in
            act, text = game_move(cell), text.replace("$loc", CELL_NAMES[cell])
        return UserTurn(act, text, self.recognize(utterance.words), cell)

    def recognize(self, words: list[str]) -> tuple[tuple[str, float], ...]:
        """The words as the noisy recogniser hears them: (word, confidence) pairs."""
        n = self.asr_noise
        if n <= 0.0:
            return tuple((w, 1.0) for w in words)
        rng = self.rng
        vocabulary = self.domain.vocabulary
        heard = []
        for word, (u, v, c) in zip(words, rng.random((len(words), 3)), strict=True):
            if u < n / 4:
                continue  # dropped
            if u < n / 2:
                heard.append((vocabulary[int(v * len(vocabulary))], float(0.1 + 0.5 * c)))
            else:
                heard.append((word, float(1.0 - n * c)))
        return tuple(heard)
