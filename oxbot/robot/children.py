"""The launcher's hold on its component processes (Linux): they die with it, a new launcher
ends what an old one left, and their shared memory goes when they do.

- The launcher's fork server asks the kernel for SIGKILL when the launcher dies
  (`PR_SET_PDEATHSIG`, `kill -9` of the launcher included: oxbot.robot.fork_server), and each
  child for SIGTERM when the fork server does; each child also watches the launcher's pid and
  sends itself SIGTERM when it is gone, names itself `oxbot-<component>` (`PR_SET_NAME`, seen
  in /proc/PID/comm and `ps`), and ends itself `ORPHAN_GRACE` seconds later if SIGTERM did not.
- The launcher writes its children's pids to a file per robot (`pid_file`); a new launcher of
  that robot ends those still running under an `oxbot-` name (SIGTERM, then SIGKILL) before
  starting its own, so a launcher killed with its children somehow alive never leaves the
  next one refused or running beside orphans.
- Zenoh's shared-memory segments (`/dev/shm/*.zenoh`) outlive their processes; the launcher
  notes those its children map, and when they have all ended removes the ones no other process
  maps; `oxbot robot` removes its own likewise when it exits.
- A child knows its siblings (`Siblings`): the processes of the same fork server named
  `oxbot-<component>`. Only this machine's process table says which they are, so a peer on the
  network cannot pass for one, whatever liveliness token it declares.
"""

from __future__ import annotations

import atexit
import contextlib
import ctypes
import json
import logging
import os
import signal
import tempfile
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

log = logging.getLogger(__name__)

PR_SET_PDEATHSIG = 1
PR_SET_NAME = 15
ORPHAN_GRACE = 5.0
"""Seconds a child whose parent died may take to end on SIGTERM before it ends itself."""
SHM = Path("/dev/shm")


def _prctl(option: int, value: int | bytes) -> None:
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(option, value, 0, 0, 0)


def hold_fork_server() -> None:
    """In the launcher's fork server: die (SIGKILL) when the launcher does."""
    _prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def hold_child(name: str, launcher: int) -> None:
    """In a launched component process: named `oxbot-<name>`, ended when its parent (the fork
    server) or the `launcher` process is gone."""
    parent = os.getppid()
    _prctl(PR_SET_NAME, process_name(name).encode())
    _prctl(PR_SET_PDEATHSIG, signal.SIGTERM)

    def gone() -> bool:
        return os.getppid() != parent or not Path(f"/proc/{launcher}").exists()

    def watch() -> None:
        while not gone():
            time.sleep(0.2)
        os.kill(os.getpid(), signal.SIGTERM)  # the component ends cleanly, as on Ctrl-C
        time.sleep(ORPHAN_GRACE)  # SIGTERM has had its chance
        os._exit(1)

    threading.Thread(target=watch, name="oxbot-orphan-watch", daemon=True).start()


def process_name(component: str) -> str:
    """The name a launched `component`'s process goes by (/proc/PID/comm: 15 bytes at most)."""
    return f"oxbot-{component}".encode()[:15].decode(errors="ignore")


@dataclass(frozen=True)
class Siblings:
    """The component processes one launcher forked beside this one (which is one of them).

    A launcher forks every child from its one fork server, so its children are the processes
    whose parent is this process's parent; each names itself `process_name(component)`.
    """

    names: frozenset[str]
    """The components the launcher runs (its launch file's `components`)."""
    fork_server: int = field(default_factory=os.getppid)
    """The parent of this launcher's children."""

    def running(self, name: str, pid: int) -> bool:
        """Whether process `pid` is this launcher's component `name` and has not ended."""
        return _comm(pid) == process_name(name) and _parent(pid) == self.fork_server


def _parent(pid: int) -> int:
    """Process `pid`'s parent's pid, 0 when it is gone."""
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, IndexError, ValueError):
        return 0


def pid_file(robot: str) -> Path:
    """Where the launcher of `robot` keeps its children's pids."""
    folder = Path(os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir())
    return folder / f"oxbot-{os.getuid()}-launch-{robot}.json"


def write_pids(robot: str, pids: Iterable[int]) -> None:
    """Note the launcher's and its children's pids (atomically, readable by the owner only)."""
    path = pid_file(robot)
    tmp = path.with_suffix(".tmp")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    # a shared temporary folder: never follow a link someone left under our name
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    with os.fdopen(fd, "w") as handle:
        json.dump({"launcher": os.getpid(), "children": sorted(pids)}, handle)
    os.replace(tmp, path)


def _comm(pid: int) -> str:
    """Process `pid`'s name, "" when it is gone (a zombie included)."""
    try:
        if Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z":
            return ""
        return Path(f"/proc/{pid}/comm").read_text().strip()
    except (OSError, IndexError):
        return ""


def end_leftovers(robot: str, timeout: float = 3.0) -> list[int]:
    """End the children an earlier launcher of `robot` left running (those its pid file names
    that still run as `oxbot-*`); the pids ended."""
    path = pid_file(robot)
    try:
        noted = json.loads(path.read_text())
        launcher, children = int(noted["launcher"]), [int(p) for p in noted["children"]]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    if launcher != os.getpid() and _comm(launcher) and Path(f"/proc/{launcher}").exists():
        alive = [p for p in children if _comm(p).startswith("oxbot-")]
        if alive:  # its launcher still runs: its children are its own, not leftovers
            return []
    left = [p for p in children if _comm(p).startswith("oxbot-")]
    for pid in left:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and any(_comm(p).startswith("oxbot-") for p in left):
        time.sleep(0.05)
    for pid in left:
        if _comm(pid).startswith("oxbot-"):
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
    if left:
        log.warning("ended %d component processes an earlier launcher left: %s", len(left), left)
    return left


def shared_memory_of(pid: int | str = "self") -> set[Path]:
    """The Zenoh shared-memory files process `pid` maps."""
    try:
        lines = Path(f"/proc/{pid}/maps").read_text().splitlines()
    except OSError:
        return set()
    return {
        Path(p)
        for p in (line.split()[-1] for line in lines if ".zenoh" in line)
        if p.startswith(str(SHM) + "/")
    }


def remove_unmapped(candidates: Iterable[Path], ignore: int | None = None) -> int:
    """Remove those of `candidates` that no process maps any more (`ignore`: but the process
    of this pid, whose mappings outlive the names); the bytes freed."""
    candidates = {p for p in candidates if p.exists()}
    if not candidates:
        return 0
    mapped: set[Path] = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and entry.name != str(ignore):
            mapped |= shared_memory_of(entry.name)
    freed = 0
    for path in candidates - mapped:
        with contextlib.suppress(OSError):
            size = path.stat().st_size
            path.unlink()
            freed += size
    if freed:
        log.info("removed %.1f MB of shared memory the components left", freed / 2**20)
    return freed


def remove_own_shared_memory_at_exit() -> None:
    """When this process exits, remove the shared-memory files it maps that no other process
    does (Zenoh leaves its own behind): for a process that ends after its last session."""
    atexit.register(lambda: remove_unmapped(shared_memory_of(), ignore=os.getpid()))
