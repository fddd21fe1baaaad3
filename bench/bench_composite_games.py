"""Benchmark of the move tracker over whole games on composed sheets, against the acceptance line
"no board with a misread symbol accepted as a move by the tracker over a sequence of frames".

    PYTHONPATH=. .venv/bin/python bench/bench_composite_games.py                 # test part
    PYTHONPATH=. .venv/bin/python bench/bench_composite_games.py --split dev --save /tmp/games

Each game is a random legal game (a random starter; the starter draws circles) played on one
sheet composed as `bench/bench_composite.py` composes its photos (real handwriting on real paper
photos of one part, `oxbot.testing.composite.compose_game`), seen by a camera held still: for
the empty sheet and after each symbol is drawn, `--frames` photos that differ only in sensor
noise. They are read as the robot reads its camera (`BoardReader.read`, then
`MoveTracker.update` with `still_readings`; a frame without a grid is a missed reading), and the
robot's own symbols are told to the tracker before they appear (`robot_draws`), as the arm does.

A person's move is *right* when the tracker accepts it, in its cell and symbol, while the frames
of its stage last; *wrong* when the tracker accepts anything else (a misread symbol, a phantom
move in an empty or the robot's stage): the game is then broken, and counted as such. A move
never accepted *stalls* the game (the robot would keep waiting and say why): safe, but no game.
Measurement only: look at and debug on `dev`, never tune on `test`.
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from composite_sources import add_source_options, load_sources, paper_kind
from config_option import add_set_option
from rich.progress import track

from oxbot.config import OxbotConfig, load_config
from oxbot.errors import NoGridFound
from oxbot.game.board import (
    CELL_NAMES,
    EMPTY_BOARD,
    ROBOT,
    USER,
    legal_moves,
    outcome,
    play,
    symbol_of,
    to_move,
)
from oxbot.perception.board import BoardReader, default_reader
from oxbot.perception.tracker import AcceptedDrawing, ImpossibleEvent, MoveTracker
from oxbot.robot.game_moves import still_readings
from oxbot.testing.composite import HandwritingSource, PaperSource, compose_game


@dataclass
class GameTally:
    """What became of the games of one kind of sheet."""

    games: int = 0
    whole: int = 0  # every person's move accepted right, nothing else accepted
    broken: int = 0  # a wrong move accepted
    stalled: int = 0  # a person's move never accepted (and nothing wrong before it)
    moves: int = 0  # the person's moves shown to the tracker
    right: int = 0
    impossible: Counter = field(default_factory=Counter)
    frames_to_accept: list[int] = field(default_factory=list)

    def add(self, other: GameTally) -> None:
        for name in ("games", "whole", "broken", "stalled", "moves", "right"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.impossible.update(other.impossible)
        self.frames_to_accept.extend(other.frames_to_accept)


def random_game(rng: np.random.Generator) -> tuple[bool, list[tuple[int, int]]]:
    """Who starts (True: the robot) and a random legal game's moves (player, cell) to its end."""
    robot_starts = bool(rng.integers(2))
    board, moves = EMPTY_BOARD, []
    while outcome(board) is None:
        player = to_move(board, robot_starts)
        cell = int(rng.choice(legal_moves(board)))
        board = play(board, cell, player)
        moves.append((player, cell))
    return robot_starts, moves


def play_game(
    rng: np.random.Generator,
    hands: HandwritingSource,
    papers: PaperSource,
    frames: int,
    reader: BoardReader,
    config: OxbotConfig,
) -> tuple[GameTally, dict[str, str], str, np.ndarray | None]:
    """One game composed and watched: its tally, what the sheet shows, what went wrong (empty
    when nothing did) and the frame it went wrong on."""
    robot_starts, moves = random_game(rng)
    labels = ["nothing"] * 9
    for player, cell in moves:
        labels[cell] = symbol_of(player, robot_starts)
    stages, notes = compose_game(rng, hands, papers, labels, [c for _, c in moves], frames)
    tracker = MoveTracker(robot_starts, config.tracker)
    tally = GameTally(games=1)
    for stage, photos in enumerate(stages):
        drawn = moves[stage - 1] if stage else None
        if drawn is not None and drawn[0] == ROBOT:
            tracker.robot_draws(drawn[1])
        expected = None
        if drawn is not None and drawn[0] == USER:
            expected = (drawn[1], labels[drawn[1]])
            tally.moves += 1
        accepted = False
        seen = []  # how each frame read the drawn cell, for a stalled game's report
        for k, photo in enumerate(photos):
            try:
                reading = reader.read(photo)
            except NoGridFound:
                event = tracker.update(None)
                seen.append("no grid")
            else:
                event = tracker.update(reading.labels, still_readings(reading) or None)
                if expected is not None:
                    cell = reading.readings[expected[0]]
                    seen.append(f"{cell.label} {cell.confidence:.2f}")
            if isinstance(event, ImpossibleEvent):
                tally.impossible[event.kind] += 1
            if not isinstance(event, AcceptedDrawing):
                continue
            if (event.cell, event.symbol) != expected:
                tally.broken = 1
                want = "nothing" if expected is None else describe(expected)
                what = (
                    f"stage {stage}: accepted {event.symbol} in {CELL_NAMES[event.cell]}, "
                    f"drawn {want}"
                )
                return tally, notes, what, photo
            accepted = True
            tally.right += 1
            tally.frames_to_accept.append(k + 1)
        if expected is not None and not accepted:
            tally.stalled = 1
            what = f"stage {stage}: {describe(expected)} never accepted, read {', '.join(seen)}"
            return tally, notes, what, photos[-1]
    tally.whole = 1
    return tally, notes, "", None


def describe(move: tuple[int, str]) -> str:
    return f"{move[1]} in {CELL_NAMES[move[0]]}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_source_options(parser)
    parser.add_argument("--games", type=int, default=100)
    parser.add_argument("--frames", type=int, default=5, help="photos per stage of a game")
    parser.add_argument(
        "--first", type=int, default=0, help="start at this game (each has its own seed)"
    )
    parser.add_argument("--save", type=Path, help="write the frame each failed game failed on")
    add_set_option(parser, "perception.plus_is_cross=true")
    args = parser.parse_args()
    hands, papers = load_sources(args.hands, args.papers, args.split, "bench_composite_games")
    hands = hands.split(args.split)
    config = load_config(assignments=args.set)
    reader = default_reader(config.perception)
    if args.save:
        args.save.mkdir(parents=True, exist_ok=True)
    total = GameTally()
    by_kind: dict[str, GameTally] = defaultdict(GameTally)
    failures = []
    games = range(args.first, args.first + args.games)
    for game in track(games, description=f"games on the {args.split} part"):
        rng = np.random.default_rng([args.seed, 3 if args.split == "dev" else 4, game])
        one, notes, what, frame = play_game(rng, hands, papers, args.frames, reader, config)
        total.add(one)
        by_kind[paper_kind(notes)].add(one)
        if what:
            status = "BROKEN " if one.broken else "stalled"
            failures.append(
                f"  {status} game {game:3d}  {what}  ({notes['paper']}, {notes['ink']}; "
                f"{notes['notes']})"
            )
            if args.save and frame is not None:
                name = args.save / f"{args.split}_game{game:03d}.png"
                cv2.imwrite(str(name), frame[:, :, ::-1])
    print(
        f"{args.games} games on the {args.split} part, seed {args.seed}, "
        f"{args.frames} frames per stage, a camera held still"
    )
    print("\n".join(failures))
    report(total, by_kind)


def report(total: GameTally, by_kind: dict[str, GameTally]) -> None:
    def line(name: str, t: GameTally) -> str:
        return (
            f"  {name:<18} {t.games:>4} games: whole {t.whole:>4}, wrong move accepted "
            f"{t.broken:>3}, stalled {t.stalled:>3}; person's moves accepted {t.right}/{t.moves}"
        )

    print(line("all", total))
    median = float(np.median(total.frames_to_accept)) if total.frames_to_accept else float("nan")
    print(
        f"  frames to accept a move, median {median:g}; impossible events told: "
        f"{dict(total.impossible)}"
    )
    print("by paper (and pencil apart):")
    for kind, part in sorted(by_kind.items()):
        print(line(kind, part))


if __name__ == "__main__":
    main()
