"""Understanding the person: recognised or typed words -> the user dialogue act.

The conversation log shows each user turn with its act, like the paper's Figure 1
(`Usr: Yes, let's play. [Confirm(playGame=yes)]`), and the interaction manager's state reads
the act the person's words were understood as, with how sure the understanding is. The acts
and how people say them come from the domain files: `user_phrases.txt` (hundreds of phrasings:
"sure why not", "nah I'm good", "maybe later", "one more"...), the user responses and the seed
dialogues' USR lines, and `[Unknown]` things people say that are none of the game's acts.

The classifier is a logistic regression (scikit-learn) over word unigrams and bigrams ("why
not" is not "not") and character n-grams within words (typed misspellings, recogniser
fragments), TF-IDF weighted. It never guesses: below `min_probability` for its best act, when
the best act is `Unknown`, when no word of the answer is a word of any phrasing, when a single
word is not itself a phrasing (a recogniser that lost "why" of "why not" leaves "not"), or when
the answer says no where it looks like a yes (or the reverse), it is Unknown, and the robot
asks again.

    classifier = UserActClassifier(load_domain())
    classifier.classify("sure why not")   # Confirm(playGame=yes), its probability, a phrase
    classifier.intent_of(recognize(wav))  # the act the N-best list as a whole votes for
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
from threadpoolctl import threadpool_limits

from oxbot.dialogue.domain import (
    ACCEPT,
    ACKNOWLEDGE,
    ASK_AGAIN,
    CLOSING,
    DECLINE,
    FEEDBACK_ACTS,
    GAME_MOVES,
    GRANT_REFUSAL,
    GRANT_STOP,
    I_START,
    INVITATION,
    MOVE_REQUEST,
    NEW_GAME,
    POSTPONE,
    REFUSALS,
    SILENCE,
    STOP,
    UNKNOWN,
    WHO_STARTS,
    Domain,
    words_of,
)
from oxbot.errors import DataError, InvalidInputError

if TYPE_CHECKING:
    from sklearn.linear_model import LogisticRegression
    from sklearn.pipeline import FeatureUnion

MIN_PROBABILITY = 0.4
"""Below this probability for its best act, an answer is Unknown (never a guess). Chosen by
cross-validation on the domain's own phrasings (see tests/dialogue/test_understanding.py)."""
MIN_YES_CONFIDENCE = 0.75
"""A yes heard with a recogniser confidence below this (`intent_of`) is Unknown: a game nobody
agreed to is worse than asking again. The answers to the invitation in the 12 tuning
voices, clean and at 20 dB (192 recordings, `tests/speech/test_evaluation.py`): 7 no's heard as
a yes with the floor at 0, 3 at 0.6, 1 at 0.7, none from 0.75; 2 of the 72 yeses then asked
again. An acknowledgement ("okay", "nice") is held to the same floor: a sneeze heard as "okay" at
0.3 is no answer to "I won". Typed words (confidence 1) are never affected, nor the simulated
person (`read`)."""
MIN_HEARD_CONFIDENCE = 0.1
"""An N-best list whose best hypothesis the recogniser is less than this sure of is Unknown,
whatever its words: a sigh heard as "no" at 0.08 is no answer. Chosen on development data only:
of the 160 development non-speech clips (bench/bench_nonspeech.py --part dev), the one Whisper
made an answer of had 0.08; the development people's yes and no (300) and the tuning voices'
phrases lost nothing to this floor at 0.1, 2 of 290 at 0.3; pocketsphinx's answers to the
invitation in the tuning voices fall from 97% to 93% understood with a floor of 0.2. Typed
words (confidence 1) are never affected."""
MIN_UNSAID_NO_CONFIDENCE = 0.75
"""A no whose words do not say no themselves (`polarity`: a stop or a goodbye in answer to the
invitation, "enough", "I have to go"), heard with a recogniser confidence below this, is
Unknown, as a yes is below `MIN_YES_CONFIDENCE`: a misheard yes ("yes" heard as "enough" at
0.4) must not send the person away. A "later" is left alone: the robot asks once more after it
anyway. Typed words are unaffected (docs/robot.md, "A no that does not say no")."""
REGULARISATION = 10.0
"""Inverse strength of the logistic regression's L2 penalty (scikit-learn's C)."""

NEGATIVE = (
    *("no", "not", "nope", "nah", "never", "don't", "won't", "can't", "cannot", "pass", "busy"),
    *("later", "another time", "in a bit", "in a while", "i'm good", "i'm okay", "i'm fine"),
    *("it's okay", "that's okay", "go away", "leave me alone"),
)
"""Words that say no. An answer read as a yes that holds one is not understood: hearing a yes
where the person said no (a flip) is the worst mistake the robot can make, asking again the
mildest."""
NEGATIVE_BUT_YES = ("why not", "don't mind", "can't wait", "not bad")
"""Yeses that hold a word that says no."""
POSITIVE = (
    *("yes", "yeah", "yep", "yup", "sure", "okay", "ok", "alright", "all right", "of course"),
    *("let's play", "let's go", "i'm in", "why not"),
)
"""Words that say yes. An answer read as a no that holds one, and none that says no, is not
understood either."""
APPROVING = (*POSITIVE, "cool", "nice", "great", "good", "fine", "right")
"""Acknowledgements that say yes when they answer a question ("cool", "okay I see"); the others
("oh", "hmm", "oh no", "oops") answer nothing and are not understood."""
UNSURE = ("not sure", "don't know", "dunno", "don't understand", "it depends", "maybe not")
"""Words that say the person has not decided: whatever they were read as, not understood."""

_AS_YES = {ACKNOWLEDGE: ACCEPT, NEW_GAME: ACCEPT, I_START: ACCEPT, WHO_STARTS: ACCEPT}
_AS_ANSWER = {**_AS_YES, CLOSING: DECLINE, STOP: DECLINE}
_AS_STOP = {DECLINE: STOP, POSTPONE: STOP, CLOSING: STOP}
IN_CONTEXT: dict[str, dict[str, str]] = {
    **{asked: _AS_ANSWER for asked in (INVITATION, ASK_AGAIN)},
    **{told: {ACCEPT: ACKNOWLEDGE} for told in FEEDBACK_ACTS.values()},
    **{playing: _AS_STOP for playing in (MOVE_REQUEST, *GAME_MOVES)},
    GRANT_REFUSAL: {NEW_GAME: ACCEPT, I_START: ACCEPT},
}
"""What an act means as the answer to a system act: asked to play, "okay then", "one game",
"can I start" and "who starts?" all say yes (the robot's "let's play" and its first move, or its
"your turn", answer who starts), "goodbye" and "I have to go" no; told who won, "yes" acknowledges
it; in the middle of a game, "no", "I don't want to" and "goodbye" ask to stop; told "okay,
another time", "one game" changes the person's mind (and a yes only with `CHANGED_MIND`'s
words)."""
CHANGED_MIND = ("play", "game", "let's go", "i'm in", "i do", "i did", "i said", "actually", "wait")
"""After the robot let a no or a stop go ("Okay, maybe another time.", "Okay, let's stop
here."), a yes is a change of mind (or a yes or a move it misheard) only with one of these
words: "okay", "sure" and even a bare "yes" there may only agree."""
_LETTING_GO = (GRANT_REFUSAL, GRANT_STOP)
YES_NO_QUESTIONS = (INVITATION, ASK_AGAIN)
"""The robot's acts that ask a yes/no question ("Shall we play?"): only an answer to one of
these may be read from the keyword model alone (`oxbot.speech.keywords.keyword_rescue`)."""


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
    """How sure the understanding is, in [0, 1]; 0 for Silence and Unknown."""
    phrase: str = ""
    """The nearest known phrasing of the act (normalised words), empty for Silence/Unknown."""
    unsure: str = ""
    """For Unknown: the act the words said when only the recogniser's confidence, below
    `MIN_YES_CONFIDENCE`, made them Unknown (a yes heard too unsurely to start a game on)."""


def normalised(text: str) -> str:
    """The words of `text` as the classifier reads them: lower case, no punctuation."""
    return " ".join(words_of(text))


class UserActClassifier:
    """Words -> user act, for typed text and recogniser hypotheses alike (see the module)."""

    def __init__(
        self,
        domain: Domain,
        min_probability: float = MIN_PROBABILITY,
        min_yes_confidence: float = MIN_YES_CONFIDENCE,
        min_unsaid_no_confidence: float = MIN_UNSAID_NO_CONFIDENCE,
        min_heard_confidence: float = MIN_HEARD_CONFIDENCE,
    ) -> None:
        from sklearn.feature_extraction.text import TfidfVectorizer
        from sklearn.linear_model import LogisticRegression
        from sklearn.pipeline import FeatureUnion

        pairs = domain.user_phrases()
        if len({act for _, act in pairs}) < 2:
            raise DataError(
                "the domain has fewer than two user acts to tell apart; add user_phrases.txt "
                "or USR lines"
            )
        self.texts = [text for text, _ in pairs]
        self.acts = [act for _, act in pairs]
        self.min_probability = min_probability
        self.min_yes_confidence = min_yes_confidence
        self.min_unsaid_no_confidence = min_unsaid_no_confidence
        self.min_heard_confidence = min_heard_confidence
        self.vectorizer = FeatureUnion(
            [
                ("words", TfidfVectorizer(ngram_range=(1, 2), token_pattern=r"[a-z']+")),
                ("chars", TfidfVectorizer(analyzer="char_wb", ngram_range=(2, 4))),
            ]
        )
        with threadpool_limits(1):  # a small fit: threads on shared cores make it 30x slower
            features = self.vectorizer.fit_transform(self.texts)
            self.model = LogisticRegression(C=REGULARISATION, max_iter=5_000)
            self.model.fit(features, self.acts)
        self.classes: list[str] = [str(c) for c in self.model.classes_]
        self._features = features
        self._parts = _linear_parts(self.vectorizer, self.model)
        self.words = frozenset(w for text in self.texts for w in text.split())
        """Every word of the phrasings: an answer with none of them is not understood."""
        self.one_word_answers = frozenset(text for text in self.texts if " " not in text)
        """The phrasings of one word: another single word is a fragment ("not" of "why not",
        "in" of "I'm in"), not an answer."""
        self._cache: dict[str, np.ndarray] = {}

    @property
    def phrases(self) -> dict[str, str]:
        """Every known phrasing (normalised words) with its act."""
        return dict(zip(self.texts, self.acts, strict=True))

    def probabilities(self, text: str) -> np.ndarray:
        """Pr(act | words) over `classes` for one utterance (memoised: answers repeat)."""
        key = normalised(text)
        found = self._cache.get(key)
        if found is None:
            found = self._parts.probabilities(key)
            if len(self._cache) < 100_000:
                self._cache[key] = found
        return found

    def classify(self, text: str, context: str = "") -> UserAct:
        """The act of `text` (typed or recognised words) as an answer to the system act
        `context` (none: out of context), or Unknown when unsure; with the nearest phrasing."""
        if not normalised(text):
            return UserAct(SILENCE, 0.0)
        return self._with_phrase(self.read(text, context), normalised(text))

    def read(self, text: str, context: str = "") -> UserAct:
        """`classify` without looking up the nearest phrasing (the simulator's fast path)."""
        words = normalised(text)
        if not words:
            return UserAct(SILENCE, 0.0)
        return self._decide(self.probabilities(words), words, context)

    def intent_of(
        self, nbest: Iterable[tuple[str, float]] | Iterable[Scored], context: str = ""
    ) -> UserAct:
        """The act an N-best list votes for, each hypothesis weighted by its confidence.

        `nbest` holds `(text, confidence)` pairs (`oxbot.speech.recognize`, JSON) or objects with
        `.text` and `.confidence` (`Recognizer.recognize`). The recogniser's top entries are often
        near ties between a right phrase and a wrong one; two hypotheses that agree outweigh one
        that does not. The score is the weighted probability of the chosen act, scaled by the
        recogniser's confidence in the best hypothesis. A best hypothesis below
        `MIN_HEARD_CONFIDENCE` is Unknown; so is a yes or an acknowledgement from one below
        `MIN_YES_CONFIDENCE`, and a no whose words do not say no below
        `MIN_UNSAID_NO_CONFIDENCE`.
        """
        total = np.zeros(len(self.classes))
        weight = 0.0
        best_text, best_confidence = "", 0.0
        no_weight = 0.0  # the vote's weight carried by hypotheses that say no in words
        for entry in nbest:
            if isinstance(entry, tuple | list):
                text, confidence = entry
            else:
                text, confidence = entry.text, entry.confidence
            if not 0.0 <= confidence <= 1.0:
                raise InvalidInputError(f"confidence {confidence!r} of {text!r} is not in [0, 1]")
            if not normalised(text):
                continue
            if not best_text:
                best_text, best_confidence = normalised(text), confidence
            total += confidence * self.probabilities(text)
            weight += confidence
            no_weight += confidence if polarity(text) == "no" else 0.0
        if weight <= 0.0 or best_confidence < self.min_heard_confidence:
            return UserAct(UNKNOWN if best_text else SILENCE, 0.0)
        decided = self._decide(total / weight, best_text, context)
        if decided.act in (ACCEPT, ACKNOWLEDGE) and best_confidence < self.min_yes_confidence:
            return UserAct(UNKNOWN, 0.0, unsure=decided.act)
        if (
            decided.act == DECLINE
            and best_confidence < self.min_unsaid_no_confidence
            and no_weight <= weight / 2
        ):
            return UserAct(UNKNOWN, 0.0)
        act = self._with_phrase(decided, best_text)
        return UserAct(act.act, round(act.score * best_confidence, 6), act.phrase)

    def _decide(self, probabilities: np.ndarray, text: str, context: str) -> UserAct:
        k = int(np.argmax(probabilities))
        act, p = self.classes[k], float(probabilities[k])
        words = text.split()
        unknown_words = self.words.isdisjoint(words)  # only letters in common
        fragment = len(words) == 1 and text not in self.one_word_answers
        meant = IN_CONTEXT.get(context, {}).get(act, act)
        if context in _LETTING_GO and meant == ACCEPT and not _holds(text, CHANGED_MIND):
            meant = ACKNOWLEDGE
        if (
            act == UNKNOWN
            or p < self.min_probability
            or unknown_words
            or fragment
            or _contradicts(act, text)
            # What the words mean here is checked too: "oh no" acknowledges, but it is no yes.
            or _contradicts(meant, text)
            or (act == ACKNOWLEDGE and meant == ACCEPT and not _holds(text, APPROVING))
        ):
            return UserAct(UNKNOWN, 0.0)
        return UserAct(meant, round(p, 6))

    def _with_phrase(self, reading: UserAct, text: str) -> UserAct:
        """`reading` with the known phrasing most like `text` among those of the act the
        classifier read (cosine of the TF-IDF vectors), for the log."""
        if reading.act in (SILENCE, UNKNOWN):
            return reading
        k = int(np.argmax(self.probabilities(text)))
        mine = np.flatnonzero(np.array(self.acts) == self.classes[k])
        similarity = (self._features[mine] @ self.vectorizer.transform([text]).T).toarray()
        return UserAct(reading.act, reading.score, self.texts[mine[int(np.argmax(similarity))]])


def polarity(text: str) -> str | None:
    """ "no" when the words say no (`NEGATIVE`, not "why not"), "yes" when they say or approve
    a yes (`APPROVING`: "fine", "i'm in"), else None; for checking one listener against
    another (`oxbot.speech.keywords.second_opinion`)."""
    words = normalised(text)
    if _holds(words, NEGATIVE) and not _holds(words, NEGATIVE_BUT_YES):
        return "no"
    if _holds(words, APPROVING):
        return "yes"
    return None


def _holds(text: str, cues: tuple[str, ...]) -> bool:
    padded = f" {text} "
    return any(f" {cue} " in padded for cue in cues)


def _contradicts(act: str, text: str) -> bool:
    """True when the words are undecided, or say the opposite of the yes or no they were read
    as."""
    if _holds(text, UNSURE):
        return True
    says_no = _holds(text, NEGATIVE) and not _holds(text, NEGATIVE_BUT_YES)
    if act == ACCEPT:
        return says_no
    return act in REFUSALS and _holds(text, POSITIVE) and not says_no


class _LinearParts:
    """The fitted TF-IDF vectorisers and logistic regression as plain arrays: Pr(act | words)
    for one utterance in microseconds (the same numbers as `predict_proba`, tested), for the
    simulator, which asks every turn."""

    def __init__(self, parts: list, intercept: np.ndarray) -> None:
        self.parts = parts
        self.intercept = intercept

    def probabilities(self, text: str) -> np.ndarray:
        logits = self.intercept.copy()
        for analyse, vocabulary, idf, weights in self.parts:
            counts = Counter(vocabulary[g] for g in analyse(text) if g in vocabulary)
            if not counts:
                continue
            index = np.fromiter(counts, dtype=np.int64)
            values = np.fromiter(counts.values(), dtype=np.float64) * idf[index]
            logits += (values / np.linalg.norm(values)) @ weights[index]
        logits -= logits.max()
        p = np.exp(logits)
        return p / p.sum()


def _linear_parts(vectorizer: FeatureUnion, model: LogisticRegression) -> _LinearParts:
    parts, start = [], 0
    for _, part in vectorizer.transformer_list:
        n = len(part.vocabulary_)
        weights = np.ascontiguousarray(model.coef_[:, start : start + n].T)
        parts.append((part.build_analyzer(), part.vocabulary_, part.idf_, weights))
        start += n
    return _LinearParts(parts, model.intercept_.astype(np.float64))
