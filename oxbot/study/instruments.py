"""The study's questionnaires and their scoring, as their authors define it.

- `PRE`: before the games, the participant's age band, experience with robots and with the game
  (categories, not scored).
- `SUS`: the System Usability Scale (Brooke, J. 1996. "SUS: a 'quick and dirty' usability
  scale". In *Usability Evaluation in Industry*, Taylor & Francis, 189-194): ten statements
  answered 1 (strongly disagree) to 5 (strongly agree); an odd item scores its answer - 1, an
  even item 5 - its answer, and the sum times 2.5 is the score, 0 to 100. "System" is read as
  "robot" in the statements, as studies of robots commonly do.
- `LIKEABILITY` and `INTELLIGENCE`: the Godspeed questionnaire's likeability and perceived
  intelligence scales (Bartneck, C., Kulić, D., Croft, E. and Zoghbi, S. 2009. "Measurement
  instruments for the anthropomorphism, animacy, likeability, perceived intelligence, and
  perceived safety of robots". *International Journal of Social Robotics* 1(1), 71-81): five
  semantic differentials each, rated 1 to 5 between the two words; a scale's score is the mean
  of its items.

An instrument's items are answered on the study page one at a time; `check_answer` refuses
a value an item cannot take, and `score` scores a complete set (None while any is missing).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from oxbot.errors import InvalidInputError


@dataclass(frozen=True)
class Item:
    """One question: its key, its wording (a statement, or the two ends of a differential) and
    the values it may take."""

    key: str
    text: str
    values: tuple[str, ...]
    low: str = ""
    high: str = ""


@dataclass(frozen=True)
class Instrument:
    """A questionnaire: its name, what the page says above it, and its items."""

    name: str
    title: str
    instructions: str
    items: tuple[Item, ...]
    scored: bool = True


LIKERT = ("1", "2", "3", "4", "5")

PRE = Instrument(
    "pre",
    "About you",
    "Three questions before the games. Pick the answer closest to yours.",
    (
        Item(
            "age_band",
            "Your age",
            ("18-24", "25-34", "35-44", "45-54", "55-64", "65+", "prefer not to say"),
        ),
        Item(
            "robot_experience",
            "How often have you talked with or used a robot before?",
            ("never", "once or twice", "a few times", "often"),
        ),
        Item(
            "game_experience",
            "How often have you played noughts and crosses (tic-tac-toe)?",
            ("never", "once or twice", "a few times", "often"),
        ),
    ),
    scored=False,
)

_SUS_TEXT = (
    "I think that I would like to use this robot frequently.",
    "I found the robot unnecessarily complex.",
    "I thought the robot was easy to use.",
    "I think that I would need the support of a technical person to be able to use this robot.",
    "I found the various functions in this robot were well integrated.",
    "I thought there was too much inconsistency in this robot.",
    "I would imagine that most people would learn to use this robot very quickly.",
    "I found the robot very cumbersome to use.",
    "I felt very confident using the robot.",
    "I needed to learn a lot of things before I could get going with this robot.",
)
SUS = Instrument(
    "sus",
    "Using the robot",
    "For each statement, pick how much you agree: 1 strongly disagree, 5 strongly agree.",
    tuple(
        Item(f"sus{i}", text, LIKERT, "strongly disagree", "strongly agree")
        for i, text in enumerate(_SUS_TEXT, start=1)
    ),
)


def _differential(prefix: str, pairs: tuple[tuple[str, str], ...]) -> tuple[Item, ...]:
    return tuple(
        Item(f"{prefix}{i}", f"{low} - {high}", LIKERT, low, high)
        for i, (low, high) in enumerate(pairs, start=1)
    )


_GODSPEED = "Please rate your impression of the robot on these scales (1 to 5)."
LIKEABILITY = Instrument(
    "likeability",
    "Your impression of the robot (1)",
    _GODSPEED,
    _differential(
        "like",
        (
            ("Dislike", "Like"),
            ("Unfriendly", "Friendly"),
            ("Unkind", "Kind"),
            ("Unpleasant", "Pleasant"),
            ("Awful", "Nice"),
        ),
    ),
)
INTELLIGENCE = Instrument(
    "intelligence",
    "Your impression of the robot (2)",
    _GODSPEED,
    _differential(
        "intel",
        (
            ("Incompetent", "Competent"),
            ("Ignorant", "Knowledgeable"),
            ("Irresponsible", "Responsible"),
            ("Unintelligent", "Intelligent"),
            ("Foolish", "Sensible"),
        ),
    ),
)

AFTER_CONDITION = (SUS, LIKEABILITY, INTELLIGENCE)
"""What a participant answers after each condition's games."""
INSTRUMENTS = {i.name: i for i in (PRE, *AFTER_CONDITION)}
SCORES = ("sus", "likeability", "intelligence")
"""The scored instruments, in the order exports and the experimenter's page show them."""


def check_answer(instrument: str, item: str, value: str) -> None:
    """InvalidInputError unless `value` is an answer `item` of `instrument` may take."""
    found = INSTRUMENTS.get(instrument)
    if found is None:
        raise InvalidInputError(f"no instrument {instrument!r}; known: {', '.join(INSTRUMENTS)}")
    items = {i.key: i for i in found.items}
    if item not in items:
        raise InvalidInputError(f"{instrument} has no item {item!r}; its items: {', '.join(items)}")
    if value not in items[item].values:
        raise InvalidInputError(
            f"{instrument} {item} takes one of {', '.join(items[item].values)}, not {value!r}"
        )


def sus_score(answers: Mapping[str, int]) -> float | None:
    """SUS as Brooke (1996) scores it: odd items answer - 1, even items 5 - answer, the sum
    times 2.5 (0-100); None unless all ten are answered."""
    keys = [f"sus{i}" for i in range(1, 11)]
    if any(k not in answers for k in keys):
        return None
    total = sum(
        answers[k] - 1 if i % 2 == 1 else 5 - answers[k] for i, k in enumerate(keys, start=1)
    )
    return total * 2.5


def mean_scale(instrument: Instrument, answers: Mapping[str, int]) -> float | None:
    """A Godspeed scale's score: the mean of its items (Bartneck et al. 2009); None unless all
    are answered."""
    values = [answers.get(i.key) for i in instrument.items]
    if any(v is None for v in values):
        return None
    return sum(values) / len(values)  # type: ignore[arg-type]


def score(instrument: str, answers: Mapping[str, str | int]) -> float | None:
    """The score of one instrument's answers (item key -> value), None if incomplete or the
    instrument is not scored."""
    if instrument not in SCORES:
        return None
    numbers = {k: int(v) for k, v in answers.items()}
    if instrument == "sus":
        return sus_score(numbers)
    if instrument in ("likeability", "intelligence"):
        return mean_scale(INSTRUMENTS[instrument], numbers)
    return None
