"""The face's mouth shapes (visemes) from phonemes and their durations.

A viseme is what a phoneme looks like on the lips: the lips shut for /m/, /b/ and /p/, round
for /o/, /u/ and /w/, open wide for /a/. A few shapes are enough for a drawn face (the page's
`VISEME_SHAPES` in `static/app.js` draws them):

- `rest`: silence, a pause at a comma or full stop (the lips together, relaxed);
- `closed`: m b p (the lips pressed shut);
- `rounded`: o u w and their kin;
- `open`: a-like vowels (the jaw dropped);
- `mid`: the other vowels (ə ɛ ɜ e ...);
- `spread`: i ɪ (the lips drawn wide, nearly shut);
- `teeth`: f v θ ð (the lip or tongue on the teeth);
- `narrow`: the other consonants (t d n s k l ...).

Stress and length marks and combining diacritics look like the phoneme before them, as does a
space between words.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Sequence

from oxbot.speech.phonemes import CLAUSE_MARKS

Viseme = tuple[float, str]
"""(start in seconds from the sentence's start, viseme name)."""
VISEMES = ("rest", "closed", "rounded", "open", "mid", "spread", "teeth", "narrow")

_BY_PHONEME = {
    **dict.fromkeys("mbpɱ", "closed"),
    **dict.fromkeys("ouwʊɔɒɵʉøœʏyʍ", "rounded"),
    **dict.fromkeys("aɑæʌɐɶ", "open"),
    **dict.fromkeys("əɚɜɛeɘᵻɨɤɯ", "mid"),
    **dict.fromkeys("iɪ", "spread"),
    **dict.fromkeys("fvθðɸβ", "teeth"),
}
_LIKE_BEFORE = frozenset("ˈˌːˑʰʲ ")


def viseme_of(phoneme: str, before: str = "rest") -> str:
    """The viseme of one phoneme (one IPA code point); `before` is the previous phoneme's,
    which marks, diacritics and spaces keep."""
    if phoneme in CLAUSE_MARKS:
        return "rest"
    if phoneme in _LIKE_BEFORE or unicodedata.combining(phoneme):
        return before
    return _BY_PHONEME.get(phoneme, "narrow")


def viseme_timeline(
    phonemes: Sequence[str], durations: Sequence[int], rate: int, lead: int = 0
) -> tuple[Viseme, ...]:
    """The mouth over a sentence: (start seconds, viseme) whenever the shape changes, from
    each phoneme's length in samples (`durations`, after `lead` samples of silence)."""
    if len(phonemes) != len(durations):
        raise ValueError(f"{len(phonemes)} phonemes but {len(durations)} durations")
    timeline: list[Viseme] = [(0.0, "rest")] if lead > 0 or not phonemes else []
    at, current = lead, "rest"
    for phoneme, length in zip(phonemes, durations, strict=True):
        current = viseme_of(phoneme, current)
        if length > 0 and (not timeline or timeline[-1][1] != current):
            timeline.append((round(at / rate, 4), current))
        at += length
    return tuple(timeline)
