"""Checking what a browser tab sends before the robot sees it: images, audio, a message's size,
JSON depth and rate.

Each check raises InvalidInputError naming what is wrong, and quotes at most an `excerpt` of
the input; the session (oxbot.web.session) sends it back to the tab as an Error.
"""

from __future__ import annotations

import base64
import binascii
import io
import re
import time
from collections.abc import Callable

import numpy as np
from PIL import Image, UnidentifiedImageError

from oxbot.config import WebConfig
from oxbot.errors import InvalidInputError
from oxbot.image_size import check_pixels
from oxbot.speech.audio import Audio, to_wav_bytes


def decode_image(payload: object, limits: WebConfig) -> np.ndarray:
    """A data URL or base64 string of a PNG/JPEG/WebP as uint8 RGB (H, W, 3).

    Raises InvalidInputError naming what is wrong (not a string, not base64, not an image,
    too big or too small).
    """
    if not isinstance(payload, str) or not payload:
        raise InvalidInputError("'image' must be a data URL or base64 string of a PNG or JPEG")
    if payload.startswith("data:"):
        header, _, payload = payload.partition(",")
        if ";base64" not in header:
            raise InvalidInputError("an image data URL must be base64-encoded")
    try:
        raw = base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError):
        raise InvalidInputError("'image' is not valid base64") from None
    # the header's size first: a small PNG can declare gigabytes of pixels
    size = check_pixels(raw, "'image'", limits.max_image_side**2)
    if size is None:
        raise InvalidInputError("'image' is not a readable PNG or JPEG image")
    try:
        with Image.open(io.BytesIO(raw)) as image:
            if image.format not in ("PNG", "JPEG", "WEBP"):
                raise InvalidInputError(f"images must be PNG, JPEG or WebP, not {image.format}")
            width, height = size
            if max(width, height) > limits.max_image_side:
                raise InvalidInputError(
                    f"image is {width}x{height}; the largest side accepted is "
                    f"{limits.max_image_side} pixels"
                )
            if min(width, height) < limits.min_image_side:
                raise InvalidInputError(
                    f"image is {width}x{height}; a readable sheet needs at least "
                    f"{limits.min_image_side} pixels a side"
                )
            return np.asarray(image.convert("RGB"), dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        if isinstance(exc, InvalidInputError):
            raise
        raise InvalidInputError(f"'image' is not a readable PNG or JPEG image ({exc})") from None


def decode_pcm(payload: object, rate: object, limits: WebConfig, what: str) -> np.ndarray:
    """Base64 little-endian int16 mono PCM at `limits.audio_rate` as samples (`what` names
    the audio in errors)."""
    if rate != limits.audio_rate:
        raise InvalidInputError(
            f"{what} must be {limits.audio_rate} Hz mono 16-bit PCM; got rate "
            f"{excerpt(rate)} (the page resamples with AudioContext({{sampleRate: "
            f"{limits.audio_rate}}}))"
        )
    if not isinstance(payload, str):
        raise InvalidInputError("'pcm' must be a base64 string of 16-bit samples")
    try:
        raw = base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError):
        raise InvalidInputError("'pcm' is not valid base64") from None
    if len(raw) % 2:
        raise InvalidInputError("'pcm' holds an odd number of bytes; samples are 16-bit")
    return np.frombuffer(raw, dtype="<i2").astype(np.int16)


def pcm_to_wav(payload: object, rate: object, limits: WebConfig) -> bytes:
    """Base64 little-endian int16 mono PCM at `limits.audio_rate` as WAV bytes."""
    samples = decode_pcm(payload, rate, limits, "push-to-talk audio")
    seconds = len(samples) / limits.audio_rate
    if seconds > limits.max_audio_seconds:
        raise InvalidInputError(
            f"recording is {seconds:.1f} s; push-to-talk takes at most "
            f"{limits.max_audio_seconds:.0f} s"
        )
    if seconds < 0.1:
        raise InvalidInputError("recording is shorter than 0.1 s; hold the button while talking")
    return to_wav_bytes(Audio(samples, limits.audio_rate))


def stream_piece(payload: object, rate: object, limits: WebConfig) -> np.ndarray:
    """A hands-free stream's next piece: base64 int16 PCM at `limits.audio_rate`, at most
    `limits.max_stream_piece_seconds` long, as samples."""
    samples = decode_pcm(payload, rate, limits, "hands-free audio")
    if not len(samples):
        raise InvalidInputError("'pcm' is empty; send the stream's next samples")
    seconds = len(samples) / limits.audio_rate
    if seconds > limits.max_stream_piece_seconds:
        raise InvalidInputError(
            f"a hands-free piece is {seconds:.2f} s; send at most "
            f"{limits.max_stream_piece_seconds:g} s at a time"
        )
    return samples


MAX_PLAYED = 16
"""The most sentences one hands-free piece may say began to play (the page marks each of the
robot's sentences once, in the piece after it starts)."""


def played_marks(played: object, rate: int, limits: WebConfig) -> list[tuple[str, int, int]]:
    """A hands-free piece's `played`: the robot's sentences the page began to play, each
    `{"text": utterance, "sentence": its index in it, "at": sample of this piece (at `rate`)
    where it began}`, as (text, sentence, at in `limits.audio_rate` samples)."""
    if played is None:
        return []
    if not isinstance(played, list) or len(played) > MAX_PLAYED:
        raise InvalidInputError(
            f"'played' must be a list of at most {MAX_PLAYED} "
            '{"text", "sentence", "at"} objects: the sentences begun since the last piece'
        )
    marks = []
    for mark in played:
        if not isinstance(mark, dict):
            raise InvalidInputError("each of 'played' must be an object {text, sentence, at}")
        text, sentence, at = mark.get("text"), mark.get("sentence"), mark.get("at")
        if not isinstance(text, str) or len(text) > limits.max_text_chars:
            raise InvalidInputError(
                f"'played' text must be the robot's utterance, at most {limits.max_text_chars} "
                "characters"
            )
        if not _is_int(sentence) or not 0 <= sentence < 1_000:
            raise InvalidInputError("'played' sentence must be its index in the utterance")
        # a sentence begins at most a few seconds after the piece that says so
        if not _is_int(at) or abs(at) > 60 * rate:
            raise InvalidInputError(
                "'played' at must be the sample of this piece where the sentence began, "
                "within a minute of it"
            )
        marks.append((text, int(sentence), round(at * limits.audio_rate / rate)))
    return marks


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


STREAM_PIECE_SECONDS = 0.1
"""How much of the hands-free stream the page sends at a time (told in Hello)."""
STREAM_PIECE_SECONDS_OVER_SPEECH = 0.05
"""The same while the robot's voice plays: a person talking over it waits for a piece to fill
before the listener hears them, and the cut comes that much later."""


def check_raw(text: str, limits: WebConfig) -> None:
    """InvalidInputError if a message is too long or nested too deep to parse; neither is
    parsed to find out."""
    if len(text) > limits.max_message_bytes:
        raise InvalidInputError(
            f"message is {len(text)} bytes; the limit is {limits.max_message_bytes}"
        )
    if json_depth(text, limits.max_json_depth) > limits.max_json_depth:
        raise InvalidInputError(
            f"message nests JSON more than {limits.max_json_depth} deep; the protocol's "
            "messages are flat objects"
        )


_JSON_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"')
_OPENS, _CLOSES = b"[{", b"]}"


def json_depth(text: str, limit: int) -> int:
    """How deep the JSON in `text` nests arrays and objects (exact when it is over `limit`;
    any value not over it when it is not), without parsing it: Python's parser recurses and
    fails on 100,000 levels."""
    if text.count("[") + text.count("{") <= limit:  # every message the page sends
        return 0
    skeleton = _JSON_STRING.sub("", text).encode("utf-8", "replace")  # brackets in strings
    codes = np.frombuffer(skeleton, np.uint8)
    steps = np.isin(codes, list(_OPENS)).astype(np.int32) - np.isin(codes, list(_CLOSES))
    return int(np.cumsum(steps).max(initial=0))


def excerpt(value: object, length: int = 40) -> str:
    """`repr(value)`, cut to about `length` characters: errors never echo a whole input."""
    text = repr(value)
    return text if len(text) <= length else f"{text[:length]}… ({len(text)} characters)"


class MessageRate:
    """A token bucket: `rate` messages a second on average, in bursts of up to `burst` (`rate`
    when not given)."""

    def __init__(
        self, rate: float, clock: Callable[[], float] = time.monotonic, burst: float | None = None
    ) -> None:
        self.rate, self.clock = rate, clock
        self.burst = rate if burst is None else burst
        self.tokens, self.last = self.burst, clock()

    def allow(self) -> bool:
        """Whether one more message may come now (and count it if so)."""
        now = self.clock()
        self.tokens = min(self.burst, self.tokens + (now - self.last) * self.rate)
        self.last = now
        if self.tokens < 1:
            return False
        self.tokens -= 1
        return True
