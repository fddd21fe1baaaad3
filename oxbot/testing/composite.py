"""Board photos composed from real handwriting on real paper: the board reader's independent test.

Nobody here drew these symbols and nobody here made these sheets: the circles and crosses (and,
where the source has them, the grid's lines) are people's own drawings from a public dataset,
the paper, whiteboards and desks are public photos, and only the putting together is ours. It
was written for that purpose without looking at `oxbot.testing.render` or the training
synthesiser, and nothing here imports `oxbot.perception`: a reader that learnt their quirks
cannot pass by recognising them. The sources are not in git; see
`bench/data/composite_boards/SOURCES.md` for what they are and how to restore them.

    HandwritingSource.load(folder, manifest)
                                     circle.json, cross.json (and line.json): lists of drawings,
                                     each a list of strokes, each a list of [x, y] points; the
                                     manifest says who drew each (the parts split by writer)
    PaperSource.load(folder, regions, part)
                                     the blank stretches of paper, whiteboard and desk photos
                                     that a CSV file lists, with the part each belongs to
    compose(rng, hands, papers)      one photo (RGB uint8) and its 9 labels, row by row
    compose_board(rng, hands, papers)
                                     the same photo with where its grid lies: the 4x4 lattice
                                     of cell corners, to fine-tune a learned grid finder on
    compose_game(rng, hands, papers, labels, order, frames)
                                     photos of one sheet from a camera held still as a game's
                                     symbols are drawn on it one by one (bench_composite_games.py)
    write_set(out, hands, papers, n, seed, split)
                                     n photos of one part's drawings (`papers` already of that
                                     part), a labels.csv that bench_real_boards.py reads and a
                                     lattices.json of where each grid lies
    symbol_cells(hands, papers, rng) every circle and cross alone in a 40x40 cell

How a photo is made, stage by stage: a crop of a paper photo (or a whiteboard) is the sheet; the
grid's four lines are a person's line drawings where the source has them (otherwise a slow,
wavering pen path), overshooting their crossings by a random amount; each symbol is a person's
drawing fitted into its cell at its own size, place and slant; ink is laid over the paper
subtractively (the paper shows through it) in a pen, marker or pencil colour; the sheet lies on
a desk photo and is seen by a camera: turned, in perspective, lit unevenly, with a shadow,
defocus or shake, sensor noise, and saved at a webcam or phone size as JPEG.
"""

from __future__ import annotations

import csv
import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from oxbot.atomic import atomic_write

PAPER_KINDS = ("plain", "squared", "ruled", "dotted", "whiteboard")
"""Kinds of surface a sheet can be cut from; regions of kind "desk" are only ever what the
sheet lies on."""
SHEET = 1000  # the sheet is composed at this many pixels a side before the camera sees it
CELLS = tuple(f"c{r}{c}" for r in range(3) for c in range(3))
COLUMNS = ("file", "board", "split", "paper", "ink", "grid_frac", *CELLS, "notes")
LATTICES = "lattices.json"
"""Beside a set's labels.csv: {photo name: its (4, 4, 2) lattice as nested lists}."""

# Ink colours as what they let through of each RGB channel (1 = all of it).
INKS = {
    "blue ballpoint": (0.25, 0.30, 0.65),
    "black pen": (0.12, 0.12, 0.14),
    "black marker": (0.05, 0.05, 0.06),
    "blue marker": (0.10, 0.25, 0.70),
    "red marker": (0.75, 0.12, 0.15),
    "green marker": (0.12, 0.55, 0.25),
    "pencil": (0.45, 0.45, 0.47),
}


@dataclass(frozen=True)
class HandwritingSource:
    """People's drawings by class: each drawing a list of (K, 2) float strokes, and who drew
    it (one writer per drawing where nothing says otherwise)."""

    drawings: dict[str, list[list[np.ndarray]]]
    writers: dict[str, list[str]]

    @classmethod
    def load(cls, folder: str | Path, manifest: str | Path | None = None) -> HandwritingSource:
        """circle.json, cross.json (and line.json) in `folder`; `manifest`, a CSV file with a
        row (class, index, writer) per drawing, says who drew what."""
        folder = Path(folder)
        writer_of: dict[tuple[str, int], str] = {}
        if manifest is not None:
            with Path(manifest).open(newline="", encoding="utf-8") as handle:
                for row in csv.DictReader(handle):
                    writer_of[row["class"], int(row["index"])] = row["writer"]
        drawings: dict[str, list[list[np.ndarray]]] = {}
        writers: dict[str, list[str]] = {}
        for name in ("circle", "cross", "line"):
            path = folder / f"{name}.json"
            if not path.is_file():
                continue
            raw = json.loads(path.read_text(encoding="utf-8"))
            drawings[name], writers[name] = [], []
            for index, drawing in enumerate(raw):
                strokes = [np.asarray(s, np.float64).reshape(-1, 2) for s in drawing if len(s)]
                if strokes and np.ptp(np.concatenate(strokes), axis=0).max() > 0:
                    drawings[name].append(strokes)
                    writers[name].append(writer_of.get((name, index), f"{name}:{index}"))
        for name in ("circle", "cross"):
            if not drawings.get(name):
                raise FileNotFoundError(
                    f"{folder / (name + '.json')} is missing or empty; restore the handwriting "
                    f"as bench/data/composite_boards/SOURCES.md says"
                )
        return cls(drawings, writers)

    def split(self, part: str) -> HandwritingSource:
        """The drawings of one part, by writer: `dev` those of a quarter of the writers (by a
        hash of their name), `test` the others'; no writer is in both."""

        def in_part(writer: str) -> bool:
            dev = int(hashlib.sha1(writer.encode()).hexdigest(), 16) % 4 == 0
            return dev == (part == "dev")

        drawings, writers = {}, {}
        for name, items in self.drawings.items():
            keep = [i for i, w in enumerate(self.writers[name]) if in_part(w)]
            drawings[name] = [items[i] for i in keep]
            writers[name] = [self.writers[name][i] for i in keep]
        return HandwritingSource(drawings, writers)


@dataclass(frozen=True)
class PaperSource:
    """Blank stretches of photos of writing surfaces, and desks, by kind: each an RGB uint8
    image with the name of the photo it was cut from and the part it belongs to."""

    photos: dict[str, list[tuple[str, np.ndarray]]]

    @classmethod
    def load(cls, folder: str | Path, regions: str | Path, part: str | None = None) -> PaperSource:
        """The regions listed in the CSV file `regions` (file, kind, split, x0, y0, x1, y1: a
        blank stretch of a photo in `folder`, chosen by looking at it), of one part or all."""
        folder = Path(folder)
        with Path(regions).open(newline="", encoding="utf-8") as handle:
            rows = list(csv.DictReader(handle))
        photos: dict[str, list[tuple[str, np.ndarray]]] = {}
        for row in rows:
            if row["kind"] not in (*PAPER_KINDS, "desk"):
                raise ValueError(f"{regions}: kind {row['kind']!r} is not one of {PAPER_KINDS}")
            if part is not None and row["split"] != part:
                continue
            image = cv2.imread(str(folder / row["file"]), cv2.IMREAD_COLOR)
            if image is None:
                raise FileNotFoundError(
                    f"{folder / row['file']} is missing or unreadable; restore the paper photos "
                    f"as bench/data/composite_boards/SOURCES.md says"
                )
            x0, y0, x1, y1 = (int(row[k]) for k in ("x0", "y0", "x1", "y1"))
            region = image[y0:y1, x0:x1, ::-1].copy()
            photos.setdefault(row["kind"], []).append((row["file"], region))
        if not any(k in photos for k in PAPER_KINDS):
            raise FileNotFoundError(f"{regions} lists no paper of part {part!r}")
        return cls(photos)


def random_position(rng: np.random.Generator) -> list[str]:
    """The 9 cells of a position of a game: crosses first, as many or one more than circles,
    from empty to full (no check for a finished line: a photo can be taken of any sheet)."""
    moves = int(rng.integers(0, 10))
    cells = rng.permutation(9)[:moves]
    labels = ["nothing"] * 9
    for turn, cell in enumerate(cells):
        labels[cell] = "cross" if turn % 2 == 0 else "circle"
    return labels


def _fit(strokes: list[np.ndarray]) -> list[np.ndarray]:
    """Strokes moved and scaled so that their box's longer side spans [-1, 1], centred."""
    points = np.concatenate(strokes)
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2, max(np.ptp(points, axis=0).max() / 2, 1e-9)
    return [(s - centre) / half for s in strokes]


def _wobbly_line(rng: np.random.Generator, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """A slow pen's straight line: a gentle bow and a tremor along it."""
    t = np.linspace(0, 1, 60)[:, None]
    along = end - start
    normal = np.array([-along[1], along[0]]) / max(np.linalg.norm(along), 1e-9)
    bow = rng.normal(0, 0.012) * np.linalg.norm(along) * np.sin(np.pi * t)
    tremor = np.cumsum(rng.normal(0, 0.35, (60, 1)), axis=0)
    tremor -= np.linspace(tremor[0], tremor[-1], 60)
    return start + t * along + normal * (bow + tremor)


MAX_LINE_BOW = 0.05
"""A person's line drawing is a grid line if it strays from the straight line between its ends
by at most this share of its length: Quick, Draw!'s "line" doodles, drawn in a hurry, hook and
bow more than a grid drawn to play on (a bow of 5% is a sixth of a cell)."""


def _bow(stroke: np.ndarray) -> float:
    """How far the stroke strays from the chord between its ends, over the chord's length."""
    chord = stroke[-1] - stroke[0]
    length = float(np.linalg.norm(chord))
    if length < 1e-6:
        return float("inf")
    normal = np.array([-chord[1], chord[0]]) / length
    return float(np.abs((stroke - stroke[0]) @ normal).max() / length)


def _grid_lines(hands: HandwritingSource) -> list[np.ndarray]:
    """The people's line drawings straight enough to be grid lines (each its longest stroke)."""
    return [
        stroke
        for stroke in (max(d, key=len) for d in hands.drawings.get("line", []))
        if len(stroke) >= 2 and _bow(stroke) <= MAX_LINE_BOW
    ]


def _line_from(
    lines: list[np.ndarray], rng: np.random.Generator, start: np.ndarray, end: np.ndarray
) -> np.ndarray:
    """One of `lines` (people's line drawings) laid from `start` to `end`, or a wobbly line
    where there are none."""
    if not lines:
        return _wobbly_line(rng, start, end)
    stroke = lines[int(rng.integers(len(lines)))]
    # Put the stroke's own ends on start and end: a similarity transform of the plane.
    a, b = stroke[0], stroke[-1]
    src, dst = complex(*(b - a)), complex(*(end - start))
    z = (stroke[:, 0] - a[0]) + 1j * (stroke[:, 1] - a[1])
    w = z * (dst / src)
    return np.stack([w.real + start[0], w.imag + start[1]], axis=1)


def _crossing(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where polylines `a` and `b` (N, 2) cross (the mean of their segments' crossings, for a
    wavering pen may cross twice), else where their chords' lines meet."""
    p, r = a[:-1], np.diff(a, axis=0)
    q, s = b[:-1], np.diff(b, axis=0)
    across = r[:, None, 0] * s[None, :, 1] - r[:, None, 1] * s[None, :, 0]
    apart = q[None] - p[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (apart[..., 0] * s[None, :, 1] - apart[..., 1] * s[None, :, 0]) / across
        u = (apart[..., 0] * r[:, None, 1] - apart[..., 1] * r[:, None, 0]) / across
    hit = (across != 0) & (t >= 0) & (t <= 1) & (u >= 0) & (u <= 1)
    if hit.any():
        i, j = np.nonzero(hit)
        return (p[i] + t[i, j, None] * r[i]).mean(axis=0)
    r, s = a[-1] - a[0], b[-1] - b[0]
    apart = b[0] - a[0]
    t = (apart[0] * s[1] - apart[1] * s[0]) / (r[0] * s[1] - r[1] * s[0])
    return a[0] + t * r


def _lattice(columns: list[np.ndarray], rows: list[np.ndarray]) -> np.ndarray:
    """The (4, 4, 2) cell corners of a drawn grid, `lattice[r, c]` at cell units x=c, y=r, as
    a grid finder reports them: the inner four where the drawn lines cross, the outer ones one
    middle cell further along each line, the corners completing parallelograms."""
    q = np.zeros((4, 4, 2))
    for j, row in zip((1, 2), rows, strict=True):
        for k, column in zip((1, 2), columns, strict=True):
            q[j, k] = _crossing(row, column)
    for k in (1, 2):
        q[0, k], q[3, k] = 2 * q[1, k] - q[2, k], 2 * q[2, k] - q[1, k]
    for j in (1, 2):
        q[j, 0], q[j, 3] = 2 * q[j, 1] - q[j, 2], 2 * q[j, 2] - q[j, 1]
    for j, jn in ((0, 1), (3, 2)):
        for k, kn in ((0, 1), (3, 2)):
            q[j, k] = q[j, kn] + q[jn, k] - q[jn, kn]
    return q


def _draw(mask: np.ndarray, strokes: list[np.ndarray], width: float, up: int = 4) -> None:
    """Adds the strokes' ink to `mask` (float32 0..1), drawn `up` times larger, then shrunk."""
    points = np.concatenate(strokes)
    low = np.floor(points.min(axis=0) - width * 2).astype(int)
    high = np.ceil(points.max(axis=0) + width * 2).astype(int)
    low = np.maximum(low, 0)
    high = np.minimum(high, [mask.shape[1] - 1, mask.shape[0] - 1])
    if np.any(high <= low):
        return
    w, h = high - low + 1
    big = np.zeros((h * up, w * up), np.uint8)
    thickness = max(1, round(width * up))
    for s in strokes:
        pts = np.round((s - low) * up).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(big, [pts], False, 255, thickness, cv2.LINE_AA)
    small = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32) / 255
    region = mask[low[1] : high[1] + 1, low[0] : high[0] + 1]
    np.maximum(region, small, out=region)


def _crop(photo: np.ndarray, rng: np.random.Generator, side: int) -> np.ndarray:
    """A random square crop of at least half the photo's shorter side, resized to `side`."""
    h, w = photo.shape[:2]
    size = int(min(h, w) * rng.uniform(0.5, 1.0))
    y, x = int(rng.integers(0, h - size + 1)), int(rng.integers(0, w - size + 1))
    return cv2.resize(photo[y : y + size, x : x + size], (side, side), interpolation=cv2.INTER_AREA)


@dataclass(frozen=True)
class _Drawing:
    """A sheet with its grid and symbols drawn but their ink not yet laid: so that the same
    sheet can be seen with only some of its symbols drawn (a game in progress)."""

    paper: np.ndarray
    """float32 RGB 0..255, SHEET a side: the crop of a paper photo."""
    labels: list[str]
    corners: np.ndarray
    """The grid's 4 outer corners in sheet pixels."""
    lattice: np.ndarray
    """(4, 4, 2) sheet pixels: the cell corners as the drawn lines place them (`_lattice`)."""
    paper_name: str
    ink: str
    grid: np.ndarray
    """float32 0..1: the grid lines' ink."""
    symbols: dict[int, np.ndarray]
    """Each drawn cell's symbol ink (float32 0..1, the whole sheet), by cell."""
    layers: tuple[tuple[str, float, np.ndarray | None], ...]
    """For the grid's ink and the symbols' ink: its name, strength, and a pencil's specks
    (where the paper shows through) or None."""

    def inked(self, cells: list[int] | None = None) -> np.ndarray:
        """The sheet (float32 RGB) with the grid and the symbols of `cells` (all by default)
        in ink, laid over the paper subtractively."""
        drawn = self.symbols if cells is None else {c: self.symbols[c] for c in cells}
        symbols = np.zeros(self.grid.shape, np.float32)
        for mask in drawn.values():
            np.maximum(symbols, mask, out=symbols)
        sheet = self.paper
        for mask, (name, strength, specks) in zip((self.grid, symbols), self.layers, strict=True):
            if specks is not None:  # graphite is grainy: paper shows through in specks
                mask = mask * specks
                mask = cv2.GaussianBlur(mask.astype(np.float32), (3, 3), 0.6)
            through = np.array(INKS[name], np.float32)
            a = (mask * strength)[:, :, None]
            sheet = sheet * (1 - a + a * through)
        return sheet


def _sheet(
    hands: HandwritingSource,
    papers: PaperSource,
    rng: np.random.Generator,
    labels: list[str] | None = None,
) -> _Drawing:
    """A drawn sheet: the grid and a random position's symbols (`labels`, row by row, if
    given)."""
    kinds = [k for k in PAPER_KINDS if k in papers.photos]
    kind = kinds[int(rng.integers(len(kinds)))]
    name, photo = papers.photos[kind][int(rng.integers(len(papers.photos[kind])))]
    sheet = _crop(photo, rng, SHEET).astype(np.float32)
    # Pencil on paper one time in five; on a whiteboard only markers.
    pens = [n for n in INKS if n != "pencil" and (kind != "whiteboard" or "marker" in n)]
    pencil = kind != "whiteboard" and rng.random() < 0.2
    ink = "pencil" if pencil else pens[int(rng.integers(len(pens)))]
    symbol_ink = ink
    if rng.random() < 0.25:  # the symbols in another pen than the grid
        symbol_ink = pens[int(rng.integers(len(pens)))]
    pen = {"marker": rng.uniform(5, 11), "pencil": rng.uniform(2, 3.5)}
    width = next((v for k, v in pen.items() if k in ink), rng.uniform(2.5, 5))
    symbol_width = next((v for k, v in pen.items() if k in symbol_ink), rng.uniform(2.5, 5))

    # The grid: the 3x3 block's side and place on the sheet, lines at roughly equal thirds.
    side = rng.uniform(0.55, 0.8) * SHEET
    x0 = rng.uniform(0.1 * SHEET, SHEET - side - 0.1 * SHEET)
    y0 = rng.uniform(0.1 * SHEET, SHEET - side - 0.1 * SHEET)
    xs = x0 + side * np.array([0, 1 / 3 + rng.normal(0, 0.02), 2 / 3 + rng.normal(0, 0.02), 1])
    ys = y0 + side * np.array([0, 1 / 3 + rng.normal(0, 0.02), 2 / 3 + rng.normal(0, 0.02), 1])
    tilt = rng.normal(0, 0.03)  # the drawer's own slant of the lines
    grid_mask = np.zeros((SHEET, SHEET), np.float32)
    people_lines = _grid_lines(hands)
    lines = []
    for i in (1, 2):
        over = side * rng.uniform(0.0, 0.12, 2)
        lines.append(
            (np.array([xs[i] + tilt * side, ys[0] - over[0]]), np.array([xs[i], ys[3] + over[1]]))
        )
        over = side * rng.uniform(0.0, 0.12, 2)
        lines.append(
            (np.array([xs[0] - over[0], ys[i]]), np.array([xs[3] + over[1], ys[i] - tilt * side]))
        )
    drawn = [_line_from(people_lines, rng, start, end) for start, end in lines]
    for line in drawn:
        _draw(grid_mask, [line], width)

    labels = random_position(rng) if labels is None else list(labels)
    symbols = {}
    for cell, label in enumerate(labels):
        if label == "nothing":
            continue
        r, c = divmod(cell, 3)
        cx, cy = (xs[c] + xs[c + 1]) / 2, (ys[r] + ys[r + 1]) / 2
        w, h = xs[c + 1] - xs[c], ys[r + 1] - ys[r]
        choices = hands.drawings[label]
        strokes = _fit(choices[int(rng.integers(len(choices)))])
        size = min(w, h) * rng.uniform(0.45, 0.8) / 2
        angle = rng.normal(0, 0.15)
        turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        stretch = np.array([rng.uniform(0.85, 1.15), 1.0])
        shift = np.array([rng.normal(0, 0.07) * w, rng.normal(0, 0.07) * h])
        placed = [(s * stretch) @ turn.T * size + np.array([cx, cy]) + shift for s in strokes]
        symbols[cell] = np.zeros((SHEET, SHEET), np.float32)
        _draw(symbols[cell], placed, symbol_width)

    layers = []
    for name_ in (ink, symbol_ink):
        strength = rng.uniform(0.75, 1.0) if "pencil" not in name_ else rng.uniform(0.45, 0.75)
        specks = rng.random((SHEET, SHEET)) < 0.75 if name_ == "pencil" else None
        layers.append((name_, strength, specks))
    corners = np.array([[xs[0], ys[0]], [xs[3], ys[0]], [xs[3], ys[3]], [xs[0], ys[3]]])
    return _Drawing(
        paper=sheet,
        labels=labels,
        corners=corners,
        lattice=_lattice(columns=drawn[0::2], rows=drawn[1::2]),
        paper_name=f"{kind} ({name})",
        ink=ink if ink == symbol_ink else (f"{ink} grid; {symbol_ink} symbols"),
        grid=grid_mask,
        symbols=symbols,
        layers=tuple(layers),
    )


def _desk(papers: PaperSource, rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """What the sheet lies on: a desk photo where there is one, else a plain dull colour."""
    h, w = shape
    desks = papers.photos.get("desk")
    if desks:
        photo = desks[int(rng.integers(len(desks)))][1]
        side = max(h, w)
        return _crop(photo, rng, side)[:h, :w].astype(np.float32)
    colour = rng.uniform(40, 170, 3).astype(np.float32)
    return np.broadcast_to(colour, (h, w, 3)).copy()


CAMERAS = ((640, 480), (1280, 720), (960, 720), (1024, 768), (800, 600))


@dataclass(frozen=True)
class _Camera:
    """How one sheet is seen: where it lies in the frame, on what, in what light, through what
    optics. Held still, it sees the sheet the same way frame after frame but for sensor noise."""

    width: int
    height: int
    homography: np.ndarray
    desk: np.ndarray
    light: np.ndarray
    """float32 (height, width, 3): the light's slope, shadow, colour cast and brightness."""
    blur: tuple[str, float, float]
    """("defocus", sigma, 0) or ("shake", length, angle in degrees)."""
    noise: float
    notes: dict[str, str]

    @classmethod
    def sample(cls, rng: np.random.Generator, drawing: _Drawing, papers: PaperSource) -> _Camera:
        corners = drawing.corners
        width, height = CAMERAS[int(rng.integers(len(CAMERAS)))]
        # Where the grid lands in the frame: a turn of up to 35 degrees and a perspective tilt
        # of the camera, then a size at which the box round the grid covers 15-60% of the
        # frame (and fits in it).
        angle = np.deg2rad(rng.uniform(-35, 35))
        centre = corners.mean(axis=0)
        sheet_corners = np.array([[0, 0], [SHEET, 0], [SHEET, SHEET], [0, SHEET]], np.float64)
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        away = rng.uniform(0, 0.35)  # one side of the sheet further from the camera
        direction = rng.uniform(0, 2 * np.pi)
        unit = np.array([np.cos(direction), np.sin(direction)])

        reach = np.abs(((sheet_corners - centre) @ rot.T) @ unit).max()

        def seen_from_camera(points: np.ndarray) -> np.ndarray:
            turned = (points - centre) @ rot.T
            return turned / (1 + away * (turned @ unit) / reach)[:, None]

        placed, grid_in = seen_from_camera(sheet_corners), seen_from_camera(corners)
        box = np.ptp(grid_in, axis=0)
        scale = np.sqrt(rng.uniform(0.15, 0.6) * width * height / (box[0] * box[1]))
        scale = min(scale, 0.95 * width / box[0], 0.95 * height / box[1])
        placed, grid_in = placed * scale, grid_in * scale
        # Move so that the grid's box is in view, with an occasional grid cut by the frame.
        low, high = grid_in.min(axis=0), grid_in.max(axis=0)
        margin = -0.04 * (high - low) if rng.random() < 0.15 else np.zeros(2)
        lo = -low + margin
        hi = np.array([width, height]) - high - margin
        offset = np.array(
            [rng.uniform(min(lo[k], hi[k]), max(lo[k], hi[k])) for k in range(2)], np.float64
        )
        frame_corners = (placed + offset).astype(np.float32)
        homography = cv2.getPerspectiveTransform(sheet_corners.astype(np.float32), frame_corners)
        grid_frame = cv2.perspectiveTransform(
            corners.reshape(-1, 1, 2).astype(np.float32), homography
        ).reshape(-1, 2)
        box = np.ptp(grid_frame, axis=0)
        grid_frac = float(box[0] * box[1] / (width * height))

        desk = _desk(papers, rng, (height, width))
        # Light: a slope across the frame, a soft shadow (a hand, the phone), a colour cast.
        yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
        slope_dir = rng.uniform(0, 2 * np.pi)
        ramp = (np.cos(slope_dir) * xx / width + np.sin(slope_dir) * yy / height) * rng.uniform(
            0, 0.45
        )
        light = 1.0 - ramp + ramp.mean()
        if rng.random() < 0.5:
            sx, sy = rng.uniform(0, width), rng.uniform(0, height)
            radius = rng.uniform(0.15, 0.45) * max(width, height)
            blob = np.exp(-(((xx - sx) ** 2 + (yy - sy) ** 2) / (2 * radius**2)))
            light = light * (1 - rng.uniform(0.15, 0.45) * blob)
        cast = rng.uniform(0.88, 1.08, 3).astype(np.float32)
        light = light[:, :, None] * cast * rng.uniform(0.75, 1.1)
        # Optics: defocus or shake.
        if rng.random() < 0.5:
            blur = ("defocus", float(rng.uniform(0.4, 1.6)), 0.0)
        else:
            blur = ("shake", float(rng.integers(2, 7)), float(rng.uniform(0, 180)))
        notes = {
            "paper": drawing.paper_name,
            "ink": drawing.ink,
            "grid_frac": f"{grid_frac:.2f}",
            "notes": (
                f"{width}x{height} JPEG {{quality}}; turned {np.rad2deg(angle):.0f} deg; "
                f"perspective {away:.2f}"
            ),
        }
        return cls(width, height, homography, desk, light, blur, rng.uniform(1, 6), notes)

    def see(self, sheet: np.ndarray) -> np.ndarray:
        """The sheet (float32 RGB) as this camera's optics bring it to the sensor: on the desk,
        in its light, defocused or shaken (float32 RGB, the frame's size)."""
        size = (self.width, self.height)
        seen = cv2.warpPerspective(sheet, self.homography, size, flags=cv2.INTER_AREA)
        cover = cv2.warpPerspective(
            np.ones((SHEET, SHEET), np.float32), self.homography, size, flags=cv2.INTER_LINEAR
        )[:, :, None]
        frame = (self.desk * (1 - cover) + seen * cover) * self.light
        kind, a, b = self.blur
        if kind == "defocus":
            frame = cv2.GaussianBlur(frame, (0, 0), a)
        else:
            length = int(a)
            kernel = np.zeros((length, length), np.float32)
            kernel[length // 2, :] = 1 / length
            turn = cv2.getRotationMatrix2D((length / 2 - 0.5, length / 2 - 0.5), b, 1)
            kernel = cv2.warpAffine(kernel, turn, (length, length))
            frame = cv2.filter2D(frame, -1, kernel / max(kernel.sum(), 1e-9))
        return frame

    def photograph(
        self, seen: np.ndarray, rng: np.random.Generator, quality: int | None = None
    ) -> tuple[np.ndarray, int]:
        """What the sensor records of `seen` (`see`): RGB uint8 with fresh sensor noise, saved
        as JPEG at `quality` (drawn from `rng` if None); and that quality. Frames of a still
        camera differ only here."""
        frame = seen + rng.normal(0, self.noise, seen.shape).astype(np.float32)
        frame = np.clip(frame, 0, 255).astype(np.uint8)
        if quality is None:
            quality = int(rng.integers(35, 92))
        ok, data = cv2.imencode(".jpg", frame[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, quality])
        assert ok
        return cv2.imdecode(data, cv2.IMREAD_COLOR)[:, :, ::-1], quality


@dataclass(frozen=True)
class ComposedBoard:
    """One composed photo of a board and its truth."""

    photo: np.ndarray
    """RGB uint8."""
    labels: list[str]
    """The 9 cells, row by row."""
    notes: dict[str, str]
    """What it shows: paper, ink, the grid's share of the frame, camera."""
    lattice: np.ndarray
    """(4, 4, 2) photo pixels (x, y): the cell corners, `lattice[r, c]` at cell units x=c,
    y=r, as `oxbot.perception.grid.Grid.lattice` has them. Pixel centres are at integers."""


def compose_board(
    rng: np.random.Generator, hands: HandwritingSource, papers: PaperSource
) -> ComposedBoard:
    """One photo of a board with its labels and where its grid lies."""
    drawing = _sheet(hands, papers, rng)
    camera = _Camera.sample(rng, drawing, papers)
    photo, quality = camera.photograph(camera.see(drawing.inked()), rng)
    notes = dict(camera.notes, notes=camera.notes["notes"].format(quality=quality))
    lattice = cv2.perspectiveTransform(
        drawing.lattice.reshape(-1, 1, 2).astype(np.float64), camera.homography
    ).reshape(4, 4, 2)
    return ComposedBoard(photo, drawing.labels, notes, lattice)


def compose(
    rng: np.random.Generator, hands: HandwritingSource, papers: PaperSource
) -> tuple[np.ndarray, list[str], dict[str, str]]:
    """One photo of a board: RGB uint8, its 9 labels row by row, and what it shows."""
    board = compose_board(rng, hands, papers)
    return board.photo, board.labels, board.notes


def compose_game(
    rng: np.random.Generator,
    hands: HandwritingSource,
    papers: PaperSource,
    labels: list[str],
    order: list[int],
    frames: int,
) -> tuple[list[list[np.ndarray]], dict[str, str]]:
    """Photos of one sheet as a game is played on it, from a camera held still: the board
    `labels` (row by row) drawn one symbol at a time in the cells of `order`. For each stage
    (nothing drawn, then each cell of `order` added in turn), `frames` photos that differ
    only in sensor noise; and what they show."""
    drawing = _sheet(hands, papers, rng, labels)
    camera = _Camera.sample(rng, drawing, papers)
    quality = int(rng.integers(35, 92))
    stages = []
    for drawn in range(len(order) + 1):
        seen = camera.see(drawing.inked(order[:drawn]))
        stages.append([camera.photograph(seen, rng, quality)[0] for _ in range(frames)])
    notes = dict(camera.notes, notes=camera.notes["notes"].format(quality=quality))
    return stages, notes


def write_set(
    out: str | Path,
    hands: HandwritingSource,
    papers: PaperSource,
    n: int,
    seed: int,
    split: str,
) -> Path:
    """`n` photos of the `split` part's drawings on `papers` in `out/images`,
    `out/labels.csv` (bench/bench_real_boards.py's format; each photo its own board) and
    `out/lattices.json` (`LATTICES`): each photo's name to its `ComposedBoard.lattice`."""
    out = Path(out)
    (out / "images").mkdir(parents=True, exist_ok=True)
    hands = hands.split(split)
    rng = np.random.default_rng([seed, 0 if split == "dev" else 1])
    rows, lattices = [], {}
    for i in range(n):
        board = compose_board(rng, hands, papers)
        photo, labels, notes = board.photo, board.labels, board.notes
        name = f"{split}_{i:04d}.png"
        lattices[name] = np.round(board.lattice, 3).tolist()
        ok, data = cv2.imencode(".png", photo[:, :, ::-1])
        assert ok
        with atomic_write(out / "images" / name) as handle:
            handle.write(data.tobytes())
        rows.append(
            {
                "file": name,
                "board": f"{split}-{i}",
                "split": split,
                **{k: notes[k] for k in ("paper", "ink", "grid_frac", "notes")},
                **dict(zip(CELLS, labels, strict=True)),
            }
        )
    labels_path = out / "labels.csv"
    existing = []
    if labels_path.is_file():
        with labels_path.open(newline="", encoding="utf-8") as handle:
            existing = [r for r in csv.DictReader(handle) if r["split"] != split]
    with atomic_write(labels_path, "w") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(existing + rows)
    lattices_path = out / LATTICES
    if lattices_path.is_file():
        kept = json.loads(lattices_path.read_text(encoding="utf-8"))
        lattices = {k: v for k, v in kept.items() if not k.startswith(f"{split}_")} | lattices
    with atomic_write(lattices_path, "w") as handle:
        json.dump(lattices, handle)
    return labels_path


def symbol_cells(
    hands: HandwritingSource, papers: PaperSource, rng: np.random.Generator, side: int = 40
) -> tuple[np.ndarray, list[str], list[str]]:
    """Every circle and cross of `hands` alone in a cell, as the board reader cuts one: a
    square of paper `side` pixels wide (gray, the darkest channel, as the reader sees ink of
    any colour), the symbol 72% as wide as the cell in a pen of random width, slightly
    blurred. uint8 (N, side, side), the labels, and the writers."""
    up = 6
    kinds = [k for k in PAPER_KINDS if k in papers.photos]
    cells, labels, writers = [], [], []
    for label in ("circle", "cross"):
        for strokes, writer in zip(hands.drawings[label], hands.writers[label], strict=True):
            kind = kinds[int(rng.integers(len(kinds)))]
            photo = papers.photos[kind][int(rng.integers(len(papers.photos[kind])))][1]
            paper = _crop(photo, rng, side * up).astype(np.float32).min(axis=2)
            mask = np.zeros(paper.shape, np.float32)
            fitted = _fit(strokes)
            half = 0.36 * side * up
            placed = [s * half + side * up / 2 for s in fitted]
            _draw(mask, placed, rng.uniform(0.04, 0.1) * side * up, up=1)
            ink = paper * (1 - rng.uniform(0.7, 0.95) * mask)
            cell = cv2.resize(ink, (side, side), interpolation=cv2.INTER_AREA)
            cell = cv2.GaussianBlur(cell, (0, 0), rng.uniform(0.3, 0.8))
            cells.append(np.clip(cell, 0, 255).astype(np.uint8))
            labels.append(label)
            writers.append(writer)
    return np.stack(cells), labels, writers
