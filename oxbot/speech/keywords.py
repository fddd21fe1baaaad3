"""A second opinion on short answers: a small keyword classifier (yes / no / other) on log-mel
features, learned from real people's recordings.

pocketsphinx's best hypothesis hears a single spoken "yes" or "no" of a person it never met
right about 9 times in 10 (Speech Commands development set, docs/robot.md), and the words it
confuses are exactly the two that matter. A classifier that knows nothing but those two words
and "something else" is small enough to train in a minute and hears them much better.
`second_opinion` joins its probabilities with the recogniser's N-best list (see there); the
recogniser asks it only about short utterances (`MAX_SPEECH_SECONDS`).

Features: the recording as the recogniser hears it (level normalised, silence trimmed, the
noise floor added), a one-second window centred on the sound, 40 log-mel bands every 20 ms
(numpy only). Model: three 3x3 convolutions, global average pooling, three outputs (about 23,000
weights). Training data: Speech Commands v0.01 (Warden 2018) and the domain's own phrases
spoken by espeak-ng (short phrases are "other"), the rule and counts in
`oxbot/data/models/keywords.SOURCES.md`; augmented with time shifts, quiet microphones, silence
before the word and white noise.

    spotter = shipped_keyword_spotter()
    spotter.probabilities(samples)      # [P(yes), P(no), P(other)], or None when not short
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from oxbot import artifacts
from oxbot.errors import DataError, ModelFileError
from oxbot.speech.audio import RATE, add_noise, normalise_level, pcm16, trim_silence

# one thread: on two busy cores a training step took 900 ms with two threads, 75 ms with one
from oxbot.torch_threads import one_thread

if TYPE_CHECKING:
    import torch

    from oxbot.dialogue.domain import Domain
    from oxbot.speech.nbest import Hypothesis

log = logging.getLogger(__name__)

LABELS = ("yes", "no", "other")
MAX_SPEECH_SECONDS = 1.25
"""The keyword model gives an opinion only when the sound lasts at most this long: it was
trained on one-second clips of single words, and longer answers are the recogniser's. A little
over one second: after silence of exact zeros, a clip's own faint background counts as sound
(`oxbot.speech.audio.speech_span`), and the whole one-second clip is then the sound."""
WINDOW = RATE
"""The model hears one second, centred on the sound."""
MARGIN = 0.2
"""Seconds kept either side of the sound (the recogniser's own trim)."""
N_FFT, FRAME, HOP, N_MELS = 512, 480, 320, 40
"""30 ms frames every 20 ms, as small keyword spotters use (Zhang et al. 2017, "Hello Edge"):
half the work of the recogniser's 10 ms."""
KIND, VERSION = "keywords", 1
SURE = 0.7
"""The keyword model overrules the recogniser only when its probability of yes (or no) reaches
this; chosen on the development set (docs/robot.md, "A second opinion on yes and no")."""
AGREE = 0.3
"""The keyword model agrees with the recogniser's yes (or no) when it gives that word at least
this probability; chosen on the development set."""
DOUBT = 0.1
"""When the recogniser heard a yes (or a no) and the keyword model gives the opposite word at
least this probability, the answer is Unknown: the robot asks again rather than guess."""


@dataclass(frozen=True)
class KeywordConfig:
    """How the keyword model is trained (`oxbot train keywords`)."""

    seed: int = 0
    """oxbot: seed of the weights, the order of the clips and every augmentation."""
    epochs: int = 50
    """oxbot: passes, each over `per_class` clips of every label."""
    per_class: int = 400
    """oxbot: clips of each label per epoch (drawn again every epoch, each augmented anew), so
    the 294 yes and 278 no clips weigh as much as the 6,029 others."""
    batch_size: int = 64
    learning_rate: float = 3e-3
    """oxbot: Adam's step size, falling linearly to 0."""
    noise_probability: float = 0.6
    """oxbot: share of clips with white noise added, at 3-30 dB SNR (the bench goes to 10)."""
    lead_probability: float = 0.3
    """oxbot: share of clips with 0.3-1.5 s of silence (zeros or a noise floor) before them."""
    quiet_probability: float = 0.3
    """oxbot: share of clips recorded quietly (peak at -45 to -20 dBFS, then brought up)."""
    silence_share: float = 0.1
    """oxbot: share of "other" clips that are noise or near-silence, no word at all."""


# --- features ---------------------------------------------------------------------------------


def short_window(samples: np.ndarray) -> np.ndarray | None:
    """The one second the model hears of a recording (int16 at 16 kHz): level normalised,
    silence trimmed, centred on the sound, zero-padded, the recogniser's noise floor added; None
    when the sound lasts longer than `MAX_SPEECH_SECONDS` or there is none."""
    from oxbot.speech.audio import with_noise_floor

    trimmed = trim_silence(normalise_level(np.asarray(samples, dtype=np.int16)), MARGIN)
    if trimmed is None or len(trimmed) - 2 * MARGIN * RATE > MAX_SPEECH_SECONDS * RATE:
        return None
    centre = len(trimmed) // 2
    start = centre - WINDOW // 2
    window = np.zeros(WINDOW, np.int16)
    lo, hi = max(0, start), min(len(trimmed), start + WINDOW)
    window[lo - start : hi - start] = trimmed[lo:hi]
    return with_noise_floor(window)


@functools.cache
def _mel_filters() -> np.ndarray:
    def mel(f: np.ndarray) -> np.ndarray:
        return 2595.0 * np.log10(1.0 + f / 700.0)

    edges = 700.0 * (
        10 ** (np.linspace(mel(np.array(20.0)), mel(np.array(7600.0)), N_MELS + 2) / 2595.0) - 1.0
    )
    bins = np.fft.rfftfreq(N_FFT, 1.0 / RATE)
    filters = np.zeros((N_MELS, len(bins)), np.float32)
    for m in range(N_MELS):
        low, centre, high = edges[m], edges[m + 1], edges[m + 2]
        rising = (bins - low) / (centre - low)
        falling = (high - bins) / (high - centre)
        filters[m] = np.maximum(0.0, np.minimum(rising, falling))
    return filters


def log_mel(window: np.ndarray) -> np.ndarray:
    """40 log-mel energies every 20 ms (30 ms Hann frames) of a one-second window: (40, 49)."""
    x = window.astype(np.float32) / 32768.0
    frame = FRAME
    starts = np.arange(0, len(x) - frame + 1, HOP)
    frames = x[starts[:, None] + np.arange(frame)[None, :]] * np.hanning(frame).astype(np.float32)
    power = np.abs(np.fft.rfft(frames, N_FFT, axis=1)) ** 2
    energies = np.log(power @ _mel_filters().T + 1e-6).T
    # Each window standardised on its own: a quiet microphone or a noisy room moves and
    # squeezes the whole picture, not the shape of the word.
    return ((energies - energies.mean()) / (energies.std() + 1e-6)).astype(np.float32)


# --- the model --------------------------------------------------------------------------------


def build_network() -> torch.nn.Module:
    """Three 3x3 convolutions (16, 32, 64 channels) with batch norm and pooling, global average
    pooling, a linear layer to the three labels."""
    from torch import nn

    def block(n_in: int, n_out: int) -> list[nn.Module]:
        return [
            nn.Conv2d(n_in, n_out, 3, padding=1),
            nn.BatchNorm2d(n_out),
            nn.ReLU(),
            nn.MaxPool2d(2),
        ]

    return nn.Sequential(
        *block(1, 16),
        *block(16, 32),
        *block(32, 64),
        nn.AdaptiveAvgPool2d(1),
        nn.Flatten(),
        nn.Dropout(0.2),
        nn.Linear(64, len(LABELS)),
    )


class KeywordSpotter:
    """The trained keyword model: a recording -> [P(yes), P(no), P(other)]."""

    def __init__(
        self,
        network: torch.nn.Module,
        mean: float,
        std: float,
        metadata: dict[str, Any] | None = None,
    ) -> None:
        self.network = network.eval()
        self.mean, self.std = mean, std
        self.metadata = metadata or {}

    def probabilities(self, samples: np.ndarray) -> np.ndarray | None:
        """P(yes), P(no), P(other) for int16 samples at 16 kHz; None when the sound is longer
        than `MAX_SPEECH_SECONDS` (not a one-word answer) or absent."""
        window = short_window(samples)
        return None if window is None else self.classify([window])[0]

    def classify(self, windows: Sequence[np.ndarray]) -> np.ndarray:
        """Probabilities (n, 3) for one-second windows (`short_window`)."""
        import torch

        features = np.stack([log_mel(w) for w in windows])[:, None]
        with one_thread(), torch.no_grad():
            logits = self.network(torch.from_numpy((features - self.mean) / self.std))
        return torch.softmax(logits, dim=1).numpy().astype(np.float64)

    def save(self, path: str | Path) -> Path:
        payload = {
            "state": {k: v.clone() for k, v in self.network.state_dict().items()},
            "mean": self.mean,
            "std": self.std,
            "metadata": self.metadata,
        }
        return artifacts.save(path, KIND, VERSION, payload)

    @classmethod
    def load(cls, path: str | Path) -> KeywordSpotter:
        remedy = "retrain it with `oxbot train keywords`"
        payload = artifacts.load(path, KIND, VERSION, "keyword model", remedy)
        with artifacts.checked(path, "keyword model", remedy):
            network = build_network()
            network.load_state_dict(payload["state"])
            return cls(
                network, float(payload["mean"]), float(payload["std"]), dict(payload["metadata"])
            )


def shipped_keyword_path() -> Path:
    """The keyword model shipped with oxbot."""
    return Path(str(importlib.resources.files("oxbot") / "data" / "models" / "keywords.pt"))


@functools.cache
def shipped_keyword_spotter() -> KeywordSpotter | None:
    """The shipped keyword model, loaded once per process; None (with a warning) when it is
    missing or unreadable, and the recogniser then hears alone."""
    try:
        return KeywordSpotter.load(shipped_keyword_path())
    except (ModelFileError, ImportError) as exc:
        log.warning("the keyword model is off, the recogniser hears short answers alone: %s", exc)
        return None


# --- joining it with the recogniser -----------------------------------------------------------


def second_opinion(
    hypotheses: list[Hypothesis],
    probabilities: np.ndarray | Sequence[float] | None,
    sure: float = SURE,
    agree: float = AGREE,
    doubt: float = DOUBT,
    rescue: bool = True,
) -> list[Hypothesis]:
    """The N-best list with the keyword model's opinion of a short answer joined in.

    What the recogniser's best hypothesis says (`oxbot.dialogue.understanding.polarity`: yes,
    no or neither) against the keyword model's P(yes) and P(no):

    1. The recogniser says yes (or no) and the keyword model gives the opposite word at least
       `doubt`: they disagree; every confidence becomes 0, so the answer is Unknown and the
       robot asks again. A flip costs more than a question.
    2. Both say the same word (the keyword model with at least `agree`): the recogniser's words
       stay ("no thanks" remains "no thanks") and the best one's confidence becomes that of two
       independent listeners agreeing, 1 - (1 - c)(1 - p).
    3. With `rescue`, `keyword_rescue`: the recogniser heard neither and the keyword model is
       sure of one. The recogniser leaves this step out (it does not know what the robot
       asked); the robot takes it only for the answer to a yes/no question
       (`oxbot.dialogue.understanding.YES_NO_QUESTIONS`), where a "hi" is a mumbled "no", not
       a greeting.
    4. Otherwise the recogniser's list stays as it is.
    """
    from oxbot.dialogue.understanding import polarity

    if probabilities is None or len(probabilities) == 0 or not hypotheses:
        return hypotheses
    p = dict(zip(LABELS, (float(v) for v in probabilities), strict=True))
    heard = polarity(hypotheses[0].text)
    if heard is not None:
        opposite = "no" if heard == "yes" else "yes"
        if p[opposite] >= doubt:
            return [dataclasses.replace(h, confidence=0.0) for h in hypotheses]
        if p[heard] >= agree:
            best = hypotheses[0]
            both = 1.0 - (1.0 - best.confidence) * (1.0 - p[heard])
            return [dataclasses.replace(best, confidence=both), *hypotheses[1:]]
        return hypotheses
    return keyword_rescue(hypotheses, probabilities, sure) if rescue else hypotheses


def answer_to(
    asked: str, hypotheses: list[Hypothesis], probabilities: np.ndarray | Sequence[float] | None
) -> list[Hypothesis]:
    """`hypotheses` as the robot reads them after its act `asked`: with `keyword_rescue` when
    `asked` is a yes/no question (`oxbot.dialogue.understanding.YES_NO_QUESTIONS`) and the
    keyword model was asked, as they are otherwise."""
    from oxbot.dialogue.understanding import YES_NO_QUESTIONS

    if probabilities is None or asked not in YES_NO_QUESTIONS:
        return hypotheses
    return keyword_rescue(hypotheses, probabilities)


def keyword_rescue(
    hypotheses: list[Hypothesis], probabilities: np.ndarray | Sequence[float], sure: float = SURE
) -> list[Hypothesis]:
    """Step 3 of `second_opinion`: when the recogniser's best words say neither yes nor no ("hi"
    for a mumbled "no"), none of its hypotheses says the opposite and the keyword model is
    `sure` of yes (or no), the list becomes that word alone, with its probability; otherwise
    `hypotheses` unchanged. (The keyword model knows single words; espeak-ng's Scottish "no
    thanks" at 20 dB was "yes" to it at 0.89, heard by the recogniser as "go on" above "nope
    not me".)"""
    from oxbot.dialogue.understanding import polarity
    from oxbot.speech.nbest import Hypothesis

    if len(probabilities) == 0 or not hypotheses or polarity(hypotheses[0].text) is not None:
        return hypotheses
    p = dict(zip(LABELS, (float(v) for v in probabilities), strict=True))
    said = {polarity(h.text) for h in hypotheses}
    for word in ("yes", "no"):
        if p[word] >= sure and ("no" if word == "yes" else "yes") not in said:
            return [Hypothesis(word, p[word], ((word, p[word]),))]
    return hypotheses


# --- training ---------------------------------------------------------------------------------


@dataclass
class KeywordData:
    """Labelled one-second clips (int16 at 16 kHz), the raw material of training."""

    clips: np.ndarray
    """(n, 16000) int16."""
    labels: np.ndarray
    """(n,) indices into LABELS."""
    rule: str = ""
    """How the clips were chosen (recorded in the model's metadata)."""

    def __add__(self, other: KeywordData) -> KeywordData:
        return KeywordData(
            np.concatenate([self.clips, other.clips]),
            np.concatenate([self.labels, other.labels]),
            f"{self.rule}; {other.rule}",
        )


def load_training_data(git_dir: Path) -> KeywordData:
    """The training clips from a fetched mini_speech_commands repository
    (`oxbot.speech.speech_commands.training_files`): yes, no, and the six other words."""
    from oxbot.speech import speech_commands as sc

    files = sc.training_files(git_dir)
    if not files:
        raise DataError(f"no training clips found in {git_dir} at {sc.TRAINING_COMMIT}")
    clips = np.zeros((len(files), WINDOW), np.int16)
    for i, data in enumerate(sc.read_blobs(git_dir, sc.TRAINING_COMMIT, [p for _, p in files])):
        samples = pcm16(data)[:WINDOW]
        clips[i, : len(samples)] = samples
    labels = np.array([LABELS.index(w) if w in ("yes", "no") else 2 for w, _ in files])
    rule = (
        f"{sc.TRAINING_REPOSITORY}@{sc.TRAINING_COMMIT}:{sc.TRAINING_FOLDER}/<word>/, words "
        f"{', '.join(sc.WORDS)}; every clip except the dataset's TEST split (speaker rule) and "
        "the speakers of bench/data/speech_commands and bench/data/speech_commands_dev"
    )
    return KeywordData(clips, labels, rule)


SPOKEN_VOICES = ("en-gb", "en+f3", "en-gb+f4", "en-gb-scotland", "en+f2", "en-gb-x-rp")
"""espeak-ng voices the model hears the domain's phrases in: the half of the tuning voices the
recogniser's constants are checked on (`oxbot.speech.evaluation.CHECK_VOICES`), none held out."""


def spoken_clips(domain: Domain, voices: Sequence[str] = SPOKEN_VOICES) -> KeywordData:
    """The domain's own phrases in espeak-ng voices, as the model must hear them: "yes" and "no"
    alone as yes and no, at three speeds; every phrase of several words ("no thanks", "yes
    please") and every single word that says neither as "other": the model knows single words,
    and a short phrase that merely starts with one must not look like it to it."""
    from oxbot.dialogue.understanding import polarity
    from oxbot.speech.synthesis import Voice, synthesize

    phrases = sorted({text for text, _ in domain.user_phrases()})
    others = [p for p in phrases if " " in p or (p not in ("yes", "no") and polarity(p) is None)]
    clips, labels = [], []
    for voice in voices:
        for word, label in (("yes", 0), ("no", 1)):
            for speed in (130, 160, 200):
                clips.append(synthesize(word, Voice(voice, speed)))
                labels.append(label)
        for phrase in others:
            clips.append(synthesize(phrase, Voice(voice)))
            labels.append(2)
    kept, kept_labels = [], []
    for wav, label in zip(clips, labels, strict=True):
        window = short_window(pcm16(wav))
        if window is not None:  # longer phrases never reach the model
            kept.append(window)
            kept_labels.append(label)
    rule = f"espeak-ng, voices {', '.join(voices)}: yes/no at 130, 160, 200 wpm; other phrases"
    return KeywordData(np.stack(kept), np.array(kept_labels), rule)


def augment(clip: np.ndarray, rng: np.random.Generator, config: KeywordConfig) -> np.ndarray:
    """A training clip as a microphone might deliver it: shifted, quiet, after silence, noisy."""
    x = np.roll(clip, int(rng.integers(-1600, 1601))).astype(np.float64)
    if rng.random() < config.quiet_probability and np.abs(x).max() > 0:
        x *= 32767 * 10 ** (rng.uniform(-45, -20) / 20) / np.abs(x).max()
        x = np.round(x)  # a quiet microphone's coarse steps
    if rng.random() < config.lead_probability:
        x = np.concatenate([np.zeros(int(rng.uniform(0.3, 1.5) * RATE)), x])
        x += rng.normal(0.0, rng.choice([0.0, 16.0, 64.0]), len(x))
    out = np.clip(np.round(x), -32768, 32767).astype(np.int16)
    if rng.random() < config.noise_probability:
        out = add_noise(out, rng.uniform(3.0, 30.0), rng)
    return out


def no_word(rng: np.random.Generator) -> np.ndarray:
    """A clip of "other" with no word: white noise or a hum, at any level."""
    t = np.arange(WINDOW) / RATE
    if rng.random() < 0.5:
        x = rng.normal(0.0, 10 ** rng.uniform(1, 3.5), WINDOW)
    else:
        x = 10 ** rng.uniform(2, 4) * np.sin(2 * np.pi * rng.uniform(50, 400) * t)
        x += rng.normal(0.0, 30.0, WINDOW)
    return np.clip(np.round(x), -32768, 32767).astype(np.int16)


def example(clip: np.ndarray, rng: np.random.Generator, config: KeywordConfig) -> np.ndarray:
    """The features of one augmented clip, as the recogniser would hand it over."""
    window = short_window(augment(clip, rng, config))
    if window is None:  # trimmed to something long by noise: the model hears the middle
        window = np.asarray(clip, np.int16)
    return log_mel(window)


def train_keywords(
    data: KeywordData,
    config: KeywordConfig | None = None,
    out: str | Path | None = None,
    show_progress: bool = True,
) -> KeywordSpotter:
    """Train the keyword model on `data` and save it to `out` with its config, seed, data rule
    and training figures. The same seed gives the same model (deterministic torch on CPU)."""
    import torch

    config = config or KeywordConfig()
    started, cpu_started = time.perf_counter(), time.process_time()
    torch.manual_seed(config.seed)
    was_deterministic = torch.are_deterministic_algorithms_enabled()
    torch.use_deterministic_algorithms(True)
    try:
        network, mean, std, history = _fit(data, config, show_progress)
    finally:
        torch.use_deterministic_algorithms(was_deterministic)
    metadata = {
        "config": dataclasses.asdict(config),
        "seed": config.seed,
        "data_rule": data.rule,
        "clips": {label: int((data.labels == k).sum()) for k, label in enumerate(LABELS)},
        "loss_per_epoch": history,
        "train_seconds": round(time.perf_counter() - started, 1),
        "train_cpu_seconds": round(time.process_time() - cpu_started, 1),
        "torch": str(torch.__version__),
    }
    spotter = KeywordSpotter(network, mean, std, metadata)
    if out is not None:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        spotter.save(out)
    return spotter


def _fit(
    data: KeywordData, config: KeywordConfig, show_progress: bool
) -> tuple[torch.nn.Module, float, float, list[float]]:
    """The training loop: fresh augmented clips every epoch, then shuffled mini-batches."""
    import torch
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    rng = np.random.default_rng(config.seed)
    network = build_network()
    optimiser = torch.optim.Adam(network.parameters(), lr=config.learning_rate)
    steps = config.epochs * -(-3 * config.per_class // config.batch_size)
    schedule = torch.optim.lr_scheduler.LambdaLR(optimiser, lambda s: 1.0 - s / steps)
    by_label = [np.flatnonzero(data.labels == k) for k in range(len(LABELS))]
    mean = std = 0.0
    history = []
    columns = (TextColumn("keywords"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with one_thread(), Progress(*columns, disable=not show_progress) as progress:
        task = progress.add_task("epochs", total=config.epochs)
        for epoch in range(config.epochs):
            # Collect: per_class augmented clips of each label, "other" partly without a word.
            features, labels = [], []
            for k, pool in enumerate(by_label):
                for i in rng.choice(pool, config.per_class, replace=len(pool) < config.per_class):
                    no_speech = k == 2 and rng.random() < config.silence_share
                    clip = no_word(rng) if no_speech else data.clips[i]
                    features.append(example(clip, rng, config))
                    labels.append(k)
            x = np.stack(features)[:, None]
            if epoch == 0:  # the input scale, fixed from the first epoch's features
                mean, std = float(x.mean()), float(x.std())
            x_t = torch.from_numpy((x - mean) / std)
            y_t = torch.tensor(labels)
            # Learn: shuffled mini-batches, cross-entropy, the step size falling to 0.
            network.train()
            order = torch.from_numpy(rng.permutation(len(y_t)))
            total = 0.0
            for batch in order.split(config.batch_size):
                loss = torch.nn.functional.cross_entropy(network(x_t[batch]), y_t[batch])
                optimiser.zero_grad()
                loss.backward()
                optimiser.step()
                schedule.step()
                total += loss.item() * len(batch)
            history.append(round(total / len(y_t), 4))
            progress.advance(task)
    return network.eval(), mean, std, history
