"""A checker of the robot's claims about a move (`oxbot.dialogue.situated`), written apart
from it and from the game module: the lines are written out, each claim found by brute force."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import NamedTuple

import numpy as np

from oxbot.dialogue.domain import Turn, game_move_cell
from oxbot.dialogue.situated import PHRASINGS, moment_of, situated_sentence
from oxbot.robot.sentences import spoken

ROWS = [(0, 1, 2), (3, 4, 5), (6, 7, 8)]
THREE_IN_A_ROW = [*ROWS, (0, 3, 6), (1, 4, 7), (2, 5, 8), (0, 4, 8), (2, 4, 6)]
R, U, E = 1, 2, 0  # robot, person, empty


def board(text: str) -> tuple[int, ...]:
    """A board from 9 characters: R the robot's, U the person's, . empty."""
    return tuple({"R": R, "U": U, ".": E}[c] for c in text.replace(" ", ""))


def completing(b, player) -> set[int]:
    """Empty cells where `player` would have three in a row."""
    return {
        line[[b[c] for c in line].index(E)]
        for line in THREE_IN_A_ROW
        if sorted(b[c] for c in line) == sorted([player, player, E])
    }


def true_claims(before_person, person_cell, before, cell) -> set[str]:
    """Every claim that holds, by brute force."""
    after = tuple(R if i == cell else v for i, v in enumerate(before))
    held = set()
    if before_person is not None:
        if person_cell in completing(before_person, R):
            held.add("good_block")
        if completing(before_person, U) - {person_cell} and person_cell not in completing(
            before_person, U
        ):
            held.add("missed_win")
    if cell in completing(before, R):
        held.add("wins")
    if cell in completing(before, U):
        held.add("blocks")
    threats = len(completing(after, R))
    held |= {"two_ways"} if threats >= 2 else {"one_away"} if threats == 1 else set()
    won = any(all(after[c] == R for c in line) for line in THREE_IN_A_ROW)
    full = E not in after
    if not won and not full and all({R, U} <= {after[c] for c in line} for line in THREE_IN_A_ROW):
        held.add("draw_coming")
    return held


def said_claims(sentence: str) -> set[str]:
    """The claims a sentence makes, by their phrasings."""
    return {claim for claim, phrases in PHRASINGS.items() if any(p in sentence for p in phrases)}


class Said(NamedTuple):
    """One of the robot's sentences in a dialogue, as the running robot says it."""

    template: str
    """The template's words (what the policy's state holds)."""
    sentence: str
    """What is said: for a move, the words about it; else the template."""
    made: set[str]
    """The claims the sentence makes (none but for a move)."""
    held: set[str]
    """The claims that hold on the board (none but for a move)."""


def robot_sentences_said(transcript: Sequence[Turn], rng: np.random.Generator) -> Iterator[Said]:
    """Each robot turn of a simulated `transcript`, worded as the robot words it: a move with
    `situated_sentence`, never its last sentence again, and its claims beside those that hold."""
    last = ""
    for i, turn in enumerate(transcript):
        if turn["speaker"] != "sys":
            continue
        sentence = template = spoken(turn["text"])
        made: set[str] = set()
        held: set[str] = set()
        if game_move_cell(turn["act"]) is not None:
            sentence = situated_sentence(transcript[: i + 1], template, rng, last)
            made, held = said_claims(sentence), true_claims(*moment_of(transcript[: i + 1]))
        yield Said(template, sentence, made, held)
        last = sentence
