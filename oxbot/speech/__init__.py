"""Speech in and out: recognition with pocketsphinx, synthesis with espeak-ng."""

from oxbot.speech.audio import RATE, Audio, add_noise, pcm16, read_wav, resample, to_wav_bytes
from oxbot.speech.recognition import (
    Hypothesis,
    PocketsphinxRecognizer,
    Recognizer,
    load_recognizer,
    recognize,
)
from oxbot.speech.synthesis import Voice, espeak_available, synthesize

__all__ = [
    "RATE",
    "Audio",
    "Hypothesis",
    "PocketsphinxRecognizer",
    "Recognizer",
    "Voice",
    "add_noise",
    "espeak_available",
    "load_recognizer",
    "pcm16",
    "read_wav",
    "recognize",
    "resample",
    "synthesize",
    "to_wav_bytes",
]
