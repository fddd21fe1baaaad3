"""Restores the real non-speech clips (`bench/data/nonspeech/`) and background recordings
(`bench/data/background/`) from fetched git directories of the public repositories they come
from, converting each source exactly as its manifest says and checking every result's SHA-1.

    .venv/bin/python bench/restore_sounds.py \\
        /work/.mirror/deeplyinc+Nonverbal-Vocalization-Dataset/repo \\
        /work/.mirror/remvze+moodist/repo /work/.mirror/librosa+data/repo \\
        /work/.mirror/rafaelmardojai+blanket/repo /work/.mirror/IBM+MAX-Audio-Classifier/repo \\
        /work/.mirror/chaeyoung-lee+wids_tutorial/repo
    .venv/bin/python bench/restore_sounds.py --check   # only say what is there

Each argument is a git directory (a clone's `.git` or a bare mirror); it is matched to the
manifests' repository whose commit it holds, so the order does not matter and a repository not
given is skipped (and reported). Nothing is downloaded. The manifests (`manifest.csv` beside each
folder's SOURCES.md) give per file: the source repository, commit, path and git blob id, the part
(`dev` or `test`), the category, the licence, the source's format, the seconds cut, the conversion
and the SHA-1 of the converted WAV.

The conversion, the same for every file: decode the source (WAV with the standard library; MP3
with FFmpeg's fixed-point decoder, whose integer output is the same on every machine; Ogg Vorbis
with FFmpeg's float decoder through PyAV, its CPU-specific code switched off so that it runs the
plain C code); cut `start_s` to `start_s + duration_s` (the whole file when empty) at the
source's rate; mix to mono as the mean of the channels; resample to 16 kHz with
`scipy.signal.resample_poly` (up and down the reduced ratio, its default Kaiser window); round to
16-bit; write a 16 kHz mono 16-bit WAV. Each source is checked against its blob id before it is
decoded, each result against its SHA-1 before it is written (through a temporary file renamed
into place). A result that differs is not written unless `--keep-different`; Vorbis sources can
differ in the last bit of a few samples under another build of FFmpeg than PyAV 18.1.0's.
Exits 1 when anything given is missing or differs.
"""

from __future__ import annotations

import argparse
import ctypes
import hashlib
import io
import math
import subprocess
import sys
import wave
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path

import av
import numpy as np
from scipy.signal import resample_poly
from sound_sets import BACKGROUND, NONSPEECH, PARTS, Item, read_manifest

from oxbot.errors import DataError
from oxbot.speech.speech_commands import read_blobs

RATE = 16000
SETS = (NONSPEECH, BACKGROUND)


def decode(data: bytes, path: str) -> tuple[np.ndarray, int, str]:
    """The samples of a source file as float64 (channels, n) in [-1, 1), its rate and format."""
    suffix = Path(path).suffix.lower()
    if suffix == ".wav":
        with wave.open(io.BytesIO(data)) as reader:
            if reader.getsampwidth() != 2:
                raise ValueError(f"{path}: only 16-bit PCM WAV is read")
            channels, rate = reader.getnchannels(), reader.getframerate()
            pcm = np.frombuffer(reader.readframes(reader.getnframes()), dtype="<i2")
        samples = pcm.reshape(-1, channels).T / 32768.0
        return samples, rate, f"pcm_s16le {rate} Hz {channels} ch"
    if suffix == ".mp3":
        samples, rate = _decode_av(data, "mp3")
        return samples, rate, f"mp3 (fixed-point decoder) {rate} Hz {samples.shape[0]} ch"
    if suffix == ".ogg":
        samples, rate = _decode_av(data, None)
        return samples, rate, f"vorbis (plain C) {rate} Hz {samples.shape[0]} ch"
    raise ValueError(f"{path}: no decoder for {suffix}")


def convert(samples: np.ndarray, rate: int, start_s: str, duration_s: str) -> tuple[bytes, str]:
    """The 16 kHz mono 16-bit WAV of `samples` cut to `start_s` + `duration_s` (both empty: the
    whole), and the description of what was done that the manifest records."""
    total = samples.shape[1]
    start = round(float(start_s) * rate) if start_s else 0
    end = start + round(float(duration_s) * rate) if duration_s else total
    if not 0 <= start < end <= total:
        raise ValueError(f"cut {start_s}+{duration_s} s outside a {total / rate:.2f} s source")
    steps = [
        f"seconds {start / rate:.2f}-{end / rate:.2f} of {total / rate:.2f}"
        if (start, end) != (0, total)
        else f"whole {total / rate:.2f} s"
    ]
    mono = samples[:, start:end].mean(axis=0)
    if samples.shape[0] > 1:
        steps.append(f"mean of {samples.shape[0]} channels")
    if rate != RATE:
        divisor = math.gcd(RATE, rate)
        up, down = RATE // divisor, rate // divisor
        mono = resample_poly(mono, up, down)
        steps.append(f"resample_poly({up}, {down}) {rate} -> {RATE} Hz")
    pcm = np.clip(np.round(mono * 32768.0), -32768, 32767).astype("<i2")
    steps.append("rounded to 16 bit")
    out = io.BytesIO()
    with wave.open(out, "wb") as writer:
        writer.setnchannels(1)
        writer.setsampwidth(2)
        writer.setframerate(RATE)
        writer.writeframes(pcm.tobytes())
    return out.getvalue(), "; ".join(steps)


def git_blob_id(data: bytes) -> str:
    """The id git gives a file of these bytes (the SHA-1 of its blob object)."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def match_sources(git_dirs: list[Path], commits: dict[str, str]) -> dict[str, Path]:
    """Repository -> the given git directory that holds its manifest commit."""
    found: dict[str, Path] = {}
    for git_dir in git_dirs:
        held = [repo for repo, commit in commits.items() if _has_commit(git_dir, commit)]
        if not held:
            print(f"{git_dir}: holds none of the manifests' commits; ignored")
        for repo in held:
            found[repo] = git_dir
    return found


def restore(git_dirs: list[Path], keep_different: bool) -> int:
    """Recreate every file whose repository is given; 1 when any differs or is missing."""
    _plain_c_ffmpeg()
    manifests = {folder: read_manifest(folder) for folder in SETS}
    commits = {item.repository: item.commit for items in manifests.values() for item in items}
    sources = match_sources(git_dirs, commits)
    status = 0
    for repo in sorted(set(commits) - set(sources)):
        print(f"not given: {repo} @ {commits[repo][:12]} (its files are skipped)")
        status = 1
    for folder, items in manifests.items():
        tally: dict[str, int] = defaultdict(int)
        for item, wav in _convert_all([i for i in items if i.repository in sources], sources):
            if hashlib.sha1(wav).hexdigest() != item.sha1:
                print(f"{folder.name}/{item.file}: SHA-1 differs from the manifest")
                tally["differ"] += 1
                status = 1
                if not keep_different:
                    continue
            _write(folder / item.file, wav)
            tally["written"] += 1
        skipped = sum(1 for item in items if item.repository not in sources)
        print(
            f"{folder.name}: {tally['written']} written, {tally['differ']} differ, "
            f"{skipped} skipped, of {len(items)}"
        )
    return status


def check() -> int:
    """Say per set and part how many files are in place, differ or are missing; 1 unless all
    are in place."""
    status = 0
    for folder in SETS:
        items = read_manifest(folder)
        for part in PARTS:
            tally: dict[str, int] = defaultdict(int)
            needed: set[str] = set()
            for item in (i for i in items if i.part == part):
                path = folder / item.file
                if not path.is_file():
                    tally["missing"] += 1
                    needed.add(item.repository)
                elif hashlib.sha1(path.read_bytes()).hexdigest() != item.sha1:
                    tally["differ"] += 1
                else:
                    tally["in place"] += 1
            print(
                f"{folder.name}/{part}: {tally['in place']} in place, {tally['differ']} differ, "
                f"{tally['missing']} missing"
                + (f" (from {', '.join(sorted(needed))})" if needed else "")
            )
            status |= int(bool(tally["missing"] or tally["differ"]))
    return status


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("git_dirs", nargs="*", type=Path, help="fetched git directories")
    parser.add_argument("--check", action="store_true", help="only say what is in place")
    parser.add_argument(
        "--keep-different",
        action="store_true",
        help="write a converted file even when its SHA-1 differs from the manifest",
    )
    args = parser.parse_args()
    if args.check:
        sys.exit(check())
    if not args.git_dirs:
        parser.error("give the fetched git directories (see SOURCES.md), or --check")
    try:
        sys.exit(restore(args.git_dirs, args.keep_different))
    except DataError as missing:  # a path not in a fetched copy: a partial fetch, say
        sys.exit(f"{missing} (a partial copy?)")


def _convert_all(items: list[Item], sources: dict[str, Path]) -> Iterator[tuple[Item, bytes]]:
    """Each item with its converted WAV, decoding every source file once."""
    by_source: dict[tuple[str, str], list[Item]] = defaultdict(list)
    for item in items:
        by_source[(item.repository, item.path)].append(item)
    by_repo: dict[str, list[tuple[str, str]]] = defaultdict(list)
    for repo, path in by_source:
        by_repo[repo].append((repo, path))
    for repo, keys in by_repo.items():
        commit = by_source[keys[0]][0].commit
        blobs = read_blobs(sources[repo], commit, [path for _, path in keys])
        for key, data in zip(keys, blobs, strict=True):
            group, blob = by_source[key], git_blob_id(data)
            if blob != group[0].blob:
                raise SystemExit(
                    f"{repo}:{key[1]} is blob {blob}, the manifest says {group[0].blob}"
                )
            samples, rate, source_format = decode(data, key[1])
            for item in group:
                if source_format != item.source_format:
                    print(f"{item.file}: source decoded as {source_format!r}")
                wav, conversion = convert(samples, rate, item.start_s, item.duration_s)
                if conversion != item.conversion:
                    print(f"{item.file}: converted as {conversion!r}")
                yield item, wav


def _decode_av(data: bytes, codec: str | None) -> tuple[np.ndarray, int]:
    chunks = []
    with av.open(io.BytesIO(data)) as container:
        stream = container.streams.audio[0]
        decoder = av.CodecContext.create(codec, "r") if codec else stream.codec_context
        for packet in container.demux(stream):
            for frame in decoder.decode(packet):
                array = frame.to_ndarray()
                if not frame.format.is_planar:
                    array = array.reshape(-1, len(frame.layout.channels)).T
                scale = 32768.0 if array.dtype == np.int16 else 1.0
                chunks.append(array.astype(np.float64) / scale)
        rate = stream.rate
    return np.concatenate(chunks, axis=1), rate


def _plain_c_ffmpeg() -> None:
    """Switch off FFmpeg's CPU-specific code (SIMD), whose float results differ between CPUs."""
    maps = Path("/proc/self/maps")
    lines = maps.read_text().splitlines() if maps.exists() else []
    libraries = {line.split(maxsplit=5)[-1] for line in lines if "libavutil" in line}
    if not libraries:
        print("FFmpeg's libavutil not found: Vorbis sources may not match their SHA-1s")
    for library in libraries:
        ctypes.CDLL(library).av_force_cpu_flags(0)


def _has_commit(git_dir: Path, commit: str) -> bool:
    result = subprocess.run(
        ["git", f"--git-dir={git_dir}", "cat-file", "-e", f"{commit}^{{commit}}"],
        capture_output=True,
        check=False,
    )
    return result.returncode == 0


def _write(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_suffix(".part")
    temporary.write_bytes(data)
    temporary.replace(path)


if __name__ == "__main__":
    main()
