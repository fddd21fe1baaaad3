"""Message latency and throughput of the bus: in-process (`LocalBus`) against Zenoh on
loopback, the subscriber in another process (as `oxbot robot --launch` runs the robot).

    .venv/bin/python bench/bench_bus.py                 # ~30 s
    .venv/bin/python bench/bench_bus.py --messages 5000

Latency is one way, from a message's stamp (`time.monotonic()` when it was made, one clock for
every process of a machine) to its arrival in the subscriber's queue, for messages sent 2 ms
apart (no queueing): a small one (HeadDirection) and a camera frame (640x480 RGB pixels,
raw, as `Robot.show` sends them: 900 KB). Throughput is small messages published back to
back, counted where they arrive. "added per hop" is Zenoh's figure minus the in-process one.

Respawn: `oxbot robot --launch`'s seven component processes (`Launcher`), each killed with
SIGKILL in turn (`--kills` rounds), timed from the kill to its new process's liveliness token.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import signal
import socket
import statistics
import threading
import time

import numpy as np

from oxbot.config import load_config
from oxbot.robot.bus import LocalBus
from oxbot.robot.frames import frame_message
from oxbot.robot.launch import COMPONENTS, Launcher, LaunchFile
from oxbot.robot.messages import DialogueEnded, Frame, HeadDirection, Message
from oxbot.robot.zenoh_bus import Endpoints, ZenohBus

ROBOT = "bench"


def receive(subscription, count: int, seconds: float = 60.0) -> list[tuple[Message, float]]:
    """(message, arrival time) for `count` messages, or what came within `seconds`."""
    got, deadline = [], time.monotonic() + seconds
    while len(got) < count and time.monotonic() < deadline:
        message = subscription.get(timeout=0.1)
        if message is not None:
            got.append((message, time.monotonic()))
    return got


def figures(arrivals: list[tuple[Message, float]]) -> tuple[float, float]:
    """Median and 99th percentile one-way latency, in ms."""
    latencies = sorted((t - m.stamp) * 1000 for m, t in arrivals)
    return statistics.median(latencies), latencies[int(0.99 * (len(latencies) - 1))]


def throughput(arrivals: list[tuple[Message, float]]) -> float:
    """Messages a second, from the first arrival to the last."""
    span = arrivals[-1][1] - arrivals[0][1]
    return (len(arrivals) - 1) / span if span > 0 else float("inf")


def sheet_frame() -> Frame:
    rng = np.random.default_rng(0)
    image = np.full((480, 640, 3), 235, np.uint8)
    image[100:380:93, 150:490] = 20  # grid lines on paper, a little noise
    image[100:380, 150:490:113] = 20
    image += rng.integers(0, 6, image.shape, dtype=np.uint8)
    return frame_message(image)  # type: ignore[return-value]


def restamped(frame: Frame) -> Frame:
    """The same pixels stamped now."""
    return Frame(image=frame.image, format=frame.format, shape=frame.shape)


def send(bus, make, count: int, gap: float) -> None:
    for _ in range(count):
        bus.publish(make())
        if gap:
            time.sleep(gap)


def run_cases(publish_bus, subscribe, count: int) -> dict[str, object]:
    """Latency of small and frame messages, and small-message throughput, over one bus."""
    frame = sheet_frame()
    results: dict[str, object] = {}
    cases = [
        ("small", HeadDirection, lambda: HeadDirection(direction="left"), count, 0.002),
        ("frame", Frame, lambda: restamped(frame), count // 10, 0.01),
        ("throughput", HeadDirection, lambda: HeadDirection(direction="up"), count * 5, 0.0),
    ]
    for name, kind, make, n, gap in cases:
        subscription = subscribe(kind)
        time.sleep(0.3)  # the subscription is known to the publisher
        arrivals: list = []
        reader = threading.Thread(
            target=lambda s=subscription, n=n, a=arrivals: a.extend(receive(s, n))
        )
        reader.start()
        send(publish_bus, make, n, gap)
        reader.join()
        subscription.close()
        if name == "throughput":
            results[name] = (throughput(arrivals), len(arrivals), n)
        else:
            results[name] = figures(arrivals)
    return results


def subscriber_process(port: int, count: int, out) -> None:
    """The other process: subscribes over Zenoh and sends back the arrival times."""
    with ZenohBus(ROBOT, Endpoints((f"tcp/127.0.0.1:{port}",), scouting=False)) as bus:
        stats: dict[str, object] = {}
        for name, kind, n in (
            ("small", HeadDirection, count),
            ("frame", Frame, count // 10),
            ("throughput", HeadDirection, count * 5),
        ):
            subscription = bus.subscribe(kind)
            bus.publish(DialogueEnded(outcome=None))  # ready
            arrivals = receive(subscription, n)
            subscription.close()
            stats[name] = (
                (throughput(arrivals), len(arrivals), n)
                if name == "throughput"
                else figures(arrivals)
            )
        out.put(stats)


def zenoh_cases(count: int) -> dict[str, object]:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    frame = sheet_frame()
    with ZenohBus(ROBOT, Endpoints(listen=(f"tcp/127.0.0.1:{port}",), scouting=False)) as bus:
        ready = bus.subscribe(DialogueEnded)
        context = multiprocessing.get_context("spawn")
        out = context.Queue()
        child = context.Process(target=subscriber_process, args=(port, count, out))
        child.start()
        try:
            for make, n, gap in (
                (lambda: HeadDirection(direction="left"), count, 0.002),
                (lambda: restamped(frame), count // 10, 0.01),
                (lambda: HeadDirection(direction="up"), count * 5, 0.0),
            ):
                if ready.get(timeout=60) is None:
                    raise RuntimeError("the subscriber process did not start")
                time.sleep(0.3)
                send(bus, make, n, gap)
            return out.get(timeout=120)
        finally:
            child.join(10)
            if child.is_alive():
                child.kill()


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def respawn_times(rounds: int) -> dict[str, list[float]]:
    """Seconds from kill -9 to the new process's liveliness token, per component."""
    launch = LaunchFile(robot="bench-respawn", listen=(f"tcp/127.0.0.1:{free_port()}",))
    # a tiny restart window: each kill counts alone, so each respawn waits the first backoff
    config = load_config(None, ["robot.restart_limit=100", "robot.restart_window=0.01"])
    launcher = Launcher(launch, config).start()
    times: dict[str, list[float]] = {name: [] for name in COMPONENTS}
    try:
        with ZenohBus(launch.robot, launch.child_endpoints()) as bus:
            joined: dict[str, tuple[float, int]] = {}
            bus.watch(lambda p, up: up and joined.__setitem__(p.name, (time.monotonic(), p.pid)))
            deadline = time.monotonic() + 120
            while set(joined) != set(COMPONENTS) and time.monotonic() < deadline:
                time.sleep(0.1)
            time.sleep(1.0)  # every model loaded
            for _ in range(rounds):
                for name in COMPONENTS:
                    pid = joined[name][1]
                    killed = time.monotonic()
                    os.kill(pid, signal.SIGKILL)
                    while joined[name][1] == pid and time.monotonic() - killed < 30:
                        time.sleep(0.005)
                    times[name].append(joined[name][0] - killed)
                    time.sleep(0.3)
    finally:
        launcher.stop()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--messages", type=int, default=2000, help="small messages per case")
    parser.add_argument("--kills", type=int, default=3, help="kill -9 rounds (0: none)")
    args = parser.parse_args()
    local = LocalBus()
    in_process = run_cases(local, local.subscribe, args.messages)
    across = zenoh_cases(args.messages)
    frame_kb = len(sheet_frame().image) / 1024
    print(f"one-way latency, ms (median / p99); frame = raw 640x480 RGB, {frame_kb:.0f} KB")
    print(f"{'':12s}{'in-process':>20s}{'zenoh, 2 processes':>22s}{'added per hop':>20s}")
    for case in ("small", "frame"):
        (m0, p0), (m1, p1) = in_process[case], across[case]
        print(
            f"{case:12s}{m0:9.3f} / {p0:8.3f}{m1:11.3f} / {p1:8.3f}{m1 - m0:9.3f} / {p1 - p0:8.3f}"
        )
    for label, result in (("in-process", in_process), ("zenoh", across)):
        rate, got, sent = result["throughput"]  # type: ignore[misc]
        print(f"throughput {label}: {rate:,.0f} small messages/s ({got} of {sent} arrived)")
    if args.kills:
        print(f"kill -9 to back up (its new liveliness token), s, {args.kills} kills: median / max")
        for name, seconds in respawn_times(args.kills).items():
            print(f"  {name:14s} {statistics.median(seconds):.2f} / {max(seconds):.2f}")


if __name__ == "__main__":
    main()
