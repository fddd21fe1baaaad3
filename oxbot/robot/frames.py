"""Images on the bus: a frame as a Frame or PersonFrame message, and back to pixels.

Frames handed over in the same process travel as raw pixels (no encoding, one copy); a PNG or
JPEG, as a web page or another machine sends them, is decoded where it is read.
"""

from __future__ import annotations

import cv2
import numpy as np

from oxbot.errors import InvalidInputError
from oxbot.image_size import check_pixels
from oxbot.robot.messages import Frame, PersonFrame


def check_frame(frame: object) -> np.ndarray:
    """`frame` if it is an image the robot can look at: uint8 (H, W, 3) RGB or (H, W) gray."""
    if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8 or frame.size == 0:
        raise InvalidInputError("a frame must be a non-empty uint8 array, (H, W, 3) RGB or (H, W)")
    if not (frame.ndim == 2 or (frame.ndim == 3 and frame.shape[2] == 3)):
        raise InvalidInputError(f"a frame has shape {frame.shape}; give (H, W, 3) RGB or (H, W)")
    return frame


def frame_message(
    frame: np.ndarray, kind: type[Frame | PersonFrame] = Frame
) -> Frame | PersonFrame:
    """A checked frame as a raw-pixel message of type `kind`."""
    frame = np.ascontiguousarray(check_frame(frame))
    return kind(image=frame.tobytes(), format="raw", shape=tuple(frame.shape))


def frame_pixels(message: Frame | PersonFrame) -> np.ndarray:
    """The image of a Frame or PersonFrame: uint8 RGB (or gray, for a raw gray frame).

    InvalidInputError if its bytes are not the image it says, or too many pixels to decode.
    """
    if message.format == "raw":
        shape = tuple(message.shape)
        if len(shape) not in (2, 3) or int(np.prod(shape)) != len(message.image):
            raise InvalidInputError(
                f"a raw frame of {len(message.image)} bytes does not have the shape {shape}"
            )
        return check_frame(np.frombuffer(message.image, dtype=np.uint8).reshape(shape))
    data = np.frombuffer(message.image, dtype=np.uint8)
    image = None
    if check_pixels(message.image, f"a {message.format.upper()} frame") is not None:
        image = cv2.imdecode(data, cv2.IMREAD_COLOR)
    if image is None:
        raise InvalidInputError(
            f"the frame's {len(message.image)} bytes are not a {message.format.upper()} image"
        )
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
