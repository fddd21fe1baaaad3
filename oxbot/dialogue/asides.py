"""Questions a person asks the robot in passing, answered in any state of the dialogue.

"Who starts?", "what's your name?", "how do you play?", "can you repeat that?" and "wait" (a
person who talks over the robot to stop it, or wants time) are no answer to what the robot
asked, and no act its policy chooses among: the interaction manager answers them itself, in the
transcript but not in what the policy sees (as it says which cell a move in words meant), and
then waits for the answer it was waiting for ("wait": as long as for an answer to a question).
The domain's understanding reads "who starts?" as a yes to "Shall we play?" (the robot's "let's
play" and first move answer it); asked outright, it is answered and taken for no yes: a
question is no consent.

>>> aside_question("who starts")
'who_starts'
>>> aside_question("Sorry, what's your name?")
'name'
>>> aside_question("pardon")
'repeat'
>>> aside_question("how do you play this game?")
'rules'
>>> aside_question("could you say that again please")
'repeat'
>>> aside_question("wait a second")
'hold'
>>> aside_question("sorry no") is None  # an apology before an answer asks nothing
True
>>> aside_question("yes let's play") is None
True

A question is read only when the words are the question and nothing else but a few words that
come with one ("sorry", "please", "oxbot", "um"): "I don't know who starts" or "yes, who starts?"
are left to the understanding.
"""

from __future__ import annotations

import re

from oxbot.dialogue.domain import words_of

MIN_CONFIDENCE = 0.5
"""A question heard less surely than this is left to the understanding (which asks again
about words it cannot make out)."""

WHO_STARTS = "who_starts"
NAME = "name"
REPEAT = "repeat"
HOLD = "hold"
RULES = "rules"
OFF_TOPIC = "off_topic"

ASIDE_ACTS = {
    WHO_STARTS: "Request(whoStarts)",
    NAME: "Request(name)",
    REPEAT: "Request(sayAgain)",
    HOLD: "Request(wait)",
    RULES: "Request(rules)",
    OFF_TOPIC: "Request(offTopic)",
}
"""How the transcript and the page's log show each question (the person's act)."""

_AROUND = r"(?:sorry|excuse me|um|uh|hmm|so|and|but|oh|please|robot|oxbot|then|now|again)"
"""Words that may come before or after a question without making it something else."""
_QUESTIONS: dict[str, tuple[str, ...]] = {
    WHO_STARTS: (
        r"who (?:starts|starts first|goes first|begins|plays first|moves first|is first"
        r"|should start|will start|is going to start|is starting)",
        r"who's (?:first|starting|going first|going to start)",
        r"(?:whose|who's) (?:turn|go|move) is it",
        r"is it (?:my|your) (?:turn|go|move)",
        r"(?:do|shall|should|will) (?:i|you|we) (?:start|go first|begin)",
        r"(?:are|am) (?:you|i) (?:starting|going first)",
        r"who goes now",
    ),
    NAME: (
        r"what(?:'s| is) your name",
        r"what are you called",
        r"who are you",
        r"what should i call you",
        r"do you have a name",
        r"what's your name again",
    ),
    REPEAT: (
        r"(?:can|could|would|will) you (?:please )?(?:repeat|say) (?:that|it|this)(?: again)?",
        r"(?:can|could|would|will) you (?:please )?repeat",
        r"(?:please )?(?:repeat|say) (?:that|it) (?:again|once more)",
        r"(?:please )?repeat(?: that| it)?",
        r"(?:pardon|pardon me|come again|sorry what|what was that|what did you say)",
        r"i (?:didn't|did not|couldn't|could not) (?:hear|catch|get|understand) (?:that|it|you)",
        r"say again",
        r"what",
        r"sorry",
    ),
    HOLD: (
        r"wait(?: a (?:second|sec|moment|minute|bit))?",
        r"(?:hold|hang) on(?: a (?:second|sec|moment|minute|bit))?",
        r"(?:just )?(?:one|a) (?:second|sec|moment|minute)",
        r"give me a (?:second|sec|moment|minute)",
        r"let me think",
    ),
    RULES: (
        r"how (?:do|does|should|can) (?:you|i|we|one|it|this|the game) (?:play|work|win)"
        r"(?: (?:it|this|this game|the game|noughts and crosses|tic tac toe))?",
        r"what are the rules(?: again)?",
        r"(?:can|could|would|will) you (?:please )?(?:tell|explain) (?:me |us )?the rules",
        r"(?:explain|tell me) the rules",
        r"how does (?:it|this|this game|the game) work",
        r"what do i (?:do|have to do|draw)",
        r"i don't know (?:how to play|the rules)",
        r"what(?:'s| is) (?:noughts and crosses|tic tac toe)",
    ),
}
_PATTERNS = {
    kind: re.compile(rf"^(?:{_AROUND} )*(?:{'|'.join(forms)})(?: {_AROUND})*$")
    for kind, forms in _QUESTIONS.items()
}


def aside_question(text: str) -> str | None:
    """Which question (`WHO_STARTS`, `NAME`, `REPEAT`, `HOLD`, `RULES`) the words `text` are, or
    None."""
    words = " ".join(words_of(text))
    if not words:
        return None
    return next((kind for kind, pattern in _PATTERNS.items() if pattern.match(words)), None)


_QUESTION_WORDS = re.compile(
    r"^(?:sorry |excuse me |um |uh |hmm |so |and |but |oh |robot |oxbot )*"
    r"(?:what|what's|how|why|where|when|who|which|are|is|can|could|do|does|did|will|would"
    r"|have|has|should|shall)\b"
)


def off_topic(text: str) -> bool:
    """Whether `text` is worded as a question ("are you a robot?", "how old are you?"): asked
    of the robot and not understood as anything of the game, it is off the topic.

    >>> off_topic("can you play chess"), off_topic("how old are you?")
    (True, True)
    >>> off_topic("blah blah"), off_topic("the middle one")
    (False, False)
    """
    return bool(_QUESTION_WORDS.match(" ".join(words_of(text))))


__all__ = [
    "ASIDE_ACTS",
    "HOLD",
    "MIN_CONFIDENCE",
    "NAME",
    "OFF_TOPIC",
    "REPEAT",
    "RULES",
    "WHO_STARTS",
    "aside_question",
    "off_topic",
]
