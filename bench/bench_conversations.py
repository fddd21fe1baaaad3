"""Whole spoken conversations with the running robot: does each go as the person wanted?

    .venv/bin/python bench/bench_conversations.py                       # 300 a level, 4 levels
    .venv/bin/python bench/bench_conversations.py --conversations 21 --levels quiet 10dB

Serves the real robot (`create_app`: Whisper, understanding, the shipped policy, the board
reader) on a free localhost port. Simulated people (`oxbot.testing.personas`: keen, declines,
hesitant, changes_mind, stopper, asks, silent, in turn) talk with it over the page's WebSocket
(`oxbot.testing.talking.converse`), push-to-talk, or hands-free for every `--hands-free`th
conversation, and draw their moves on the page's sheet. They speak phrasings the project's
phrase files do not hold (`bench/data/conversation_phrasings.csv`, written apart from them) in
voices it never tuned on (`HELD_OUT_ESPEAK` and `HELD_OUT_FLITE`), in rooms made from real
background recordings of the `--part` (`bench/data/background/SOURCES.md`): quiet (a
microphone's hiss), 20 dB and 10 dB under the speech (every category), and babble (the babble
recordings, 10 dB under). A silent person's room plays non-speech clips of the same part
(`bench/data/nonspeech`) or nothing. The robot runs `--speed` times faster than real time.

Prints, per level, success per persona and over all, turns, the times the robot asked again,
flips, moves without consent, moves the person did not make, noises answered and hearing
latency (median and p90: push-to-talk, from the answer's audio leaving the client to the
recogniser's hypotheses; hands-free, from the words' last piece, so with the listener's wait for
the end of speech); writes every conversation to `--out`/conversations.jsonl and the success per
persona and level to `--out`/success.png. Not a test (tests/testing/test_personas.py and
tests/web/test_conversation_harness.py test its pieces).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import time
from pathlib import Path

import numpy as np
from sound_sets import background, nonspeech_clips

from oxbot.atomic import save_figure
from oxbot.config import load_config
from oxbot.speech.audio import pcm16
from oxbot.speech.evaluation import HELD_OUT_ESPEAK, HELD_OUT_FLITE
from oxbot.testing.personas import PERSONAS, Persona, judge, read_phrasings
from oxbot.testing.rooms import Room
from oxbot.testing.talking import converse
from oxbot.web.server import create_app, serving_in_background

PHRASINGS = Path(__file__).resolve().parent / "data" / "conversation_phrasings.csv"
VOICES = (*HELD_OUT_ESPEAK, *HELD_OUT_FLITE)
LEVELS = {
    "quiet": (None, None),
    "20dB": (20.0, None),
    "10dB": (10.0, None),
    "babble": (10.0, "babble"),
}
"""Level name -> (SNR in dB under the speech, None: quiet; background category, None: all)."""


def recordings(part: str, category: str | None) -> list[np.ndarray]:
    return [pcm16(path.read_bytes()) for path in background(part, category)]


async def run_level(url: str, level: str, args: argparse.Namespace, phrasings: dict) -> list[dict]:
    snr, category = LEVELS[level]
    sounds = recordings(args.part, category) if snr is not None else []
    noises = [pcm16(path.read_bytes()) for path, _ in nonspeech_clips(args.part)]
    results: list[dict] = []
    queue = list(range(args.conversations))

    async def one(i: int) -> None:
        rng = np.random.default_rng([args.seed, i, list(LEVELS).index(level)])
        kind = PERSONAS[i % len(PERSONAS)]
        persona = Persona(
            kind, phrasings, rng, rematch=bool(rng.random() < 0.5), stop_at=int(rng.integers(1, 3))
        )
        voice = VOICES[(i // len(PERSONAS)) % len(VOICES)]
        recording = sounds[int(rng.integers(len(sounds)))] if sounds else None
        room = Room(level, recording, snr, rng)
        hands_free = bool(args.hands_free) and i % args.hands_free == 0
        started = time.monotonic()
        c = await converse(
            url,
            persona,
            voice,
            room,
            seed=int(rng.integers(2**31)),
            hands_free=hands_free,
            noises=noises if rng.random() < 0.5 else (),
            timeout=args.timeout,
        )
        wrong = judge(c)
        results.append(
            {
                "level": level,
                "persona": kind,
                "voice": voice,
                "hands_free": hands_free,
                "success": not wrong,
                "wrong": wrong,
                "outcome": c.outcome,
                "said": [[r.family, r.text] for r in c.said],
                "heard": c.heard,
                "turns": c.turns,
                "person_turns": len(c.said),
                "asked_again": c.asked_again(),
                "confirmations": c.confirmations(),
                "flips": c.flips(),
                "moves_without_consent": c.moves_without_consent,
                "moves_not_made": sum(
                    sum(cell not in g.drawn for cell in g.accepted) for g in c.games
                ),
                "noise_answered": c.noise_answered,
                "games": [[g.board, g.drawn, g.accepted, g.feedback] for g in c.games],
                "latencies": c.latencies,
                "seconds": time.monotonic() - started,
            }
        )
        with (args.out / "conversations.jsonl").open("a", encoding="utf-8") as log:
            log.write(json.dumps(results[-1]) + "\n")  # kept as it goes: a stopped run loses none
        mark = "ok " if not wrong else "BAD"
        print(f"  {level:6} {i:4} {kind:12} {voice:24} {mark} {'; '.join(wrong)}", flush=True)

    async def worker() -> None:
        while queue:
            await one(queue.pop(0))

    await asyncio.gather(*(worker() for _ in range(args.concurrent)))
    return results


def table(results: list[dict], levels: list[str]) -> str:
    rows = ["| | " + " | ".join(levels) + " |", "| --- |" + " --- |" * len(levels)]

    def cell(level: str, pick, show) -> str:
        chosen = [r for r in results if r["level"] == level and pick(r)]
        return show(chosen) if chosen else "-"

    def share(chosen: list[dict]) -> str:
        ok = sum(r["success"] for r in chosen)
        return f"{100 * ok / len(chosen):.0f}% ({ok}/{len(chosen)})"

    for kind in PERSONAS:
        rows.append(
            f"| {kind} | "
            + " | ".join(cell(lv, lambda r, k=kind: r["persona"] == k, share) for lv in levels)
            + " |"
        )
    rows.append(
        "| **all** | " + " | ".join(cell(lv, lambda r: True, share) for lv in levels) + " |"
    )

    def total(key: str):
        return lambda chosen: str(sum(r[key] for r in chosen))

    def mean(key: str):
        return lambda chosen: f"{np.mean([r[key] for r in chosen]):.1f}"

    def latency(q: float, hands_free: bool):
        def show(chosen: list[dict]) -> str:
            values = [x for r in chosen if r["hands_free"] == hands_free for x in r["latencies"]]
            return f"{np.quantile(values, q):.2f} s" if values else "-"

        return show

    for name, show in (
        ("person turns (mean)", mean("person_turns")),
        ('asked again ("Sorry, I didn\'t catch that")', total("asked_again")),
        (
            "asked about what it heard",
            lambda chosen: str(sum(r.get("confirmations", 0) for r in chosen)),
        ),
        ("flips", total("flips")),
        ("moves without consent", total("moves_without_consent")),
        ("moves the person did not make", total("moves_not_made")),
        ("noises answered", total("noise_answered")),
        ("hearing latency, push-to-talk, median", latency(0.5, False)),
        ("hearing latency, push-to-talk, p90", latency(0.9, False)),
        ("from the words' end, hands-free, median", latency(0.5, True)),
        ("from the words' end, hands-free, p90", latency(0.9, True)),
    ):
        rows.append(
            f"| {name} | " + " | ".join(cell(lv, lambda r: True, show) for lv in levels) + " |"
        )
    return "\n".join(rows)


def plot(results: list[dict], levels: list[str], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4))
    width = 0.8 / len(levels)
    for j, level in enumerate(levels):
        shares = []
        for kind in (*PERSONAS, "all"):
            chosen = [r for r in results if r["level"] == level and kind in ("all", r["persona"])]
            shares.append(100 * np.mean([r["success"] for r in chosen]) if chosen else 0.0)
        ax.bar(np.arange(len(PERSONAS) + 1) + j * width, shares, width, label=level)
    ax.set_xticks(np.arange(len(PERSONAS) + 1) + 0.4 - width / 2, [*PERSONAS, "all"])
    ax.set_ylabel("conversations as wanted (%)")
    ax.set_ylim(0, 100)
    ax.legend(title="room", loc="lower left")
    ax.set_title("Whole spoken conversations with the robot, by persona and room")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--conversations", type=int, default=300, help="per level")
    parser.add_argument("--levels", nargs="+", default=list(LEVELS), choices=list(LEVELS))
    parser.add_argument("--part", default="test", choices=("dev", "test"))
    parser.add_argument("--hands-free", type=int, default=4, help="every Nth conversation; 0: none")
    parser.add_argument("--concurrent", type=int, default=2)
    parser.add_argument("--speed", type=float, default=4.0)
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds a conversation")
    parser.add_argument("--seed", type=int, default=48)
    parser.add_argument("--out", type=Path, default=Path("runs/conversations"))
    parser.add_argument("--table", type=Path, help="print the table of a saved run and stop")
    args = parser.parse_args()
    if args.table is not None:
        saved = [json.loads(line) for line in args.table.read_text().splitlines()]
        print(table(saved, [level for level in LEVELS if any(r["level"] == level for r in saved)]))
        return
    phrasings = read_phrasings(PHRASINGS)
    speed = args.speed
    config = load_config(
        None,
        [
            f"robot.speed_factor={speed}",
            f"robot.answer_timeout={2.0 * speed}",  # 2 s of the person's time after a greeting
            f"robot.question_timeout={8.0 * speed}",  # 8 s to answer a question
            "robot.pause_timeout=0",
            f"robot.hang_seconds={10.0}",
        ],
    )
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "conversations.jsonl").unlink(missing_ok=True)
    results: list[dict] = []
    with serving_in_background(create_app(config)) as url:
        socket = url.replace("http://", "ws://") + "/ws"
        for level in args.levels:
            print(f"{level}: {args.conversations} conversations", flush=True)
            results += asyncio.run(run_level(socket, level, args, phrasings))
    plot(results, args.levels, args.out / "success.png")
    print(table(results, args.levels))
    print(f"wrote {args.out / 'conversations.jsonl'} and {args.out / 'success.png'}")


if __name__ == "__main__":
    main()
