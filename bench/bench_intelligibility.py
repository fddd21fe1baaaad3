"""Benchmark of the robot's voices as a listener hears them: every sentence the robot can say,
synthesised by Piper's joe voice and by espeak-ng, transcribed by the project's own Whisper
recogniser (`[speech.whisper]`, base by default), and the word error rate of each voice.

    .venv/bin/python bench/bench_intelligibility.py                  # both voices, ~3 min
    .venv/bin/python bench/bench_intelligibility.py --model tiny.en  # the smaller Whisper
    .venv/bin/python bench/bench_intelligibility.py --voices piper --show-all

The sentences (`oxbot.robot.session.robot_sentences`): every template of
`oxbot/data/dialogue/templates.txt` (the words it says, its drawing tag left out), and every
sentence the interaction manager makes itself with every cell name ("I take the upper left.",
"The middle is already taken. ...") or part name, and its guidance about the camera. The WER
is the words' edit distance over the words said, after both are lower-cased and stripped of
punctuation (`oxbot.speech.nbest.normalise`) and three spelling variants are written one way
(`SPELLINGS`). Whisper here reads the game's words as its prompt, as it does on the robot.
Not a test.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

from oxbot.config import SpeechConfig
from oxbot.robot.session import robot_sentences
from oxbot.speech.nbest import normalise
from oxbot.speech.piper import load_piper_voice
from oxbot.speech.recognition import load_recognizer
from oxbot.speech.synthesis import Voice, synthesize

VOICES = ("piper", "espeak")
SPELLINGS = {"good bye": "goodbye", "ok": "okay", "all right": "alright"}
"""Parts named in the robot's goodbye when one is lost (`STOPPED_SENTENCE`)."""


def words(text: str) -> list[str]:
    """The words of `text` as compared: `normalise`d, with spelling variants that sound the
    same written one way ("good bye" and "goodbye", "ok" and "okay", "all right" and
    "alright")."""
    text = f" {normalise(text)} "
    for variant, spelling in SPELLINGS.items():
        text = text.replace(f" {variant} ", f" {spelling} ")
    return text.split()


def word_errors(said: Sequence[str], heard: Sequence[str]) -> int:
    """Substitutions, insertions and deletions from `said` to `heard` (Levenshtein on words)."""
    row = list(range(len(heard) + 1))
    for i, word in enumerate(said, start=1):
        previous, row[0] = row[0], i
        for j, other in enumerate(heard, start=1):
            previous, row[j] = row[j], min(row[j] + 1, row[j - 1] + 1, previous + (word != other))
    return row[-1]


def speaker(name: str) -> Callable[[str], bytes]:
    """One of the robot's voices, text to WAV: `piper` (joe), `espeak` (en-us, 160 words a
    minute, as `[speech] espeak_voice`)."""
    if name == "piper":
        return load_piper_voice(SpeechConfig().piper_threads).synthesize
    return lambda text: synthesize(text, Voice(SpeechConfig().espeak_voice))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--voices", nargs="+", default=["piper", "espeak"], choices=VOICES)
    parser.add_argument("--model", default=SpeechConfig().whisper.model)
    parser.add_argument("--show-all", action="store_true", help="every sentence, not only errors")
    args = parser.parse_args()
    config = SpeechConfig()
    recognizer = load_recognizer(replace(config, whisper=replace(config.whisper, model=args.model)))
    sentences = robot_sentences()
    n_words = sum(len(words(s)) for s in sentences)
    print(f"{len(sentences)} sentences, {n_words} words; Whisper {args.model}\n")
    results = {}
    for name in args.voices:
        speak = speaker(name)
        errors, started = 0, time.perf_counter()
        wrong = []
        for sentence in sentences:
            hypotheses = recognizer.recognize(speak(sentence))
            heard = hypotheses[0].text if hypotheses else ""
            e = word_errors(words(sentence), words(heard))
            errors += e
            if e or args.show_all:
                wrong.append((e, sentence, heard))
        results[name] = errors / n_words
        print(
            f"{name}: WER {errors / n_words:.1%} ({errors} of {n_words} words), "
            f"{time.perf_counter() - started:.0f} s"
        )
        for e, sentence, heard in wrong:
            print(f"  [{e}] said {sentence!r} / heard {heard!r}")
        print()
    print("voice    WER")
    for name, wer in results.items():
        print(f"{name:8s} {wer:.1%}")


if __name__ == "__main__":
    main()
