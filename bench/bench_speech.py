"""Benchmark of hearing the person: intents understood, flips and decoding speed, on what the
project tunes on and on held-out phrases, voices and people it never tunes on.

    .venv/bin/python bench/bench_speech.py                    # everything: ~30 min, 30,000 clips
    .venv/bin/python bench/bench_speech.py --quick            # a sample of each: ~2 min
    .venv/bin/python bench/bench_speech.py --sets espeak flite --conditions clean "10 dB"
    .venv/bin/python bench/bench_speech.py --recognizer pocketsphinx   # the fallback

Sets (`--sets`):
  tuning           the domain's own user phrases in the 12 espeak-ng voices the project tunes on
  everyday         the domain's own yes and no answers in the held-out espeak-ng and Flite voices
  phrases          held-out phrases (bench/data/held_out_answers.txt) in 3 of those voices
  espeak           held-out phrases in held-out espeak-ng voices and speaking rates
  flite            held-out phrases in CMU Flite's voices, a second synthesiser
  speech_commands  people saying "yes" and "no" (bench/data/speech_commands/, Warden 2018)

Each is heard under every condition of `oxbot.speech.evaluation.CONDITIONS`: clean; white noise
at 20, 15 and 10 dB SNR; 0.5-1.5 s of silence before the speech, exact zeros or a faint noise
floor; a quiet microphone (-30 dBFS peak). For each set and condition it prints the accept/decline
accuracy (an accept understood as `Confirm(playGame…)`, a decline as `Reject(playGame…)`), the
flips (accept understood as decline or the reverse: the worst error), how many answers were
unsure (Unknown or Silence: the robot asks again) or read as another act, the accuracy on the
other intents, and the real-time factor (median decoding time / audio duration). Then, per set,
the accuracy per voice, the acts each other intent was read as, and every flip.

The held-out sets are worth something only while nobody tunes on them: never copy their phrases
into the domain, and never choose voices, rates or thresholds by their scores. Not a test.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import Counter, defaultdict
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

from oxbot.dialogue.domain import load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech.evaluation import (
    CONDITIONS,
    HELD_OUT_ESPEAK,
    HELD_OUT_FLITE,
    VOICES,
    Condition,
    Trial,
    accuracy,
    intent_of_act,
    listening_test,
    median_real_time_factor,
    read_labelled_phrases,
    recording_test,
    speech_commands,
)
from oxbot.speech.nbest import Recognizer
from oxbot.speech.recognition import shipped_recognizer

DATA = Path(__file__).parent / "data"
HELD_OUT_PHRASES = DATA / "held_out_answers.txt"
SPEECH_COMMANDS = DATA / "speech_commands"
SETS = ("tuning", "everyday", "phrases", "espeak", "flite", "speech_commands")
ANSWERS = ("accept", "decline")


def every_nth(phrases: dict[str, str], n: int) -> dict[str, str]:
    """Every n-th phrase of each label (all labels stay represented)."""
    kept: dict[str, str] = {}
    seen: Counter[str] = Counter()
    for phrase, label in phrases.items():
        if seen[label] % n == 0:
            kept[phrase] = label
        seen[label] += 1
    return kept


def plan(
    args: argparse.Namespace, classifier: UserActClassifier
) -> dict[str, Callable[[Sequence[Condition], Recognizer], list[Trial]]]:
    """Each chosen set: a function of the conditions and the recogniser that runs it."""
    held_out = read_labelled_phrases(HELD_OUT_PHRASES)
    tuning = classifier.phrases
    tuning_voices, phrase_voices = VOICES, VOICES[:3]
    espeak, flite = HELD_OUT_ESPEAK, HELD_OUT_FLITE
    if args.quick:
        held_out = every_nth(held_out, 4)
        tuning_voices, phrase_voices = VOICES[:3], VOICES[:1]
        espeak = (HELD_OUT_ESPEAK[0], HELD_OUT_ESPEAK[4])
        flite = (HELD_OUT_FLITE[1], HELD_OUT_FLITE[4])
    recordings = speech_commands(args.speech_commands)

    def synthesised(phrases: dict[str, str], voices: Sequence[str]):
        return lambda conditions, recognizer: listening_test(
            phrases, classifier, voices, conditions, recognizer, args.seed
        )

    everyday = {
        phrase: act for phrase, act in tuning.items() if intent_of_act(act) in ("accept", "decline")
    }
    runs = {
        "tuning": synthesised(tuning, tuning_voices),
        "everyday": synthesised(everyday, (*espeak, *flite)),
        "phrases": synthesised(held_out, phrase_voices),
        "espeak": synthesised(held_out, espeak),
        "flite": synthesised(held_out, flite),
        "speech_commands": lambda conditions, recognizer: recording_test(
            recordings, classifier, conditions, recognizer, args.seed
        ),
    }
    sizes = {
        "tuning": f"{len(tuning)} domain phrases x {len(tuning_voices)} voices",
        "everyday": f"{len(everyday)} domain yes/no answers x {len(espeak) + len(flite)} held-out"
        " voices",
        "phrases": f"{len(held_out)} held-out phrases x {len(phrase_voices)} tuning voices",
        "espeak": f"{len(held_out)} held-out phrases x {len(espeak)} held-out espeak-ng voices",
        "flite": f"{len(held_out)} held-out phrases x {len(flite)} Flite voices",
        "speech_commands": f"{len(recordings)} recordings, "
        f"{len({r.speaker for r in recordings})} speakers",
    }
    chosen = [name for name in args.sets if name != "speech_commands" or recordings]
    if len(chosen) < len(args.sets):
        print(f"speech_commands: no recordings under {args.speech_commands} (see SOURCES.md)")
    for name in chosen:
        print(f"{name}: {sizes[name]}")
    return {name: runs[name] for name in chosen}


def row(trials: Sequence[Trial]) -> str:
    """accept/decline: n, right, flips, unsure, other; other intents: n, right; RTF."""
    answers = [t for t in trials if t.expected_intent in ANSWERS]
    rest = [t for t in trials if t.expected_intent not in ANSWERS]
    flips = sum(t.flip for t in answers)
    unsure = sum(t.unsure for t in answers)
    other = len(answers) - sum(t.right for t in answers) - flips - unsure
    return (
        f"{len(answers):6d} {accuracy(answers):7.1%} {flips:6d} {unsure:7d} {other:6d}"
        f" | {len(rest):5d} {f'{accuracy(rest):.1%}' if rest else '-':>7s}"
        f" | {median_real_time_factor(trials):6.3f}"
    )


HEADER = (
    f"  {'':18s} {'n a/d':>6s} {'right':>7s} {'flips':>6s} {'unsure':>7s} {'other':>6s}"
    f" | {'n oth':>5s} {'right':>7s} | {'RTF':>6s}"
)


def report(name: str, trials: list[Trial], conditions: Sequence[Condition]) -> None:
    print(f"\n== {name}: {len(trials)} recordings heard")
    print(HEADER)
    for condition in conditions:
        own = [t for t in trials if t.condition == condition]
        print(f"  {condition.name:18s} {row(own)}")
    print(f"  {'all':18s} {row(trials)}")

    by_voice: dict[str, list[Trial]] = defaultdict(list)
    for trial in trials:
        if trial.expected_intent in ANSWERS:
            by_voice[trial.voice].append(trial)
    if by_voice:
        scores = {voice: accuracy(own) for voice, own in by_voice.items()}
        print(
            f"  accept/decline per voice: median {statistics.median(scores.values()):.1%}, "
            f"worst {min(scores.values()):.1%}, best {max(scores.values()):.1%}"
        )
        for voice, own in by_voice.items():
            flips = sum(t.flip for t in own)
            print(f"    {voice:24s} {scores[voice]:6.1%}  flips {flips}")

    by_intent: dict[str, list[Trial]] = defaultdict(list)
    for trial in trials:
        by_intent[trial.expected_intent].append(trial)
    print("  each intent, and the acts it was read as:")
    for intent, own in by_intent.items():
        acts = Counter(t.act for t in own).most_common()
        read = ", ".join(f"{act} {count}" for act, count in acts)
        print(f"    {intent:12s} {len(own):5d} {accuracy(own):6.1%}  {read}")

    flips = [t for t in trials if t.flip]
    print(f"  flips: {len(flips)}")
    for t in flips:
        print(
            f"    FLIP {t.voice} [{t.condition.name}] {t.phrase!r} ({t.expected_intent}) "
            f"heard {t.heard!r} -> {t.act}"
        )


def summary(results: dict[str, list[Trial]], conditions: Sequence[Condition]) -> None:
    print("\n== summary: accept/decline accuracy (flips) per set and condition")
    print(f"  {'set':16s}" + "".join(f" {c.name:>14s}" for c in conditions) + f" {'all':>14s}")
    for name, trials in results.items():
        cells = []
        for group in [[t for t in trials if t.condition == c] for c in conditions] + [trials]:
            answers = [t for t in group if t.expected_intent in ANSWERS]
            cells.append(f"{accuracy(answers):6.1%} ({sum(t.flip for t in answers):4d})")
        print(f"  {name:16s}" + "".join(f" {cell:>14s}" for cell in cells))
    print("\n== totals per set")
    for name, trials in results.items():
        answers = [t for t in trials if t.expected_intent in ANSWERS]
        rest = [t for t in trials if t.expected_intent not in ANSWERS]
        audio = sum(t.audio_seconds for t in trials)
        decoding = sum(t.decode_seconds for t in trials)
        top = accuracy([replace(t, act=t.top_act) for t in answers])
        print(
            f"  {name:16s} accept/decline {accuracy(answers):6.1%} of {len(answers)} "
            f"(best hypothesis alone {top:.1%}), "
            f"flips {sum(t.flip for t in answers)}, unsure {sum(t.unsure for t in answers)}; "
            f"other intents {f'{accuracy(rest):.1%}' if rest else '-'} of {len(rest)}; "
            f"RTF median {median_real_time_factor(trials):.3f}, "
            f"max {max(t.real_time_factor for t in trials):.3f}, "
            f"total {decoding:.1f} s / {audio:.1f} s audio"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", nargs="+", choices=SETS, default=list(SETS), help="sets to run")
    parser.add_argument(
        "--conditions",
        nargs="+",
        choices=[c.name for c in CONDITIONS],
        default=[c.name for c in CONDITIONS],
        help="listening conditions",
    )
    parser.add_argument(
        "--quick", action="store_true", help="a quarter of the phrases, fewer voices (minutes)"
    )
    parser.add_argument(
        "--speech-commands",
        type=Path,
        default=SPEECH_COMMANDS,
        help="folder with yes/ and no/ Speech Commands WAVs",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the noise and silences")
    parser.add_argument(
        "--recognizer",
        choices=["whisper", "pocketsphinx"],
        default="whisper",
        help="the recogniser heard with (the robot's default: whisper)",
    )
    args = parser.parse_args()

    conditions = [c for c in CONDITIONS if c.name in args.conditions]
    classifier = UserActClassifier(load_domain())
    started = time.perf_counter()
    recognizer = shipped_recognizer(args.recognizer)
    print(f"{args.recognizer} built in {time.perf_counter() - started:.2f} s")
    results = {}
    for name, run in plan(args, classifier).items():
        started = time.perf_counter()
        results[name] = run(conditions, recognizer)
        report(name, results[name], conditions)
        print(f"  ({time.perf_counter() - started:.0f} s)")
    summary(results, conditions)


if __name__ == "__main__":
    main()
