"""Listening tests: spoken answers through the real recogniser, scored by the intent understood.

The listening goal: "On espeak-ng recordings of the user answers in several voices, with and
without 20 dB noise, the recogniser gets the accept/decline intent right in ≥ 95% and decodes
faster than real time." `listening_test` runs that measurement (and the same for any phrases);
`bench/bench_speech.py` prints it and `tests/speech/test_evaluation.py` asserts it.

A listening test hears utterances — a phrase spoken by a synthetic voice (`listening_test`) or a
person's recording (`recording_test`) — under a listening `Condition` (clean, white noise,
silence before the speech, a quiet microphone), decodes each to an N-best list and reads the
user act from it with `UserActClassifier.intent_of`. Noise and silence are seeded by voice,
phrase and condition, so every run hears the same audio.

What is scored is the intent the act expresses (`intent_of_act`), not the act's exact name, so
the scores survive a domain that names more acts: an accept is any `Confirm(playGame…)`, a
decline any `Reject(playGame…)` (`Reject(playGame=later)` too). Reading an accept as a decline
or the reverse is a flip, the worst error; Unknown or Silence is only a question asked again.

Voices are strings (`speak`): espeak-ng voices as `en-gb+f4` (160 words a minute, as the robot
speaks) or `en-gb+f4@200`; CMU Flite voices as `flite:slt`, or `flite:slt@1.2` with every
duration stretched by 1.2. The project tunes on `VOICES`; `HELD_OUT_ESPEAK` and `HELD_OUT_FLITE`
are never tuned on, and neither are the phrases of bench/data/held_out_answers.txt
(`read_labelled_phrases`) nor the people of bench/data/speech_commands/ (`speech_commands`).
"""

from __future__ import annotations

import re
import shutil
import statistics
import subprocess
import tempfile
import time
import zlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from oxbot.dialogue.domain import (
    ACKNOWLEDGE,
    INVITATION,
    SILENCE,
    UNKNOWN,
    Domain,
    accepts_game,
    is_game_move,
    refuses_game,
)
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.errors import DataError, SpeechUnavailable
from oxbot.speech.audio import RATE, Audio, add_noise, pcm16, to_wav_bytes
from oxbot.speech.keywords import answer_to
from oxbot.speech.nbest import Hypothesis, Recognizer
from oxbot.speech.recognition import default_recognizer
from oxbot.speech.speech_commands import speaker_of
from oxbot.speech.sphinx import PocketsphinxRecognizer
from oxbot.speech.synthesis import Voice, synthesize

VOICES: tuple[str, ...] = (
    "en-us",
    "en-gb",
    "en+m3",
    "en+f3",
    "en+m7",
    "en-gb+f4",
    "en-us+f2",
    "en-gb-scotland",
    "en+m1",
    "en+f2",
    "en-us+m5",
    "en-gb-x-rp",
)
"""espeak-ng voices: American, British and Scottish accents, male and female variants.

The project tunes on these. Every held-out voice below differs from all of them."""
TUNING_VOICES = VOICES[0::2]
"""The half of VOICES the recogniser's constants are fitted on (`bench/tune_recognition.py`)."""
CHECK_VOICES = VOICES[1::2]
"""The other half, on which the fitted constants are checked."""

HELD_OUT_ESPEAK: tuple[str, ...] = (
    "en-gb-x-gbclan+m2@130",
    "en-gb-x-gbclan+f5@220",
    "en-gb-x-gbcwmd+m4@175",
    "en-gb-x-gbcwmd+f1@130",
    "en-029+m6@220",
    "en-029+Annie@175",
    "en-us-nyc+m8@130",
    "en-us-nyc+klatt@175",
    "en-us+aunty@220",
)
"""espeak-ng voices never tuned on: Lancaster, West Midlands, Caribbean and New York accents
(none in VOICES), variants VOICES does not use, and the Klatt synthesiser; three at each of
130, 175 and 220 words a minute (VOICES speak at 160)."""

HELD_OUT_FLITE: tuple[str, ...] = (
    "flite:kal",
    "flite:kal16@1.25",
    "flite:awb@0.85",
    "flite:rms",
    "flite:slt@1.15",
    "flite:slt@0.85",
)
"""CMU Flite voices (Debian's `flite`): a second synthesiser, never tuned on. kal is a diphone
voice at 8 kHz, kal16 at 16 kHz; awb (Scottish), rms and slt are unit-selection voices. The
number stretches every duration (1.25: slower; 0.85: faster)."""

INTENTS: tuple[str, ...] = (
    "accept",
    "decline",
    "stop",
    "new_game",
    "greet",
    "thank",
    "goodbye",
    "who_starts",
    "i_start",
    "complain",
    "unrelated",
)
"""What a person means, as held-out phrases are labelled (bench/data/held_out_answers.txt)."""

UNSURE = "unsure"
"""The intent of Unknown and Silence: the robot did not understand and would ask again."""

# Words in an act's name that say which intent it expresses, checked in this order. Generous on
# purpose: the domain may name new acts (`Request(newGame)`, `Inform(userFirst)`) and the scores
# should not depend on the spelling.
_INTENT_WORDS: tuple[tuple[str, frozenset[str]], ...] = (
    ("greet", frozenset({"greeting", "greet", "hello", "hi"})),
    ("goodbye", frozenset({"closing", "bye", "goodbye", "farewell"})),
    ("thank", frozenset({"thank", "thanks", "thanking", "gratitude"})),
    (
        "complain",
        frozenset({"complain", "complaint", "cheat", "unfair", "wrong", "mistake", "problem"}),
    ),
    ("stop", frozenset({"stop", "quit", "end", "abort", "finish", "halt"})),
    ("new_game", frozenset({"again", "another", "rematch", "restart", "replay", "new", "more"})),
    ("unrelated", frozenset({"chat", "chitchat", "smalltalk", "topic", "unrelated", "irrelevant"})),
)
_STARTING = frozenset({"start", "starts", "first", "begin", "begins", "turn", "order"})
_THE_PERSON = frozenset({"user", "usr", "me", "i", "person", "human", "player"})


def intent_of_act(act: str) -> str:
    """The intent a user act expresses: one of INTENTS, UNSURE, "move", "acknowledge" or "other".

    An accept is any `Confirm(playGame…)`, a decline any `Reject(playGame…)`; other acts are
    read by the words of their names (`Salutation(greeting)` greets, `Request(newGame)` asks
    for a new game, `Inform(userFirst)` wants to start, `Request(firstMove)` asks who starts).
    """
    if act in (UNKNOWN, SILENCE):
        return UNSURE
    if accepts_game(act):
        return "accept"
    if refuses_game(act):
        return "decline"
    if is_game_move(act):
        return "move"
    words = {w.lower() for w in re.findall(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])", act)}
    for intent, keys in _INTENT_WORDS:
        if words & keys:
            return intent
    if words & _STARTING:
        return "i_start" if words & _THE_PERSON else "who_starts"
    if act == ACKNOWLEDGE:
        return "acknowledge"
    return "other"


@dataclass(frozen=True)
class Condition:
    """How a recording reaches the recogniser: clean, in noise, after silence, or quiet."""

    name: str
    snr_db: float | None = None
    """White noise at this signal-to-noise ratio over the whole recording; None: no noise."""
    lead_seconds: tuple[float, float] | None = None
    """Silence before the speech, its length drawn uniformly from this range (push-to-talk
    pressed before speaking); None: the recording starts with the speech."""
    floor: float = 0.0
    """A microphone's noise floor under everything, lead included: the standard deviation of
    white noise in 16-bit steps (0: the silence is exact zeros)."""
    peak_dbfs: float | None = None
    """Scale the speech so its peak lies here (a quiet microphone); None: as recorded."""

    @property
    def seed_key(self) -> str:
        # Plain noise keeps the key the listening test always used, so the figures measured
        # with it before the other conditions existed do not move; every other condition is
        # keyed by its name.
        if self.lead_seconds is None and not self.floor and self.peak_dbfs is None:
            return str(self.snr_db)
        return self.name

    def heard(self, samples: np.ndarray, noise_key: str, seed: int = 0) -> np.ndarray:
        """`apply`, with the noise and silences drawn from `seed` and `noise_key` (a voice and
        a phrase, say): the same recording under the same condition every run."""
        key = zlib.crc32(f"{noise_key}|{self.seed_key}".encode())
        return self.apply(samples, np.random.default_rng([seed, key]))

    def apply(self, samples: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """`samples` (int16 at 16 kHz) as heard under this condition."""
        x = samples.astype(np.float64)
        if self.peak_dbfs is not None and len(x) and np.abs(x).max() > 0:
            x *= 32767 * 10 ** (self.peak_dbfs / 20) / np.abs(x).max()
        if self.lead_seconds is not None:
            x = np.concatenate([np.zeros(round(rng.uniform(*self.lead_seconds) * RATE)), x])
        if self.floor:
            x += rng.normal(0.0, self.floor, len(x))
        out = np.clip(np.round(x), -32768, 32767).astype(np.int16)
        return out if self.snr_db is None else add_noise(out, self.snr_db, rng)


CLEAN = Condition("clean")


def white_noise(snr_db: float) -> Condition:
    """White noise at `snr_db` below the speech's power (20 dB: a quiet room; 10 dB: a loud one)."""
    return Condition(f"{snr_db:g} dB", snr_db=snr_db)


CONDITIONS: tuple[Condition, ...] = (
    CLEAN,
    white_noise(20.0),
    white_noise(15.0),
    white_noise(10.0),
    Condition("lead zeros", lead_seconds=(0.5, 1.5)),
    Condition("lead floor", lead_seconds=(0.5, 1.5), floor=16.0),
    Condition("quiet", peak_dbfs=-30.0),
)
"""Every listening condition of the held-out benchmark: clean; white noise at 20, 15 and 10 dB
SNR; 0.5-1.5 s of silence before the speech, as exact zeros and over a faint noise floor
(-66 dBFS); a quiet microphone (speech peaking at -30 dBFS)."""


def as_condition(condition: Condition | float | None) -> Condition:
    """A Condition as given, None as CLEAN, a number as white noise at that SNR in dB."""
    if isinstance(condition, Condition):
        return condition
    return CLEAN if condition is None else white_noise(float(condition))


def chatter_sentences() -> list[str]:
    """Made-up things a person might say that are none of the game's acts, most of their words
    outside the domain (`oxbot/data/speech/chatter.txt`): even lines for tuning, odd ones for
    checking."""
    path = resources.files("oxbot") / "data" / "speech" / "chatter.txt"
    lines = path.read_text(encoding="utf-8").splitlines()
    return [line.strip() for line in lines if line.strip() and not line.startswith("#")]


@dataclass(frozen=True)
class Trial:
    """One utterance in one voice under one condition, as the robot heard and understood it."""

    voice: str
    """The synthetic voice (`speak`), or the speaker of a recording (`sc:0a7c2a8d`)."""
    condition: Condition
    phrase: str
    expected: str
    """What the phrase means: an intent of INTENTS, or a user act (read as its intent)."""
    heard: str
    """The recogniser's best hypothesis ("" when nothing was heard)."""
    act: str
    """The act the whole N-best list votes for (`UserActClassifier.intent_of`)."""
    top_act: str
    """The act of the best hypothesis alone (`UserActClassifier.classify`)."""
    decode_seconds: float
    audio_seconds: float

    @property
    def snr_db(self) -> float | None:
        """Signal-to-noise ratio of the added white noise; None without noise."""
        return self.condition.snr_db

    @property
    def intent(self) -> str:
        """The intent of the act understood (`intent_of_act`)."""
        return intent_of_act(self.act)

    @property
    def expected_intent(self) -> str:
        return self.expected if self.expected in INTENTS else intent_of_act(self.expected)

    @property
    def right(self) -> bool:
        """Understood: the act expresses the expected intent (exactly the expected act, when
        that act has no intent of INTENTS); unrelated chatter may also go un-understood."""
        want = self.expected_intent
        if want in INTENTS and self.intent == want:
            return True
        return self.act == self.expected or (want == "unrelated" and self.intent == UNSURE)

    @property
    def flip(self) -> bool:
        """An accept understood as a decline, or a decline as an accept: the worst error."""
        return {self.expected_intent, self.intent} == {"accept", "decline"}

    @property
    def unsure(self) -> bool:
        """Read as Unknown or Silence: the robot would ask again."""
        return self.intent == UNSURE

    @property
    def real_time_factor(self) -> float:
        return self.decode_seconds / self.audio_seconds


@dataclass(frozen=True)
class Recording:
    """A person's recorded answer (a WAV file) and what it means."""

    path: Path
    expected: str
    """An intent of INTENTS, or a user act."""
    speaker: str
    words: str
    """What is said in it."""


def accept_decline_phrases(domain: Domain) -> dict[str, str]:
    """The person's yes and no answers to the invitation (`Request(playGame)`), phrase -> act
    (its other answers, "what time is it", are left out)."""
    return {
        " ".join(u.words): u.act
        for u in domain.responses_to(INVITATION)
        if u.words and intent_of_act(u.act) in ("accept", "decline")
    }


def read_labelled_phrases(path: str | Path) -> dict[str, str]:
    """A labelled phrase file (`label words` per line, `#` comments), phrase -> label.

    Every label must be one of INTENTS and every phrase must be new, or DataError names the
    line. The format is documented at the top of bench/data/held_out_answers.txt."""
    phrases: dict[str, str] = {}
    seen: dict[str, int] = {}
    for number, line in enumerate(Path(path).read_text(encoding="utf-8").splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        label, *rest = line.split(maxsplit=1)
        words = " ".join(rest[0].split()) if rest else ""
        where = f"{path}:{number}"
        if label not in INTENTS:
            raise DataError(f"{where}: unknown label {label!r}; use one of {', '.join(INTENTS)}")
        if not words:
            raise DataError(f"{where}: {label} has no words; write `{label} what is said`")
        key = words.lower()
        if key in seen:
            raise DataError(f"{where}: {words!r} already on line {seen[key]}; keep one")
        seen[key] = number
        phrases[words] = label
    if not phrases:
        raise DataError(f"{path} holds no labelled phrase")
    return phrases


def speech_commands(directory: str | Path) -> list[Recording]:
    """Speech Commands recordings (Warden 2018) under `directory`: yes/*.wav accept,
    no/*.wav decline; the speaker is the file name's first part (`0a7c2a8d_nohash_0.wav`)."""
    directory = Path(directory)
    return [
        Recording(path, intent, "sc:" + speaker_of(path.name), word)
        for word, intent in (("yes", "accept"), ("no", "decline"))
        for path in sorted((directory / word).glob("*.wav"))
    ]


def speak(text: str, voice: str) -> bytes:
    """`text` spoken in `voice`, as WAV bytes at the synthesiser's own rate.

    `voice` is an espeak-ng voice (`en-gb+f4`, 160 words a minute; `en-gb+f4@200` at 200) or a
    Flite voice (`flite:slt`; `flite:slt@1.2` stretches every duration by 1.2)."""
    name, _, rate = voice.partition("@")
    if name.startswith("flite:"):
        return _flite(text, name.removeprefix("flite:"), float(rate) if rate else 1.0)
    return synthesize(text, Voice(name, int(rate)) if rate else Voice(name))


def _flite(text: str, voice: str, stretch: float) -> bytes:
    if shutil.which("flite") is None:
        raise SpeechUnavailable(
            "flite is not installed, so the Flite voices cannot speak; install it with "
            "`apt-get install flite` (make setup does this)"
        )
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "flite.wav"
        command = ["flite", "-voice", voice, "--setf", f"duration_stretch={stretch:g}"]
        result = subprocess.run(
            [*command, "-t", text, "-o", str(out)], capture_output=True, timeout=30, check=False
        )
        if result.returncode != 0 or not out.exists() or out.stat().st_size <= 44:
            message = result.stderr.decode(errors="replace").strip()
            raise SpeechUnavailable(f"flite could not say {text!r} with voice {voice!r}: {message}")
        return out.read_bytes()


def listening_test(
    phrases: Mapping[str, str],
    classifier: UserActClassifier,
    voices: Sequence[str] = VOICES,
    conditions: Iterable[Condition | float | None] = (None, 20.0),
    recognizer: Recognizer | None = None,
    seed: int = 0,
) -> list[Trial]:
    """Every phrase (text -> expected intent or act) in every voice under every condition.

    A condition may be given as a Condition, a number (white noise at that SNR in dB) or None
    (clean)."""
    recognizer = recognizer or default_recognizer()
    conditions = tuple(as_condition(c) for c in conditions)
    trials = []
    for voice in voices:
        for phrase, expected in phrases.items():
            clean = pcm16(speak(phrase, voice))
            noise_key = f"{voice}|{phrase}"
            trials += _hear(
                clean, voice, phrase, expected, noise_key, conditions, classifier, recognizer, seed
            )
    return trials


def recording_test(
    recordings: Sequence[Recording],
    classifier: UserActClassifier,
    conditions: Iterable[Condition | float | None] = (None,),
    recognizer: Recognizer | None = None,
    seed: int = 0,
) -> list[Trial]:
    """Every recording under every condition, recognised; a trial's voice is the speaker."""
    recognizer = recognizer or default_recognizer()
    conditions = tuple(as_condition(c) for c in conditions)
    trials = []
    for rec in recordings:
        noise_key = f"{rec.speaker}|{rec.path.name}"
        trials += _hear(
            pcm16(rec.path),
            rec.speaker,
            rec.words,
            rec.expected,
            noise_key,
            conditions,
            classifier,
            recognizer,
            seed,
        )
    return trials


def _hear(
    clean: np.ndarray,
    voice: str,
    phrase: str,
    expected: str,
    noise_key: str,
    conditions: Sequence[Condition],
    classifier: UserActClassifier,
    recognizer: Recognizer,
    seed: int,
) -> list[Trial]:
    """One utterance under every condition: decoded, timed and understood, as an answer to the
    invitation when it is one (accept or decline: the robot reads it in that context)."""
    trials = []
    intent = expected if expected in INTENTS else intent_of_act(expected)
    context = INVITATION if intent in ("accept", "decline") else ""
    for condition in conditions:
        samples = condition.heard(clean, noise_key, seed)
        started = time.perf_counter()
        hypotheses, keywords = heard_by(recognizer, samples)
        decode_seconds = time.perf_counter() - started
        nbest = answer_to(context, hypotheses, keywords)  # as the robot reads them (manager.py)
        top = classifier.classify(nbest[0].text, context).act if nbest else SILENCE
        trials.append(
            Trial(
                voice,
                condition,
                phrase,
                expected,
                nbest[0].text if nbest else "",
                classifier.intent_of(nbest, context).act,
                top,
                decode_seconds,
                len(samples) / RATE,
            )
        )
    return trials


def heard_by(
    recognizer: Recognizer, samples: np.ndarray
) -> tuple[list[Hypothesis], np.ndarray | None]:
    """What `recognizer` hears in int16 samples at 16 kHz, as the robot's hearing component
    hands it on: the N-best list, and the keyword model's opinion where pocketsphinx has one."""
    if isinstance(recognizer, PocketsphinxRecognizer):
        listening = recognizer.listen(samples)
        return (listening.hypotheses, listening.keywords) if listening else ([], None)
    return recognizer.recognize(to_wav_bytes(Audio(samples, RATE))), None


def accuracy(trials: Sequence[Trial]) -> float:
    """The share of trials whose intent was understood right."""
    return sum(t.right for t in trials) / len(trials) if trials else 0.0


def median_real_time_factor(trials: Sequence[Trial]) -> float:
    """The median over trials of decoding time / audio duration (< 1: faster than real time)."""
    return statistics.median(t.real_time_factor for t in trials) if trials else 0.0
