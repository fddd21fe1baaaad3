"""Text to the phonemes a Piper voice reads: espeak-ng's IPA, sentence by sentence, with the
punctuation kept, and the phonemes as the voice's ids.

Piper links espeak-ng as a library (GPL), so oxbot runs the espeak-ng program instead
(`espeak-ng -q --ipa`), as the espeak-ng voice does. The program drops the punctuation that
Piper's voices were trained with and writes one line per clause, so the text is cut into
clauses here first; each clause's line gets its mark back (`,` `.` `?` `!` `;` `:`), and a
sentence ends at `.`, `?` or `!`, as in Piper. Phonemes are the IPA's code points after
canonical decomposition (NFD), and a voice's ids are BOS, then each phoneme's id followed by the
pad, then EOS (`phoneme_ids`), as Piper's training made them.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from oxbot.errors import SpeechUnavailable

ESPEAK = "espeak-ng"
BOS, EOS, PAD = "^", "$", "_"
"""Piper's begin, end and pad symbols (the `_`, `^`, `$` of every voice's `phoneme_id_map`)."""
SENTENCE_ENDS = frozenset(".?!")
CLAUSE_MARKS = frozenset(",;:") | SENTENCE_ENDS
_CLAUSE = re.compile(r"([^,;:.?!]*)([,;:.?!]+|$)")
_BRACKETS = re.compile(r"\[[^\]]*\]")  # cues such as "[the robot waves]" are not said


@dataclass(frozen=True)
class PhonemeSentence:
    """One sentence of text and its phonemes, punctuation included (one code point each)."""

    text: str
    phonemes: tuple[str, ...]


def clauses(text: str) -> list[tuple[str, str]]:
    """`text` cut into (words, mark) clauses: the mark is the clause's last punctuation
    (`,` `.` `?` `!` `;` `:`; "" for a text that ends without one); clauses without words
    are dropped. A run of marks ("?!", "...") counts as its last sentence end, or its last."""
    text = _BRACKETS.sub(" ", text)
    found = []
    for match in _CLAUSE.finditer(text):
        words, marks = match.group(1).strip(), match.group(2)
        if not words:
            continue
        ends = [m for m in marks if m in SENTENCE_ENDS]
        found.append((words, ends[-1] if ends else marks[-1:]))
    return found


def phonemize(text: str, voice: str = "en-us") -> list[PhonemeSentence]:
    """`text` as Piper reads it: a sentence's phonemes per `.`, `?` or `!`, each clause's mark
    kept, with espeak-ng's IPA for the words. SpeechUnavailable without espeak-ng."""
    parts = clauses(text)
    if not parts:
        return []
    lines = _espeak_ipa([words for words, _ in parts], voice)
    sentences: list[PhonemeSentence] = []
    said: list[str] = []
    phones: list[str] = []
    for (words, mark), ipa in zip(parts, lines, strict=True):
        said.append(words + mark)
        phones.extend(unicodedata.normalize("NFD", ipa.strip()))
        if mark:
            phones.append(mark)
        if mark in SENTENCE_ENDS or (words, mark) == parts[-1]:
            sentences.append(PhonemeSentence(" ".join(said), tuple(phones)))
            said, phones = [], []
        else:
            phones.append(" ")  # Piper's space after a comma, colon or semicolon
    return sentences


def phoneme_ids(phonemes: Sequence[str], id_map: Mapping[str, Sequence[int]]) -> list[int]:
    """The voice's input ids for `phonemes`: BOS, then each phoneme's id and the pad, then EOS;
    a phoneme the voice does not know is left out (as Piper does)."""
    ids = [*id_map[BOS], *id_map[PAD]]
    for phoneme in phonemes:
        if phoneme in id_map:
            ids += [*id_map[phoneme], *id_map[PAD]]
    return [*ids, *id_map[EOS]]


def _espeak_ipa(clause_words: Sequence[str], voice: str) -> list[str]:
    """espeak-ng's IPA for each clause, one line each.

    All clauses go in one call, one per line: espeak-ng ends a clause at each line's end when
    the line has a full stop, so each is given one and read back as one line. When the count of
    lines differs (espeak-ng cut a long clause itself), each clause is asked for alone.
    """
    lines = _run_espeak(". ".join(clause_words) + ".", voice)
    if len(lines) == len(clause_words):
        return lines
    return [" ".join(_run_espeak(words, voice)) for words in clause_words]


def _run_espeak(text: str, voice: str) -> list[str]:
    if shutil.which(ESPEAK) is None:
        raise SpeechUnavailable(
            "espeak-ng is not installed, so the robot cannot speak; install it with "
            "`apt-get install espeak-ng` (make run does this) or use text only"
        )
    result = subprocess.run(
        [ESPEAK, "-q", "--ipa", "-v", voice, text],
        capture_output=True,
        timeout=30,
        check=False,
    )
    if result.returncode != 0:
        message = result.stderr.decode(errors="replace").strip()
        raise SpeechUnavailable(f"espeak-ng could not phonemise {text!r}: {message}")
    return [line for line in result.stdout.decode("utf-8").splitlines() if line.strip()]
