"""A fake webcam for paper mode: a Y4M video of a rendered sheet on which symbols appear
stroke by stroke, for Chromium's `--use-file-for-fake-video-capture`.

    video = PaperVideo(seed=3)
    video.hold(2.0)                         # the empty grid
    video.draw("middle", "cross")           # stroke by stroke, the pen lifting between
    video.hold(4.0)
    video.write_y4m(path)                   # 640x480, 10 frames a second
    video.symbols[0].complete_frame         # the first frame showing the whole cross

The sheet is `oxbot.testing.render`'s (paper on a desk, a hand-drawn grid, the tuning style's
pens), upright and whole in view, as a person holds a phone or a laptop camera over it. Every
frame carries its own index as a strip of blocks on the desk below the sheet (`frame_index`
reads it back from a frame, at any scale), so a test can tell which moment of the video the
robot was looking at. Besides the sheet, `show` puts frames the robot cannot read in the
video: an empty desk, the sheet partly out of frame, too dark, blurred, a hand over it.

Chromium plays the file from its first frame when the page opens the camera, and loops it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from oxbot.errors import InvalidInputError
from oxbot.game.board import cell_index
from oxbot.testing.render import TUNING_STYLE, HandStyle, SheetScene, random_scene

View = Literal["sheet", "no_grid", "off_edge", "dark", "blurred", "hand"]
"""What a frame shows: the sheet as it is, or one of the frames the robot cannot read."""

STYLE = dataclasses.replace(
    TUNING_STYLE,
    name="webcam",
    max_rotation=3.0,
    perspective=0.0,
    light_gradient=(0.0, 0.1),
    brightness=(0.95, 1.0),
    noise_sigma=(1.5, 1.5),
    blur_sigma=(0.3, 0.3),
    jpeg_quality=(90, 90),
    pen_width=(0.045, 0.05),
    hand=dataclasses.replace(
        HandStyle(), symbols="sketch", symbol_size=(0.55, 0.65), symbol_offset=0.05
    ),
)
"""A tidy sheet under a steady camera: the tuning style of the board reader, upright (the grid
finder's own tests cover tilted photos), so that every frame of the sheet is readable."""

BITS = 12
"""Bits of the frame index strip: 4096 frames, 6.8 minutes at 10 frames a second."""
_STRIP = (8 / 640, 446 / 480, 14 / 640, 22 / 480)
"""The index strip's left, top, block width and height, as shares of the frame's size."""


@dataclass
class DrawnSymbol:
    """A symbol the video draws, and when."""

    cell: str
    label: str
    start_frame: int
    """The first frame on which its first stroke shows."""
    complete_frame: int = -1
    """The first frame on which the whole symbol shows (its last stroke finished)."""


class PaperVideo:
    """A scripted video of a sheet: hold, draw, show; then `write_y4m` or `frames`."""

    def __init__(self, seed: int = 0, size: tuple[int, int] = (640, 480), fps: int = 10) -> None:
        if size[0] % 2 or size[1] % 2:
            raise InvalidInputError(f"a Y4M 4:2:0 video needs an even size; got {size}")
        self.fps = fps
        self.size = size
        self.rng = np.random.default_rng(seed)
        style = dataclasses.replace(STYLE, size=size)
        scene = random_scene(
            self.rng, style, grid_fraction=(0.62, 0.62), center=(0.5, 0.47), rotation=1.5
        )
        paper = np.array([[-0.35, -0.35], [3.35, -0.35], [3.35, 3.35], [-0.35, 3.35]])
        self.scene: SheetScene = dataclasses.replace(scene, paper_corners=paper)
        self.symbols: list[DrawnSymbol] = []
        self._progress: dict[int, float] = {}  # cell -> strokes drawn so far
        self._timeline: list[tuple[tuple[tuple[int, float], ...], View]] = []

    # --- the script ---

    @property
    def frame_count(self) -> int:
        return len(self._timeline)

    def hold(self, seconds: float) -> PaperVideo:
        """The sheet as it is, for `seconds`."""
        return self.show("sheet", seconds)

    def show(self, view: View, seconds: float) -> PaperVideo:
        """`view` for `seconds` (the sheet's drawings as they are, where it shows the sheet)."""
        state = tuple(sorted(self._progress.items()))
        self._timeline += [(state, view)] * max(1, round(seconds * self.fps))
        return self

    def draw(
        self, cell: str, label: str, stroke_seconds: float = 0.6, lift_seconds: float = 0.5
    ) -> DrawnSymbol:
        """Draw `label` in `cell` as a hand does: each stroke over `stroke_seconds`, the pen
        lifted for `lift_seconds` between strokes."""
        index = cell_index(cell)
        if index in self._progress:
            raise InvalidInputError(f"the video already has a symbol in {cell}")
        self.scene = self.scene.with_symbol(index, label, self.rng)
        strokes = len(self.scene.symbols[index].strokes)
        symbol = DrawnSymbol(cell, label, start_frame=self.frame_count)
        steps = max(2, round(stroke_seconds * self.fps))
        for k in range(strokes):
            if k:
                self.hold(lift_seconds)
            for step in range(1, steps + 1):
                self._progress[index] = k + step / steps
                if step == steps and k == strokes - 1:
                    self._progress[index] = float(strokes)
                    symbol.complete_frame = self.frame_count
                self._timeline.append((tuple(sorted(self._progress.items())), "sheet"))
        self.symbols.append(symbol)
        return symbol

    # --- the frames ---

    def frames(self):
        """Each frame as uint8 (H, W, 3) RGB, in order (identical frames are one array)."""
        cache: dict[tuple, np.ndarray] = {}
        for index, (state, view) in enumerate(self._timeline):
            key = (state, view)
            if key not in cache:
                cache[key] = self._render(dict(state), view)
            yield stamp_index(cache[key], index)

    def _render(self, progress: dict[int, float], view: View) -> np.ndarray:
        drawn = {cell: progress.get(cell, 0.0) for cell in self.scene.symbols}
        rng = np.random.default_rng(len(progress))
        if view == "no_grid":
            return dataclasses.replace(self.scene, grid_lines=(), symbols={}).photo(rng)
        if view == "off_edge":
            shift = np.array([[1, 0, 0.45 * self.size[0]], [0, 1, 0], [0, 0, 1]])
            moved = dataclasses.replace(self.scene, homography=shift @ self.scene.homography)
            return moved.photo(rng, drawn)
        photo = self.scene.photo(rng, drawn).astype(np.float32)
        if view == "dark":
            photo = photo * 0.05 + rng.normal(0, 2.0, photo.shape)
        elif view == "blurred":
            photo = cv2.GaussianBlur(photo, (0, 0), 0.012 * self.size[0])
        elif view == "hand":
            photo = _hand_over(photo, self.size)
        return np.clip(photo, 0, 255).astype(np.uint8)

    def write_y4m(self, path: str | Path, speed: float = 1.0) -> Path:
        """The video as a Y4M file (4:2:0, BT.601 limited range), as Chromium's fake webcam
        reads it; played `speed` times faster than it was scripted (its frame rate says so),
        so that a test sees the same frames in less time."""
        if not speed > 0:
            raise InvalidInputError(f"a video plays at a positive speed; got {speed}")
        path = Path(path)
        width, height = self.size
        planes: dict[tuple, tuple[np.ndarray, bytes]] = {}  # each distinct picture converted once
        played = Fraction(self.fps * speed).limit_denominator(1000)
        rate = f"{played.numerator}:{played.denominator}"
        with path.open("wb") as out:
            out.write(f"YUV4MPEG2 W{width} H{height} F{rate} Ip A1:1 C420jpeg\n".encode())
            for index, (state, view) in enumerate(self._timeline):
                key = (state, view)
                if key not in planes:
                    yuv = to_yuv420(stamp_index(self._render(dict(state), view), 0))
                    luma = np.frombuffer(yuv[: width * height], np.uint8).reshape(height, width)
                    planes[key] = (luma, yuv[width * height :])
                luma, chroma = planes[key]
                # the strip is grey: only the luma plane changes from frame to frame
                out.write(b"FRAME\n")
                out.write(stamp_index(luma, index, high=231, low=25).tobytes())
                out.write(chroma)
        return path


def to_yuv420(rgb: np.ndarray) -> bytes:
    """An RGB frame as the Y, U and V planes of a 4:2:0 Y4M frame."""
    h, w = rgb.shape[:2]
    r, g, b = (rgb[..., i].astype(np.float32) for i in range(3))
    y = 16 + 0.257 * r + 0.504 * g + 0.098 * b
    u = 128 - 0.148 * r - 0.291 * g + 0.439 * b
    v = 128 + 0.439 * r - 0.368 * g - 0.071 * b
    planes = [y] + [c.reshape(h // 2, 2, w // 2, 2).mean((1, 3)) for c in (u, v)]
    return b"".join(np.clip(p, 0, 255).round().astype(np.uint8).tobytes() for p in planes)


def _hand_over(photo: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """A hand and forearm, skin-coloured, reaching over the sheet from the lower right."""
    width, height = size
    mask = np.zeros((height, width), np.float32)
    arm = np.array([[width, 0.55 * height], [width, height], [0.55 * width, height]])
    palm = (int(0.5 * width), int(0.55 * height))
    cv2.fillConvexPoly(mask, np.round(arm).astype(np.int32), 1.0)
    cv2.ellipse(mask, palm, (int(0.16 * width), int(0.2 * height)), 35, 0, 360, 1.0, -1)
    cv2.line(mask, palm, (int(0.72 * width), int(0.8 * height)), 1.0, int(0.2 * width))
    mask = cv2.GaussianBlur(mask, (0, 0), 3)[..., None]
    skin = np.array([224, 172, 140], np.float32)
    return photo * (1 - mask) + skin * mask


def stamp_index(frame: np.ndarray, index: int, high: int = 250, low: int = 10) -> np.ndarray:
    """`frame` (RGB, or one plane) with `index` written in the strip of blocks below the sheet:
    a white and a black block to calibrate, then BITS blocks, most significant first (white,
    `high`, is 1; black, `low`, is 0)."""
    out = frame.copy()
    h, w = out.shape[:2]
    left, top, block, tall = _STRIP
    bits = [1, 0] + [(index >> (BITS - 1 - k)) & 1 for k in range(BITS)]
    for k, bit in enumerate(bits):
        x0, x1 = round((left + k * block) * w), round((left + (k + 1) * block) * w)
        out[round(top * h) : round((top + tall) * h), x0:x1] = high if bit else low
    return out


def frame_index(frame: np.ndarray) -> int:
    """The index `stamp_index` wrote in `frame` (any scale; RGB or gray)."""
    gray = frame if frame.ndim == 2 else frame.mean(axis=2)
    h, w = gray.shape
    left, top, block, tall = _STRIP
    y = round((top + tall / 2) * h)
    levels = [
        float(gray[y - 1 : y + 2, round((left + (k + 0.5) * block) * w) - 1 :][:, :3].mean())
        for k in range(BITS + 2)
    ]
    threshold = (levels[0] + levels[1]) / 2
    if levels[0] - levels[1] < 60:
        raise InvalidInputError("this frame carries no frame index (no strip below the sheet)")
    value = 0
    for level in levels[2:]:
        value = value * 2 + (level > threshold)
    return value


__all__ = ["STYLE", "DrawnSymbol", "PaperVideo", "frame_index", "stamp_index", "to_yuv420"]
