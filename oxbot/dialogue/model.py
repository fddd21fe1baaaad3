"""The dialogue model: a domain and what is learned from it, built once per process.

The domain (the shipped one, or the folder `[dialogue] domain` names) gives, by its vocabulary,
the state's feature layout; its seed dialogues train the Naive Bayes action model. `new_state`
starts a dialogue read with both, and `template` picks the words the robot says an act with.
The environment and the interaction manager hold one each.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from oxbot.config import OxbotConfig
from oxbot.dialogue.action_model import ActionModel
from oxbot.dialogue.domain import SYSTEM_ACTS, Domain, load_domain
from oxbot.dialogue.features import FeatureLayout
from oxbot.dialogue.state import DialogueState
from oxbot.dialogue.understanding import UserActClassifier
from oxbot.errors import ConfigError


class DialogueModel:
    """A domain, its feature layout and its action model."""

    def __init__(self, domain: Domain, layout: FeatureLayout, action_model: ActionModel) -> None:
        self.domain = domain
        self.layout = layout
        self.action_model = action_model
        self._templates = {act: domain.templates_for(act) for act in SYSTEM_ACTS}
        self._understanding: UserActClassifier | None = None

    @property
    def understanding(self) -> UserActClassifier:
        """The domain's language understanding, trained at first use (a second)."""
        if self._understanding is None:
            self._understanding = UserActClassifier(self.domain)
        return self._understanding

    def new_state(self, robot_starts: bool) -> DialogueState:
        """A dialogue before its first act."""
        return DialogueState(self.layout, robot_starts, self.action_model)

    def template(self, act: str, rng: np.random.Generator, last: str = "") -> str:
        """One of the act's template texts, picked at random (the cell filled for a GameMove),
        never `last` (the robot's previous sentence) when the act has others."""
        texts = self._templates[act]
        if last in texts and len(texts) > 1:
            texts = tuple(t for t in texts if t != last)
        return texts[int(rng.integers(len(texts)))]


def build_dialogue_model(config: OxbotConfig, domain: Domain | None = None) -> DialogueModel:
    """The dialogue model of `domain`; when None, of the folder `config.dialogue.domain` names
    (the shipped one when empty), built once per process while its files stay unchanged."""
    d, r = config.dialogue, config.reward
    settings = (d.nb_alpha, d.nb_binarize, r.mask_threshold)
    if domain is not None:
        return _build(domain, *settings)
    if not d.domain:
        return _cached("", (), *settings)
    folder = Path(d.domain).expanduser().resolve()
    if not folder.is_dir():
        raise ConfigError(
            f"[dialogue] domain is {d.domain!r}, which is not a folder; give a folder with "
            "dialogues.txt, templates.txt and user_responses.txt (copy oxbot/data/dialogue)"
        )
    files = tuple(sorted((p.name, p.stat().st_mtime_ns) for p in folder.glob("*.txt")))
    return _cached(str(folder), files, *settings)


@functools.cache
def _cached(
    folder: str, files: tuple, alpha: float, binarize: float, threshold: float
) -> DialogueModel:
    # `files` (names and modification times) keys the cache: an edited domain is read again
    return _build(load_domain(folder or None), alpha, binarize, threshold)


def _build(domain: Domain, alpha: float, binarize: float, threshold: float) -> DialogueModel:
    layout = FeatureLayout(domain.vocabulary)
    action_model = ActionModel.from_domain(
        domain, layout, alpha=alpha, binarize=binarize, threshold=threshold
    )
    return DialogueModel(domain, layout, action_model)


def shipped_dialogue_model() -> DialogueModel:
    """The shipped domain's model with the default settings."""
    return build_dialogue_model(OxbotConfig())
