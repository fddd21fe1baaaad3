"""Speech synthesis: the robot's words as WAV audio, and which voice says them.

The paper used MARY TTS from templates. oxbot's robot speaks with Piper's neural joe voice
(`oxbot.speech.piper`) and falls back on espeak-ng (a Debian package the setup installs, called
as a subprocess that writes the WAV to standard output) when Piper cannot load
(`robot_voice`). The held-out voices of the listening tests are espeak-ng's.
"""

from __future__ import annotations

import functools
import logging
import shutil
import subprocess
import threading
from dataclasses import dataclass

from oxbot.config import SpeechConfig
from oxbot.errors import ModelFileError, SpeechUnavailable
from oxbot.speech.piper import PiperVoice, load_piper_voice

log = logging.getLogger(__name__)

ESPEAK = "espeak-ng"


def espeak_available() -> bool:
    """True when the espeak-ng program is on the PATH."""
    return shutil.which(ESPEAK) is not None


@dataclass(frozen=True)
class Voice:
    """An espeak-ng voice: language plus optional variant (`en-us+f2`), speed and pitch."""

    name: str = "en-us"
    """espeak-ng voice, e.g. en-us, en-gb, en-us+f2 (see `espeak-ng --voices=en`)."""
    words_per_minute: int = 160
    """espeak-ng's default speed is 175; a little slower reads better to a player."""
    pitch: int = 50
    """espeak-ng's pitch, 0-99; 50 is its default."""


def synthesize(text: str, voice: Voice = Voice()) -> bytes:
    """`text` spoken by espeak-ng, as the bytes of a mono WAV (22,050 Hz, espeak's own rate)."""
    if not text.strip():
        raise SpeechUnavailable("there is nothing to say: the text is empty")
    if not espeak_available():
        raise SpeechUnavailable(
            "espeak-ng is not installed, so the robot cannot speak; install it with "
            "`apt-get install espeak-ng` (make run does this) or use text only"
        )
    command = [ESPEAK, "-v", voice.name, "-s", str(voice.words_per_minute)]
    command += ["-p", str(voice.pitch), "--stdout", text]
    result = subprocess.run(command, capture_output=True, timeout=30, check=False)
    if result.returncode != 0 or not result.stdout:
        message = result.stderr.decode(errors="replace").strip()
        raise SpeechUnavailable(
            f"espeak-ng could not say {text!r} with voice {voice.name!r}: {message}"
        )
    return _fix_stream_header(result.stdout)


def robot_voice(config: SpeechConfig) -> Voice | PiperVoice:
    """The voice the robot speaks with: Piper's joe voice (loaded once per process) when
    `config.voice` is piper and it loads, else espeak-ng's `config.espeak_voice`; one warning
    per process says why Piper is not used."""
    if config.voice == "piper":
        piper = _piper_once(config.piper_threads)
        if isinstance(piper, PiperVoice):
            return piper
    return Voice(config.espeak_voice)


_loading = threading.Lock()


def _piper_once(threads: int) -> PiperVoice | str:
    """The loaded voice, or why it cannot load (kept, so that a bad file is hashed once);
    robots starting together (the server's warm-up and the first tab) wait for one load."""
    with _loading:
        return _load_piper(threads)


@functools.cache
def _load_piper(threads: int) -> PiperVoice | str:
    try:
        return load_piper_voice(threads)
    except (SpeechUnavailable, ModelFileError) as exc:
        log.warning("the robot speaks with espeak-ng, as Piper cannot load: %s", exc)
        return str(exc)


def _fix_stream_header(wav: bytes) -> bytes:
    """espeak-ng writes a streaming WAV whose size fields are 0x7fffffff; set the real sizes."""
    if len(wav) < 44 or wav[:4] != b"RIFF" or wav[36:40] != b"data":
        return wav
    data_size = len(wav) - 44
    return (
        wav[:4]
        + (36 + data_size).to_bytes(4, "little")
        + wav[8:40]
        + data_size.to_bytes(4, "little")
        + wav[44:]
    )
