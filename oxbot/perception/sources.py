"""Where frames come from: a webcam, a video file, a folder of images, or other code.

Every source has the same small interface, and is a context manager:

    with open_source("0") as source:        # webcam 0; or "game.avi", or "photos/"
        for frame in source:                 # uint8 (H, W, 3) RGB until the source ends
            ...

`PushedFrames` is the odd one out: other code (the web page's drawing canvas) pushes frames
into it from another thread, and the reader blocks until the next one arrives.
"""

from __future__ import annotations

import abc
import contextlib
import logging
import queue
import threading
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType

import cv2
import numpy as np

from oxbot.errors import FrameSourceError, InvalidInputError
from oxbot.image_size import MAX_PIXELS, check_pixels

log = logging.getLogger(__name__)

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
"""Files an image folder reads, by suffix (case-insensitive)."""


def load_image(path: str | Path, max_pixels: int = MAX_PIXELS) -> np.ndarray:
    """The image file at `path` as uint8 (H, W, 3) RGB; InvalidInputError if it is unreadable
    or has more than `max_pixels` pixels (checked before decoding)."""
    path = Path(path)
    if not path.is_file():
        raise InvalidInputError(f"image {path} does not exist (or is not a file); check the path")
    data = np.fromfile(path, np.uint8)
    image = None
    if check_pixels(data.tobytes(), f"image {path}", max_pixels) is not None:
        with _quiet_opencv():
            image = cv2.imdecode(data, cv2.IMREAD_COLOR)
    if image is None:
        raise InvalidInputError(
            f"{path} is not an image OpenCV can read (corrupt, truncated or another kind of "
            f"file); give a PNG or JPEG photo"
        )
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


class FrameSource(abc.ABC):
    """A source of uint8 (H, W, 3) RGB frames; `open` it (or use `with`), `read`, `close`."""

    def __init__(self) -> None:
        self._opened = False

    @property
    @abc.abstractmethod
    def name(self) -> str:
        """What the source reads from, for messages."""

    def open(self) -> FrameSource:
        """Get ready to read; FrameSourceError if the source cannot be opened."""
        if not self._opened:
            self._open()
            self._opened = True
        return self

    def close(self) -> None:
        """Release the camera or file; reading afterwards needs `open` again."""
        if self._opened:
            self._close()
            self._opened = False

    def read(self) -> np.ndarray | None:
        """The next frame, or None when the source has no more."""
        if not self._opened:
            raise FrameSourceError(f"{self.name} is not open; use it in a `with` block")
        return self._read()

    def __iter__(self) -> Iterator[np.ndarray]:
        while (frame := self.read()) is not None:
            yield frame

    def __enter__(self) -> FrameSource:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _open(self) -> None:  # noqa: B027 - optional hook
        pass

    def _close(self) -> None:  # noqa: B027 - optional hook
        pass

    @abc.abstractmethod
    def _read(self) -> np.ndarray | None: ...


@contextlib.contextmanager
def _quiet_opencv() -> Iterator[None]:
    """Silence OpenCV's own warnings while probing a device: our error says it better."""
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(level)


class _CaptureSource(FrameSource):
    """A cv2.VideoCapture behind the FrameSource interface."""

    def __init__(self) -> None:
        super().__init__()
        self._capture: cv2.VideoCapture | None = None

    def _close(self) -> None:
        if self._capture is not None:
            self._capture.release()
            self._capture = None

    def _read(self) -> np.ndarray | None:
        assert self._capture is not None
        ok, frame = self._capture.read()
        if not ok or frame is None:
            return None
        return cv2.cvtColor(frame, cv2.COLOR_BGR2RGB)


class CameraSource(_CaptureSource):
    """A webcam, by OpenCV's device index (0 is the first camera)."""

    def __init__(self, index: int = 0, width: int | None = None, height: int | None = None):
        super().__init__()
        if isinstance(index, bool) or not isinstance(index, int) or index < 0:
            raise FrameSourceError(f"camera index must be a whole number 0 or more; got {index!r}")
        self.index, self.width, self.height = index, width, height

    @property
    def name(self) -> str:
        return f"camera {self.index}"

    def _open(self) -> None:
        with _quiet_opencv():
            capture = cv2.VideoCapture(self.index)
        if not capture.isOpened():
            capture.release()
            raise FrameSourceError(
                f"camera {self.index} does not exist or cannot be opened; plug a webcam in, "
                f"check that no other program uses it, or try another index (0 is the first)"
            )
        if self.width:
            capture.set(cv2.CAP_PROP_FRAME_WIDTH, self.width)
        if self.height:
            capture.set(cv2.CAP_PROP_FRAME_HEIGHT, self.height)
        self._capture = capture


class VideoFileSource(_CaptureSource):
    """A video file, frame by frame, at the pace the reader asks for them."""

    def __init__(self, path: str | Path) -> None:
        super().__init__()
        self.path = Path(path)

    @property
    def name(self) -> str:
        return f"video {self.path}"

    @property
    def fps(self) -> float:
        """Frames per second the video was recorded at (0 if it does not say)."""
        return float(self._capture.get(cv2.CAP_PROP_FPS)) if self._capture is not None else 0.0

    def _open(self) -> None:
        if not self.path.is_file():
            raise FrameSourceError(f"video {self.path} does not exist; check the path")
        with _quiet_opencv():
            capture = cv2.VideoCapture(str(self.path))
        ok = capture.isOpened()
        width = int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)) if ok else 0
        height = int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)) if ok else 0
        if width * height > MAX_PIXELS:  # known from the container, before a frame is decoded
            capture.release()
            raise FrameSourceError(
                f"video {self.path} has {width}x{height} frames; the limit is {MAX_PIXELS:,} "
                f"pixels a frame; give a smaller video"
            )
        if ok:  # some backends "open" anything; a first frame proves it is a video
            ok, _ = capture.read()
            capture.set(cv2.CAP_PROP_POS_FRAMES, 0)
        if not ok:
            capture.release()
            raise FrameSourceError(
                f"video {self.path} cannot be opened: it is corrupt or not a video OpenCV can "
                f"decode (try an .avi or .mp4 file)"
            )
        self._capture = capture


class ImageFolderSource(FrameSource):
    """The images of a folder in name order, one frame each (e.g. a camera's snapshots)."""

    def __init__(self, folder: str | Path) -> None:
        super().__init__()
        self.folder = Path(folder)
        self._files: list[Path] = []
        self._next = 0

    @property
    def name(self) -> str:
        return f"image folder {self.folder}"

    @property
    def files(self) -> list[Path]:
        """The image files the source reads, in order."""
        return list(self._files)

    def _open(self) -> None:
        if not self.folder.is_dir():
            raise FrameSourceError(f"image folder {self.folder} does not exist; check the path")
        self._files = sorted(
            p for p in self.folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file()
        )
        if not self._files:
            raise FrameSourceError(
                f"image folder {self.folder} holds no images ({', '.join(IMAGE_SUFFIXES)})"
            )
        self._next = 0

    def _read(self) -> np.ndarray | None:
        if self._next >= len(self._files):
            return None
        path = self._files[self._next]
        self._next += 1
        return load_image(path)


class PushedFrames(FrameSource):
    """Frames handed over by other code, e.g. the web page's canvas, from any thread.

    `push(frame)` adds one (dropping the oldest if the reader falls `capacity` frames behind,
    as a live camera would); `finish()` ends the stream; `read(timeout)` waits for the next.
    """

    _END = object()

    def __init__(self, capacity: int = 4, name: str = "pushed frames") -> None:
        super().__init__()
        if capacity < 1:
            raise FrameSourceError(f"capacity must be at least 1; got {capacity}")
        self._queue: queue.Queue[object] = queue.Queue(maxsize=capacity)
        self._lock = threading.Lock()
        self._name = name
        self._finished = False

    @property
    def name(self) -> str:
        return self._name

    def push(self, frame: np.ndarray) -> None:
        """Hand over one uint8 (H, W, 3) RGB or (H, W) grayscale frame."""
        if self._finished:
            raise FrameSourceError(f"{self.name} has finished; no more frames can be pushed")
        if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8 or frame.size == 0:
            raise InvalidInputError(
                "a pushed frame must be a non-empty uint8 numpy array (H, W, 3) RGB or (H, W)"
            )
        if frame.ndim == 2:
            frame = cv2.cvtColor(frame, cv2.COLOR_GRAY2RGB)
        elif frame.ndim != 3 or frame.shape[2] != 3:
            raise InvalidInputError(
                f"a pushed frame has shape {frame.shape}; give (H, W, 3) RGB or (H, W) gray"
            )
        self._put(frame.copy())

    def finish(self) -> None:
        """No more frames: the reader gets None once it has read the ones already pushed."""
        self._finished = True
        self._put(self._END)

    def _put(self, item: object) -> None:
        with self._lock:
            while True:
                try:
                    self._queue.put_nowait(item)
                    return
                except queue.Full:
                    with contextlib.suppress(queue.Empty):
                        dropped = self._queue.get_nowait()
                        if dropped is self._END:  # never drop the end marker
                            self._queue.put_nowait(dropped)
                            return

    def read(self, timeout: float | None = None) -> np.ndarray | None:
        """The next pushed frame; None once finished, or if `timeout` seconds pass first."""
        if not self._opened:
            raise FrameSourceError(f"{self.name} is not open; use it in a `with` block")
        try:
            item = self._queue.get(timeout=timeout)
        except queue.Empty:
            return None
        if item is self._END:
            self._put(self._END)  # later reads end too
            return None
        assert isinstance(item, np.ndarray)
        return item

    def _read(self) -> np.ndarray | None:
        return self.read()


def open_source(spec: str | int | Path) -> FrameSource:
    """A source from a command-line spec: a camera index ("0"), a folder, or a video file."""
    if isinstance(spec, int) or (isinstance(spec, str) and spec.strip().isdigit()):
        return CameraSource(int(spec))
    path = Path(spec)
    if path.is_dir():
        return ImageFolderSource(path)
    return VideoFileSource(path)
