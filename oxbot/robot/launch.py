"""The robot as processes: one component per process, launched and respawned.

`oxbot component NAME` runs one component (`run_component`) on a `ZenohBus`; `oxbot robot
--launch robot.toml` starts a whole robot (`Launcher`), like ROS 2 launch with `respawn`: a
component process that ends is started again after a backoff that doubles with each end within
`[robot] restart_window` (from `restart_backoff` up to `restart_backoff_max`), and given up
after `restart_limit` of them. The launcher forks its components from a fork server that has
already imported oxbot and torch, so a respawned component is up again in well under a second
instead of the seconds a cold start takes. The launcher owns its children
(oxbot.robot.children): they die with it, `kill -9` included; a new launcher ends what an old
one left; their shared memory is removed when they end. A launched child overrides a liveliness
token that claims its name (any peer may declare one) instead of refusing to start, and the
launched manager tells its siblings' deaths from the process table, not from tokens.

A launch file:

    robot = "kitchen"                       # key expressions oxbot/kitchen/...
    listen = ["tcp/0.0.0.0:7447"]           # the launcher's router; its components connect to it
    connect = []                            # or routers / peers elsewhere
    scouting = false                        # multicast scouting on the LAN
    components = ["manager", "perception", "recognition", "voice", "arm",
                  "head-tracking", "head-movement"]

    [perception]
    camera = "0"                            # a camera index, a video or an image folder
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import multiprocessing
import os
import signal
import threading
import time
import tomllib
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import TYPE_CHECKING, Any

from oxbot.config import OxbotConfig
from oxbot.errors import ConfigError, OxbotError
from oxbot.robot.bus import Bus, Component, Supervisor
from oxbot.robot.bus_security import BusSecurity
from oxbot.robot.children import (
    Siblings,
    end_leftovers,
    hold_child,
    pid_file,
    remove_own_shared_memory_at_exit,
    remove_unmapped,
    shared_memory_of,
    write_pids,
)
from oxbot.robot.liveliness import PartsWatcher
from oxbot.robot.resync import catch_up
from oxbot.robot.zenoh_bus import NAME, Endpoints, ZenohBus

if TYPE_CHECKING:
    from oxbot.robot.remote import RemoteRobot  # loads the models: imported when driven

log = logging.getLogger(__name__)

COMPONENTS: dict[str, tuple[str, str]] = {
    "manager": ("oxbot.robot.manager", "InteractionManagerComponent"),
    "perception": ("oxbot.robot.game_moves", "GameMoveComponent"),
    "recognition": ("oxbot.robot.voice", "SpeechRecognitionComponent"),
    "voice": ("oxbot.robot.voice", "SpeechSynthesisComponent"),
    "arm": ("oxbot.robot.arm", "ArmComponent"),
    "head-tracking": ("oxbot.robot.head_tracking", "HeadTrackingComponent"),
    "head-movement": ("oxbot.robot.head_movement", "HeadMovementComponent"),
}
"""The robot's seven components by process name: module and class."""
CAMERAS = ("perception", "head-tracking")
"""The components that may watch a camera of their own (`camera`)."""


def component_class(name: str) -> type[Component]:
    """The Component class of process name `name`; ConfigError naming the choices."""
    if name not in COMPONENTS:
        raise ConfigError(f"no component {name!r}; choose one of {', '.join(COMPONENTS)}")
    module, cls = COMPONENTS[name]
    return getattr(importlib.import_module(module), cls)


def parts() -> dict[str, tuple[str, str, bool]]:
    """Each process name's (component name, part, essential), as messages name them."""
    classes = {name: component_class(name) for name in COMPONENTS}
    return {name: (c.__name__, c.part, c.essential) for name, c in classes.items()}


def build_component(
    name: str, bus: Bus, config: OxbotConfig, camera: str | None = None, seed: int | None = None
) -> Component:
    """Component `name` on `bus`, configured as `oxbot.robot.session.Robot` configures it."""
    import numpy as np

    cls: Any = component_class(name)
    body = config.robot
    rng = np.random.default_rng(seed)
    source = None
    if camera is not None:
        from oxbot.perception.sources import open_source

        if name not in CAMERAS:
            raise ConfigError(f"component {name!r} has no camera; only {', '.join(CAMERAS)} do")
        source = open_source(camera)
    if name == "manager":
        from oxbot.robot.session import shared_policy

        return cls(bus, policy=shared_policy(body.manager, config), config=config, rng=rng)
    if name == "perception":
        return cls(
            bus,
            config.game.robot_starts,
            source=source,
            config=config.tracker,
            perception=config.perception,
        )
    if name == "recognition":
        return cls(bus, None, config.speech)
    if name == "voice":
        from oxbot.speech.synthesis import robot_voice

        return cls(bus, robot_voice(config.speech), speed_factor=body.speed_factor)
    if name == "arm":
        return cls(bus, body.arm, rng=rng, speed_factor=body.speed_factor)
    if name == "head-tracking":
        from oxbot.robot.head_tracking import HeadTracker

        return cls(bus, HeadTracker(body.head), source=source)
    return cls(bus)


def run_component(
    name: str,
    robot: str,
    endpoints: Endpoints,
    config: OxbotConfig,
    camera: str | None = None,
    stop: threading.Event | None = None,
    seed: int | None = None,
    replace: bool = False,
    siblings: Iterable[str] = (),
) -> None:
    """Run component `name` of robot `robot` in this process until `stop` is set (or SIGTERM
    / SIGINT in the main thread). Raises the BusError or ConfigError that prevents it.

    With `replace` (a launcher's child: the launcher starts one process per name, and only once
    the last has ended), a liveliness token that claims the name is up already is logged and
    overridden, not obeyed: any peer can declare one, and a fake must not block a respawn.
    `siblings`, in a launcher's child, are the components the launcher runs beside it: the
    manager's `PartsWatcher` judges those by this machine's process table, not by tokens."""
    component_class(name)  # an unknown name fails before any network work
    if name in ("manager", "perception"):
        import torch

        torch.set_num_threads(1)  # one component per process: a core's share is enough
    stop = stop if stop is not None else threading.Event()
    if threading.current_thread() is threading.main_thread():
        for signum in (signal.SIGTERM, signal.SIGINT):
            signal.signal(signum, lambda *_: stop.set())
    beside = Siblings(frozenset(siblings)) if siblings else None
    vouched = (lambda peer: beside.running(peer.name, peer.pid)) if beside is not None else None
    bus = ZenohBus(robot, endpoints, vouched=vouched)
    supervisor = watcher = None
    try:
        if replace:
            twins = [p for p in bus.alive() if p.name == name and p.zid != bus.zid]
            for twin in twins:
                log.warning(
                    "a process claims to be %s already (zenoh id %s, pid %d); this launcher's "
                    "%s takes its place",
                    name,
                    twin.zid,
                    twin.pid,
                    name,
                )
        else:
            bus.check_running(name)  # before seconds of model loading
        component = build_component(name, bus, config, camera, seed)
        bus.join(name, replace=replace)
        catch_up(name, component, bus.game_so_far())
        on_lost = None
        if name == "manager":
            others = {n: p for n, p in parts().items() if n != name}
            watcher = PartsWatcher(
                bus, others, rejoin_seconds=config.robot.rejoin_seconds, siblings=beside
            ).start()

            def on_lost(lost: Component) -> None:
                from oxbot.game.board import outcome
                from oxbot.robot.manager import say_goodbye

                say_goodbye(bus, lost.part, outcome(lost.board))  # type: ignore[attr-defined]

        supervisor = Supervisor([component], bus, config.robot, on_lost=on_lost).start()
        log.info("%s is up for robot %r (pid %d)", name, robot, os.getpid())
        while not stop.wait(0.2):
            if supervisor.lost:  # its restart budget spent: a fresh process may do better
                log.error("%s stays off; ending its process (a launcher respawns it)", name)
                break
    finally:
        if watcher is not None:
            watcher.stop()
        if supervisor is not None:
            supervisor.stop()
        bus.close()
    if supervisor is not None and supervisor.lost:
        raise SystemExit(1)


# --- launching a whole robot ---


@dataclass(frozen=True)
class LaunchFile:
    """A robot's processes: see the module docstring for the TOML."""

    robot: str = "oxbot"
    """The robot's name: its key expressions are oxbot/<robot>/..."""
    components: tuple[str, ...] = tuple(COMPONENTS)
    """Which components to run here (the others may run on other machines)."""
    listen: tuple[str, ...] = ("tcp/127.0.0.1:7447",)
    """The launcher's router endpoints; its components connect to them."""
    connect: tuple[str, ...] = ()
    """Routers or peers elsewhere (other machines of the robot)."""
    scouting: bool = False
    """Multicast scouting on the LAN, besides the endpoints."""
    cameras: dict[str, str] = field(default_factory=dict)
    """A camera spec per component (`[perception] camera = "0"`)."""
    respawn: bool = True
    """Start a component whose process ended again (ROS 2 launch's `respawn`)."""
    security: BusSecurity | None = None
    """Zenoh TLS with mutual authentication and access control, from a `[security]` table
    (oxbot.robot.bus_security); the router's and the children's alike."""

    def child_endpoints(self) -> Endpoints:
        """How the launched components reach each other: through this launcher's router."""
        local = tuple(
            e.replace("0.0.0.0", "127.0.0.1").replace("[::]", "[::1]") for e in self.listen
        )
        return Endpoints(
            connect=local + self.connect, scouting=self.scouting, security=self.security
        )


MAX_LAUNCH_FILE_BYTES = 1_000_000
"""A launch file is a few hundred bytes; a bigger one (or /dev/zero) is refused unread."""
LAUNCH_TYPES: dict[str, type] = {
    "robot": str,
    "components": list,
    "listen": list,
    "connect": list,
    "scouting": bool,
    "respawn": bool,
}
"""The TOML type of each launch-file key."""


def load_launch_file(path: Path) -> LaunchFile:
    """The launch file at `path`; ConfigError naming what is wrong."""
    path = Path(path)
    try:
        if not path.is_file():
            raise ConfigError(f"launch file {path} is not a regular file; give a .toml file")
        with path.open("rb") as handle:  # bounded: never read a device until memory runs out
            raw = handle.read(MAX_LAUNCH_FILE_BYTES + 1)
        if len(raw) > MAX_LAUNCH_FILE_BYTES:
            raise ConfigError(f"launch file {path} is over {MAX_LAUNCH_FILE_BYTES:,} bytes")
        data = tomllib.loads(raw.decode("utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read launch file {path}: {exc}") from None
    known = set(LAUNCH_TYPES)
    fields: dict[str, Any] = {}
    cameras: dict[str, str] = {}
    security = None
    for key, value in data.items():
        if key == "security" and isinstance(value, dict):
            security = _security(path, value)
        elif key in COMPONENTS and isinstance(value, dict):
            extra = set(value) - {"camera"}
            if extra:
                raise ConfigError(f"{path}: [{key}] has only `camera`, not {sorted(extra)}")
            if "camera" in value:
                cameras[key] = str(value["camera"])
        elif key in known:
            if not isinstance(value, LAUNCH_TYPES[key]):
                kind = {str: "a string", list: "a list", bool: "true or false"}[LAUNCH_TYPES[key]]
                raise ConfigError(f"{path}: {key} must be {kind}, not {value!r:.60}")
            fields[key] = tuple(value) if isinstance(value, list) else value
        else:
            raise ConfigError(
                f"{path}: unknown key {key!r}; a launch file has {', '.join(sorted(known))} "
                f"a table per component ({', '.join(COMPONENTS)}) and [security]"
            )
    for key in ("components", "listen", "connect"):
        if not all(isinstance(e, str) for e in fields.get(key, ())):
            raise ConfigError(f"{path}: {key} is a list of strings")
    names = fields.get("components", ())
    for name in names:
        component_class(name)
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f"{path}: components lists {', '.join(twice)} twice; list each once")
    if "robot" in fields and not NAME.match(fields["robot"]):
        raise ConfigError(f"{path}: robot {fields['robot']!r}: letters, digits, '_', '-', '.'")
    return LaunchFile(**fields, cameras=cameras, security=security)


def _security(path: Path, table: dict[str, Any]) -> BusSecurity:
    """The `[security]` table: ca, certificate, key (paths relative to the launch file's
    folder) and allowed (certificate names)."""
    wanted = {"ca", "certificate", "key", "allowed"}
    if set(table) != wanted:
        raise ConfigError(f"{path}: [security] has exactly {', '.join(sorted(wanted))}")
    allowed = table["allowed"]
    files = [table[k] for k in ("ca", "certificate", "key")]
    if not all(isinstance(f, str) for f in files) or not (
        isinstance(allowed, list) and all(isinstance(a, str) for a in allowed)
    ):
        raise ConfigError(f"{path}: [security] paths are strings, allowed a list of names")
    ca, certificate, key = (path.parent / f for f in files)
    return BusSecurity(ca, certificate, key, tuple(allowed))


def _child(
    name: str,
    robot: str,
    endpoints: Endpoints,
    config: OxbotConfig,
    camera: str | None,
    level: int,
    launcher: int,
    siblings: tuple[str, ...],
) -> None:
    """A launched component process's main; `launcher` is the launcher's pid, `siblings` the
    components it runs."""
    hold_child(name, launcher)  # dies with the launcher (oxbot.robot.children)
    logging.basicConfig(level=level, format=f"%(levelname)s {name}: %(message)s")
    try:
        run_component(name, robot, endpoints, config, camera, replace=True, siblings=siblings)
    except OxbotError as exc:
        log.error("%s", exc)
        raise SystemExit(2) from None


class Launcher:
    """Starts the components of a launch file as processes and respawns the ones that end.

    `start` opens the launcher's own Zenoh router (when the file has `listen`) and starts every
    component; `stop` ends them (SIGTERM, then SIGKILL after `timeout`). `respawns` logs each
    respawn as (component, seconds since its process ended).
    """

    POLL = 0.02

    def __init__(self, launch: LaunchFile, config: OxbotConfig | None = None) -> None:
        self.launch = launch
        self.config = config if config is not None else OxbotConfig()
        self.processes: dict[str, BaseProcess] = {}
        self.respawns: list[tuple[str, float]] = []
        self.gave_up: list[str] = []
        self._ends: dict[str, deque[float]] = {n: deque() for n in launch.components}
        self._due: dict[str, float] = {}  # name -> when to start it again
        self._ended: dict[str, float] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._context: Any = None
        self._segments: set[Path] = set()
        self.bus: ZenohBus | None = None

    def start(self) -> Launcher:
        end_leftovers(self.launch.robot)  # an earlier launcher's children, killed with it
        if self.launch.listen:
            router = Endpoints(
                listen=self.launch.listen,
                connect=self.launch.connect,
                scouting=self.launch.scouting,
                router=True,
                security=self.launch.security,
            )
            self.bus = ZenohBus(self.launch.robot, router)
        context = multiprocessing.get_context("forkserver")
        # imported once by the fork server: every (re)spawned component starts warm
        context.set_forkserver_preload(
            ["oxbot.robot.fork_server"] + [m for m, _ in COMPONENTS.values()] + [__name__]
        )
        self._context = context
        for name in self.launch.components:
            self._spawn(name)
        self._thread = threading.Thread(target=self._watch, name="oxbot-launcher", daemon=True)
        self._thread.start()
        return self

    def _spawn(self, name: str) -> None:
        launch = self.launch
        args = (
            name,
            launch.robot,
            launch.child_endpoints(),
            self.config,
            launch.cameras.get(name),
            logging.getLogger().getEffectiveLevel(),
            os.getpid(),
            launch.components,
        )
        process = self._context.Process(target=_child, args=args, name=f"oxbot-{name}")
        process.start()
        self.processes[name] = process
        log.info("started %s (pid %s)", name, process.pid)
        with contextlib.suppress(OSError):
            write_pids(self.launch.robot, [p.pid for p in self.processes.values() if p.pid])

    def _watch(self) -> None:
        body = self.config.robot
        noted = 0.0
        while not self._stop.wait(self.POLL):
            now = time.monotonic()
            if now - noted > 1.0:  # the shared memory to remove once they have ended
                noted = now
                for process in self.processes.values():
                    if process.pid:
                        self._segments |= shared_memory_of(process.pid)
            for name, process in list(self.processes.items()):
                if name in self._due or name in self.gave_up or process.is_alive():
                    continue
                code = process.exitcode
                ends = self._ends[name]
                while ends and now - ends[0] > body.restart_window:
                    ends.popleft()
                ends.append(now)
                how = f"signal {-code}" if code is not None and code < 0 else f"code {code}"
                if not self.launch.respawn or code == 2 or len(ends) > body.restart_limit:
                    # code 2: an error it explained (a twin, a version): again would not help
                    log.error("%s (pid %s) ended with %s; not respawned", name, process.pid, how)
                    self.gave_up.append(name)
                    continue
                delay = min(body.restart_backoff * 2 ** (len(ends) - 1), body.restart_backoff_max)
                log.warning(
                    "%s (pid %s) ended with %s; respawning in %.1f s", name, process.pid, how, delay
                )
                self._ended[name] = now
                self._due[name] = now + delay
            for name, due in list(self._due.items()):
                if now >= due and not self._stop.is_set():
                    del self._due[name]
                    self._spawn(name)
                    self.respawns.append((name, time.monotonic() - self._ended.pop(name)))

    def stop(self, timeout: float = 5.0) -> None:
        """End every component process (SIGTERM; SIGKILL for any still up after `timeout`)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        for process in self.processes.values():
            if process.pid:
                self._segments |= shared_memory_of(process.pid)
            if process.is_alive():
                process.terminate()
        deadline = time.monotonic() + timeout
        for process in self.processes.values():
            process.join(max(0.0, deadline - time.monotonic()))
            if process.is_alive():
                process.kill()
                process.join(1.0)
        if self.bus is not None:
            self.bus.close()
        remove_unmapped(self._segments, ignore=os.getpid())  # this process only read them
        with contextlib.suppress(OSError):
            pid_file(self.launch.robot).unlink()

    def wait(self, until: Callable[[], bool] | None = None) -> None:
        """Block until `until()` (or Ctrl-C, or every component given up)."""
        while not self._stop.wait(0.2):
            if until is not None and until():
                return
            if self.gave_up and len(self.gave_up) == len(self.processes):
                raise OxbotError("every component ended for good; see the log above")

    def __enter__(self) -> Launcher:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


# --- the commands: oxbot component, oxbot robot ---


def endpoints_of(
    connect: list[str] | None,
    listen: list[str] | None,
    scouting: bool,
    security: Path | None = None,
) -> Endpoints:
    """Command-line endpoints, with the `[security]` table of the TOML file `security` if
    given; ConfigError for an endpoint that is not `proto/address:port`."""
    for endpoint in [*(connect or ()), *(listen or ())]:
        if "/" not in endpoint:
            raise ConfigError(
                f"endpoint {endpoint!r}: write protocol/address:port, e.g. tcp/127.0.0.1:7447"
            )
    return Endpoints(
        connect=tuple(connect or ()),
        listen=tuple(listen or ()),
        scouting=scouting,
        security=load_security_file(security) if security is not None else None,
    )


def load_security_file(path: Path) -> BusSecurity:
    """The `[security]` table of the TOML file at `path` (as in a launch file; its paths are
    relative to the file's folder)."""
    path = Path(path)
    try:
        if not path.is_file():
            raise ConfigError(f"security file {path} is not a regular file")
        with path.open("rb") as handle:
            raw = handle.read(MAX_LAUNCH_FILE_BYTES + 1)
        data = tomllib.loads(raw[:MAX_LAUNCH_FILE_BYTES].decode("utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read security file {path}: {exc}") from None
    if set(data) != {"security"} or not isinstance(data["security"], dict):
        raise ConfigError(f"{path}: a security file holds one [security] table")
    return _security(path, data["security"])


def _interrupt(*_: object) -> None:
    raise KeyboardInterrupt


def run_robot(
    config: OxbotConfig,
    launch: LaunchFile | None,
    robot: str,
    endpoints: Endpoints,
    drive: Callable[[RemoteRobot], None] | None,
) -> None:
    """`oxbot robot`: launch the processes of `launch` (if given) and, if `drive` is given, drive
    the robot from here through it (`TerminalRobot(...).run`, or the web page's `serve`); else
    wait until Ctrl-C."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _interrupt)  # a service manager's stop, like Ctrl-C
    remove_own_shared_memory_at_exit()
    launcher = Launcher(launch, config).start() if launch is not None else None
    try:
        if drive is None:
            if launcher is None:
                raise ConfigError("give --launch FILE, or --terminal / --web to drive a robot")
            launcher.wait()
            return
        if launch is not None:
            robot, endpoints = launch.robot, launch.child_endpoints()
        with ZenohBus(robot, endpoints) as bus:
            from oxbot.robot.remote import RemoteRobot

            drive(RemoteRobot(bus, config))
    finally:
        if launcher is not None:
            launcher.stop()
