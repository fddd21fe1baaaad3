"""The size of an encoded image, read from its header before any pixel is decoded.

A PNG of a few kilobytes can declare 20000x20000 pixels and take gigabytes to decode (a
"decompression bomb"). Every place that decodes an image it was handed — a web page's frames,
`oxbot see`, image folders, encoded bus frames, seed folders — asks `check_pixels` first:

    size = check_pixels(data, "photo.png")   # (width, height), or None if not an image
    image = cv2.imdecode(...)                 # safe: at most MAX_PIXELS pixels

Only formats Pillow can identify are decoded, so that every size is known first.
"""

from __future__ import annotations

import io
import re

from PIL import Image, UnidentifiedImageError

from oxbot.errors import InvalidInputError

MAX_PIXELS = 50_000_000
"""oxbot: the most pixels an image may have (a 50-megapixel photo, 150 MB as RGB; phone
cameras give 12-48 MP)."""


def check_pixels(
    data: bytes, what: str = "image", max_pixels: int = MAX_PIXELS
) -> tuple[int, int] | None:
    """The (width, height) that encoded image `data` declares, or None if it is not an image
    Pillow can identify. InvalidInputError naming the size and the limit if it has more than
    `max_pixels` pixels. Reads the header only."""
    try:
        with Image.open(io.BytesIO(data)) as image:  # lazy: parses the header, no pixels
            width, height = image.size
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        # Pillow's own limit (far above ours) refused it before telling us the size
        found = re.search(r"\((\d+) pixels\)", str(exc))
        pixels = f"{int(found[1]):,} pixels" if found else "too many pixels"
        raise InvalidInputError(_too_big(what, pixels, max_pixels)) from None
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError, EOFError):
        return None
    if width * height > max_pixels:
        raise InvalidInputError(_too_big(what, f"{width}x{height} pixels", max_pixels))
    return width, height


def _too_big(what: str, size: str, max_pixels: int) -> str:
    return (
        f"{what} is {size}; the limit is {max_pixels:,} pixels (it would take too much "
        f"memory to decode); give a smaller image"
    )


__all__ = ["MAX_PIXELS", "check_pixels"]
