"""Cells in words: where a person says they play, typed or heard, as the cell it names.

>>> read_cell("top left").cell  # the upper left
0
>>> read_cell("I'll take the middle one").cell  # the centre
4
>>> read_cell("row two column three").cell  # the middle right; "road to column three" too
5
>>> read_cell("number five").cell  # cells 1-9 row by row, as the terminal numbers them
4
>>> read_cell("I'm left handed") is None  # "left" alone names no cell
True
>>> move_in_words([("top left", 0.8), ("top left please", 0.5), ("stop it", 0.1)]).cell
0

The names are the board's (`oxbot.game.board`: rows upper, middle, lower; columns left, middle,
right; the centre is the middle), with the words people use for them: top and bottom for the
rows, centre, center and central for the middle, in either order ("left middle" is the middle
left), with "corner", "square", "one" and the like around them. Rows and columns go by number or
ordinal ("row 2 column 3", "the second row third column", "the left column of the top row"), and a
cell by its number ("number five", "cell 5", or the number alone, but for "one", which is "this
one" as often as the first cell).

A cell is read only when the words name exactly one cell and say nothing else but words that
come with a move ("I'll take", "please", "okay", "the", "one"...): "not the middle", "the middle
or the top left", "what's left" and "I'm left handed" name none. Where other words surround a
cell ("I'll go in the middle this time", "middle of nowhere"), the reading is `loose`: no move,
but the robot may ask which cell was meant when it understood nothing else. A comma or full stop
ends a reference: "right, the middle one" is the centre, where "right the middle one" is the
middle right (a recogniser writes no comma; see docs/robot.md, "Moves in words"); a row and
its column may be apart ("row 2, column 3").

A recogniser mishears some words of a row or column in ways nobody would type: "road to column
three" is "row two column three" (Whisper). `REPAIRS` undoes the few that are safe, and only
right where they can mean nothing else: "road", "roll" or "rho" before a number and with a
column named too, "to" or "too" after "row", "column" or "number". A reading that needed one is
`repaired`, and counts as less sure (`REPAIRED_CERTAINTY`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from oxbot.game.board import CELL_NAMES, COLUMN_NAMES, N_CELLS, ROW_NAMES, SIZE

_MIDDLE = SIZE // 2
ROW_WORDS: dict[str, int] = {
    **{name: i for i, name in enumerate(ROW_NAMES)},
    "top": 0,
    "bottom": SIZE - 1,
}
"""A row's words: the board's names and the ones people say."""
COLUMN_WORDS: dict[str, int] = {name: i for i, name in enumerate(COLUMN_NAMES)}
"""A column's words: the board's names."""
MIDDLE_WORDS = frozenset({"middle", "centre", "center", "central", "mid"})
"""The middle of a row or a column, and the centre of the board alone."""
ROW_KEYS = frozenset({"row", "rows"})
COLUMN_KEYS = frozenset({"column", "columns", "col"})
NUMBER_KEYS = frozenset({"number", "cell", "square", "box", "field", "no"})
"""Words before a cell's number: "number five", "cell 5"."""
NUMBERS: dict[str, int] = {
    **{w: i for i, w in enumerate(("one", "two", "three", "four", "five"), start=1)},
    **{w: i for i, w in enumerate(("six", "seven", "eight", "nine"), start=6)},
    **{str(i): i for i in range(1, N_CELLS + 1)},
}
ORDINALS: dict[str, int] = {
    "first": 1,
    "second": 2,
    "third": 3,
    "1st": 1,
    "2nd": 2,
    "3rd": 3,
    "last": SIZE,
}
"""A row's or column's place: "the second row", "the last column"."""
REPAIRS: dict[str, str] = {"road": "row", "roll": "row", "rho": "row", "to": "two", "too": "two"}
"""A recogniser's mishearings of a row or column's words, undone only in place (see the module):
Whisper wrote "road to column three" for "row two column three"."""
REPAIRED_CERTAINTY = 0.8
"""How sure a reading that needed a repair is, against 1 for the words as they are: heard at
confidence c, it counts as 0.8 c against the robot's gate (`speech.min_move_confidence`)."""
FILLERS = frozenset(
    {
        *("the", "a", "an", "one", "ones", "of", "in", "on", "at", "into", "to", "and"),
        *("corner", "square", "cell", "box", "spot", "space", "place", "position", "hand", "side"),
        *("i", "i'll", "i'd", "i'm", "me", "my", "mine", "we", "let's", "let", "it", "is", "that"),
        *("take", "taking", "pick", "choose", "go", "going", "gonna", "put", "play", "want"),
        *("like",),
        *("would", "will", "have", "draw", "mark", "move", "turn", "there", "here", "this"),
        *("please", "thanks", "thank", "you", "okay", "ok", "alright", "right", "yes", "yeah"),
        *("um", "uh", "er", "erm", "hmm", "so", "well", "then", "now", "just", "maybe"),
    }
)
"""Words that may come with a move and name no cell. "Right" and "one" among them too: where they
name a cell ("top right", "number one") they are read as that, elsewhere they are these."""
_AFTER_RIGHT = frozenset({"in", "at", "on", "there", "here", "now", "away", "into"})
_INTERJECTIONS = frozenset({"okay", "ok", "alright", "right", "yes", "yeah", "so", "well", "um"})
_LINE_WORDS = ROW_KEYS | COLUMN_KEYS | {w for w, r in REPAIRS.items() if r == "row"}
_TOKEN = re.compile(r"\d+(?:st|nd|rd|th)?|[a-z]+(?:'[a-z]+)?")
_CHUNKS = re.compile(r"[,.;:!?]+")


@dataclass(frozen=True)
class CellWords:
    """A cell named in words: which, and how the words named it."""

    cell: int
    """The cell's index, row-major from the upper left (`CELL_NAMES`)."""
    loose: bool = False
    """Other words came with it: perhaps no move at all ("middle of nowhere"); never played."""
    repaired: bool = False
    """A recogniser's mishearing was undone to read it ("road to column three")."""

    @property
    def certainty(self) -> float:
        """How sure the words alone make the reading: 1, `REPAIRED_CERTAINTY`, 0 when loose."""
        if self.loose:
            return 0.0
        return REPAIRED_CERTAINTY if self.repaired else 1.0


@dataclass(frozen=True)
class MoveHeard:
    """A move an N-best list says in words, with how sure the robot may be of it."""

    cell: int
    score: float
    """The best hypothesis's confidence, times the certainty of its reading, times the share of
    the N-best's confidence that names the same cell; in [0, 1]."""
    words: str
    """The best hypothesis, which named the cell."""
    agreement: float = 1.0
    """Of the N-best's confidence on hypotheses that name a cell, the share on this one: below
    `MIN_AGREEMENT` the hypotheses are torn between cells, however sure the best one is."""

    def played_at(self, gate: float) -> bool:
        """Whether the robot plays this move with `gate` (`speech.min_move_confidence`): heard
        surely enough, and the N-best not torn between cells; otherwise it asks which cell."""
        return self.score >= gate and self.agreement >= MIN_AGREEMENT


MIN_AGREEMENT = 2 / 3
"""A move the N-best list is torn about (two cells heard about as surely, "top left" 0.8 and
"top right" 0.8: agreement 0.5) is asked about whatever the gate: the recogniser's confidence
says how sure it is of the words, not which of two cells was meant."""


def read_cell(text: str) -> CellWords | None:
    """The one cell `text` names (see the module), or None when it names none, or several."""
    found: list[CellWords] = []
    other = False
    half: list[str] = []  # "row two," waiting for its column
    for chunk in _CHUNKS.split(text.lower()):
        tokens = half + _TOKEN.findall(chunk)
        half = []
        if not tokens or all(t in _INTERJECTIONS for t in tokens):
            continue
        reading = _read_chunk(tokens)
        if reading is None and _LINE_WORDS.intersection(tokens):
            half = tokens
        elif reading is None:
            other = True  # words that name no cell: the whole answer names one loosely at best
        else:
            found.append(reading)
    other = other or bool(half)
    if len({r.cell for r in found}) != 1:
        return None
    return CellWords(
        found[0].cell,
        loose=other or any(r.loose for r in found),
        repaired=any(r.repaired for r in found),
    )


def move_in_words(nbest: Iterable[tuple[str, float]]) -> MoveHeard | None:
    """The move the best hypothesis of `nbest` names, with its score (see `MoveHeard`), or None
    when it names no cell, or names one only loosely."""
    hypotheses = [(text, confidence) for text, confidence in nbest if _TOKEN.search(text.lower())]
    if not hypotheses:
        return None
    best_text, best_confidence = hypotheses[0]
    best = read_cell(best_text)
    if best is None or best.loose:
        return None
    total = sum(confidence for _, confidence in hypotheses)
    same = naming = 0.0
    for text, confidence in hypotheses:
        reading = read_cell(text)
        if reading is not None and not reading.loose:
            naming += confidence
            same += confidence if reading.cell == best.cell else 0.0
    agreement = same / total if total > 0 else 1.0
    score = best_confidence * best.certainty * agreement
    among_cells = same / naming if naming > 0 else 1.0
    return MoveHeard(best.cell, round(score, 6), best_text, round(among_cells, 6))


def _read_chunk(tokens: Sequence[str]) -> CellWords | None:
    """The cell one stretch of words names, or None (none, part of one, or several)."""
    tokens, repaired = _repaired(list(tokens))
    # "right in the middle", "right there": "right" says where exactly, not which column
    after = [*tokens[1:], ""]
    used = [t == "right" and next_ in _AFTER_RIGHT for t, next_ in zip(tokens, after, strict=True)]
    row = _line(tokens, used, ROW_KEYS, ROW_WORDS)
    column = _line(tokens, used, COLUMN_KEYS, COLUMN_WORDS)
    cells: list[int] = []
    positions = [i for i, t in enumerate(tokens) if not used[i] and _is_position(t)]
    if row is not None or column is not None:
        # "the middle of the top row": the line's other half is a position word
        for i in positions:
            t = tokens[i]
            if row is None and (t in ROW_WORDS or t in MIDDLE_WORDS):
                row, used[i] = ROW_WORDS.get(t, _MIDDLE), True
            elif column is None and (t in COLUMN_WORDS or t in MIDDLE_WORDS):
                column, used[i] = COLUMN_WORDS.get(t, _MIDDLE), True
        if row is None or column is None:
            return None  # half a cell: "row two"
        cells.append(row * SIZE + column)
        positions = [i for i in positions if not used[i]]
    if positions:
        cell = _position([tokens[i] for i in positions])
        if cell is None:
            return None  # "left" alone, "top bottom"
        cells.append(cell)
        for i in positions:
            used[i] = True
    for i, t in enumerate(tokens):
        if t in NUMBER_KEYS and i + 1 < len(tokens) and tokens[i + 1] in NUMBERS:
            cells.append(NUMBERS[tokens[i + 1]] - 1)
            used[i] = used[i + 1] = True
        elif t.replace("'", "") in CELL_NAMES and t not in MIDDLE_WORDS:
            cells.append(CELL_NAMES.index(t))  # the board's own names: "upperleft"
            used[i] = True
    said = [t for i, t in enumerate(tokens) if not used[i]]
    if not cells:
        # a number alone ("five", "I'll take 5"); never "one" alone ("I pick this one")
        numbers = [t for t in said if t in NUMBERS and t != "one"]
        others = [t for t in said if t not in FILLERS and t not in numbers]
        if len(numbers) != 1 or others:
            return None
        cells.append(NUMBERS[numbers[0]] - 1)
        said.remove(numbers[0])
    if len(set(cells)) != 1:
        return None
    loose = any(t not in FILLERS for t in said)
    return CellWords(cells[0], loose=loose, repaired=repaired)


def _repaired(tokens: list[str]) -> tuple[list[str], bool]:
    """The tokens with a recogniser's mishearings undone where they can mean nothing else, and
    whether any was."""
    repaired = False
    has_column = any(t in COLUMN_KEYS for t in tokens)
    for i, t in enumerate(tokens):
        after = tokens[i + 1] if i + 1 < len(tokens) else ""
        before = tokens[i - 1] if i else ""
        if REPAIRS.get(t) == "row" and has_column and (after in NUMBERS or after in REPAIRS):
            tokens[i], repaired = "row", True
        elif REPAIRS.get(t) == "two" and before in ROW_KEYS | COLUMN_KEYS | NUMBER_KEYS:
            tokens[i], repaired = "two", True
    return tokens, repaired


def _line(
    tokens: Sequence[str], used: list[bool], keys: frozenset[str], words: dict[str, int]
) -> int | None:
    """The row (or column) `tokens` name with one of `keys` and its `words`: "row 2", "second
    row", "top row", "middle row"; its index, or None. Marks the words it read as used."""
    for i, t in enumerate(tokens):
        if t not in keys:
            continue
        after = tokens[i + 1] if i + 1 < len(tokens) else ""
        before = tokens[i - 1] if i else ""
        if after in NUMBERS and 1 <= NUMBERS[after] <= SIZE:
            used[i] = used[i + 1] = True
            return NUMBERS[after] - 1
        if before in ORDINALS and ORDINALS[before] <= SIZE:
            used[i] = used[i - 1] = True
            return ORDINALS[before] - 1
        if before in MIDDLE_WORDS or before in words:
            used[i] = used[i - 1] = True
            return _MIDDLE if before in MIDDLE_WORDS else words[before]
    return None


def _is_position(token: str) -> bool:
    return token in ROW_WORDS or token in COLUMN_WORDS or token in MIDDLE_WORDS


def _position(words: Sequence[str]) -> int | None:
    """The cell two position words name in either order ("top left", "left top", "middle left",
    "top middle"), or the centre for a middle alone; None for anything else."""
    if len(words) == 1:
        return _MIDDLE * SIZE + _MIDDLE if words[0] in MIDDLE_WORDS else None
    if len(words) != 2:
        return None
    a, b = words
    for first, second in ((a, b), (b, a)):
        if first in ROW_WORDS and first not in MIDDLE_WORDS and second in COLUMN_WORDS:
            return ROW_WORDS[first] * SIZE + COLUMN_WORDS[second]
        if first in ROW_WORDS and first not in MIDDLE_WORDS and second in MIDDLE_WORDS:
            return ROW_WORDS[first] * SIZE + _MIDDLE
        if first in MIDDLE_WORDS and second in COLUMN_WORDS and second not in MIDDLE_WORDS:
            return _MIDDLE * SIZE + COLUMN_WORDS[second]
    if a in MIDDLE_WORDS and b in MIDDLE_WORDS:
        return _MIDDLE * SIZE + _MIDDLE
    return None
