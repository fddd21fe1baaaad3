"""Benchmark of hearing the person: intent accuracy and decoding speed on espeak-ng voices.

    .venv/bin/python bench/bench_speech.py                   # 12 voices, clean and 20 dB SNR
    .venv/bin/python bench/bench_speech.py --voices en-us en-gb --snr 20 10

Speaks every answer to the invitation (the `Request(playGame)` user responses) in each voice,
clean and with white noise, decodes it with the shipped recogniser and reads the user act from
the N-best list (`oxbot.speech.evaluation.listening_test`). Prints the accept/decline accuracy
per voice and overall, what went wrong, the real-time factor (median decoding time / audio
duration), and the same accuracy for every user phrase of the domain. Issue 6's acceptance:
≥ 95% accept/decline, faster than real time. Not a test.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

from oxbot.dialogue.domain import load_domain
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.speech.evaluation import (
    VOICES,
    Trial,
    accept_decline_phrases,
    accuracy,
    listening_test,
    median_real_time_factor,
)
from oxbot.speech.recognition import default_recognizer


def report(title: str, trials: list[Trial]) -> None:
    by_voice: dict[str, list[Trial]] = defaultdict(list)
    for trial in trials:
        by_voice[trial.voice].append(trial)
    top = sum(t.top_act == t.expected for t in trials) / len(trials)
    print(f"\n{title}: {len(trials)} recordings")
    print(f"  {'voice':16s} {'clean':>7s} {'noisy':>7s} {'all':>7s}")
    for voice, own in by_voice.items():
        clean = [t for t in own if t.snr_db is None]
        noisy = [t for t in own if t.snr_db is not None]
        print(f"  {voice:16s} {accuracy(clean):7.1%} {accuracy(noisy):7.1%} {accuracy(own):7.1%}")
    print(f"  overall {accuracy(trials):.1%} (best hypothesis alone: {top:.1%})")
    for t in trials:
        if not t.right:
            noise = "clean" if t.snr_db is None else f"{t.snr_db:g} dB"
            print(f"  wrong: {t.voice} {noise}: {t.phrase!r} heard {t.heard!r} -> {t.act}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--voices", nargs="+", default=list(VOICES), help="espeak-ng voices")
    parser.add_argument(
        "--snr", nargs="+", type=float, default=[20.0], help="noisy SNRs in dB (and clean)"
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the added noise")
    args = parser.parse_args()

    domain = load_domain()
    classifier = UserActClassifier(domain)
    started = time.perf_counter()
    recognizer = default_recognizer()
    print(f"recogniser built in {time.perf_counter() - started:.2f} s")
    snrs = [None, *args.snr]

    answers = listening_test(
        accept_decline_phrases(domain), classifier, args.voices, snrs, recognizer, args.seed
    )
    report("accept/decline intent (answers to Request(playGame))", answers)
    everything = listening_test(
        classifier.phrases, classifier, args.voices, snrs, recognizer, args.seed
    )
    report("user act, every user phrase of the domain", everything)

    trials = answers + everything
    audio = sum(t.audio_seconds for t in trials)
    decoding = sum(t.decode_seconds for t in trials)
    print(
        f"\nreal-time factor: median {median_real_time_factor(trials):.3f}, "
        f"total {decoding:.1f} s decoding / {audio:.1f} s audio = {decoding / audio:.3f}"
    )


if __name__ == "__main__":
    main()
