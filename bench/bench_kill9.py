"""kill -9 of each component process at each act of a scripted game: does the game finish?

A `Launcher` runs the robot's seven component processes on loopback (a fresh robot name and
port), and a `RemoteRobot` plays scripted games against it: "yes, let's play" to every
invitation, a typed move on the first free cell of a fixed order at every "Your move", nothing
else. In each game one component's process is killed with SIGKILL right after one act:

    greeting            the robot's greeting (DialogueAct Salutation(greeting))
    invitation          "Shall we play?" (Request(playGame))
    person's move       the person's move reaches the bus (GameMove)
    your move           "Your move" (Request(userGameMove))
    robot's move        the robot announces its move (its GameMove act; the arm is to draw it)
    feedback            "Well played" and the like (Provide(feedback=...))

A game finishes when the robot says goodbye with the game's result (DialogueEnded with an
outcome, no "stopped working") within `--timeout` seconds. For each kill it measures the
recovery: from the kill to the respawned process's liveliness token ("back"), and to the robot's
next act or goodbye after it ("on"; this includes the robot's own waits). Prints one row per
component and act, then the totals.

    .venv/bin/python bench/bench_kill9.py                       # 7 x 6 x 3 games
    .venv/bin/python bench/bench_kill9.py --rounds 1 --components manager arm

The person's moves are typed (no camera), so the eyes' reading of the sheet is not exercised
here; tests/robot/test_zenoh.py kills them under a camera.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import statistics
import threading
import time
import uuid
from dataclasses import dataclass, field

from oxbot.config import load_config
from oxbot.dialogue.domain import (
    ASK_AGAIN,
    FEEDBACK_ACTS,
    GREETING,
    INVITATION,
    MOVE_REQUEST,
    game_move_cell,
)
from oxbot.game.board import EMPTY, outcome
from oxbot.robot.launch import COMPONENTS, Launcher, LaunchFile
from oxbot.robot.messages import DialogueAct, DialogueEnded, GameMove, Message
from oxbot.robot.remote import RemoteRobot
from oxbot.robot.zenoh_bus import ZenohBus

SETTINGS = [
    "robot.speed_factor=8",
    "robot.answer_timeout=4",
    "robot.question_timeout=30",
    "robot.move_timeout=60",
    # dozens of kills a minute: a respawn is never given up, nor put off for long
    "robot.restart_limit=1000",
    "robot.restart_window=1",
    "robot.restart_backoff_max=0.5",
]
ACTS = ("greeting", "invitation", "person's move", "your move", "robot's move", "feedback")
PREFER = (4, 0, 2, 6, 8, 1, 3, 5, 7)


def at_act(act: str, message: Message) -> bool:
    """Whether `message` is the moment `act` (one of ACTS) names."""
    if act == "person's move":
        return isinstance(message, GameMove) and message.who == "usr"
    if not isinstance(message, DialogueAct) or message.speaker != "sys":
        return False
    if act == "greeting":
        return message.act == GREETING
    if act == "invitation":
        return message.act == INVITATION
    if act == "your move":
        return message.act == MOVE_REQUEST
    if act == "robot's move":
        return game_move_cell(message.act) is not None
    return message.act in FEEDBACK_ACTS.values()


@dataclass
class Game:
    """One game with one kill: what became of it."""

    finished: bool = False
    killed: bool = False
    back: float | None = None  # kill -> the new process's liveliness token
    on: float | None = None  # kill -> the robot's next act or goodbye
    why: str = ""
    transcript: list[str] = field(default_factory=list)


def play(remote: RemoteRobot, bus: ZenohBus, name: str, act: str, timeout: float) -> Game:
    """A scripted game in which component `name`'s process is killed right after `act`."""
    game = Game()
    comeback = threading.Event()
    old_pid: list[int] = []
    killed_at = 0.0

    def joined(peer, up: bool) -> None:
        if up and peer.name == name and old_pid and peer.pid != old_pid[0] and not game.back:
            game.back = time.monotonic() - killed_at
            comeback.set()

    events = bus.subscribe()  # from now on: the robot's own subscription starts with history
    bus.watch(joined)
    asked = time.monotonic()
    remote.new_game()
    deadline = time.monotonic() + timeout
    started = False
    while time.monotonic() < deadline:
        message = events.get(0.05)
        if message is None:
            continue
        if isinstance(message, DialogueAct) and message.speaker == "sys" and message.stamp > asked:
            started = started or message.act == GREETING
        if not started:
            continue  # the last game's tail
        if isinstance(message, DialogueAct):
            game.transcript.append(f"{message.speaker}: {message.text} [{message.act}]")
        robots = isinstance(message, DialogueEnded) or (
            isinstance(message, DialogueAct) and message.speaker == "sys"
        )
        # one monotonic clock for the machine's processes: an act stamped after the kill
        if game.killed and game.on is None and robots and message.stamp > killed_at:
            game.on = time.monotonic() - killed_at
        if isinstance(message, DialogueEnded):
            said = "\n".join(game.transcript)
            game.finished = message.outcome is not None and "stopped working" not in said
            game.why = game.why if game.finished else f"ended {message.outcome}; {game.why}"
            break
        if not game.killed and at_act(act, message):
            pids = [p.pid for p in bus.alive() if p.name == name]
            if pids:
                old_pid.append(pids[0])
                killed_at = time.monotonic()
                os.kill(pids[0], signal.SIGKILL)
                game.killed = True
            else:
                game.why = "no process to kill (not back from the last kill?)"
        if isinstance(message, DialogueAct) and message.speaker == "sys":
            if message.act in (INVITATION, ASK_AGAIN):
                remote.say("yes let's play")
            elif message.act == MOVE_REQUEST:
                board = remote.board
                free = [c for c in PREFER if board[c] == EMPTY]
                if free and outcome(board) is None:
                    remote.draw(free[0])
    else:
        game.why = f"no goodbye within {timeout:.0f} s"
    events.close()
    if game.killed:
        comeback.wait(10)
    return game


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--components", nargs="+", default=list(COMPONENTS), choices=COMPONENTS)
    parser.add_argument("--acts", nargs="+", default=list(ACTS), choices=ACTS)
    parser.add_argument("--rounds", type=int, default=3, help="games per component and act")
    parser.add_argument("--timeout", type=float, default=60.0, help="seconds a game may take")
    parser.add_argument("-v", "--verbose", action="store_true", help="the robot's log lines")
    parser.add_argument("--transcripts", action="store_true", help="every game's, not just lost")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING if args.verbose else logging.CRITICAL)
    config = load_config(None, SETTINGS)
    robot = f"kill9-{uuid.uuid4().hex[:8]}"
    launch = LaunchFile(robot=robot, listen=(f"tcp/127.0.0.1:{free_port()}",), scouting=False)
    launcher = Launcher(launch, config).start()
    rows = []
    began = time.monotonic()
    try:
        with ZenohBus(robot, launch.child_endpoints()) as bus:
            deadline = time.monotonic() + 120
            while set(COMPONENTS) - {p.name for p in bus.alive()}:
                if time.monotonic() > deadline:
                    raise SystemExit("the robot's processes did not come up within 120 s")
                time.sleep(0.2)
            with RemoteRobot(bus, config) as remote:
                for name in args.components:
                    for act in args.acts:
                        games = [
                            play(remote, bus, name, act, args.timeout) for _ in range(args.rounds)
                        ]
                        rows.append((name, act, games))
                        print_row(name, act, games)
    finally:
        launcher.stop()
    games = [g for _, _, gs in rows for g in gs]
    backs = [g.back for g in games if g.back is not None]
    print(
        f"\n{sum(g.finished for g in games)} of {len(games)} games finished; "
        f"{sum(g.killed for g in games)} kills, {len(backs)} processes back"
        + (f" (median {statistics.median(backs):.2f} s, max {max(backs):.2f} s)" if backs else "")
        + f"; {time.monotonic() - began:.0f} s in all"
    )
    for name, act, gs in rows:
        for g in gs:
            if not g.finished or g.why or args.transcripts:
                state = f"finished {g.why}" if g.finished else f"lost ({g.why})"
                turns = g.transcript if args.transcripts else g.transcript[-8:]
                print(f"\n{name} at {act}: {state}\n  " + "\n  ".join(turns))


def print_row(name: str, act: str, games: list[Game]) -> None:
    backs = ", ".join(f"{g.back:.2f}" if g.back is not None else "-" for g in games)
    ons = ", ".join(f"{g.on:.2f}" if g.on is not None else "-" for g in games)
    finished = sum(g.finished for g in games)
    print(
        f"| {name} | {act} | {finished} of {len(games)} | {sum(g.killed for g in games)} | "
        f"{backs} | {ons} |",
        flush=True,
    )


if __name__ == "__main__":
    print("| component | killed after | games finished | kills | back (s) | robot on (s) |")
    print("|---|---|---|---|---|---|")
    main()
