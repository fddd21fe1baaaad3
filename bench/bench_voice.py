"""Benchmark of the robot's voices, Piper's joe beside espeak-ng: how soon the robot starts
speaking after deciding to, how fast each voice makes audio, and the memory it takes.

    .venv/bin/python bench/bench_voice.py               # both voices, idle and during a game
    .venv/bin/python bench/bench_voice.py --voices piper

Each voice is measured in its own process (so that its memory is its own):

- **act to first audio**: the time from an Utterance published on the bus to the
  SpeakingStarted carrying the first sentence's WAV (the synthesis component as the robot runs
  it: phonemes, the network, the WAV), over every sentence the robot can say
  (`oxbot.robot.session.robot_sentences`); median and p90, in ms. "first time": Piper's
  kept sentences forgotten first, so each is made; "said before": the same again, as the
  robot's sentences come back during a game (`PiperVoice` keeps them); espeak-ng keeps nothing.
  "idle": nothing else runs in this process; "game": the robot's eyes read a rendered photo of
  the sheet every 100 ms beside it (`read_board`, as `GameMoveComponent` does during a game).
  The machine's load average is printed: other jobs on the same 2 cores slow every figure;
- **real-time factor**: the time to synthesise each whole sentence over its audio's duration
  (median over the sentences; below 1 is faster than speech), in wall time and in this
  process's CPU time (which other jobs inflate less; espeak-ng's runs in its own process);
- **resident memory**: the process's RSS with oxbot's robot imported, then with the voice
  loaded and after synthesising every sentence (peak, VmHWM), in MB.
Not a test.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

VOICES = ("piper", "espeak")


def rss_mb(field: str = "VmRSS") -> float:
    """This process's resident memory (or its peak, VmHWM), in MB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


def p90(values: list[float]) -> float:
    """The 90th percentile (nearest rank)."""
    ordered = sorted(values)
    return ordered[max(0, round(0.9 * len(ordered)) - 1)]


def busy_eyes(stop: threading.Event) -> None:
    """The robot's eyes during a game: read a photo of the sheet every 100 ms."""
    import numpy as np

    from oxbot.errors import NoGridFound
    from oxbot.perception import read_board
    from oxbot.testing.render import render_photo

    photo = render_photo(np.random.default_rng(0)).image
    while not stop.wait(0.1):
        with contextlib.suppress(NoGridFound):
            read_board(photo)


def act_to_first_audio(voice: object, sentences: list[str]) -> list[float]:
    """ms from each Utterance to its SpeakingStarted, with the robot's synthesis component."""
    from oxbot.robot.bus import LocalBus
    from oxbot.robot.messages import SpeakingFinished, SpeakingStarted, Utterance
    from oxbot.robot.voice import SpeechSynthesisComponent

    bus = LocalBus()
    inbox = bus.subscribe(SpeakingStarted, SpeakingFinished)
    latencies = []
    with SpeechSynthesisComponent(bus, voice, realtime=False):  # type: ignore[arg-type]
        for text in sentences:
            act = Utterance(text=text, act="bench")
            bus.publish(act)
            started = None
            while True:
                message = inbox.get(timeout=30)
                if isinstance(message, SpeakingStarted):
                    started = message
                elif isinstance(message, SpeakingFinished):
                    break
            assert started is not None
            latencies.append((started.stamp - act.stamp) * 1000)
    return latencies


def measure(name: str) -> dict[str, float]:
    """Every figure of one voice, in this process."""
    from oxbot.config import SpeechConfig
    from oxbot.perception.board import default_reader
    from oxbot.robot.session import robot_sentences  # the robot's imports, before the voice's
    from oxbot.speech.audio import read_wav
    from oxbot.speech.piper import PiperVoice, load_piper_voice
    from oxbot.speech.synthesis import Voice, synthesize

    default_reader()  # the eyes' model, loaded before any timing
    before = rss_mb()
    config = SpeechConfig()
    started = time.perf_counter()
    voice = load_piper_voice(config.piper_threads) if name == "piper" else Voice()
    load_seconds = time.perf_counter() - started
    loaded = rss_mb()
    sentences = robot_sentences()
    factors, cpu_factors = [], []
    for text in sentences:
        started, started_cpu = time.perf_counter(), time.process_time()
        wav = voice.synthesize(text) if name == "piper" else synthesize(text, voice)  # type: ignore[union-attr,arg-type]
        seconds = read_wav(wav).seconds
        factors.append((time.perf_counter() - started) / seconds)
        cpu_factors.append((time.process_time() - started_cpu) / seconds)
    figures = {
        "load_s": load_seconds,
        "rtf": statistics.median(factors),
        "rtf_cpu": statistics.median(cpu_factors),
        "rss_robot_mb": before,
        "rss_voice_mb": loaded,
    }
    for load in ("idle", "game"):
        stop = threading.Event()
        eyes = threading.Thread(target=busy_eyes, args=(stop,), daemon=True)
        if load == "game":
            eyes.start()
        try:
            if isinstance(voice, PiperVoice):
                voice.forget()
            for when in ("first", "again"):
                latencies = act_to_first_audio(voice, sentences)
                figures[f"{load}_{when}_median_ms"] = statistics.median(latencies)
                figures[f"{load}_{when}_p90_ms"] = p90(latencies)
        finally:
            stop.set()
    figures["rss_peak_mb"] = rss_mb("VmHWM")
    figures["sentences"] = len(sentences)
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--voices", nargs="+", default=list(VOICES), choices=VOICES)
    parser.add_argument("--child", choices=VOICES, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(args.child)))
        return
    results = {}
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for name in args.voices:
        command = [sys.executable, __file__, "--child", name]
        out = subprocess.run(command, capture_output=True, text=True, check=True).stdout
        results[name] = json.loads(out.strip().splitlines()[-1])
    rows = [
        ("sentences timed", "sentences", "{:.0f}"),
        *(
            (
                f"act to first audio, {load}, {label}, {stat} (ms)",
                f"{load}_{when}_{stat}_ms",
                "{:.1f}",
            )
            for load in ("idle", "game")
            for when, label in (("first", "first time"), ("again", "said before"))
            for stat in ("median", "p90")
        ),
        ("real-time factor (median)", "rtf", "{:.3f}"),
        ("real-time factor in CPU time, this process (median)", "rtf_cpu", "{:.3f}"),
        ("load (s)", "load_s", "{:.2f}"),
        ("RSS, robot imported (MB)", "rss_robot_mb", "{:.0f}"),
        ("RSS, voice loaded (MB)", "rss_voice_mb", "{:.0f}"),
        ("RSS peak (MB)", "rss_peak_mb", "{:.0f}"),
    ]
    print(f"load average after: {os.getloadavg()[0]:.2f} (2 cores)\n")
    print(f"{'':56s}" + "".join(f"{name:>10s}" for name in results))
    for label, key, form in rows:
        print(f"{label:56s}" + "".join(f"{form.format(r[key]):>10s}" for r in results.values()))


if __name__ == "__main__":
    main()
