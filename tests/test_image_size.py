"""Images with too many pixels are refused from their header, before decoding, on every path."""

from __future__ import annotations

import base64
import io
import resource

import cv2
import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from oxbot.cli import app
from oxbot.config import WebConfig
from oxbot.errors import DataError, InvalidInputError
from oxbot.image_size import check_pixels
from oxbot.perception.seeds import load_seeds
from oxbot.perception.sources import ImageFolderSource, load_image
from oxbot.robot.frames import frame_pixels
from oxbot.robot.messages import Frame
from oxbot.testing.hostile import decompression_bomb
from oxbot.web.inbound import decode_image

BOMB = decompression_bomb(20_000)
"""48 KB that would decode to 400 million pixels."""


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def png(width: int, height: int) -> bytes:
    buffer = io.BytesIO()
    Image.new("RGB", (width, height), "white").save(buffer, format="PNG")
    return buffer.getvalue()


def test_check_pixels_reads_the_size_from_the_header_and_names_the_limit():
    assert check_pixels(png(64, 48)) == (64, 48)
    assert check_pixels(b"not an image") is None
    with pytest.raises(InvalidInputError, match=r"is 64x48 pixels; the limit is 3,000 pixels"):
        check_pixels(png(64, 48), max_pixels=3000)
    # beyond Pillow's own bomb limit it refuses before giving a size; ours still says the count
    with pytest.raises(InvalidInputError, match=r"400,000,000 pixels; the limit is 50,000,000"):
        check_pixels(BOMB, "bomb.png")


def test_every_path_refuses_a_decompression_bomb_without_decoding_it(tmp_path):
    before = peak_rss_mb()
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(BOMB)
    with pytest.raises(InvalidInputError, match=r"bomb\.png is 400,000,000 pixels"):
        load_image(bomb)
    with pytest.raises(InvalidInputError, match="the limit"), ImageFolderSource(tmp_path) as source:
        source.read()
    with pytest.raises(InvalidInputError, match="PNG frame is 400,000,000 pixels"):
        frame_pixels(Frame(image=BOMB, format="png"))
    with pytest.raises(InvalidInputError, match=r"'image' is 400,000,000 pixels"):
        decode_image(base64.b64encode(BOMB).decode(), WebConfig())
    for label in ("circle", "cross", "nothing"):
        (tmp_path / "seeds" / label).mkdir(parents=True)
        cv2.imwrite(str(tmp_path / "seeds" / label / "a.png"), np.full((40, 40), 255, np.uint8))
    (tmp_path / "seeds" / "cross" / "b.png").write_bytes(BOMB)
    with pytest.raises(DataError, match=r"b\.png is 400,000,000 pixels"):
        load_seeds(tmp_path / "seeds")
    # decoding any of them would have taken 400 MB or more
    assert peak_rss_mb() - before < 100


def test_see_reports_a_decompression_bomb_as_an_error_not_a_traceback(tmp_path):
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(BOMB)
    result = CliRunner().invoke(app, ["see", str(bomb)])
    assert result.exit_code == 2
    assert "bomb.png is 400,000,000 pixels; the limit is 50,000,000" in result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)


def test_images_under_the_limit_still_load(tmp_path):
    path = tmp_path / "sheet.png"
    path.write_bytes(png(640, 480))
    assert load_image(path).shape == (480, 640, 3)
    assert frame_pixels(Frame(image=png(64, 48), format="png")).shape == (48, 64, 3)
