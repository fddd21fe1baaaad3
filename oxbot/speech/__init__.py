"""Speech in and out: recognition with Whisper (pocketsphinx the fallback), synthesis with
espeak-ng."""

from oxbot.speech.audio import RATE, Audio, add_noise, pcm16, read_wav, resample, to_wav_bytes
from oxbot.speech.nbest import Hypothesis, Recognizer
from oxbot.speech.recognition import load_recognizer, recognize
from oxbot.speech.sphinx import PocketsphinxRecognizer
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
