"""The user simulator: a semi-random person built from the domain, heard through noisy ASR.

Paper §3.3: "we used user simulations that provide semi-randomly generated user responses ...
responses already chosen were not allowed. For example, drawing a symbol in the middle of the
grid was only allowed if the location was empty."

Each dialogue the person is one of three kinds, drawn at `reset`: one who wants to play, one
who declines the first invitation ("maybe later", `Reject(playGame=later)`) and accepts when
asked again (`decline_probability`), and one who declines for good ("no thanks",
`Reject(playGame=no)`, `refuse_probability`). Either of the last two may say no before being
asked, in answer to the greeting or the introduction (`early_refusal_probability`): that no is
for a person who declines once, their one no. And, independently, one who asks to stop in
the middle of the game (`stop_probability`). In any answer the person may say something that
is none of the game's acts (`nonsense_probability`) or nothing at all (`silence_probability`);
asked for a move, they may answer out of turn with small talk (`out_of_turn_probability`);
told the outcome, they may ask for another game (`rematch_probability`). A person who never
agreed to play answers "Your turn" by asking to stop; one who wants to play but was heard saying
no (or stop) answers "Okay, maybe another time" (or "Okay, let's stop here") with a yes ("Yes,
I want to play.", the yeses of the user responses to these acts). `cooperative=True` is a
person who always agrees and plays a whole game (recognition noise still on), for measuring
game play.

What the person says is one of the domain's phrasings of the act they mean
(`user_phrases.txt`, the user responses), each equally often unless `phrasing_weights` says
otherwise (`oxbot learn agent` fits them to recorded dialogues); the cell they draw in comes from
the opponent strategy (`f(board) -> cell`), checked with `checked_move`. The robot hears it
through a speech recogniser model with noise level `asr_noise` = n: each word is dropped with
probability n/4, replaced by a random word of the phrasings (confidence uniform in [0.1, 0.6])
with probability n/4, and otherwise heard with a confidence uniform in [1-n, 1]; then
understands it with the real `UserActClassifier`, in the context of what the robot just said.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from oxbot.dialogue.cells_in_words import read_cell
from oxbot.dialogue.domain import (
    ACCEPT,
    ASK_AGAIN,
    DECLINE,
    GAME_MOVE_TEMPLATE,
    GRANT_REFUSAL,
    GRANT_STOP,
    GREETING,
    INTRODUCTION,
    INVITATION,
    MOVE_REQUEST,
    NEW_GAME,
    POSTPONE,
    SILENCE,
    STOP,
    UNKNOWN,
    Domain,
    draw_tag,
    game_move,
    is_feedback,
    is_game_move,
    words_of,
)
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.game.board import EMPTY_BOARD, Board, outcome
from oxbot.game.opponents import Opponent, checked_move, random_opponent

Heard = tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class UserTurn:
    """What the person did in answer to one system act."""

    act: str
    """What the person meant, e.g. `Confirm(playGame=yes)` or `GameMove(gridloc=middle)`;
    `Silence`."""
    text: str
    """What the person said, with the drawing in brackets; empty when silent."""
    heard: Heard
    """The recogniser's words with their confidences."""
    cell: int | None = None
    """The cell the person drew on, or None."""
    understood: tuple[str, float] = (SILENCE, 0.0)
    """The act the robot's understanding read in what it heard, with its score."""


SILENT = UserTurn(SILENCE, "", ())


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
        refuse_probability: float = 0.0,
        stop_probability: float = 0.0,
        nonsense_probability: float = 0.0,
        silence_probability: float = 0.0,
        rematch_probability: float = 0.0,
        early_refusal_probability: float = 0.0,
        cooperative: bool = False,
        understanding: UserActClassifier | None = None,
        phrasing_weights: dict[str, dict[str, float]] | None = None,
    ) -> None:
        self.domain = domain
        self.rng = rng if rng is not None else np.random.default_rng()
        self.opponent = opponent if opponent is not None else random_opponent(self.rng)
        self.asr_noise = asr_noise
        self.cooperative = cooperative
        off = 0.0 if cooperative else 1.0
        self.decline_probability = decline_probability * off
        self.refuse_probability = refuse_probability * off
        self.stop_probability = stop_probability * off
        self.nonsense_probability = nonsense_probability * off
        self.silence_probability = silence_probability * off
        self.rematch_probability = rematch_probability * off
        self.early_refusal_probability = early_refusal_probability * off
        self.out_of_turn_probability = out_of_turn_probability
        self.understanding = (
            understanding if understanding is not None else UserActClassifier(domain)
        )
        self._phrasings, self._words = _phrasings(domain)
        # how often each phrasing of an act is said, fitted to recorded dialogues
        self._weights = {
            act: np.array([weights.get(t, 1.0) for t in self._phrasings[act]], np.float64)
            for act, weights in (phrasing_weights or {}).items()
            if act in self._phrasings
        }
        self._small_talk = tuple(
            u
            for act in (GREETING, INTRODUCTION)
            for u in domain.responses_to(act)
            if u.act != SILENCE
        )
        self.reset()

    def reset(self) -> None:
        """Start a new dialogue with a new person, who has not yet been asked to play."""
        roll = self.rng.random()
        self.refuses = roll < self.refuse_probability
        self.declines_once = not self.refuses and roll < (
            self.refuse_probability + self.decline_probability
        )
        self.stops_after = (
            int(self.rng.integers(1, 4)) if self.rng.random() < self.stop_probability else None
        )
        # drawn only when it can happen, so that people who never say no early (the cooperative
        # ones among them) meet the same random stream as before this kind existed
        self.refuses_early = (
            (self.refuses or self.declines_once)
            and self.early_refusal_probability > 0.0
            and self.rng.random() < self.early_refusal_probability
        )
        self.asked = 0
        self.agreed = False
        self.refused = False
        self.asked_to_stop = False
        self.moves = 0

    @property
    def kind(self) -> str:
        """What this person wanted: "agrees", "declines once", "refuses" or "stops"."""
        if self.refuses:
            return "refuses"
        if self.asked_to_stop and self.agreed:
            return "stops"
        return "declines once" if self.declines_once else "agrees"

    # --- answers ------------------------------------------------------------------------------

    def respond(self, system_act: str, board: Board, person_to_move: bool) -> UserTurn:
        """The person's answer to `system_act`, given the board and whether they may draw."""
        rng = self.rng
        if system_act in (INVITATION, ASK_AGAIN):
            return self._asked_to_play(system_act)
        if system_act in (GREETING, INTRODUCTION) and self.refuses_early and not self.refused:
            self.refused = True
            return self._say(self._no(), system_act)
        if system_act == MOVE_REQUEST:
            return self._asked_to_move(board, person_to_move)
        if is_feedback(system_act) and rng.random() < self.rematch_probability:
            return self._say(NEW_GAME, system_act)
        alternatives = self.domain.responses_to(system_act)
        if system_act in (GRANT_REFUSAL, GRANT_STOP):
            # "Okay, another time", "Okay, let's stop here": only a person who wanted to play
            # on, heard saying no or stop, says yes to it
            yes = [" ".join(u.words) for u in alternatives if u.act == ACCEPT]
            if yes and self._wants_to_play(system_act, board):
                self.agreed = True
                return self._say(ACCEPT, system_act, texts=yes)
            alternatives = tuple(u for u in alternatives if u.act != ACCEPT)
        if not alternatives:
            return SILENT
        choice = alternatives[rng.integers(len(alternatives))]
        if choice.act == SILENCE:
            return SILENT
        return self._say(choice.act, system_act)

    def _wants_to_play(self, system_act: str, board: Board) -> bool:
        """Whether this person, told that the game will not be or stops here, wants to play:
        before the game, one who said yes or would; in it, one who has not asked to stop."""
        if self.asked_to_stop or outcome(board) is not None:
            return False
        if system_act == GRANT_STOP:
            return self.agreed and board != EMPTY_BOARD
        return board == EMPTY_BOARD and (
            self.agreed or not (self.refuses or self.declines_once or self.refused)
        )

    def _asked_to_play(self, system_act: str) -> UserTurn:
        rng = self.rng
        self.asked += 1
        if rng.random() < self.silence_probability:
            return SILENT
        if rng.random() < self.nonsense_probability:
            return self._say(UNKNOWN, system_act)
        first_no = self.declines_once and self.asked == 1 and not self.refuses_early
        if self.refuses or first_no:
            self.refused = True
            return self._say(self._no(), system_act)
        self.agreed = True
        return self._say(ACCEPT, system_act)

    def _no(self) -> str:
        """How this person says no: for good ("no thanks") or for now ("maybe later")."""
        return DECLINE if self.refuses else POSTPONE

    def _asked_to_move(self, board: Board, person_to_move: bool) -> UserTurn:
        rng = self.rng
        if not self.agreed or self.asked_to_stop or self.moves == self.stops_after:
            self.asked_to_stop = True  # nobody asked them, or they have had enough
            return self._say(STOP, MOVE_REQUEST)
        if self._small_talk and rng.random() < self.out_of_turn_probability:
            line = self._small_talk[rng.integers(len(self._small_talk))]
            return self._say(line.act, MOVE_REQUEST)
        if not person_to_move:
            return SILENT
        if rng.random() < self.nonsense_probability:
            return self._say(UNKNOWN, MOVE_REQUEST)
        cell = checked_move(self.opponent, board)
        self.moves += 1
        return self._say(GAME_MOVE_TEMPLATE, MOVE_REQUEST, cell)

    def _say(
        self,
        act: str,
        system_act: str,
        cell: int | None = None,
        texts: Sequence[str] | None = None,
    ) -> UserTurn:
        """`act` said in one of its phrasings (or of `texts`; a drawing in `cell`), heard
        and understood."""
        phrasings = self._phrasings[act] if texts is None else texts
        weights = self._weights.get(act) if texts is None else None
        if weights is None:  # the same random stream as before weights existed
            text = phrasings[int(self.rng.integers(len(phrasings)))]
        else:
            text = phrasings[int(self.rng.choice(len(phrasings), p=weights / weights.sum()))]
        if cell is not None:
            act = game_move(cell)
            text = f"{text} {draw_tag('usr', cell)}".strip()
        heard, understood = self.hear(text, system_act)
        return UserTurn(act, text, heard, cell, understood)

    def hear(
        self, text: str, system_act: str, noisy: bool = True
    ) -> tuple[Heard, tuple[str, float]]:
        """What the robot hears of `text` (through the noisy recogniser, unless not `noisy`)
        and understands it as, in answer to `system_act`: the act and its score."""
        words = words_of(text)
        heard = self.recognize(words) if noisy else tuple((w, 1.0) for w in words)
        if not heard:
            return (), (SILENCE, 0.0)
        reading = self.understanding.read(" ".join(w for w, _ in heard), system_act)
        score = 1.0 if reading.act == UNKNOWN else reading.score * _mean(heard)
        return heard, (reading.act, score)

    def phrasings(self, act: str) -> tuple[str, ...]:
        """The texts the person may say `act` with."""
        return self._phrasings[act]

    def recognize(self, words: list[str]) -> Heard:
        """The words as the noisy recogniser hears them: (word, confidence) pairs."""
        n = self.asr_noise
        if n <= 0.0:
            return tuple((w, 1.0) for w in words)
        rng = self.rng
        vocabulary = self._words
        heard = []
        for word, (u, v, c) in zip(words, rng.random((len(words), 3)), strict=True):
            if u < n / 4:
                continue  # dropped
            if u < n / 2:
                heard.append((vocabulary[int(v * len(vocabulary))], float(0.1 + 0.5 * c)))
            else:
                heard.append((word, float(1.0 - n * c)))
        return tuple(heard)


_PHRASINGS: dict[int, tuple[Domain, dict[str, tuple[str, ...]], tuple[str, ...]]] = {}


def phrasings_of(domain: Domain) -> dict[str, tuple[str, ...]]:
    """User act -> the texts the simulated person may say it with (`_phrasings`)."""
    return _phrasings(domain)[0]


def _phrasings(domain: Domain) -> tuple[dict[str, tuple[str, ...]], tuple[str, ...]]:
    """User act -> the texts the person may say it with (its phrasings and user responses; a
    drawing: its response texts without the tag, "" for a silent drawing, never one that names a
    cell), and every word of them; worked out once per domain."""
    cached = _PHRASINGS.get(id(domain))
    if cached is not None and cached[0] is domain:
        return cached[1], cached[2]
    found: dict[str, dict[str, None]] = {}
    for text, act in domain.user_phrases():
        if act == GAME_MOVE_TEMPLATE and read_cell(text) is not None:
            continue  # "top left" with a drawing that may be anywhere: a person would not
        found.setdefault(act, {})[text] = None
    for utterance in domain.responses_to(MOVE_REQUEST):
        if is_game_move(utterance.act):
            found.setdefault(GAME_MOVE_TEMPLATE, {})[" ".join(utterance.words)] = None
    phrasings = {act: tuple(texts) for act, texts in found.items()}
    words = tuple(
        dict.fromkeys(w for texts in phrasings.values() for t in texts for w in t.split())
    )
    _PHRASINGS[id(domain)] = (domain, phrasings, words)
    return phrasings, words


def _mean(heard: Heard) -> float:
    return sum(c for _, c in heard) / len(heard)
