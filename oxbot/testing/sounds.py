"""Sounds for testing the robot's ears: room noises, and spoken answers placed in them.

The noises stand for what a microphone hears when nobody talks to the robot: a quiet room's
hiss, a loud fan, pink and brown noise, mains hum, keyboard clicks. Speech comes from
espeak-ng (`oxbot.speech.synthesis`), so the tests hear real synthesised words.
"""

from __future__ import annotations

import numpy as np

from oxbot.speech.audio import RATE

NOISES = ("hiss", "fan", "pink", "brown", "hum", "clicks")
"""The kinds of `room_noise`, in the order `noise_only` plays them."""


def _at_level(x: np.ndarray, dbfs: float) -> np.ndarray:
    """`x` scaled to an RMS of `dbfs` (decibels relative to int16 full scale)."""
    rms = float(np.sqrt(np.mean(x**2))) or 1.0
    return x * (32768 * 10 ** (dbfs / 20) / rms)


def room_noise(kind: str, seconds: float, rng: np.random.Generator, rate: int = RATE) -> np.ndarray:
    """`seconds` of one kind of noise (see NOISES) as float samples on the int16 scale."""
    n = int(seconds * rate)
    white = rng.normal(0.0, 1.0, n)
    if kind == "hiss":  # a quiet room
        return _at_level(white, -50)
    if kind == "fan":  # loud broadband noise
        return _at_level(white, -30)
    if kind in ("pink", "brown"):
        spectrum = np.fft.rfft(white)
        f = np.fft.rfftfreq(n, 1 / rate)
        f[0] = f[1]
        spectrum /= np.sqrt(f) if kind == "pink" else f
        return _at_level(np.fft.irfft(spectrum, n), -35 if kind == "pink" else -30)
    if kind == "hum":  # 50 Hz mains and its harmonics
        t = np.arange(n) / rate
        hum = sum(np.sin(2 * np.pi * 50 * k * t + k) / k for k in range(1, 6))
        return _at_level(hum, -35) + _at_level(white, -55)
    if kind == "clicks":  # a keyboard: about five sharp decaying ticks a second
        x = _at_level(white, -55)
        tick = rng.normal(0.0, 1.0, int(0.015 * rate)) * np.exp(-np.arange(int(0.015 * rate)) / 40)
        for at in rng.integers(0, n - len(tick), int(5 * seconds)):
            x[at : at + len(tick)] += tick * 32768 * 10 ** (-12 / 20) / np.abs(tick).max()
        return x
    raise ValueError(f"unknown noise {kind!r}; known: {', '.join(NOISES)}")


def noise_only(seconds: float, rng: np.random.Generator, rate: int = RATE) -> np.ndarray:
    """`seconds` of the NOISES one after another, in equal parts, as int16."""
    part = seconds / len(NOISES)
    return to_int16(np.concatenate([room_noise(k, part, rng, rate) for k in NOISES]))


def in_noise(
    speech: np.ndarray,
    rng: np.random.Generator,
    before: float = 1.0,
    after: float = 1.0,
    noise: str = "hiss",
    snr_db: float | None = None,
    rate: int = RATE,
) -> tuple[np.ndarray, int]:
    """`speech` (int16) with `before`/`after` seconds of `noise` around it, and the sample
    where the speech starts. With `snr_db`, the noise is scaled to that far below the
    speech's power (over the whole clip) instead of its own level."""
    lead, tail = int(before * rate), int(after * rate)
    x = room_noise(noise, (lead + len(speech) + tail) / rate + 0.01, rng, rate)
    x = x[: lead + len(speech) + tail]
    if snr_db is not None:
        power = float(np.mean(speech.astype(np.float64) ** 2))
        x = _at_level(x, 10 * np.log10(power / 32768**2) - snr_db)
    x[lead : lead + len(speech)] += speech
    return to_int16(x), lead


def onset(speech: np.ndarray, rate: int = RATE) -> int:
    """The first sample of `speech` louder than -40 dBFS in a 5 ms window (its first sound)."""
    win = int(0.005 * rate)
    power = np.convolve(speech.astype(np.float64) ** 2, np.ones(win) / win, mode="same")
    loud = np.flatnonzero(power > (32768 * 10 ** (-40 / 20)) ** 2)
    return int(loud[0]) if len(loud) else 0


def to_int16(x: np.ndarray) -> np.ndarray:
    return np.clip(np.round(x), -32768, 32767).astype(np.int16)


__all__ = ["NOISES", "in_noise", "noise_only", "onset", "room_noise", "to_int16"]
