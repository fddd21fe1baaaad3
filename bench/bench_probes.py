"""Hostile and unlucky probes of the recordings, the web routes, the bus and the launcher,
bounded and on loopback; prints a table of what each group of probes got, then one paragraph in
the form of the safety review's (how many probes, how many got a clear error or a traceback,
games or robots lost, pieces of data lost, ways recorded data outlived `forget` or leaked).

    .venv/bin/python bench/bench_probes.py                  # ~1 min on two cores
    .venv/bin/python bench/bench_probes.py --no-processes   # without the launcher's kill -9

Each probe ends in one of: `error` (a clear oxbot error, as it should), `held` (it did what the
guarantee says: nothing outside the folder deleted, the flood dropped, the orphan gone...),
`traceback` (an exception that is not oxbot's), `hang` (no answer within `--timeout`), `lost`
(a game, a robot, or recorded data lost), `leak` (data that outlived `forget` or left the
folder). The tests under tests/recording, tests/web/test_routes_admission.py,
tests/robot/test_hostile_peers.py and tests/robot/test_launcher_children.py hold the same
guarantees on a few cases each; this script runs them all. Not repeated here: `kill -9` of each
of the seven components at each act of a game (`bench/bench_bus.py` kills each, and
tests/robot/test_zenoh.py plays a game through such kills), and Zenoh's TLS and access
control, which oxbot does not configure yet.
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures
import contextlib
import io
import logging
import os
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from oxbot.errors import OxbotError
from oxbot.testing.hostile import HTTP_ROUTES, break_an_index

OUTCOMES = ("error", "held", "traceback", "hang", "lost", "leak")
Probe = tuple[str, str, Callable[[Path], str]]  # group, name, probe(folder) -> outcome


def run(probe: Callable[[Path], str], timeout: float) -> tuple[str, str]:
    """A probe's outcome and a word on it, in a folder of its own, within `timeout` seconds."""
    folder = Path(tempfile.mkdtemp(prefix="oxbot-probe-"))
    pool = concurrent.futures.ThreadPoolExecutor(1)
    try:
        return pool.submit(probe, folder).result(timeout), ""
    except concurrent.futures.TimeoutError:
        return "hang", f"no answer within {timeout:g} s"
    except OxbotError as exc:
        return "error", str(exc)[:80]
    except Exception as exc:  # what the probe counts: not oxbot's own error
        return "traceback", f"{type(exc).__name__}: {exc}"[:120]
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
        shutil.rmtree(folder, ignore_errors=True)


# --- the recordings ---


def _session(store) -> int:
    from oxbot.game.board import EMPTY_BOARD
    from oxbot.recording import Recorder
    from oxbot.robot.bus import LocalBus
    from oxbot.robot.messages import DialogueAct, GameState, SpeechHypotheses

    recorder = Recorder(LocalBus(), store)
    for message in (
        GameState(board=EMPTY_BOARD, robot_starts=True),
        DialogueAct(speaker="sys", act="Request(playGame)", text="Shall we play?"),
        SpeechHypotheses(nbest=(("yes secret words", 0.8),), words=(("yes", 0.8),)),
        DialogueAct(speaker="usr", act="Confirm(playGame=yes)", text="yes secret words"),
    ):
        recorder.handle(message)
    return recorder.sessions[-1]


def _recorded(folder: Path) -> int:
    from oxbot.recording import RecordingStore

    with RecordingStore(folder / "data") as store:
        return _session(store)


def _cli(*args: str) -> None:
    """An oxbot command in this process: raises what it raised, as the command line would
    print it (an OxbotError) or as a traceback."""
    from typer.testing import CliRunner

    from oxbot.cli import app

    result = CliRunner().invoke(app, list(args))
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception


def forget_probes() -> list[Probe]:
    from oxbot.recording import RecordingStore

    def crafted(path_of: Callable[[Path], str]) -> Callable[[Path], str]:
        def probe(folder: Path) -> str:
            victim = folder / "victim.txt"
            victim.write_text("mine")
            sid = _recorded(folder)
            db = sqlite3.connect(folder / "data" / "recordings.sqlite3")
            db.execute(
                "INSERT INTO derived (path, session_id, kind) VALUES (?,?,'x')",
                (path_of(folder), sid),
            )
            db.commit()
            db.close()
            with RecordingStore(folder / "data") as store:
                store.forget(sid)
            gone = not victim.exists() or not (folder / "data" / "recordings.sqlite3").exists()
            return "leak" if gone else "held"

        return probe

    def copied(folder: Path) -> str:
        with RecordingStore(folder / "a") as store:
            sid = _session(store)
            model = folder / "a" / "learned" / "learn_agent.json"
            store.register_derived([model], [sid], "agent")
            model.write_text("{}")
        shutil.copytree(folder / "a", folder / "b")
        with RecordingStore(folder / "b") as store:
            store.forget(sid)
        return (
            "held"
            if model.exists() and not (folder / "b/learned/learn_agent.json").exists()
            else "leak"
        )

    def temp_left(folder: Path) -> str:
        with RecordingStore(folder / "data") as store:
            sid = _session(store)
            model = folder / "data" / "learned" / "perceiver.pt"
            store.register_derived([model], [sid], "perceiver")
            (model.parent / ".perceiver.pt.x1y2.tmp").write_bytes(b"learnt")
            store.forget(sid)
        return "leak" if list(model.parent.glob(".*.tmp")) else "held"

    def damaged_row(folder: Path) -> str:
        with RecordingStore(folder / "data") as store:
            sid = _session(store)
            with store.transaction() as db:
                db.execute("UPDATE answers SET nbest = '{x' WHERE session_id = ?", (sid,))
            store.forget(sid)
            return "held" if not store.session_ids() else "leak"

    def no_byte_left(folder: Path) -> str:
        with RecordingStore(folder / "data") as store:
            sid = _session(store)
            from oxbot.recording.export import export

            export(store, folder / "out")
            store.forget(sid)
        raw = b"".join(p.read_bytes() for p in (folder / "data").iterdir() if p.is_file())
        left = b"secret words" in raw or any((folder / "out").glob("*.parquet"))
        return "leak" if left else "held"

    named = {
        "a file outside": lambda f: str(f / "victim.txt"),
        "../": lambda f: "../victim.txt",
        "itself": lambda f: "recordings.sqlite3",
    }
    return [
        *(("data: forget", f"a crafted database names {k}", crafted(v)) for k, v in named.items()),
        ("data: forget", "a copied folder", copied),
        ("data: forget", "a temp file a killed write left", temp_left),
        ("data: forget", "a damaged row", damaged_row),
        ("data: forget", "no byte of the session left, exports included", no_byte_left),
    ]


def _garbage_mid_file(data: Path) -> None:
    from oxbot.recording import RecordingStore

    with RecordingStore(data) as store:
        for _ in range(3):
            _session(store)
        with store.transaction() as db:
            db.executemany(
                "INSERT INTO crops VALUES (1, ?, 0, 0.0, ?, 'cross', 1.0, 2, 'cross')",
                [(i, os.urandom(3000)) for i in range(40)],
            )
        store.compact()
    path = data / "recordings.sqlite3"
    raw = bytearray(path.read_bytes())
    raw[4096 * 6 : 4096 * 8] = os.urandom(8192)
    path.write_bytes(bytes(raw))


def _other_app(data: Path) -> None:
    data.mkdir()
    db = sqlite3.connect(data / "recordings.sqlite3")
    db.execute("CREATE TABLE contacts (name TEXT)")
    db.commit()
    db.close()


def _wrong_types(data: Path) -> None:
    from oxbot.recording import RecordingStore

    with RecordingStore(data) as store:
        sid = _session(store)
        with store.transaction() as db:
            db.execute("UPDATE sessions SET started_at = 'yesterday' WHERE id = ?", (sid,))
            db.execute("UPDATE turns SET t = 'late', seq = 'x' WHERE session_id = ?", (sid,))


def _oversized_crop(data: Path) -> None:
    from oxbot.recording import RecordingStore
    from oxbot.testing.hostile import decompression_bomb

    with RecordingStore(data) as store:
        sid = _session(store)
        with store.transaction() as db:
            db.executemany(
                "INSERT INTO crops VALUES (?, ?, 0, 0.0, ?, 'circle', 0.9, 2, 'cross')",
                [(sid, i, decompression_bomb(20_000)) for i in range(2)],
            )


def _fails_integrity(data: Path) -> None:
    from oxbot.recording import RecordingStore

    with RecordingStore(data) as store:
        _session(store)
        with store.transaction() as db:
            break_an_index(db)


DAMAGES: dict[str, Callable[[Path], None]] = {
    "garbage mid-file": _garbage_mid_file,
    "another app's SQLite file": _other_app,
    "/dev/zero": lambda d: (d.mkdir(), os.symlink("/dev/zero", d / "recordings.sqlite3")),
    "zeros": lambda d: (d.mkdir(), (d / "recordings.sqlite3").write_bytes(bytes(8192))),
    "wrong types": _wrong_types,
    "oversized crops": _oversized_crop,
    "fails integrity_check": _fails_integrity,
}
COMMANDS = {
    "data list": ("data", "list"),
    "data show": ("data", "show", "1"),
    "data export": ("data", "export", "{out}"),
    "data forget": ("data", "forget", "1"),
    "learn perceiver": ("learn", "perceiver", "--quiet"),
    "learn agent": ("learn", "agent", "--quiet", "--steps", "10", "--games", "2"),
}
ACCEPTABLE = {  # damage -> commands that may succeed on it (nothing damaged is read)
    "oversized crops": {"data list", "data forget", "data show", "data export"},
    "fails integrity_check": {"data list", "data show", "data forget"},
}


def damaged_probes() -> list[Probe]:
    def probe(damage: str, command: str) -> Callable[[Path], str]:
        def run_it(folder: Path) -> str:
            DAMAGES[damage](folder / "data")
            args = [a.format(out=folder / "out") for a in COMMANDS[command]]
            _cli(*args, "--data-dir", str(folder / "data"))
            if command.startswith("learn") or command not in ACCEPTABLE.get(damage, ()):
                return "leak"  # silently accepted: it read or learnt from a damaged file
            return "held"

        return run_it

    probes: list[Probe] = [
        ("data: damaged input", f"{command} on {damage}", probe(damage, command))
        for damage in DAMAGES
        for command in COMMANDS
    ]

    def lists_nothing(folder: Path) -> str:
        _cli("data", "list", "--data-dir", str(folder / "none"))
        return "leak" if (folder / "none").exists() else "held"

    def export_to(target: Callable[[Path], str]) -> Callable[[Path], str]:
        def run_it(folder: Path) -> str:
            _recorded(folder)
            (folder / "file").write_text("x")
            with contextlib.suppress(FileExistsError):
                os.symlink(folder / "nowhere", folder / "dangling")
            _cli("data", "export", target(folder), "--data-dir", str(folder / "data"))
            return "leak"  # it should have refused

        return run_it

    probes.append(("data: damaged input", "data list makes no folder", lists_nothing))
    for name, target in {
        "an existing file": lambda f: str(f / "file"),
        "a dangling link": lambda f: str(f / "dangling"),
        "/dev/null": lambda f: "/dev/null",
        "a read-only file system": lambda f: "/sys/oxbot-export",
    }.items():
        probes.append(("data: export", f"data export to {name}", export_to(target)))
    return probes


def busy_probes() -> list[Probe]:
    from oxbot.recording import Recorder, RecordingStore
    from oxbot.robot.bus import LocalBus
    from oxbot.robot.messages import DialogueAct, DialogueEnded, GameState

    def export_while_locked(folder: Path) -> str:
        from oxbot.errors import DatabaseBusy
        from oxbot.recording.export import export

        sid = _recorded(folder)
        other = sqlite3.connect(folder / "data" / "recordings.sqlite3", timeout=0)
        other.execute("BEGIN EXCLUSIVE")
        try:
            with (
                RecordingStore(folder / "data", busy_timeout=0.3) as store,
                contextlib.suppress(DatabaseBusy),
            ):
                export(store, folder / "out")
        finally:
            other.rollback()
        with RecordingStore(folder / "data") as store:
            store.forget(sid)
        return "leak" if any((folder / "out").glob("*")) else "held"

    def recorder_while_locked(folder: Path) -> str:
        with RecordingStore(folder / "data", busy_timeout=0.2) as store:
            recorder = Recorder(LocalBus(), store)
            recorder.handle(GameState(board=(0,) * 9, robot_starts=True))
            other = sqlite3.connect(folder / "data" / "recordings.sqlite3", timeout=0)
            for turn in range(14):
                if turn == 3:
                    other.execute("BEGIN IMMEDIATE")  # busy for about 3 s
                if turn == 9:
                    other.rollback()
                recorder.handle(DialogueAct(speaker="sys", act="Inform", text=f"turn {turn}"))
                time.sleep(0.05)
            recorder.handle(DialogueEnded(outcome="draw"))
            kept = store.query("SELECT COUNT(*) AS n FROM turns")[0]["n"]
        return "held" if kept == 14 else "lost"

    return [
        ("data: busy database", "export while another holds the lock", export_while_locked),
        ("data: busy database", "the recorder while another holds the lock", recorder_while_locked),
    ]


# --- the web routes ---


def web_probes() -> list[Probe]:
    from fastapi.testclient import TestClient

    from oxbot.config import load_config
    from oxbot.web.recording import RecordingSetup
    from oxbot.web.server import create_app

    config = load_config(None, [])

    def foreign(route: str, headers: dict[str, str]) -> Callable[[Path], str]:
        def run_it(folder: Path) -> str:
            app = create_app(config, recording=RecordingSetup(folder))
            client = TestClient(app, base_url="http://127.0.0.1:8000")
            status = client.get(route, headers=headers).status_code
            return "held" if 400 <= status < 500 else "leak"

        return run_it

    def oversized(folder: Path) -> str:
        _oversized_crop(folder / "data")
        app = create_app(config, recording=RecordingSetup(folder / "data"))
        client = TestClient(app, base_url="http://127.0.0.1:8000")
        client.get("/recording/learned")
        before = _rss_mb()
        for _ in range(10):
            if client.get("/recording/learned").status_code >= 500:
                return "traceback"
        return "held" if _rss_mb() - before < 50 else "lost"

    probes: list[Probe] = [
        ("web: Host and Origin", f"{route} from {next(iter(h.values()))}", foreign(route, h))
        for route in HTTP_ROUTES
        for h in ({"host": "evil.example:8000"}, {"origin": "http://evil.example"})
    ]
    probes.append(("web: sizes", "10 requests for an oversized crop", oversized))
    return probes


def _rss_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


# --- the bus ---


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@contextlib.contextmanager
def _network():
    import uuid

    from oxbot.robot.zenoh_bus import Endpoints, ZenohBus

    port, robot = _free_port(), f"probe-{uuid.uuid4().hex[:8]}"
    endpoint = (f"tcp/127.0.0.1:{port}",)
    with (
        ZenohBus(robot, Endpoints(listen=endpoint, scouting=False)) as ours,
        ZenohBus(robot, Endpoints(connect=endpoint, scouting=False)) as theirs,
    ):
        yield ours, theirs


def bus_probes() -> list[Probe]:
    from oxbot.robot.messages import ArmCommand, NewGame, Utterance, to_json
    from oxbot.robot.zenoh_bus import FORMAT

    hostile = {
        "ArmCommand(where='nowhere')": (
            "arm/command",
            to_json(ArmCommand(where="middle", symbol="cross")).replace("middle", "nowhere"),
        ),
        "a 200 KB Utterance": ("speech/say", to_json(Utterance(text="a" * 200_000, act="x"))),
        "a 100,000-deep list": (
            "game/new",
            '{"type": "NewGame", "data": {"x": ' + "[" * 100_000 + "]" * 100_000 + "}}",
        ),
        "a wrong type": ("game/new", '{"type": "NewGame", "data": {"robot_starts": "yes"}}'),
    }

    def dropped(topic: str, text: str) -> Callable[[Path], str]:
        def run_it(folder: Path) -> str:
            with _network() as (ours, theirs):
                inbox = ours.subscribe(ArmCommand, Utterance, NewGame)
                time.sleep(0.3)
                theirs.session.put(theirs.prefix + topic, text.encode(), attachment=FORMAT)
                time.sleep(0.5)
                return "lost" if inbox.drain() else "held"

        return run_it

    def flood(folder: Path) -> str:
        with _network() as (ours, theirs):
            inbox = ours.subscribe(NewGame)
            time.sleep(0.3)
            for _ in range(2_000):
                theirs.publish(NewGame())
            time.sleep(1.5)
            flooded = len(inbox.drain())
            theirs.publish(NewGame(robot_starts=False))
            after = inbox.get(timeout=5.0)
        return "held" if flooded <= 5 and after is not None else "lost"

    def poisoned_record(folder: Path) -> str:
        with _network() as (ours, theirs):
            deep = "[" * 200_000 + "]" * 200_000
            queryable = theirs.session.declare_queryable(
                theirs.prefix + "state/evil",
                lambda q: q.reply(q.key_expr, deep, attachment=FORMAT),
            )
            try:
                return "held" if ours.game_so_far() == [] else "lost"
            finally:
                queryable.undeclare()

    def fake_token(folder: Path) -> str:
        import threading

        from oxbot.config import load_config
        from oxbot.robot.launch import run_component
        from oxbot.robot.zenoh_bus import Endpoints

        with _network() as (ours, theirs):
            token = f"{theirs.prefix}alive/head-movement/{FORMAT}/0123456789abcdef/4242"
            fake = theirs.session.liveliness().declare_token(token)
            stop = threading.Event()
            child = threading.Thread(
                target=run_component,
                args=(
                    "head-movement",
                    ours.robot,
                    Endpoints(ours.endpoints.listen, ()),
                    load_config(None, []),
                ),
                kwargs={"stop": stop, "replace": True},
            )
            child.start()
            try:
                deadline = time.monotonic() + 20
                while time.monotonic() < deadline:
                    if any(p.name == "head-movement" and p.pid != 4242 for p in ours.alive()):
                        return "held"
                    time.sleep(0.1)
                return "lost"
            finally:
                stop.set()
                child.join(10)
                fake.undeclare()

    probes: list[Probe] = [
        ("bus: messages", f"{name} from a peer", dropped(topic, text))
        for name, (topic, text) in hostile.items()
    ]
    probes += [
        ("bus: messages", "2,000 NewGames in a burst", flood),
        ("bus: messages", "a 200,000-deep game record", poisoned_record),
        ("bus: liveliness", "a fake token for a respawned component", fake_token),
    ]
    return probes


def launch_probes(processes: bool) -> list[Probe]:
    from oxbot.robot.launch import load_launch_file

    def launch_file(text: str | None) -> Callable[[Path], str]:
        def run_it(folder: Path) -> str:
            path = Path("/dev/zero") if text is None else folder / "robot.toml"
            if text is not None:
                path.write_text(text)
            load_launch_file(path)
            return "leak"  # it should have refused

        return run_it

    def kill_9_launcher(folder: Path) -> str:
        script = (
            "import sys, time\n"
            "from oxbot.config import load_config\n"
            "from oxbot.robot.launch import Launcher, LaunchFile\n"
            "launch = LaunchFile(robot=sys.argv[1], components=('head-movement', 'arm', 'voice'),"
            " listen=(f'tcp/127.0.0.1:{sys.argv[2]}',))\n"
            "launcher = Launcher(launch, load_config(None, [])).start()\n"
            "print(' '.join(str(p.pid) for p in launcher.processes.values()), flush=True)\n"
            "time.sleep(600)\n"
        )
        robot = f"probe-{os.getpid()}"
        launcher = subprocess.Popen(
            [sys.executable, "-c", script, robot, str(_free_port())],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        try:
            children = [int(p) for p in launcher.stdout.readline().split()]
            time.sleep(1.0)
            children.append(int(Path(f"/proc/{children[0]}/stat").read_text().split()[3]))
            launcher.send_signal(signal.SIGKILL)
            launcher.wait(10)
            time.sleep(10.0)
            alive = [p for p in children if _running(p)]
            for pid in alive:
                os.kill(pid, signal.SIGKILL)
            return "lost" if alive else "held"
        finally:
            launcher.kill()

    probes: list[Probe] = [
        ("launch files", name, launch_file(text))
        for name, text in {
            'respawn = "no"': 'respawn = "no"\n',
            "a string of components": 'components = "manager"\n',
            "duplicate components": 'components = ["arm", "arm"]\n',
            "/dev/zero": None,
        }.items()
    ]
    if processes:
        probes.append(("launcher", "kill -9 of the launcher: orphans after 10 s", kill_9_launcher))
    return probes


def _running(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


# --- the table ---


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--timeout", type=float, default=60.0, help="Seconds before a hang.")
    parser.add_argument("--no-processes", action="store_true", help="Skip the launcher's kill -9.")
    parser.add_argument("--verbose", action="store_true", help="One line per probe.")
    args = parser.parse_args()
    logging.basicConfig(level=logging.CRITICAL)  # the probes' log lines are expected
    probes = (
        forget_probes()
        + damaged_probes()
        + busy_probes()
        + web_probes()
        + bus_probes()
        + launch_probes(not args.no_processes)
    )
    table: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    started = time.monotonic()
    for group, name, probe in probes:
        with contextlib.redirect_stdout(io.StringIO()):
            outcome, word = run(probe, args.timeout)
        table[group][outcome] += 1
        if args.verbose or outcome in ("traceback", "hang", "lost", "leak"):
            print(f"{outcome:9s} {group}: {name}{' (' + word + ')' if word else ''}")
    total: collections.Counter[str] = sum(table.values(), collections.Counter())
    print(f"\n{'group':24s} {'probes':>6s} " + " ".join(f"{o:>9s}" for o in OUTCOMES))
    for group, counts in [*table.items(), ("total", total)]:
        cells = " ".join(f"{counts[o]:9d}" for o in OUTCOMES)
        print(f"{group:24s} {sum(counts.values()):6d} {cells}")
    print(
        f"\n{sum(total.values())} probes in {time.monotonic() - started:.0f} s. "
        f"{total['error']} got a clear error, {total['held']} held, and {total['traceback']} got "
        f"a traceback; {total['hang']} hung. {total['lost']} games, robots or pieces of data were "
        f"lost, and in {total['leak']} ways recorded data outlived `oxbot data forget`, leaked or "
        "was silently accepted."
    )


if __name__ == "__main__":
    main()
