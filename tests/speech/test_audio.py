import io
import wave

import numpy as np
import pytest

from oxbot.errors import InvalidInputError
from oxbot.speech.audio import (
    RATE,
    Audio,
    add_noise,
    level_dbfs,
    normalise_level,
    pcm16,
    read_wav,
    resample,
    speech_span,
    to_wav_bytes,
    trim_silence,
)


def tone(freq: float, rate: int, seconds: float = 0.5) -> np.ndarray:
    t = np.arange(int(rate * seconds)) / rate
    return (8000 * np.sin(2 * np.pi * freq * t)).astype(np.int16)


def dominant_frequency(samples: np.ndarray, rate: int) -> float:
    spectrum = np.abs(np.fft.rfft(samples.astype(np.float64)))
    return float(np.fft.rfftfreq(len(samples), 1 / rate)[spectrum.argmax()])


def wav_bytes(samples: np.ndarray, rate: int, channels: int = 1, width: int = 2) -> bytes:
    out = io.BytesIO()
    with wave.open(out, "wb") as handle:
        handle.setnchannels(channels)
        handle.setsampwidth(width)
        handle.setframerate(rate)
        handle.writeframes(samples.tobytes())
    return out.getvalue()


@pytest.mark.parametrize("rate", [8000, 22050, 44100, 48000])
def test_resampling_keeps_the_pitch(rate):
    out = resample(Audio(tone(440, rate), rate))
    assert out.rate == 16000
    assert len(out.samples) == pytest.approx(8000, abs=2)
    assert dominant_frequency(out.samples, 16000) == pytest.approx(440, abs=3)


def test_shrinking_the_rate_filters_out_what_would_alias():
    # 7 kHz at 44.1 kHz lies under the new Nyquist frequency (8 kHz): kept.
    # 12 kHz lies above it and would fold down to 4 kHz: removed.
    def rms(samples):  # away from the filter's edges
        middle = samples[100:-100].astype(float)
        return np.sqrt(np.mean(middle**2))

    kept = resample(Audio(tone(7000, 44100), 44100)).samples
    folded = resample(Audio(tone(12000, 44100), 44100)).samples
    assert rms(kept) > 4000
    assert rms(folded) < 0.02 * rms(kept)


def test_stereo_and_8_bit_files_become_mono_int16():
    left = tone(300, 16000)
    stereo = np.stack([left, left], axis=1).reshape(-1)
    audio = read_wav(wav_bytes(stereo, 16000, channels=2))
    assert audio.samples.dtype == np.int16 and len(audio.samples) == len(left)
    assert np.array_equal(audio.samples, left)
    eight = ((left.astype(np.int32) >> 8) + 128).astype(np.uint8)
    audio8 = read_wav(wav_bytes(eight, 16000, width=1))
    assert np.abs(audio8.samples.astype(int) - left).max() < 300


def test_round_trip_through_wav_bytes_and_files(tmp_path):
    samples = tone(500, 16000)
    data = to_wav_bytes(Audio(samples, 16000))
    (tmp_path / "a.wav").write_bytes(data)
    assert np.array_equal(pcm16(data), samples)
    assert np.array_equal(pcm16(tmp_path / "a.wav"), samples)


def test_bad_audio_says_what_to_do(tmp_path):
    with pytest.raises(InvalidInputError, match=r"not a PCM WAV.*sox"):
        read_wav(b"this is not audio")
    with pytest.raises(InvalidInputError, match="does not exist"):
        read_wav(tmp_path / "missing.wav")


def test_noise_at_20_db_has_the_right_power():
    samples = tone(440, 16000, 2.0)
    noisy = add_noise(samples, 20.0, np.random.default_rng(0))
    noise = noisy.astype(float) - samples
    ratio = 10 * np.log10(np.mean(samples.astype(float) ** 2) / np.mean(noise**2))
    assert ratio == pytest.approx(20.0, abs=0.3)


def burst(seconds: float = 0.5, level: float = 8000) -> np.ndarray:
    """A tone that starts and stops like a word, for the silence and level tests."""
    samples = tone(300, RATE, seconds).astype(float) * level / 8000
    return samples.astype(np.int16)


def test_the_level_is_brought_to_the_same_peak_whatever_the_microphone():
    loud, quiet = burst(level=20000), burst(level=20000 * 10 ** (-30 / 20))
    assert level_dbfs(quiet) == pytest.approx(level_dbfs(loud) - 30, abs=0.1)
    for samples in (loud, quiet):
        assert level_dbfs(normalise_level(samples)) == pytest.approx(-6.0, abs=0.1)
    silence = np.zeros(RATE, np.int16)
    assert np.array_equal(normalise_level(silence), silence)
    hiss = np.random.default_rng(0).normal(0, 3, RATE).astype(np.int16)  # about -75 dBFS
    assert level_dbfs(normalise_level(hiss)) < level_dbfs(hiss) + 36.1  # not made loud


def test_silence_around_the_sound_is_trimmed_to_the_same_margin():
    word = burst()
    zeros = np.zeros(RATE, np.int16)
    hiss = np.random.default_rng(1).normal(0, 32, RATE).astype(np.int16)  # -60 dBFS
    bare = trim_silence(word)
    assert bare is not None and len(bare) == len(word) + 2 * round(0.2 * RATE)
    for padded in (
        np.concatenate([zeros, word, zeros]),
        np.concatenate([word, zeros[:4000]]),
        np.concatenate([hiss, word, hiss]),
    ):
        trimmed = trim_silence(padded)
        # the same length within a frame at either end (25 ms, where the frames fall)
        assert trimmed is not None and abs(len(trimmed) - len(bare)) <= 2 * RATE * 25 // 1000
    assert trim_silence(zeros) is None and speech_span(zeros[:100]) is None
