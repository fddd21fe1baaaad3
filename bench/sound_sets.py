"""The real non-speech clips and background recordings of `bench/data/` for the hearing benches:
their manifests, and the restored files a bench reads.

    from sound_sets import background, nonspeech_clips
    clips = nonspeech_clips("dev")  # [(path, category), ...]; "test" is never tuned on
    babble = background("test", "babble")

Both sets come from public repositories and are git-ignored; `bench/restore_sounds.py` recreates
them from fetched git directories, checking every file against the SHA-1 of its manifest
(`bench/data/nonspeech/manifest.csv`, `bench/data/background/manifest.csv`, described in each
folder's SOURCES.md). A part is split from the other by source recording: no recording gives
clips to both. Not a bench: run on its own it does nothing.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

DATA = Path(__file__).resolve().parent / "data"
NONSPEECH = DATA / "nonspeech"
BACKGROUND = DATA / "background"
PARTS = ("dev", "test")
RESTORE = ".venv/bin/python bench/restore_sounds.py <git dir> ..."


@dataclass(frozen=True)
class Item:
    """One row of a set's manifest: a converted file and where it came from."""

    part: str
    file: str
    category: str
    repository: str
    commit: str
    path: str
    blob: str
    licence: str
    source_format: str
    start_s: str
    duration_s: str
    conversion: str
    sha1: str


def read_manifest(folder: Path) -> list[Item]:
    """The rows of `folder/manifest.csv`, in order."""
    with (folder / "manifest.csv").open(newline="", encoding="utf-8") as handle:
        return [Item(**row) for row in csv.DictReader(handle)]


def nonspeech_clips(part: str) -> list[tuple[Path, str]]:
    """(path, category) of every non-speech clip of `part` ("dev" or "test"): 1-5 s, 16 kHz mono
    16-bit WAVs of sounds that must never be taken for an answer (coughs, music, rain, ...).
    Stops with what to run when any is missing."""
    items = _part(NONSPEECH, part)
    return [(NONSPEECH / item.file, item.category) for item in items]


def background(part: str, category: str | None = None) -> list[Path]:
    """Paths of the continuous background recordings of `part` ("dev" or "test"), 16 kHz mono
    16-bit WAVs for mixing under speech; only those of `category` ("babble", "street", ...) when
    given. Stops with what to run when any is missing."""
    items = _part(BACKGROUND, part)
    if category is not None:
        items = [item for item in items if item.category == category]
        if not items:
            known = sorted({item.category for item in read_manifest(BACKGROUND)})
            raise SystemExit(f"no background category {category!r}; there are {known}")
    return [BACKGROUND / item.file for item in items]


def _part(folder: Path, part: str) -> list[Item]:
    if part not in PARTS:
        raise SystemExit(f"part must be one of {PARTS}, not {part!r}")
    items = [item for item in read_manifest(folder) if item.part == part]
    missing = [item.file for item in items if not (folder / item.file).is_file()]
    if missing:
        raise SystemExit(
            f"{len(missing)} of the {len(items)} files of {folder.name}/{part} are missing "
            f"(first: {missing[0]}); restore them with {RESTORE} "
            f"(bench/data/{folder.name}/SOURCES.md says which repositories to fetch)"
        )
    return items
