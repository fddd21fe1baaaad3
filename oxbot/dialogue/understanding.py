"""Understanding the person: recognised or typed words -> the user dialogue act.

The conversation log shows each user turn with its act, like the paper's Figure 1
(`Usr: Yes, let's play. [Confirm(playGame=yes)]`). The acts come from the domain files: every
user response alternative and every USR line of the seed dialogues is a known phrase with its
act. An utterance gets the act of the nearest known phrase.

Nearness is a soft word alignment: the best monotonic pairing of the heard words with the
phrase's words (a weighted longest common subsequence), where equal words count 1 and words
spelt nearly alike ("thank"/"thanks", "lets"/"let's") count their character similarity. The
score is the Dice coefficient of that pairing, 2·matched / (heard + phrase words), so recogniser
fragments ("yes play") and extra words ("yes let's play please") still land on their phrase.

    classifier = UserActClassifier(load_domain())
    classifier.classify("yes play")       # Confirm(playGame=yes), score 0.8, "yes let's play"
    classifier.intent_of(recognize(wav))  # the act the N-best list as a whole votes for
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from difflib import SequenceMatcher
from functools import lru_cache
from typing import Protocol

from oxbot.dialogue.domain import (
    GAME_MOVE_TEMPLATE,
    SILENCE,
    UNKNOWN,
    Domain,
    is_game_move,
    words_of,
)
from oxbot.errors import DataError, InvalidInputError

MIN_SCORE = 0.3
"""Below this the nearest phrase shares too little with what was heard: the act is Unknown."""
SPELLING_SIMILARITY = 0.75
"""Two different words count as the same word, partly, from this character similarity up."""
ALIASES = {"ok": "okay", "yeah": "yes", "yep": "yes", "nope": "no", "goodbye": "good bye"}
"""Typed spellings of domain words that are too short or too far apart to match by letters."""


class Scored(Protocol):
    """An N-best entry of `Recognizer.recognize`."""

    text: str
    confidence: float


@dataclass(frozen=True)
class UserAct:
    """What the person did in one turn, as the conversation log shows it."""

    act: str
    """A user act of the domain (`GameMove(gridloc=$loc)` for a move), `Silence` or `Unknown`."""
    score: float
    """How well the words matched `phrase`, in [0, 1]; 0 for Silence and Unknown."""
    phrase: str = ""
    """The nearest known phrase (normalised words), empty when nothing matched."""


@lru_cache(maxsize=4096)
def _word_similarity(a: str, b: str) -> float:
    if a == b:
        return 1.0
    ratio = SequenceMatcher(None, a, b).ratio()
    return ratio if ratio >= SPELLING_SIMILARITY else 0.0


def similarity(heard: Sequence[str], phrase: Sequence[str]) -> float:
    """Dice coefficient of the best soft alignment of two word sequences, in [0, 1]."""
    if not heard or not phrase:
        return 0.0
    # matched[i][j]: best total similarity pairing heard[:i] with phrase[:j] in order.
    matched = [[0.0] * (len(phrase) + 1) for _ in range(len(heard) + 1)]
    for i, h in enumerate(heard, start=1):
        for j, p in enumerate(phrase, start=1):
            matched[i][j] = max(
                matched[i - 1][j],
                matched[i][j - 1],
                matched[i - 1][j - 1] + _word_similarity(h, p),
            )
    return 2.0 * matched[-1][-1] / (len(heard) + len(phrase))


class UserActClassifier:
    """Nearest known phrase -> user act, for typed text and recogniser hypotheses alike."""

    def __init__(self, domain: Domain, min_score: float = MIN_SCORE) -> None:
        # How often each (phrase, act) occurs breaks ties: "yes" is nearer to the acceptances,
        # which the domain has more of, than to "yes i won".
        self.counts: Counter[tuple[str, str]] = Counter()
        for utterance in domain.user_utterances():
            if utterance.words:
                act = GAME_MOVE_TEMPLATE if is_game_move(utterance.act) else utterance.act
                self.counts[" ".join(utterance.words), act] += 1
        if not self.counts:
            raise DataError("the domain has no user phrase to classify answers by; add USR lines")
        self.min_score = min_score

    @property
    def phrases(self) -> dict[str, str]:
        """Every known phrase (normalised words) with its act."""
        return {phrase: act for phrase, act in self.counts}

    def classify(self, text: str) -> UserAct:
        """The act of the known phrase nearest to `text` (typed or recognised words)."""
        heard = " ".join(ALIASES.get(w, w) for w in words_of(text)).split()
        if not heard:
            return UserAct(SILENCE, 0.0)
        score, _, phrase, act = max(
            (similarity(heard, phrase.split()), count, phrase, act)
            for (phrase, act), count in self.counts.items()
        )
        if score < self.min_score:
            return UserAct(UNKNOWN, 0.0)
        return UserAct(act, round(score, 6), phrase)

    def intent_of(self, nbest: Iterable[tuple[str, float]] | Iterable[Scored]) -> UserAct:
        """The act an N-best list votes for, each hypothesis weighted by its confidence.

        `nbest` holds `(text, confidence)` pairs (`oxbot.speech.recognize`, JSON) or objects with
        `.text` and `.confidence` (`Recognizer.recognize`). The recogniser's top entries are
        often near ties between a right phrase and a wrong one; two hypotheses that agree on the
        act outweigh one that does not. The score is the act's share of the votes times how well
        its best phrase matched.
        """
        votes: Counter[str] = Counter()
        best: dict[str, UserAct] = {}
        for entry in nbest:
            if isinstance(entry, tuple | list):
                text, confidence = entry
            else:
                text, confidence = entry.text, entry.confidence
            if not 0.0 <= confidence <= 1.0:
                raise InvalidInputError(f"confidence {confidence!r} of {text!r} is not in [0, 1]")
            heard = self.classify(text)
            votes[heard.act] += confidence * heard.score
            if heard.act not in best or heard.score > best[heard.act].score:
                best[heard.act] = heard
        total = sum(votes.values())
        if total <= 0.0:  # nothing heard, or nothing that matched
            return UserAct(UNKNOWN if set(best) - {SILENCE} else SILENCE, 0.0)
        act = max(votes, key=lambda a: votes[a])
        return UserAct(act, round(votes[act] / total * best[act].score, 6), best[act].phrase)
