"""WAV in and out: whatever a person, a browser or espeak-ng hands us, as 16 kHz mono PCM.

The recogniser works on 16-bit mono PCM at 16 kHz. Other rates, channel counts and sample
widths are converted here, so that every caller can pass the WAV it has.
"""

from __future__ import annotations

import io
import os
import wave
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from oxbot.errors import InvalidInputError

RATE = 16_000
"""The recogniser's sample rate (pocketsphinx en-us model)."""


@dataclass(frozen=True)
class Audio:
    """Mono 16-bit PCM samples and their rate."""

    samples: np.ndarray
    rate: int

    @property
    def seconds(self) -> float:
        return len(self.samples) / self.rate


def read_wav(wav: str | os.PathLike[str] | bytes) -> Audio:
    """A WAV file's path or bytes as mono int16 samples at their own rate."""
    where = "the WAV bytes" if isinstance(wav, bytes | bytearray) else f"WAV file {wav}"
    if isinstance(wav, bytes | bytearray):
        data = bytes(wav)
    else:
        try:
            data = Path(wav).read_bytes()
        except FileNotFoundError:
            raise InvalidInputError(f"{where} does not exist; check the path") from None
    try:
        with wave.open(io.BytesIO(data), "rb") as handle:
            channels, width = handle.getnchannels(), handle.getsampwidth()
            rate, frames = handle.getframerate(), handle.readframes(handle.getnframes())
    except (wave.Error, EOFError) as exc:
        raise InvalidInputError(
            f"{where} is not a PCM WAV ({exc}); record 16-bit mono PCM, e.g. "
            "`sox in.any -r 16000 -c 1 -b 16 out.wav`"
        ) from None
    samples = _to_int16(frames, width, where)
    if channels > 1:
        usable = len(samples) - len(samples) % channels
        samples = samples[:usable].reshape(-1, channels).mean(axis=1).astype(np.int16)
    return Audio(samples, rate)


def _to_int16(frames: bytes, width: int, where: str) -> np.ndarray:
    if width == 2:
        return np.frombuffer(frames[: len(frames) // 2 * 2], dtype="<i2").copy()
    if width == 1:  # unsigned 8-bit
        return ((np.frombuffer(frames, dtype=np.uint8).astype(np.int16) - 128) << 8).astype(
            np.int16
        )
    if width in (3, 4):
        raw = np.frombuffer(frames[: len(frames) // width * width], dtype=np.uint8)
        raw = raw.reshape(-1, width)[:, width - 2 :]  # keep the two most significant bytes
        return raw.copy().view("<i2").reshape(-1)
    raise InvalidInputError(f"{where} has {width * 8}-bit samples; use 8, 16, 24 or 32-bit PCM")


def resample(audio: Audio, rate: int = RATE) -> Audio:
    """`audio` at `rate`: a windowed-sinc low-pass when shrinking, then linear interpolation."""
    if audio.rate == rate or len(audio.samples) == 0:
        return Audio(audio.samples, rate)
    x = audio.samples.astype(np.float64)
    if rate < audio.rate:  # keep what lies above the new Nyquist frequency out
        cutoff = 0.5 * rate / audio.rate
        taps = np.arange(-32, 33)
        kernel = 2 * cutoff * np.sinc(2 * cutoff * taps) * np.hamming(len(taps))
        x = np.convolve(x, kernel / kernel.sum(), mode="same")
    n_out = round(len(x) * rate / audio.rate)
    t = np.arange(n_out) * (audio.rate / rate)
    y = np.interp(t, np.arange(len(x)), x)
    return Audio(np.clip(np.round(y), -32768, 32767).astype(np.int16), rate)


def to_wav_bytes(audio: Audio) -> bytes:
    """`audio` as the bytes of a 16-bit mono WAV file."""
    out = io.BytesIO()
    with wave.open(out, "wb") as handle:
        handle.setnchannels(1)
        handle.setsampwidth(2)
        handle.setframerate(audio.rate)
        handle.writeframes(audio.samples.astype("<i2").tobytes())
    return out.getvalue()


def pcm16(wav: str | os.PathLike[str] | bytes) -> np.ndarray:
    """A WAV's samples as mono int16 at 16 kHz, converted when needed."""
    return resample(read_wav(wav), RATE).samples


def add_noise(samples: np.ndarray, snr_db: float, rng: np.random.Generator) -> np.ndarray:
    """`samples` with white noise at `snr_db` below the signal's power (20 dB: a quiet room)."""
    x = samples.astype(np.float64)
    power = float(np.mean(x**2)) if len(x) else 0.0
    noise = rng.normal(0.0, np.sqrt(power / 10 ** (snr_db / 10)), len(x))
    return np.clip(np.round(x + noise), -32768, 32767).astype(np.int16)
