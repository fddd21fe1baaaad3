"""`oxbot study export DIR`: the study's data as CSV and JSON, with a data dictionary.

Files written (each to a temporary file, then renamed):

- `participants.csv`, `answers.csv`, `games.csv`, `blocks.csv`: one table each (`DICTIONARY`
  says what every column holds);
- `study.json`: the same four tables, the design and the per-condition summary;
- `data_dictionary.csv`: file, column, meaning, for every column above.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

from oxbot.atomic import atomic_write
from oxbot.study.results import block_rows, summary
from oxbot.study.store import StudyStore

_GAME = {
    "participant_id": "the participant's random id",
    "block": "the condition's position in the participant's order (1 = first)",
    "game": "the game's number within the block (1 = first)",
    "manager": "who chose the robot's words: dqn (the trained policy) or rules (hand-written)",
    "starter": "who drew first: robot or person",
    "input": "how the person was asked to answer: voice or typing",
    "status": "ended (the robot said goodbye) or left (the session stopped before)",
    "outcome": "from the robot's side: win, draw, loss, declined, stopped; empty if left",
    "success": "1 if a game was played to its end (win, draw or loss), else 0",
    "turns": "dialogue acts said, by the robot and the person",
    "moves": "the person's moves",
    "duration": "seconds from the robot's first act to its goodbye (or last act)",
    "time_per_move": "mean seconds from the robot's last act to each of the person's moves",
    "confidence": "mean recogniser confidence of the best hypothesis over spoken answers",
    "spoken": "answers given by voice",
    "typed": "answers typed",
    "asked_again": "times the robot asked the person to say it again (Request(repeat))",
    "corrected": "misunderstandings the person corrected: a yes or a move right after the "
    "robot took their answer for a no or a stop",
    "well_formed": "1 if the dialogue keeps oxbot's well-formedness rules, else 0",
    "problem": "why the dialogue is not well formed (empty when it is)",
    "transcript": "the dialogue as JSON: [{speaker, act, text}, ...]",
    "ended_at": "when the game's metrics were kept (Unix seconds)",
}
DICTIONARY: dict[str, dict[str, str]] = {
    "participants.csv": {
        "id": "the participant's random id (no name, no address)",
        "consented_at": "when they consented (Unix seconds)",
        "order_row": "their row of the balanced Latin square (counterbalancing)",
        "conditions": "their conditions in order, as manager/starter/input labels",
    },
    "answers.csv": {
        "participant_id": "the participant's random id",
        "instrument": "pre (about you), sus, likeability or intelligence",
        "block": "0 for the pre-questionnaire, else the condition's position it follows",
        "item": "the item's key: age_band, robot_experience, game_experience, sus1-sus10, "
        "like1-like5, intel1-intel5 (docs/study.md lists their wording)",
        "value": "the answer: a category for pre, 1-5 for the others",
        "answered_at": "when it was answered (Unix seconds)",
    },
    "games.csv": _GAME,
    "blocks.csv": {
        "participant": "the participant's random id",
        "block": "the condition's position in the participant's order",
        "condition": "manager/starter/input",
        "manager": "dqn or rules",
        "starter": "robot or person",
        "input": "voice or typing",
        "games": "games played in the block",
        "success": "share of the block's games played to their end",
        "turns": "mean turns per game",
        "duration": "mean seconds per game",
        "time_per_move": "mean of the games' time per move",
        "confidence": "mean of the games' recogniser confidence",
        "asked_again": "mean times asked again per game",
        "corrected": "mean corrections per game",
        "well_formed": "share of well-formed dialogues",
        "sus": "SUS score, 0-100 (Brooke 1996); empty if incomplete",
        "likeability": "Godspeed likeability, mean of 5 items, 1-5; empty if incomplete",
        "intelligence": "Godspeed perceived intelligence, mean of 5 items, 1-5; empty if "
        "incomplete",
    },
}


def tables(store: StudyStore) -> dict[str, list[dict[str, Any]]]:
    """The four exported tables, by file name."""
    participants = [
        {**p, "conditions": " ".join("/".join(c.values()) for c in p["conditions"])}
        for p in store.participants()
    ]
    return {
        "participants.csv": participants,
        "answers.csv": store.answers(),
        "games.csv": store.games(),
        "blocks.csv": block_rows(store),
    }


def to_csv(rows: list[dict[str, Any]], columns: list[str]) -> str:
    """`rows` as CSV text with a header of `columns` (None as an empty field)."""
    out = io.StringIO()
    writer = csv.DictWriter(out, columns, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({c: "" if row.get(c) is None else row[c] for c in columns})
    return out.getvalue()


def export(store: StudyStore, folder: str | Path) -> list[Path]:
    """Write the study's CSV and JSON files and the data dictionary into `folder`; the files."""
    folder = Path(folder)
    found = tables(store)
    written = []
    for name, rows in found.items():
        written.append(_write(folder / name, to_csv(rows, list(DICTIONARY[name]))))
    data = {
        "design": store.design(),
        **{name.removesuffix(".csv"): rows for name, rows in found.items()},
        "summary": summary(found["blocks.csv"]),
    }
    written.append(_write(folder / "study.json", json.dumps(data, indent=1)))
    meanings = [
        {"file": name, "column": column, "meaning": meaning}
        for name, columns in DICTIONARY.items()
        for column, meaning in columns.items()
    ]
    written.append(
        _write(folder / "data_dictionary.csv", to_csv(meanings, ["file", "column", "meaning"]))
    )
    return written


def _write(path: Path, text: str) -> Path:
    with atomic_write(path, "w") as handle:
        handle.write(text)
    return path
