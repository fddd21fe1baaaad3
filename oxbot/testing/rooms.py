"""What a microphone hears in a room: the person's speech over a real background recording.

Speech is set to one level (`SPEECH_DBFS`, a person at arm's length) and the room's recording
`snr_db` below it, so that 10 dB means the same whatever the voice. A quiet room is the
microphone's faint hiss alone.

    room = Room("10 dB", recording, snr_db=10.0, rng=np.random.default_rng(0))
    heard = room.around(speech)      # int16, with the room before and after the words
    room.stream(1600)                # the next 0.1 s of the room, for a hands-free stream
"""

from __future__ import annotations

import numpy as np

from oxbot.speech.audio import RATE
from oxbot.testing.sounds import to_int16

SPEECH_DBFS = -20.0
"""Every answer's RMS level, in dB relative to int16 full scale."""
QUIET_FLOOR_DBFS = -66.0
"""A quiet room's hiss: a microphone's noise floor."""


def level_dbfs(samples: np.ndarray) -> float:
    """RMS level of `samples` in dB relative to int16 full scale (-inf for silence)."""
    rms = float(np.sqrt(np.mean(np.asarray(samples, dtype=np.float64) ** 2)))
    return 20 * np.log10(rms / 32768) if rms > 0 else float("-inf")


def at_level(samples: np.ndarray, dbfs: float) -> np.ndarray:
    """`samples` as float, scaled to an RMS of `dbfs`."""
    x = np.asarray(samples, dtype=np.float64)
    rms = float(np.sqrt(np.mean(x**2))) or 1.0
    return x * (32768 * 10 ** (dbfs / 20) / rms)


class Room:
    """A room's sound, `snr_db` below speech (None: a quiet room), looping over `recording`
    (int16 at RATE) from a random point."""

    def __init__(
        self,
        name: str,
        recording: np.ndarray | None,
        snr_db: float | None,
        rng: np.random.Generator,
    ) -> None:
        if snr_db is not None and (recording is None or len(recording) < RATE):
            raise ValueError(
                f"room {name!r} needs a recording of at least 1 s to mix at {snr_db} dB"
            )
        self.name, self.snr_db, self.rng = name, snr_db, rng
        if snr_db is None:
            self.sound = None
        else:
            self.sound = at_level(recording, SPEECH_DBFS - snr_db)
        self.at = 0 if self.sound is None else int(rng.integers(len(self.sound)))

    def stream(self, n: int) -> np.ndarray:
        """The room's next `n` samples (float, int16 scale), going on where the last call
        stopped."""
        if self.sound is None:
            return self.rng.normal(0.0, 32768 * 10 ** (QUIET_FLOOR_DBFS / 20), n)
        indices = (self.at + np.arange(n)) % len(self.sound)
        self.at = (self.at + n) % len(self.sound)
        return self.sound[indices]

    def around(self, speech: np.ndarray, before: float = 0.3, after: float = 0.4) -> np.ndarray:
        """`speech` at SPEECH_DBFS with `before` and `after` seconds of the room around it, as
        push-to-talk records it (int16)."""
        voice = at_level(speech, SPEECH_DBFS)
        lead, tail = int(before * RATE), int(after * RATE)
        heard = self.stream(lead + len(voice) + tail)
        heard[lead : lead + len(voice)] += voice
        return to_int16(heard)

    def noise(self, seconds: float) -> np.ndarray:
        """`seconds` of the room alone (int16): what push-to-talk records when nobody speaks."""
        return to_int16(self.stream(int(seconds * RATE)))


__all__ = ["QUIET_FLOOR_DBFS", "SPEECH_DBFS", "Room", "at_level", "level_dbfs"]
