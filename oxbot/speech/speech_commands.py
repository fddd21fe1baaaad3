"""Speech Commands recordings (Warden 2018) from a fetched git repository: the dataset's split
rule, the manifests of the benchmark sets, and the training set of the keyword model.

Nothing here downloads anything. A repository holding the recordings is fetched beforehand as a
bare git directory; files are read from it at a fixed commit (`git cat-file --batch`, one
process for thousands of files). Which files the keyword model may learn from, and why, is
written in `oxbot/data/models/keywords.SOURCES.md`; `training_files` is that rule.
"""

from __future__ import annotations

import hashlib
import re
import subprocess
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from oxbot.errors import DataError

TRAINING_REPOSITORY = "MahmoudEhab3/Yes-No-Speech-Classifier"
TRAINING_COMMIT = "7c2aafb0c374397c27c25aa983817e7ce967858c"
TRAINING_FOLDER = "Speech/mini_speech_commands"
"""TensorFlow's mini_speech_commands excerpt of v0.01: 1,000 clips of each of eight words."""
WORDS = ("yes", "no", "down", "go", "left", "right", "stop", "up")
BENCH = Path(__file__).resolve().parents[2] / "bench" / "data"
HELD_OUT_MANIFEST = BENCH / "speech_commands" / "SOURCES.md"
DEV_MANIFEST = BENCH / "speech_commands_dev" / "SOURCES.md"
MAX_NUM_WAVS_PER_CLASS = 2**27 - 1
"""The dataset's README ("Partitioning"): the constant of its split rule."""


def split_of(speaker: str) -> str:
    """The dataset's split of a speaker's every file: SHA-1 of the speaker id (the file name's
    part before `_nohash_`) modulo 2^27, as a percentage of 2^27 - 1; below 10 validation,
    below 20 testing, else training (the README's `which_set`, validation 10%, testing 10%)."""
    digest = int(hashlib.sha1(speaker.encode("utf-8")).hexdigest(), 16)
    percentage = (digest % (MAX_NUM_WAVS_PER_CLASS + 1)) * (100.0 / MAX_NUM_WAVS_PER_CLASS)
    if percentage < 10:
        return "validation"
    if percentage < 20:
        return "testing"
    return "training"


def speaker_of(file_name: str) -> str:
    """`0a7c2a8d_nohash_0.wav` -> `0a7c2a8d`."""
    return Path(file_name).name.split("_nohash_")[0]


@dataclass(frozen=True)
class Entry:
    """One line of a benchmark set's manifest (its SOURCES.md table)."""

    word: str
    file: str
    speaker: str
    sha1: str
    source: str


def read_manifest(path: Path) -> list[Entry]:
    """The table of a SOURCES.md (`| word | file | speaker | split | SHA-1 | src |`)."""
    pattern = re.compile(
        r"^\|\s*(yes|no)\s*\|\s*(\S+\.wav)\s*\|\s*(\w+)\s*\|\s*\w+\s*\|"
        r"\s*([0-9a-f]{40})\s*\|\s*(\w)\s*\|"
    )
    entries = [
        Entry(*match.groups())
        for line in path.read_text(encoding="utf-8").splitlines()
        if (match := pattern.match(line))
    ]
    if not entries:
        raise DataError(f"{path} holds no manifest table")
    return entries


def excluded_speakers() -> set[str]:
    """Speakers whose recordings the keyword model never learns from: those of the held-out
    set (any word of theirs) and of the development set (so it stays a fair measure)."""
    return {e.speaker for path in (HELD_OUT_MANIFEST, DEV_MANIFEST) for e in read_manifest(path)}


def tree(git_dir: Path, commit: str, folder: str) -> list[tuple[str, str]]:
    """(path, blob id) of every file under `folder` at `commit`."""
    listing = _git(git_dir, "ls-tree", "-r", commit, "--", folder).decode()
    rows = []
    for line in listing.splitlines():
        meta, path = line.split("\t", 1)
        rows.append((path, meta.split()[2]))
    return rows


def training_files(git_dir: Path, commit: str = TRAINING_COMMIT) -> list[tuple[str, str]]:
    """(word, path) of every clip the keyword model learns from: the eight words' files at
    `commit`, except the dataset's TEST split (by speaker, `split_of`) and the held-out and
    development sets' speakers; sorted by path, so the selection is the same everywhere."""
    excluded = excluded_speakers()
    chosen = []
    for path, _ in tree(git_dir, commit, TRAINING_FOLDER):
        parts = path.split("/")
        if len(parts) != 4 or parts[2] not in WORDS or not parts[3].endswith(".wav"):
            continue
        speaker = speaker_of(parts[3])
        if split_of(speaker) == "testing" or speaker in excluded:
            continue
        chosen.append((parts[2], path))
    return sorted(chosen, key=lambda item: item[1])


def read_blobs(git_dir: Path, commit: str, paths: Iterable[str]) -> Iterator[bytes]:
    """The bytes of each `path` at `commit`, in order, through one `git cat-file --batch`."""
    paths = list(paths)
    request = "".join(f"{commit}:{path}\n" for path in paths).encode()
    out = _git(git_dir, "cat-file", "--batch", stdin=request)
    at = 0
    for path in paths:
        header_end = out.index(b"\n", at)
        header = out[at:header_end].split()
        if len(header) < 3 or header[1] != b"blob":
            raise DataError(f"{path} is not in {git_dir} at {commit}")
        size = int(header[2])
        yield out[header_end + 1 : header_end + 1 + size]
        at = header_end + 1 + size + 1


def restore(manifest: Path, sources: dict[str, tuple[Path, str, str]], into: Path) -> int:
    """Copy a benchmark set's files from the fetched repositories into `into/<word>/`, checking
    each SHA-1; `sources` maps the manifest's src letter to (git dir, commit, folder)."""
    entries = read_manifest(manifest)
    written = 0
    for letter, (git_dir, commit, folder) in sources.items():
        own = [e for e in entries if e.source == letter]
        blobs = read_blobs(git_dir, commit, [f"{folder}/{e.word}/{e.file}" for e in own])
        for entry, data in zip(own, blobs, strict=True):
            if hashlib.sha1(data).hexdigest() != entry.sha1:
                raise DataError(f"{entry.word}/{entry.file}: SHA-1 differs from the manifest")
            target = into / entry.word / entry.file
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
            written += 1
    if written != len(entries):
        raise DataError(f"restored {written} of the {len(entries)} files of {manifest}")
    return written


def _git(git_dir: Path, *args: str, stdin: bytes | None = None) -> bytes:
    result = subprocess.run(
        ["git", f"--git-dir={git_dir}", *args], input=stdin, capture_output=True, check=False
    )
    if result.returncode != 0:
        raise DataError(f"git {' '.join(args[:2])} in {git_dir}: {result.stderr.decode().strip()}")
    return result.stdout
