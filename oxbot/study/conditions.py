"""The study's conditions and their counterbalancing across participants.

A condition fixes three factors: the interaction manager (`dqn`, the trained policy, or
`rules`, the hand-written baseline), who starts (`robot` or `person`) and how the person
answers (`voice` or `typing`). The experimenter picks which factors vary (`--vary`, default
all three: 8 conditions); the others keep their `FIXED` value.

The orders are the rows of a balanced Latin square (Williams, E. J. 1949, "Experimental designs
balanced for the estimation of residual effects of treatments", *Australian Journal of
Scientific Research* 2(3), 149-168): each condition comes at each position equally often, and
each condition directly follows each other equally often (first-order carry-over balanced).
For n conditions there are n rows when n is even, 2n (the square and its mirror) when n is odd.
Participant k (counted from 0 as they consent) takes row k modulo the number of rows; a study
whose participants take only the first `blocks` conditions of their row still has each
condition at each of those positions equally often over a whole number of squares.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

from oxbot.errors import ConfigError

FACTORS: dict[str, tuple[str, ...]] = {
    "manager": ("dqn", "rules"),
    "starter": ("robot", "person"),
    "input": ("typing", "voice"),
}
"""Each factor's levels."""
FIXED = {"manager": "dqn", "starter": "robot", "input": "typing"}
"""A factor's level when it does not vary."""


def conditions(vary: Sequence[str] = tuple(FACTORS)) -> list[dict[str, str]]:
    """Every condition of a design varying the factors in `vary`: their full factorial, the
    rest fixed; in a fixed order (the levels' order, the first factor slowest)."""
    unknown = [f for f in vary if f not in FACTORS]
    if unknown:
        raise ConfigError(
            f"no factor {', '.join(unknown)}: a study varies some of {', '.join(FACTORS)}"
        )
    varying = [f for f in FACTORS if f in vary]
    return [
        {**FIXED, **dict(zip(varying, levels, strict=True))}
        for levels in itertools.product(*(FACTORS[f] for f in varying))
    ]


def balanced_latin_square(n: int) -> list[list[int]]:
    """The rows of a Williams design for n treatments (n rows if n is even, else 2n): each
    treatment once per row, equally often at each position and after each other treatment."""
    if n < 1:
        raise ConfigError("a study needs at least one condition")
    # the first row runs 0, 1, n-1, 2, n-2, ...; row i adds i to each, modulo n
    first, low, high = [0], 1, n - 1
    while len(first) < n:
        first.append(low)
        low += 1
        if len(first) < n:
            first.append(high)
            high -= 1
    rows = [[(c + i) % n for c in first] for i in range(n)]
    if n % 2 == 1:
        rows += [list(reversed(r)) for r in rows]
    return rows


@dataclass(frozen=True)
class Design:
    """A study's design: its conditions, the games in each, and how many conditions each
    participant takes."""

    vary: tuple[str, ...] = tuple(FACTORS)
    games: int = 1
    blocks: int = 0
    """Conditions per participant (0: all of them)."""

    def __post_init__(self) -> None:
        if self.games < 1:
            raise ConfigError(f"--games must be at least 1, not {self.games}")
        n = len(self.conditions)
        if not 0 <= self.blocks <= n:
            raise ConfigError(
                f"--blocks must be between 1 and {n} (the conditions), not {self.blocks}"
            )

    @property
    def conditions(self) -> list[dict[str, str]]:
        """Every condition of the design, in `conditions`' order."""
        return conditions(self.vary)

    @property
    def per_participant(self) -> int:
        """How many conditions each participant plays."""
        return self.blocks or len(self.conditions)

    def order(self, row: int) -> list[dict[str, str]]:
        """The conditions, in order, of the participant who takes counterbalancing row `row`."""
        square = balanced_latin_square(len(self.conditions))
        chosen = square[row % len(square)][: self.per_participant]
        return [self.conditions[c] for c in chosen]

    def to_dict(self) -> dict:
        """The design as the database and the export keep it."""
        return {"vary": list(self.vary), "games": self.games, "blocks": self.per_participant}

    @classmethod
    def from_dict(cls, data: dict) -> Design:
        """The design `to_dict` wrote."""
        return cls(tuple(data["vary"]), int(data["games"]), int(data["blocks"]))


def label(condition: dict[str, str]) -> str:
    """A condition's short name, e.g. "dqn/robot/voice"."""
    return "/".join(condition[f] for f in FACTORS)
