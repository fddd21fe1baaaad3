"""Words that fit the moment: what the robot says with its move, read from the board.

The paper's robot said a fixed template with every move ("I take this one"), and names a
situated language generator as the way forward. Here the policy still chooses the act, and its
state still sees the template's words (the paper's features, unchanged); the person hears a
sentence about the game instead, made only of claims that are true on the board:
- why it plays there: the move wins, blocks the person's win, makes two ways to win, or one;
- what it thinks of the person's last move: it blocked the robot's win, or missed their own;
- that a draw is coming: no line is open to either player any more.
The template is said too ("Good block. I'll go here. One more and I win."), so that the words
say which template the state holds. `claims` names what holds; `situated_sentence` words it,
never the robot's previous sentence when it has another way to say it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from oxbot.dialogue.domain import Turn, game_move_cell
from oxbot.game.board import (
    EMPTY,
    EMPTY_BOARD,
    LINES,
    ROBOT,
    USER,
    Board,
    is_winning_move,
    outcome,
    play,
    winning_cells,
)

PHRASINGS: dict[str, tuple[str, ...]] = {
    "wins": ("And that makes three.", "This one wins it."),
    "blocks": (
        "I'll block you here.",
        "I have to stop you here.",
        "Not so fast, I'll take this one.",
    ),
    "two_ways": ("Now I have two ways to win.", "That gives me two ways to win."),
    "one_away": ("One more and I win.", "I'm one away from three in a row."),
    "draw_coming": ("This is heading for a draw.", "Nobody can win this one now."),
    "good_block": ("Good block.", "Nice block.", "You stopped me there."),
    "missed_win": ("You could have won there.", "Phew, you missed a win."),
}
"""The words of each claim; a sentence is a reaction to the person's move, then why the robot
plays there, then whether a draw is coming, each where it holds."""
REACTIONS = ("good_block", "missed_win")
REASONS = ("wins", "blocks", "two_ways", "one_away")
"""In order of precedence: a move that wins is not also called a block."""


def claims(
    before_person: Board | None, person_cell: int | None, before: Board, cell: int
) -> list[str]:
    """What is true of the robot's move on `cell` (the board `before` it), and of the person's
    last move on `person_cell` (the board `before_person` it; None: no move of theirs since the
    robot's last): at most one reaction, one reason, and "draw_coming"."""
    said: list[str] = []
    if before_person is not None and person_cell is not None:
        if is_winning_move(before_person, person_cell, ROBOT):
            said.append("good_block")
        elif winning_cells(before_person, USER) and not is_winning_move(
            before_person, person_cell, USER
        ):
            said.append("missed_win")
    after = play(before, cell, ROBOT)
    threats = len(winning_cells(after, ROBOT))
    if is_winning_move(before, cell, ROBOT):
        said.append("wins")
    elif cell in winning_cells(before, USER):
        said.append("blocks")
    elif threats >= 2:
        said.append("two_ways")
    elif threats == 1:
        said.append("one_away")
    if outcome(after) is None and not any(_open(after, line) for line in LINES):
        said.append("draw_coming")
    return said


def _open(board: Board, line: Sequence[int]) -> bool:
    """Whether one player can still complete `line`: it holds no mark of the other."""
    marks = {board[c] for c in line} - {EMPTY}
    return len(marks) <= 1


def moment_of(transcript: Sequence[Turn]) -> tuple[Board | None, int | None, Board, int] | None:
    """The boards around the robot's move that ends `transcript` (its last turn, a GameMove of
    the robot's), replayed from every drawn move in it: the board before the person's last
    move and that move (None, None if the person has not moved since the robot's last move),
    the board before the robot's, and its cell. None if the last turn is no move of the robot."""
    if not transcript or transcript[-1]["speaker"] != "sys":
        return None
    cell = game_move_cell(transcript[-1]["act"])
    if cell is None:
        return None
    board: Board = EMPTY_BOARD
    before_person: Board | None = None
    person_cell: int | None = None
    for turn in transcript[:-1]:
        moved = game_move_cell(turn["act"])
        if moved is None or board[moved] != EMPTY:
            continue
        player = USER if turn["speaker"] == "usr" else ROBOT
        if player == USER:
            before_person, person_cell = board, moved
        else:
            before_person = person_cell = None
        board = play(board, moved, player)
    return before_person, person_cell, board, cell


def situated_sentence(
    transcript: Sequence[Turn],
    template: str,
    rng: np.random.Generator,
    last: str = "",
    says_where: bool = False,
) -> str:
    """What the robot says with the move that ends `transcript`: its reaction to the person's
    move, `template` (the act's template, as spoken), why it plays there and whether a draw is
    coming, each where it holds; never `last` when the claims have another wording. The
    template is always said, so that the words say which one the policy's state holds
    (`template_in`). `says_where`: `template` says where the robot plays (on paper, where no arm
    points), and comes first."""
    moment = moment_of(transcript)
    template = template if template[-1:] in (".", "!", "?") else f"{template}."
    held = claims(*moment) if moment is not None else []
    sentence = template
    # not a wording that opens as the template does ("This one is mine. This one wins it.")
    opening = template.lower().split()[:2]
    wordings = {
        claim: [p for p in PHRASINGS[claim] if p.lower().split()[:2] != opening]
        or list(PHRASINGS[claim])
        for claim in held
    }
    for _ in range(8):
        parts = [wordings[claim][int(rng.integers(len(wordings[claim])))] for claim in held]
        reacts = 0 if says_where else sum(claim in REACTIONS for claim in held)
        parts.insert(reacts, template)
        sentence = " ".join(parts)
        if sentence != last:
            return sentence
    return sentence


def template_in(said: str, templates: Sequence[str]) -> str | None:
    """The template, of `templates` (spoken, without their mark-up), that a sentence of
    `situated_sentence` was made around, or None. Longest first: one template may hold
    another's words."""
    for template in sorted(templates, key=len, reverse=True):
        words = template.rstrip(".!?")
        if words and words in said:
            return template
    return None
