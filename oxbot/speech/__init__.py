"""Speech in and out: recognition with pocketsphinx, synthesis with espeak-ng."""

from oxbot.speech.audio import RATE, Audio, add_noise, pcm16, read_wav, resample, to_wav_bytes
from oxbot.speech.recognition import Hypothesis, Recognizer, recognize
from oxbot.speech.synthesis import Voice, espeak_available, synthesize

__all__ = [
    "RATE",
    "Audio",
    "Hypothesis",
    "Recognizer",
    "Voice",
    "add_noise",
    "espeak_available",
    "pcm16",
    "read_wav",
    "recognize",
    "resample",
    "synthesize",
    "to_wav_bytes",
]
