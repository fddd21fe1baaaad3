"""Soak benchmark of the web server: bursts of connections and hostile clients, measured from
outside, as a person's browser and an attacker would see it.

    .venv/bin/python bench/bench_soak.py                 # 3 bursts of 200, max_sessions 32
    .venv/bin/python bench/bench_soak.py --bursts 5 --connections 300 --sessions 4

Runs `oxbot play` in its own process (real robots, 8x speed) and, from this one:

1. RSS baseline: after the models are loaded and one game has been played;
2. each burst: `--connections` WebSockets opened at once while a scripted game plays in
   another session; /health is asked again and again meanwhile (its answer times); how many
   got a robot and how many the busy close (1013); RSS while they are open, and once they
   have closed;
3. hostile clients: a decompression-bomb PNG, 100,000-deep JSON, a 4 MB type, a flood of
   messages, and a tab that draws and answers for 30 s but never reads; RSS around it and
   after them all.

The goal: /health within 1 s during a burst, the game finishes, at most
`max_sessions` robots, and RSS back within 50 MB of its baseline once the connections close.
Prints medians and maxima; not a test.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import websockets
from websockets.exceptions import ConnectionClosed

from oxbot.testing.hostile import decompression_bomb, nested_json
from oxbot.testing.player import data_url, play_game
from oxbot.testing.sheet import Sheet


def rss_mb(pid: int) -> float:
    """The resident memory of process `pid`, in MB."""
    with open(f"/proc/{pid}/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for process {pid}")


def threads(pid: int) -> int:
    return len(os.listdir(f"/proc/{pid}/task"))


@contextlib.contextmanager
def server_process(sessions: int) -> Iterator[tuple[str, int]]:
    """`oxbot play` on a free port in its own process; yields its URL and process id."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    # `oxbot`, dumping every thread's stack on SIGUSR1 should it ever stop answering
    command = [
        sys.executable,
        "-c",
        "import faulthandler, signal; faulthandler.register(signal.SIGUSR1, all_threads=True); "
        "from oxbot.cli import app; app(prog_name='oxbot')",
        *("--set", "robot.answer_timeout=16", "--set", "robot.move_timeout=240"),
        *("--set", f"web.max_sessions={sessions}"),
        *("play", "--port", str(port), "--speed", "8"),
    ]
    with tempfile.NamedTemporaryFile("w+b", prefix="bench_soak_server_", suffix=".log") as log:
        server = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=log)
        url = f"http://127.0.0.1:{port}"
        try:
            deadline = time.monotonic() + 60
            while True:
                with contextlib.suppress(httpx.HTTPError):
                    if httpx.get(url + "/health").status_code == 200:
                        break
                if server.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"the server did not start; see {log.name}")
                time.sleep(0.2)
            yield url, server.pid
        except BaseException:
            server.send_signal(signal.SIGUSR1)  # its threads' stacks, into its log
            time.sleep(1)
            raise
        finally:
            server.terminate()
            server.wait(timeout=30)
            log.seek(0)
            errors = log.read().decode(errors="replace")
            tracebacks = errors.count("Traceback") + errors.count("Thread 0x")
            print(f"server log: {tracebacks} tracebacks, {len(errors.splitlines())} lines")
            if tracebacks:
                kept = Path(log.name).with_suffix(".kept.log")
                kept.write_text(errors)
                print(f"  kept in {kept}")


def settle(url: str, pid: int, seconds: float = 3.0) -> float:
    """RSS once every session has ended and the server has been quiet for `seconds`."""
    deadline = time.monotonic() + 60
    while httpx.get(url + "/health").json()["sessions"] and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(seconds)
    return rss_mb(pid)


async def burst(url: str, pid: int, connections: int, seed: int) -> dict:
    """`connections` sockets at once beside a scripted game; what each saw, /health's times."""
    ws_url = url.replace("http://", "ws://") + "/ws"
    game = asyncio.create_task(play_game(ws_url, seed=seed, timeout=180))
    while httpx.get(url + "/health").json()["sessions"] < 1:
        await asyncio.sleep(0.05)
    release = asyncio.Event()
    answered = 0

    async def tab() -> str:
        nonlocal answered
        try:
            async with websockets.connect(ws_url, proxy=None, open_timeout=60) as ws:
                first = json.loads(await ws.recv())
                answered += 1
                if first["type"] == "Hello":
                    await release.wait()
                    return "robot"
                with contextlib.suppress(ConnectionClosed):
                    while True:
                        await ws.recv()
                return f"closed {ws.close_code}"
        except (OSError, TimeoutError, ConnectionClosed) as exc:
            answered += 1
            return f"failed {type(exc).__name__}"

    client = httpx.Client(timeout=30)
    tabs = [asyncio.create_task(tab()) for _ in range(connections)]
    health = []
    while answered < connections:
        started = time.monotonic()
        await asyncio.to_thread(client.get, url + "/health")
        health.append(time.monotonic() - started)
    open_rss, open_threads = rss_mb(pid), threads(pid)
    running = client.get(url + "/health").json()["sessions"]
    release.set()
    outcomes = await asyncio.gather(*tabs)
    record = await game
    client.close()
    return {
        "health": health,
        "open_rss": open_rss,
        "open_threads": open_threads,
        "running": running,
        "outcomes": {o: outcomes.count(o) for o in sorted(set(outcomes))},
        "game": f"ended={record.ended} outcome={record.outcome} errors={len(record.errors)}",
    }


async def hostile(url: str, pid: int) -> list[str]:
    """The hostile probes, one socket each; how each ended."""
    ws_url = url.replace("http://", "ws://") + "/ws"
    bomb = json.dumps({"type": "frame", "image": data_url(decompression_bomb(20_000))})
    ended = []
    for name, payloads in (
        ("bomb PNG", [bomb]),
        ("100,000-deep JSON", [nested_json(100_000)]),
        ("4 MB unknown type", [json.dumps({"type": "x" * 3_900_000})]),
        ("flood", ['{"type": "listen_off"}'] * 5_000),
    ):
        async with websockets.connect(ws_url, proxy=None, max_size=2**24) as ws:
            await ws.recv()  # Hello
            replies = []
            with contextlib.suppress(ConnectionClosed):
                for payload in payloads:
                    await ws.send(payload)
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(3):
                        while True:
                            message = json.loads(await ws.recv())
                            if message["type"] == "Error":
                                replies.append(len(message["data"]["message"]))
            ended.append(
                f"{name}: {len(replies)} Error(s) of at most {max(replies, default=0)} "
                f"characters; close {ws.close_code} {ws.close_reason or ''}".rstrip()
            )
    # a tab that never reads while it draws (a sheet every 100 ms) and keeps answering
    before = rss_mb(pid)
    sheet = json.dumps({"type": "frame", "image": data_url(Sheet(3).png())})
    async with websockets.connect(ws_url, proxy=None, max_queue=1) as ws:
        for i in range(300):
            await ws.send(sheet if i % 10 else json.dumps({"type": "say", "text": "yes"}))
            await asyncio.sleep(0.1)
        during = rss_mb(pid)
        ended.append(
            f"never reads, 30 s of sheets and answers: RSS {before:.0f} MB before, "
            f"{during:.0f} MB after ({during - before:+.0f} MB); close {ws.close_code}"
        )
    return ended


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connections", type=int, default=200)
    parser.add_argument("--bursts", type=int, default=3)
    parser.add_argument("--sessions", type=int, default=32, help="web.max_sessions")
    args = parser.parse_args()
    with server_process(args.sessions) as (url, pid):
        asyncio.run(play_game(url.replace("http://", "ws://") + "/ws", seed=1, timeout=180))
        baseline = settle(url, pid)
        print(f"RSS baseline (models loaded, one game played): {baseline:.0f} MB")
        for i in range(args.bursts):
            result = asyncio.run(burst(url, pid, args.connections, seed=10 + i))
            after = settle(url, pid)
            health = result["health"]
            print(
                f"burst {i + 1}: {args.connections} at once; /health median "
                f"{1e3 * statistics.median(health):.0f} ms, max {1e3 * max(health):.0f} ms "
                f"({len(health)} asked); {result['running']} sessions running (limit "
                f"{args.sessions}); {result['outcomes']}; live game {result['game']}"
            )
            print(
                f"  RSS with them open {result['open_rss']:.0f} MB "
                f"({result['open_threads']} threads); after they closed {after:.0f} MB "
                f"({after - baseline:+.0f} MB from baseline, {threads(pid)} threads)"
            )
        for line in asyncio.run(hostile(url, pid)):
            print(f"hostile: {line}")
        after = settle(url, pid)
        print(f"RSS after the hostile clients: {after:.0f} MB ({after - baseline:+.0f} MB)")


if __name__ == "__main__":
    main()
