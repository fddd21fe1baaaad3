"""Head-move recognition: where the person's head points, from webcam frames (paper §3.1).

The paper read the head from a Kinect's depth images with random forests and mapped it to
left / right / up / down / centre by thresholds. oxbot finds the face with OpenCV's Haar
cascades (frontal, then profile both ways round; they ship in opencv-python-headless 4.x as
`cv2.data`) and compares the face's centre with a calibrated centre: the first few detections,
or an explicit `calibrate(frame)` while the person looks at the robot. Offsets are measured in
face widths, so the thresholds hold whether the person sits near the camera or far from it.

Directions are the person's own: a camera facing them sees their left on the image's right.
Set `mirrored=True` for a camera that already flips its image like a mirror.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from oxbot.config import HeadConfig
from oxbot.errors import FrameSourceError, InvalidInputError
from oxbot.perception.sources import FrameSource, PushedFrames
from oxbot.robot.bus import Bus, Component
from oxbot.robot.frames import check_frame, frame_pixels
from oxbot.robot.messages import Direction, HeadDirection, Message, PersonFrame

log = logging.getLogger(__name__)

FRONTAL_CASCADE = "haarcascade_frontalface_default.xml"
PROFILE_CASCADE = "haarcascade_profileface.xml"


@dataclass(frozen=True)
class Face:
    """A face found in a frame, in the frame's pixels."""

    x: float
    y: float
    width: float
    height: float

    @property
    def centre(self) -> tuple[float, float]:
        return self.x + self.width / 2, self.y + self.height / 2


class FaceDetector:
    """The largest face in a frame, by OpenCV's frontal cascade and then its profile cascade."""

    def __init__(self, config: HeadConfig | None = None) -> None:
        self.config = config if config is not None else HeadConfig()
        self._frontal = _cascade(FRONTAL_CASCADE)
        self._profile = _cascade(PROFILE_CASCADE)

    def find(self, frame: np.ndarray) -> Face | None:
        """The largest face in a uint8 RGB or gray frame, or None."""
        gray = _gray(frame)
        scale = min(1.0, self.config.detection_width / gray.shape[1])
        if scale < 1.0:
            gray = cv2.resize(gray, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        size = (self.config.min_face, self.config.min_face)
        boxes = list(self._frontal.detectMultiScale(gray, 1.1, 5, minSize=size))
        if not boxes:
            # The profile cascade knows faces turned one way only; look at the mirror image too.
            boxes = list(self._profile.detectMultiScale(gray, 1.1, 5, minSize=size))
            width = gray.shape[1]
            mirror = np.ascontiguousarray(gray[:, ::-1])
            for x, y, w, h in self._profile.detectMultiScale(mirror, 1.1, 5, minSize=size):
                boxes.append((width - x - w, y, w, h))
        if not boxes:
            return None
        x, y, w, h = max(boxes, key=lambda b: b[2] * b[3])
        return Face(x / scale, y / scale, w / scale, h / scale)


class HeadTracker:
    """Frames in, head directions out: `direction(frame)` is left/right/up/down/centre or None.

    Until the centre is known the tracker gathers it from the first detections (answering
    "centre" meanwhile), unless `calibrate(frame)` sets it at once.
    """

    def __init__(self, config: HeadConfig | None = None) -> None:
        self.config = config if config is not None else HeadConfig()
        self.detector = FaceDetector(self.config)
        self.centre: tuple[float, float] | None = None
        self._samples: list[tuple[float, float]] = []

    @property
    def calibrated(self) -> bool:
        return self.centre is not None

    def calibrate(self, frame: np.ndarray) -> tuple[float, float]:
        """Take the face in `frame` as looking straight ahead; its centre, in pixels."""
        face = self.detector.find(frame)
        if face is None:
            raise InvalidInputError(
                "no face in the calibration frame; look at the camera, in good light"
            )
        self.centre = face.centre
        self._samples.clear()
        return self.centre

    def reset(self) -> None:
        """Forget the centre: the next detections calibrate again."""
        self.centre = None
        self._samples.clear()

    def direction(self, frame: np.ndarray) -> Direction | None:
        """Where the head in `frame` points, from the person's point of view; None if no face."""
        face = self.detector.find(frame)
        if face is None:
            return None
        if self.centre is None:
            self._samples.append(face.centre)
            if len(self._samples) >= self.config.calibration_detections:
                xs, ys = zip(*self._samples, strict=True)
                self.centre = (float(np.mean(xs)), float(np.mean(ys)))
                self._samples.clear()
            return "centre"
        return self.classify(face)

    def classify(self, face: Face) -> Direction:
        """The direction of `face` relative to the calibrated centre."""
        assert self.centre is not None, "calibrate first"
        cx, cy = face.centre
        dx = (cx - self.centre[0]) / face.width
        dy = (cy - self.centre[1]) / face.height
        # How far past its threshold each axis is; the one further past decides.
        over_x = abs(dx) / self.config.horizontal_threshold
        over_y = abs(dy) / self.config.vertical_threshold
        if max(over_x, over_y) < 1.0:
            return "centre"
        if over_x >= over_y:
            # A camera facing the person sees their left on the right of its image.
            image_right = dx > 0
            return "right" if image_right == self.config.mirrored else "left"
        return "up" if dy < 0 else "down"


class HeadTrackingComponent(Component):
    """Publishes HeadDirection whenever the person's head direction changes.

    Frames come from `source` (a webcam, a video, an image folder), one per `period`, or, when
    no source is given, from PersonFrame messages (or `push(frame)`). A frame without a face
    changes nothing. A source that cannot be opened is reported by one warning and then left
    alone.
    """

    listens_to = (PersonFrame,)
    period = 0.1  # 10 Hz, the rate the game-move recognition reads frames at
    part = "head tracking"
    essential = False  # the head only mirrors the person; the game does not need it

    def __init__(
        self,
        bus: Bus,
        tracker: HeadTracker | None = None,
        source: FrameSource | None = None,
        name: str | None = None,
    ) -> None:
        super().__init__(bus, name)
        self.tracker = tracker or HeadTracker()
        self._pushed = source is None
        self.source: FrameSource = source if source is not None else PushedFrames(capacity=64)
        self.current: Direction | None = None
        self._unavailable = False

    def push(self, frame: np.ndarray) -> None:
        """Hand over one frame (only when the component was made without a source)."""
        if not isinstance(self.source, PushedFrames):
            raise FrameSourceError(f"{self.name} reads {self.source.name}; frames cannot be pushed")
        self.source.push(frame)

    def take_over(self, old: Component) -> None:
        assert isinstance(old, HeadTrackingComponent)
        self.current, self._unavailable = old.current, old._unavailable

    def handle(self, message: Message) -> None:
        if isinstance(message, PersonFrame) and self._pushed:
            self.push(frame_pixels(message))

    def tick(self) -> None:
        if self._unavailable:
            return
        try:
            self.source.open()
        except FrameSourceError as exc:
            self._unavailable = True
            log.warning("head tracking is off: %s", exc)
            return
        if isinstance(self.source, PushedFrames):
            while (frame := self.source.read(timeout=0)) is not None:
                self.see(frame)
            return
        frame = self.source.read()
        if frame is None:
            self._unavailable = True
            log.info("%s has no more frames; head tracking stops", self.source.name)
            return
        self.see(frame)

    def see(self, frame: np.ndarray) -> Direction | None:
        """Track one frame; publish HeadDirection if the direction changed."""
        direction = self.tracker.direction(frame)
        if direction is not None and direction != self.current:
            self.current = direction
            self.bus.publish(HeadDirection(direction=direction))
        return direction

    def stop(self, timeout: float = 2.0) -> None:
        super().stop(timeout)
        self.source.close()


def _cascade(name: str) -> cv2.CascadeClassifier:
    path = cv2.data.haarcascades + name
    cascade = cv2.CascadeClassifier(path)
    if cascade.empty():
        raise FrameSourceError(
            f"OpenCV's Haar cascade {path} is missing; install opencv-python-headless>=4.8,<5 "
            "(5.0 dropped the cascades from the main package)"
        )
    return cascade


def _gray(frame: np.ndarray) -> np.ndarray:
    frame = check_frame(frame)
    return frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)
