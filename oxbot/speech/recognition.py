"""Which speech recogniser the robot hears with: the one the config names, built once.

`speech.recognizer` names one of `RECOGNIZERS` or any `module:factory`, where
`factory(phrases, nbest)` builds an object with `recognize(wav) -> list[Hypothesis]`
(`oxbot.speech.nbest.Recognizer`). The default is Whisper tiny.en (`oxbot.speech.whisper`);
pocketsphinx (`oxbot.speech.sphinx`) is the fallback: when Whisper cannot load (its package or
weights missing, or not the pinned ones) the robot says so in one log line and hears with
pocketsphinx. `recognize(wav)` is the public one-call interface.
"""

from __future__ import annotations

import functools
import importlib
import logging
import os
from collections.abc import Callable
from typing import TYPE_CHECKING

from oxbot.config import SpeechConfig
from oxbot.errors import ConfigError, SpeechUnavailable
from oxbot.speech.nbest import Recognizer

if TYPE_CHECKING:
    from oxbot.dialogue.domain import Domain

log = logging.getLogger(__name__)

BUILT_IN = ("whisper", "pocketsphinx")
"""The recognisers `speech.recognizer` can name without a module path."""
FALLBACK = "pocketsphinx"
"""Heard with when Whisper cannot load."""


def user_phrases(domain: Domain) -> list[str]:
    """Everything the person may say in a domain (`Domain.user_phrases()`: the phrasings of
    every user act, chatter that is none, the user responses and the seed dialogues' USR
    lines), each once."""
    return sorted({text for text, _ in domain.user_phrases()})


def load_recognizer(config: SpeechConfig | None = None, domain: Domain | None = None) -> Recognizer:
    """The recogniser `config` names, built for the phrases of `domain` (default: shipped).

    The shipped domain's recogniser is built once per process and shared (building one takes a
    second or more; a recogniser serves one recording at a time, under its own lock)."""
    config = config if config is not None else SpeechConfig()
    if domain is None:
        return _shipped_recognizer(config)
    return _build(config, user_phrases(domain))


@functools.cache
def _shipped_recognizer(config: SpeechConfig) -> Recognizer:
    from oxbot.dialogue.domain import load_domain

    return _build(config, user_phrases(load_domain()))


def _build(config: SpeechConfig, phrases: list[str]) -> Recognizer:
    name = config.recognizer
    if name == "whisper":
        from oxbot.speech.whisper import make_whisper

        try:
            return make_whisper(phrases, config.nbest, config.whisper)
        except SpeechUnavailable as exc:
            log.warning("hearing with pocketsphinx instead of Whisper: %s", exc)
            name = FALLBACK
    return recognizer_factory(name)(phrases, nbest=config.nbest)


def recognizer_factory(name: str) -> Callable[..., Recognizer]:
    """The factory `speech.recognizer` names: one of `BUILT_IN`, or `module:factory`."""
    if name == "whisper":
        from oxbot.speech.whisper import make_whisper

        return make_whisper
    if name == "pocketsphinx":
        from oxbot.speech.sphinx import PocketsphinxRecognizer

        return PocketsphinxRecognizer
    module_name, _, attribute = name.partition(":")
    if not attribute:
        raise ConfigError(
            f"speech.recognizer is {name!r}; use {', '.join(BUILT_IN)} or module:factory"
        )
    try:
        return getattr(importlib.import_module(module_name), attribute)
    except (ImportError, AttributeError) as exc:
        raise ConfigError(f"speech.recognizer {name!r} cannot be imported: {exc}") from None


def shipped_recognizer(name: str) -> Recognizer:
    """The shipped domain's recogniser `name` (one of `BUILT_IN`) with the default settings,
    shared by every caller: what a test or a bench that measures one of them hears with."""
    return load_recognizer(SpeechConfig(recognizer=name))


def default_recognizer() -> Recognizer:
    """The recogniser for the shipped domain with the default config, shared by every caller."""
    return load_recognizer()


def recognize(wav: str | os.PathLike[str] | bytes) -> list[tuple[str, float]]:
    """A 16 kHz mono WAV (path or bytes) -> N-best list of (text, confidence)."""
    return [(h.text, h.confidence) for h in default_recognizer().recognize(wav)]
