"""Restores the git-ignored sources of `bench/bench_composite.py` (and the real board photos of
`bench/bench_real_boards.py`) from local copies of the public repositories they come from.

    PYTHONPATH=. .venv/bin/python bench/restore_composite.py \\
        --exupery /work/.mirror/borismus+exupery/repo \\
        --unipen /work/.mirror/GreenCappuccino+train_r01_v07/repo \\
        --air-drawer bench/data/composite_boards/sources/index/Nitins2005+air-drawer \\
        --paper-repo moritzgauss/strassstein=/work/.mirror/moritzgauss+strassstein/repo \\
        --paper-repo marcomusy/vedo=/work/.mirror/marcomusy+vedo/repo \\
        --paper-repo mzucker/noteshrink=/work/.mirror/mzucker+noteshrink/repo \\
        --paper-repo acharneski/ImageLabs=/work/.mirror/acharneski+ImageLabs/repo/.git \\
        --paper-repo JohnTigue/whiteboarder=/work/.mirror/JohnTigue+whiteboarder/repo \\
        --paper-repo mypaint/mypaint=/work/.mirror/mypaint+mypaint/repo \\
        --paper-repo RobotLocomotion/models=/work/.mirror/RobotLocomotion+models/repo \\
        --paper-repo Breta01/handwriting-ocr=/work/.mirror/Breta01+handwriting-ocr/repo \\
        --paper-repo mzucker/page_dewarp=/work/.mirror/mzucker+page_dewarp/repo \\
        --paper-repo clovaai/donut=/work/.mirror/clovaai+donut/repo \\
        --paper-repo sparkfish/augraphy=/work/.mirror/sparkfish+augraphy/repo \\
        --real-boards /work/.mirror/kvuletic2+tic-tac-toe_opencv/repo
    PYTHONPATH=. .venv/bin/python bench/restore_composite.py --check   # only say what is there

Every source is a git directory (a clone's `.git`, or a bare mirror) holding the commit that
`bench/data/composite_boards/SOURCES.md` and `handwriting_manifest.csv` name; nothing is
downloaded. The one exception is `--air-drawer`, `Nitins2005/air-drawer` @ `6eb5b75987a8`, which
may also be a folder holding `data/circle.ndjson` and `data/line.ndjson` (or the two files
directly) as far as they could be read (characters 16,000-32,000 of each are enough; records cut
at either end are skipped).

Writes, each through a temporary file renamed into place:

- `bench/data/composite_boards/sources/handwriting/{circle,cross,line}.json`: for each class the
  manifest's drawings in its order, a drawing a list of pen-down strokes, a stroke a list of
  [x, y] in the source's own units. Quick, Draw! items are found by `key_id` (exupery holds the
  raw format, strokes [[xs], [ys], [ts]]; air-drawer the simplified one, [[xs], [ys]]). UNIPEN
  items are `segment N` of a `data/1b` or `data/1c` file: its N-th `.SEGMENT` line (from 0),
  whose delineation numbers the components of the files it `.INCLUDE`s (from `include/`), a
  component being a `.PEN_DOWN` or `.PEN_UP` with at least one point; the segment's pen-down
  components are its strokes. A class's file is written only when every one of its items was
  found, so that indices keep matching the manifest's.
- `bench/data/composite_boards/sources/paper/<file>`: the 31 rows of `paper_regions.csv` (27
  photos) copied unchanged, each checked against the SHA-1 prefix SOURCES.md records.
- `bench/data/real_boards/images/kvuletic2_image<i>.jpeg` (`--real-boards`), checked against
  the full SHA-1s of `bench/data/real_boards/SOURCES.md`.

Checks and reports: a commit or file not in a git directory, a manifest item not found, a paper
copy whose SHA-1 does not match, the number of drawings per class against the manifest, and
items that do not meet SOURCES.md's criteria (a Quick, Draw! drawing not `recognized`, a line
not one straight stroke, a UNIPEN "O" not 1 or 2 strokes, an "X" or "x" not 2). Exits 1 when
anything is missing or wrong; what could be restored is restored all the same.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import itertools
import json
import math
import re
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path

from oxbot.atomic import atomic_write, write_text_atomic

ROOT = Path(__file__).resolve().parent
COMPOSITE = ROOT / "data" / "composite_boards"
MANIFEST = COMPOSITE / "handwriting_manifest.csv"
REGIONS = COMPOSITE / "paper_regions.csv"
HANDS = COMPOSITE / "sources" / "handwriting"
PAPERS = COMPOSITE / "sources" / "paper"
REAL_IMAGES = ROOT / "data" / "real_boards" / "images"

EXUPERY = "borismus/exupery"
AIR_DRAWER = "Nitins2005/air-drawer"
UNIPEN = "GreenCappuccino/train_r01_v07"

# file here: (repository, commit, path there, SHA-1 prefix), as SOURCES.md records them.
PAPER = {
    "plain_ambientcg-paper001_1.jpg": (
        "moritzgauss/strassstein",
        "d5b0b4ee4837",
        "Paper001_1K-JPG/Paper001_1K-JPG_Color.jpg",
        "20bdb6a7",
    ),
    "plain_vedo-pxhere_1.jpg": (
        "marcomusy/vedo",
        "904d1d2dcaa5",
        "vedo/textures/paper1.jpg",
        "35cbdd29",
    ),
    "plain_vedo-pxhere_2.jpg": (
        "marcomusy/vedo",
        "904d1d2dcaa5",
        "vedo/textures/paper2.jpg",
        "6c0e622e",
    ),
    "plain_vedo-pxhere_3.jpg": (
        "marcomusy/vedo",
        "904d1d2dcaa5",
        "vedo/textures/paper3.jpg",
        "1b5089bd",
    ),
    "squared_noteshrink_1.jpg": (
        "mzucker/noteshrink",
        "7d876e5b4392",
        "examples/graph-paper-front.jpg",
        "c674b031",
    ),
    "squared_noteshrink_2.jpg": (
        "mzucker/noteshrink",
        "7d876e5b4392",
        "examples/graph-paper-pencil-only.jpg",
        "0844123e",
    ),
    "ruled_noteshrink_1.jpg": (
        "mzucker/noteshrink",
        "7d876e5b4392",
        "examples/tree.jpg",
        "fa9349ba",
    ),
    "whiteboard_imagelabs_1.jpg": (
        "acharneski/ImageLabs",
        "68b0cdf05e82",
        "src/test/resources/Whiteboard1.jpg",
        "2d3f5bd0",
    ),
    "whiteboard_whiteboarder_1.jpg": (
        "JohnTigue/whiteboarder",
        "85cb136b6fb7",
        "images/demo_captured_boards/red_black_transition.jpg",
        "46099a59",
    ),
    "whiteboard_whiteboarder_2.jpg": (
        "JohnTigue/whiteboarder",
        "85cb136b6fb7",
        "images/demo_captured_boards/just_black_and_green.jpg",
        "989e61f2",
    ),
    "plain_mypaint-mrmamurk-a1_grey-fibrous_1.png": (
        "mypaint/mypaint",
        "35aa9d33cd3d",
        "backgrounds/mrmamurk/mamurk_a_1.png",
        "78f3cc70",
    ),
    "plain_mypaint-mrmamurk-c3_cream-rough_1.png": (
        "mypaint/mypaint",
        "35aa9d33cd3d",
        "backgrounds/mrmamurk/mamurk_c_3.png",
        "a62538b1",
    ),
    "plain_mypaint-mrmamurk-e2_white-laid_1.png": (
        "mypaint/mypaint",
        "35aa9d33cd3d",
        "backgrounds/mrmamurk/mamurk_e_2.png",
        "d5e5ec49",
    ),
    "plain_mypaint-mrmamurk-f1_peach-fibre_1.png": (
        "mypaint/mypaint",
        "35aa9d33cd3d",
        "backgrounds/mrmamurk/mamurk_f_1.png",
        "0c74a0ea",
    ),
    "plain_breta_1.jpg": (
        "Breta01/handwriting-ocr",
        "64457fa24e85",
        "data/pages/page01.jpg",
        "dde69447",
    ),
    "plain_breta_2.jpg": (
        "Breta01/handwriting-ocr",
        "64457fa24e85",
        "data/pages/page02.jpg",
        "7eba459a",
    ),
    "plain_breta_3.jpg": (
        "Breta01/handwriting-ocr",
        "64457fa24e85",
        "data/pages/test1.jpg",
        "11515a46",
    ),
    "plain_breta_4.jpg": (
        "Breta01/handwriting-ocr",
        "64457fa24e85",
        "data/pages/page09.jpg",
        "b7584a7a",
    ),
    "plain_breta_5.jpg": (
        "Breta01/handwriting-ocr",
        "64457fa24e85",
        "data/pages/page10.jpg",
        "e3ad8d05",
    ),
    "plain_pagedewarp_1.jpg": (
        "mzucker/page_dewarp",
        "d3257d7b564b",
        "example_input/linguistics_thesis_b.jpg",
        "b8f00f6c",
    ),
    "plain_pagedewarp_2.jpg": (
        "mzucker/page_dewarp",
        "d3257d7b564b",
        "example_input/linguistics_thesis_a.jpg",
        "941f8375",
    ),
    "plain_donut_5.jpg": (
        "clovaai/donut",
        "4cfcf972560e",
        "synthdog/resources/paper/paper_5.jpg",
        "60c34ff6",
    ),
    "plain_donut_6.jpg": (
        "clovaai/donut",
        "4cfcf972560e",
        "synthdog/resources/paper/paper_6.jpg",
        "e9619c48",
    ),
    "plain_augraphy_1.jpg": (
        "sparkfish/augraphy",
        "45c3a7ef767f",
        "paper_textures/texture-1.jpg",
        "e4dc259c",
    ),
    "desk_polyhaven-woodtableworn_1.jpg": (
        "RobotLocomotion/models",
        "4723170e1c8e",
        "tutorials/models/assets/textures/wood_table_worn_diff_1k.jpg",
        "4901fcf2",
    ),
    "desk_vedo-pxhere_1.jpg": (
        "marcomusy/vedo",
        "904d1d2dcaa5",
        "vedo/textures/wood1.jpg",
        "75558fc8",
    ),
    "desk_vedo-pxhere_2.jpg": (
        "marcomusy/vedo",
        "904d1d2dcaa5",
        "vedo/textures/wood3.jpg",
        "ad3debc6",
    ),
}

REAL_REPO = "kvuletic2/tic-tac-toe_opencv"
REAL_COMMIT = "04a1992fafad811030d280730cff3e95f3912c9f"
# image number: full SHA-1, as bench/data/real_boards/SOURCES.md records them.
REAL = {
    1: "3b0467ba7066f68fa4d9ab1ec45e496b3f62b6e9",
    2: "79cc7c0b6a591dbb31a9664e06c5ee1b093d3d83",
    3: "bf6c0d6bd0f247dc18e647bc97953d5e73569f7d",
    4: "42338e579be9fbbe4eb9222e24d0f2c9005f129b",
    5: "932ca16057daaca0ce4c1ad340edcf47f7f415fb",
    6: "e5b41c5b58c65f3a01b698c0cafb18b99e47b550",
    7: "fab7e31c22469386fcb3343ed7efbd9a889a4be8",
    8: "b308b81f65bac93db40bb3ade8564c5b20466368",
    9: "aec49380734408753f3e13322d818433831de2f6",
    10: "21c9ee860c5a67119cb511883106cda782ebae96",
    11: "af03dbd39a32a92cfd95426bb6931080584f1215",
    12: "abc386105eb2c8468c7bb1d49ce035d53f223eb4",
    13: "f1b276b356cd41e0f092fef3b2be7f2e13d4f3e1",
    14: "b89069962f6aa2efcba5deae546520ff24f35272",
    15: "1067ce4ed46c469560230a332046594b1d3b499e",
}

# What SOURCES.md says was taken: drawings per class and source.
EXPECTED = {"circle": 600, "cross": 600, "line": 156}
MIN_LINE_STRAIGHTNESS = 0.9  # end to end over along the path, SOURCES.md's rule for a line


class Problems:
    """Everything missing or wrong, said once as it is found and counted for the exit status."""

    def __init__(self) -> None:
        self.said: set[str] = set()

    @property
    def count(self) -> int:
        return len(self.said)

    def __call__(self, message: str) -> None:
        if message not in self.said:
            self.said.add(message)
            print(f"  PROBLEM: {message}", file=sys.stderr)


class GitDir:
    """Reads files of one commit of a git directory (`git cat-file`, no work tree needed)."""

    def __init__(self, path: Path, name: str) -> None:
        self.path, self.name = path, name
        if not path.is_dir():
            raise SystemExit(f"restore_composite: {name}: {path} is not a directory")
        self._commits: dict[str, str | None] = {}
        self._trees: dict[str, dict[str, str]] = {}

    def _git(self, *args: str, data: bytes | None = None) -> subprocess.CompletedProcess:
        return subprocess.run(
            ["git", "--git-dir", str(self.path), *args], input=data, capture_output=True
        )

    def commit(self, abbrev: str) -> str | None:
        """The full commit id, or None when the directory does not hold it."""
        if abbrev not in self._commits:
            done = self._git("rev-parse", "--verify", "--quiet", f"{abbrev}^{{commit}}")
            self._commits[abbrev] = done.stdout.decode().strip() if done.returncode == 0 else None
        return self._commits[abbrev]

    def tree(self, commit: str) -> dict[str, str]:
        """Path -> blob id of every file of the commit."""
        if commit not in self._trees:
            done = self._git("ls-tree", "-r", "-z", commit)
            files = {}
            for entry in done.stdout.decode("utf-8", "surrogateescape").split("\0"):
                if entry:
                    meta, path = entry.split("\t", 1)
                    files[path] = meta.split()[2]
            self._trees[commit] = files
        return self._trees[commit]

    def read_at(self, abbrev: str, path: str, problems: Problems, owner: object) -> bytes | None:
        """The file at the commit `abbrev` names, or None, said to `problems` for `owner` (what
        was being restored), when the directory lacks the commit, the file or its blob."""
        commit = self.commit(abbrev)
        data = self.read(commit, path) if commit else None
        if data is None:
            what = f"commit {abbrev}" if commit is None else f"{path} @ {abbrev} (or its blob)"
            problems(f"{owner}: {self.path} does not hold {what}")
        return data

    def read(self, commit: str, path: str) -> bytes | None:
        """The file's bytes, or None when the commit has no such file or its blob is absent."""
        blob = self.tree(commit).get(path)
        if blob is None:
            return None
        done = self._git("cat-file", "blob", blob)
        return done.stdout if done.returncode == 0 else None


def repo_arg(text: str) -> tuple[str, Path]:
    name, sep, path = text.partition("=")
    if not sep or name.count("/") != 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not OWNER/NAME=GITDIR")
    return name, Path(path)


# --- Quick, Draw! ----------------------------------------------------------------------------


def quickdraw_records(text: str) -> tuple[dict[str, dict], int]:
    """key_id -> record of an ndjson text (first record of each key), and how many lines could
    not be read (records cut at the ends of a partial copy)."""
    records: dict[str, dict] = {}
    unreadable = 0
    for line in text.splitlines():
        if not line.strip():
            continue
        try:
            record = json.loads(line)
            key = str(record["key_id"])
        except (ValueError, KeyError, TypeError):
            unreadable += 1
            continue
        records.setdefault(key, record)
    return records, unreadable


def quickdraw_strokes(record: dict) -> list[list[list[float]]]:
    """A record's strokes as [[x, y], ...]: raw ([xs], [ys], [ts]) and simplified ([xs], [ys])
    alike (a Quick, Draw! stroke is always pen-down)."""
    strokes = []
    for stroke in record["drawing"]:
        xs, ys = stroke[0], stroke[1]
        if len(xs) != len(ys):
            raise ValueError(f"key_id {record['key_id']}: a stroke's xs and ys differ in length")
        strokes.append([[x, y] for x, y in zip(xs, ys, strict=True)])
    return strokes


def air_drawer_texts(path: Path, rows: list[dict], problems: Problems) -> dict[str, str]:
    """path in the repository -> text, from a git directory or a folder of saved files."""
    wanted = sorted({r["path"] for r in rows if r["repo"] == AIR_DRAWER})
    texts: dict[str, str] = {}
    if (path / "HEAD").is_file() or (path / ".git").exists():
        git = GitDir(path / ".git" if (path / ".git").exists() else path, AIR_DRAWER)
        commits = {r["commit"] for r in rows if r["repo"] == AIR_DRAWER}
        for abbrev in sorted(commits):
            commit = git.commit(abbrev)
            if commit is None:
                problems(f"{AIR_DRAWER}: {path} does not hold commit {abbrev}")
                continue
            for name in wanted:
                data = git.read(commit, name)
                if data is None:
                    problems(f"{AIR_DRAWER}@{abbrev}: {name} is not in {path}")
                else:
                    texts[name] = data.decode("utf-8")
        return texts
    for name in wanted:
        found = [p for p in (path / name, path / Path(name).name) if p.is_file()]
        if found:
            texts[name] = found[0].read_text(encoding="utf-8")
        else:
            problems(f"{AIR_DRAWER}: neither {path / name} nor {path / Path(name).name} exists")
    return texts


# --- UNIPEN ----------------------------------------------------------------------------------


def _number(text: str) -> float | int:
    try:
        return int(text)
    except ValueError:
        return float(text)


def unipen_components(
    git: GitDir, commit: str, path: str, depth: int = 0
) -> list[tuple[str, list[list[float]]]]:
    """The components of a UNIPEN file, its `.INCLUDE`d files' (from `include/`) in place: each
    a `.PEN_DOWN` or `.PEN_UP` with at least one point, as (keyword, [[x, y], ...]). A point is
    a line of numbers after the keyword, x and y first (`.COORD X Y [T] [P]`); `.DT` is no
    component and any other keyword ends one."""
    data = git.read(commit, path)
    if data is None:
        raise FileNotFoundError(f"{UNIPEN}@{commit[:12]}: {path} is missing from {git.path}")
    out: list[tuple[str, list[list[float]]]] = []
    current: tuple[str, list[list[float]]] | None = None

    def close() -> None:
        if current is not None and current[1]:
            out.append(current)

    for line in data.decode("latin-1").splitlines():
        if line.startswith("."):
            words = line.split()
            keyword = words[0] if words else "."
            if keyword in (".PEN_DOWN", ".PEN_UP"):
                close()
                current = (keyword, [])
            elif keyword == ".DT":
                continue
            else:
                close()
                current = None
                if keyword == ".INCLUDE":
                    if depth > 4:
                        raise ValueError(f"{path}: .INCLUDE nested too deep")
                    out.extend(unipen_components(git, commit, f"include/{words[1]}", depth + 1))
        elif current is not None:
            words = line.split()
            if len(words) >= 2 and re.fullmatch(r"-?\d+(\.\d*)?", words[0]):
                current[1].append([_number(words[0]), _number(words[1])])
    close()
    return out


def unipen_segments(git: GitDir, commit: str, path: str) -> list[tuple[str, str, str]]:
    """The `.SEGMENT` lines of a file, in order: (delineation, quality, label)."""
    data = git.read(commit, path)
    if data is None:
        raise FileNotFoundError(f"{UNIPEN}@{commit[:12]}: {path} is missing from {git.path}")
    segments = []
    for line in data.decode("latin-1").splitlines():
        if line.startswith(".SEGMENT"):
            match = re.match(r'\.SEGMENT\s+\S+\s+(\S+)\s+(\S+)\s+"(.*)"', line)
            if match is None:
                segments.append(("", "", line))
            else:
                segments.append((match[1], match[2], match[3]))
    return segments


def delineation(text: str) -> list[tuple[int, int | None, int | None]]:
    """UNIPEN's "a-b,c,d:p-e:q" as (component, first point, last point) per component (None:
    from the start / to the end; the end point is taken as included)."""
    parts = []
    for part in text.split(","):
        start, _, end = part.partition("-")
        end = end or start
        c0, _, p0 = start.partition(":")
        c1, _, p1 = end.partition(":")
        first, last = int(c0), int(c1)
        for comp in range(first, last + 1):
            parts.append(
                (
                    comp,
                    int(p0) if p0 and comp == first else None,
                    int(p1) if p1 and comp == last else None,
                )
            )
    return parts


def unipen_item(
    git: GitDir, commit: str, path: str, item: str, cache: dict
) -> tuple[list[list[list[float]]] | None, str]:
    """The pen-down strokes of `segment N (label)` of a file, or None and why not."""
    match = re.fullmatch(r"segment (\d+) \((.+)\)", item)
    if match is None:
        return None, f"item {item!r} is not 'segment N (label)'"
    index, label = int(match[1]), match[2]
    if path not in cache:
        cache[path] = (
            unipen_segments(git, commit, path),
            unipen_components(git, commit, path),
        )
    segments, components = cache[path]
    if index >= len(segments):
        return None, f"{path} has {len(segments)} segments, not {index + 1}"
    delin, quality, seg_label = segments[index]
    if seg_label != label:
        return None, f"{path} segment {index} is {seg_label!r}, not {label!r}"
    if quality == "BAD":
        return None, f"{path} segment {index} is of quality BAD"
    strokes = []
    for comp, p0, p1 in delineation(delin):
        if comp >= len(components):
            return None, f"{path} segment {index} names component {comp} of {len(components)}"
        keyword, points = components[comp]
        if keyword == ".PEN_DOWN":
            strokes.append(points[p0 or 0 : None if p1 is None else p1 + 1])
    return [s for s in strokes if s], ""


# --- checks ----------------------------------------------------------------------------------


def straightness(stroke: list[list[float]]) -> float:
    along = sum(math.dist(a, b) for a, b in itertools.pairwise(stroke))
    return math.dist(stroke[0], stroke[-1]) / along if along > 0 else 0.0


def criteria(row: dict, strokes: list, record: dict | None) -> str:
    """Why a drawing does not meet SOURCES.md's rules for its class, or ''."""
    if record is not None and not record.get("recognized", True):
        return "not 'recognized' in Quick, Draw!"
    if not strokes:
        return "no pen-down stroke"
    if row["class"] == "line":
        if len(strokes) != 1:
            return f"a line of {len(strokes)} strokes"
        if straightness(strokes[0]) < MIN_LINE_STRAIGHTNESS:
            return f"a line only {straightness(strokes[0]):.2f} as long end to end as along"
    if row["repo"] == UNIPEN:
        if row["class"] == "circle" and len(strokes) not in (1, 2):
            return f"an 'O' of {len(strokes)} strokes"
        if row["class"] == "cross" and len(strokes) != 2:
            return f"a cross of {len(strokes)} strokes"
    xs = [p[0] for s in strokes for p in s]
    ys = [p[1] for s in strokes for p in s]
    if max(xs) == min(xs) and max(ys) == min(ys):
        return "all its points are one point (the bench would drop it)"
    return ""


# --- restoring -------------------------------------------------------------------------------


def restore_handwriting(args: argparse.Namespace, problems: Problems) -> None:
    with MANIFEST.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    by_class: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        by_class[row["class"]].append(row)
    for name, expected in EXPECTED.items():
        got = len(by_class.get(name, []))
        if got != expected:
            problems(f"the manifest lists {got} {name} drawings, SOURCES.md {expected}")
        indices = [int(r["index"]) for r in by_class.get(name, [])]
        if indices != list(range(len(indices))):
            problems(f"the manifest's {name} indices are not 0, 1, 2, ... in order")

    # Quick, Draw! records by repository and path.
    quickdraw: dict[tuple[str, str], dict[str, dict]] = {}
    if args.exupery:
        git = GitDir(args.exupery, EXUPERY)
        for abbrev, path in sorted(
            {(r["commit"], r["path"]) for r in rows if r["repo"] == EXUPERY}
        ):
            data = git.read_at(abbrev, path, problems, EXUPERY)
            if data is None:
                continue
            quickdraw[EXUPERY, path], _ = quickdraw_records(data.decode("utf-8"))
    if args.air_drawer:
        for path, text in air_drawer_texts(args.air_drawer, rows, problems).items():
            records, unreadable = quickdraw_records(text)
            quickdraw[AIR_DRAWER, path] = records
            print(f"  {AIR_DRAWER} {path}: {len(records)} records ({unreadable} cut lines skipped)")
    unipen = GitDir(args.unipen, UNIPEN) if args.unipen else None
    unipen_cache: dict[str, tuple] = {}

    for name in EXPECTED:
        drawings: list[list] = []
        missing: list[str] = []
        unmet = 0
        sources = Counter()
        for row in by_class.get(name, []):
            where = f"{name} {row['index']} ({row['repo']} {row['path']} {row['item']})"
            strokes, record = None, None
            if row["repo"] in (EXUPERY, AIR_DRAWER):
                records = quickdraw.get((row["repo"], row["path"]))
                key = row["item"].removeprefix("key_id ").strip()
                if records is None:
                    missing.append(f"{where}: no copy of {row['repo']} given or readable")
                elif key not in records:
                    missing.append(f"{where}: key_id not in the copy")
                else:
                    record = records[key]
                    try:
                        strokes = quickdraw_strokes(record)
                    except (KeyError, IndexError, TypeError, ValueError) as err:
                        missing.append(f"{where}: unreadable drawing ({err})")
            elif row["repo"] == UNIPEN:
                commit = unipen.commit(row["commit"]) if unipen else None
                if unipen is None:
                    missing.append(f"{where}: no --unipen given")
                elif commit is None:
                    missing.append(f"{where}: {args.unipen} does not hold commit {row['commit']}")
                else:
                    try:
                        strokes, why = unipen_item(
                            unipen, commit, row["path"], row["item"], unipen_cache
                        )
                    except (FileNotFoundError, ValueError) as err:
                        strokes, why = None, str(err)
                    if strokes is None:
                        missing.append(f"{where}: {why}")
            else:
                missing.append(f"{where}: unknown repository")
            if strokes is None:
                continue
            why = criteria(row, strokes, record)
            if why:
                unmet += 1
                problems(f"{where}: {why}")
            drawings.append(strokes)
            sources[row["repo"]] += 1
        out = args.hands / f"{name}.json"
        for line in missing[:20]:
            problems(line)
        if len(missing) > 20:
            problems(f"... and {len(missing) - 20} more {name} items not found")
        wanted = len(by_class.get(name, []))
        if missing or len(drawings) != wanted:
            problems(
                f"{out} not written: {len(drawings)} of the manifest's {wanted} {name} "
                f"drawings found"
            )
            continue
        write_text_atomic(out, json.dumps(drawings, separators=(",", ":")))  # ASCII
        said = ", ".join(f"{n} from {repo}" for repo, n in sorted(sources.items()))
        print(f"  wrote {out}: {len(drawings)} drawings ({said}); {unmet} against the criteria")


def restore_papers(args: argparse.Namespace, problems: Problems) -> None:
    with REGIONS.open(newline="", encoding="utf-8") as handle:
        listed = sorted({row["file"] for row in csv.DictReader(handle)})
    unknown = [f for f in listed if f not in PAPER]
    for name in unknown:
        problems(f"{REGIONS.name} lists {name}, which this script does not know where to find")
    repos = dict(args.paper_repo)
    gits = {name: GitDir(path, name) for name, path in repos.items()}
    done = 0
    for name in listed:
        if name not in PAPER:
            continue
        repo, abbrev, path, sha = PAPER[name]
        target = args.papers / name
        if repo not in gits:
            if target.is_file() and hashlib.sha1(target.read_bytes()).hexdigest().startswith(sha):
                done += 1  # already there and right
            else:
                problems(f"{target}: give --paper-repo {repo}=GITDIR ({path} @ {abbrev})")
            continue
        data = gits[repo].read_at(abbrev, path, problems, target)
        if data is None:
            continue
        got = hashlib.sha1(data).hexdigest()
        if not got.startswith(sha):
            problems(
                f"{target}: {repo} {path} has SHA-1 {got[:8]}, SOURCES.md says {sha}; not copied"
            )
            continue
        with atomic_write(target) as handle:
            handle.write(data)
        done += 1
    print(f"  paper: {done} of {len(listed)} photos in {args.papers}, SHA-1 prefixes checked")


def restore_real(args: argparse.Namespace, problems: Problems) -> None:
    git = GitDir(args.real_boards, REAL_REPO)
    commit = git.commit(REAL_COMMIT)
    if commit is None:
        problems(f"{REAL_REPO}: {args.real_boards} does not hold commit {REAL_COMMIT}")
        return
    done = 0
    for number, sha in REAL.items():
        target = REAL_IMAGES / f"kvuletic2_image{number}.jpeg"
        data = git.read(commit, f"pictures/image{number}.jpeg")
        if data is None:
            problems(f"{target}: pictures/image{number}.jpeg is not in {args.real_boards}")
            continue
        got = hashlib.sha1(data).hexdigest()
        if got != sha:
            problems(f"{target}: SHA-1 {got}, SOURCES.md says {sha}; not copied")
            continue
        with atomic_write(target) as handle:
            handle.write(data)
        done += 1
    print(f"  real boards: {done} of {len(REAL)} photos in {REAL_IMAGES}, SHA-1s checked")


def check(args: argparse.Namespace, problems: Problems) -> None:
    """Says what is in place, without reading any source."""
    with MANIFEST.open(newline="", encoding="utf-8") as handle:
        counts = Counter(row["class"] for row in csv.DictReader(handle))
    for name in EXPECTED:
        path = args.hands / f"{name}.json"
        if not path.is_file():
            problems(f"{path} is missing")
            continue
        got = len(json.loads(path.read_text(encoding="utf-8")))
        if got != counts[name]:
            problems(f"{path}: {got} drawings, the manifest lists {counts[name]}")
        else:
            print(f"  {path}: {got} drawings, as the manifest")
    with REGIONS.open(newline="", encoding="utf-8") as handle:
        listed = sorted({row["file"] for row in csv.DictReader(handle)})
    right = 0
    for name in listed:
        path = args.papers / name
        sha = PAPER.get(name, ("", "", "", "?"))[3]
        if not path.is_file():
            problems(f"{path} is missing")
        elif not hashlib.sha1(path.read_bytes()).hexdigest().startswith(sha):
            problems(f"{path}: SHA-1 does not start {sha}")
        else:
            right += 1
    print(f"  paper: {right} of {len(listed)} photos right")
    right = 0
    for number, sha in REAL.items():
        path = REAL_IMAGES / f"kvuletic2_image{number}.jpeg"
        if path.is_file() and hashlib.sha1(path.read_bytes()).hexdigest() == sha:
            right += 1
        else:
            problems(f"{path} is missing or its SHA-1 is not {sha}")
    print(f"  real boards: {right} of {len(REAL)} photos right")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exupery", type=Path, help=f"git directory of {EXUPERY}")
    parser.add_argument("--unipen", type=Path, help=f"git directory of {UNIPEN}")
    parser.add_argument(
        "--air-drawer",
        type=Path,
        help=f"git directory of {AIR_DRAWER}, or a folder of its data/*.ndjson as read",
    )
    parser.add_argument(
        "--paper-repo",
        type=repo_arg,
        action="append",
        default=[],
        metavar="OWNER/NAME=GITDIR",
        help="git directory of a paper photo's repository (repeat for each)",
    )
    parser.add_argument("--real-boards", type=Path, help=f"git directory of {REAL_REPO}")
    parser.add_argument("--hands", type=Path, default=HANDS, help="where the JSON files go")
    parser.add_argument("--papers", type=Path, default=PAPERS, help="where the photos go")
    parser.add_argument("--check", action="store_true", help="only check what is in place")
    args = parser.parse_args()
    problems = Problems()
    if args.check:
        check(args, problems)
    else:
        if not (
            args.exupery or args.unipen or args.air_drawer or args.paper_repo or args.real_boards
        ):
            parser.error("give at least one source (see the module docstring), or --check")
        if args.exupery or args.unipen or args.air_drawer:
            print("handwriting:")
            restore_handwriting(args, problems)
        if args.paper_repo:
            print("paper:")
            restore_papers(args, problems)
        if args.real_boards:
            print("real boards:")
            restore_real(args, problems)
    if problems.count:
        raise SystemExit(f"restore_composite: {problems.count} problem(s), listed above")
    print("restore_composite: all done, nothing missing")


if __name__ == "__main__":
    main()
