"""Speech in and out: recognition with Whisper (pocketsphinx the fallback), synthesis with
Piper's neural voice (espeak-ng the fallback, and the listening tests' voices)."""

from oxbot.speech.audio import RATE, Audio, add_noise, pcm16, read_wav, resample, to_wav_bytes
from oxbot.speech.nbest import Hypothesis, Recognizer
from oxbot.speech.piper import PiperVoice, load_piper_voice
from oxbot.speech.recognition import load_recognizer, recognize
from oxbot.speech.sphinx import PocketsphinxRecognizer
from oxbot.speech.synthesis import Voice, espeak_available, robot_voice, synthesize

__all__ = [
    "RATE",
    "Audio",
    "Hypothesis",
    "PiperVoice",
    "PocketsphinxRecognizer",
    "Recognizer",
    "Voice",
    "add_noise",
    "espeak_available",
    "load_piper_voice",
    "load_recognizer",
    "pcm16",
    "read_wav",
    "recognize",
    "resample",
    "robot_voice",
    "synthesize",
    "to_wav_bytes",
]
