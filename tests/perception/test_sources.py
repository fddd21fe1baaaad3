import threading

import cv2
import numpy as np
import pytest

from oxbot.errors import FrameSourceError, InvalidInputError
from oxbot.perception.sources import (
    CameraSource,
    FrameSource,
    ImageFolderSource,
    PushedFrames,
    VideoFileSource,
    load_image,
    open_source,
)


def solid(value: int, size: tuple[int, int] = (48, 64)) -> np.ndarray:
    """An RGB frame whose red channel is `value`, green 10, blue 200."""
    frame = np.zeros((*size, 3), np.uint8)
    frame[..., 0], frame[..., 1], frame[..., 2] = value, 10, 200
    return frame


def write_png(path, rgb: np.ndarray) -> None:
    assert cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


def test_load_image_gives_rgb(tmp_path):
    write_png(tmp_path / "a.png", solid(120))
    image = load_image(tmp_path / "a.png")
    assert image.dtype == np.uint8 and image.shape == (48, 64, 3)
    assert tuple(image[0, 0]) == (120, 10, 200)


def test_load_image_refuses_a_corrupt_file_and_a_missing_one(tmp_path):
    good = cv2.imencode(".png", solid(50))[1].tobytes()
    (tmp_path / "cut.png").write_bytes(good[: len(good) // 3])
    (tmp_path / "notes.jpg").write_text("not an image at all")
    (tmp_path / "empty.png").write_bytes(b"")
    for name in ("cut.png", "notes.jpg", "empty.png"):
        with pytest.raises(InvalidInputError, match="not an image OpenCV can read"):
            load_image(tmp_path / name)
    with pytest.raises(InvalidInputError, match="does not exist"):
        load_image(tmp_path / "missing.png")


def test_image_folder_reads_images_in_name_order_and_skips_other_files(tmp_path):
    for i, value in enumerate((30, 60, 90)):
        write_png(tmp_path / f"frame{i:02d}.png", solid(value))
    (tmp_path / "readme.txt").write_text("not a frame")
    with ImageFolderSource(tmp_path) as source:
        frames = list(source)
        assert [f.name for f in source.files] == ["frame00.png", "frame01.png", "frame02.png"]
    assert [int(f[0, 0, 0]) for f in frames] == [30, 60, 90]


def test_image_folder_errors_name_the_problem(tmp_path):
    with pytest.raises(FrameSourceError, match="does not exist"):
        ImageFolderSource(tmp_path / "nowhere").open()
    with pytest.raises(FrameSourceError, match="holds no images"):
        ImageFolderSource(tmp_path).open()
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    with ImageFolderSource(tmp_path) as source, pytest.raises(InvalidInputError, match="broken"):
        source.read()


def test_video_file_frames_come_out_rgb_in_order(tmp_path):
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (64, 48))
    for value in (40, 120, 200):
        writer.write(cv2.cvtColor(solid(value), cv2.COLOR_RGB2BGR))
    writer.release()
    with VideoFileSource(path) as video:
        assert video.fps == pytest.approx(10)
        frames = list(video)
    assert len(frames) == 3
    assert all(f.shape == (48, 64, 3) and f.dtype == np.uint8 for f in frames)
    reds = [int(f[..., 0].mean()) for f in frames]
    assert [abs(r - v) <= 8 for r, v in zip(reds, (40, 120, 200), strict=True)] == [True] * 3
    assert int(frames[0][..., 2].mean()) > 180  # blue stays blue: BGR was converted


def test_a_video_that_cannot_be_opened_is_a_clear_error(tmp_path):
    (tmp_path / "broken.avi").write_bytes(b"RIFF" + bytes(range(256)) * 8)
    with pytest.raises(FrameSourceError, match="cannot be opened"):
        VideoFileSource(tmp_path / "broken.avi").open()
    with pytest.raises(FrameSourceError, match="does not exist"):
        VideoFileSource(tmp_path / "missing.mp4").open()


def test_a_camera_that_does_not_exist_is_a_clear_error():
    with pytest.raises(FrameSourceError, match="camera 97 does not exist"), CameraSource(97):
        pass
    with pytest.raises(FrameSourceError, match="whole number"):
        CameraSource(-1)


def test_reading_a_closed_source_says_to_open_it(tmp_path):
    write_png(tmp_path / "a.png", solid(1))
    source = ImageFolderSource(tmp_path)
    with pytest.raises(FrameSourceError, match="not open"):
        source.read()
    with source:
        assert source.read() is not None
    with pytest.raises(FrameSourceError, match="not open"):
        source.read()


def test_pushed_frames_cross_threads_and_end_on_finish():
    frames = PushedFrames(capacity=8)

    def producer() -> None:
        for value in range(5):
            frames.push(solid(value * 10))
        frames.push(np.full((48, 64), 77, np.uint8))  # grayscale becomes RGB
        frames.finish()

    with frames:
        thread = threading.Thread(target=producer, name="canvas")
        thread.start()
        received = list(frames)
        thread.join(timeout=5)
    assert [int(f[0, 0, 0]) for f in received] == [0, 10, 20, 30, 40, 77]
    assert received[-1].shape == (48, 64, 3)
    with pytest.raises(FrameSourceError, match="finished"):
        frames.push(solid(1))


def test_pushed_frames_drop_the_oldest_when_the_reader_falls_behind():
    frames = PushedFrames(capacity=2)
    for value in (1, 2, 3, 4):
        frames.push(solid(value))
    with frames:
        assert [int(frames.read()[0, 0, 0]) for _ in range(2)] == [3, 4]
        assert frames.read(timeout=0.05) is None  # nothing more yet


def test_pushed_frames_refuse_what_is_not_a_frame():
    frames = PushedFrames()
    for bad in (np.zeros((4, 4, 3), np.float32), np.zeros((0, 4, 3), np.uint8), [[1, 2]]):
        with pytest.raises(InvalidInputError):
            frames.push(bad)  # type: ignore[arg-type]
    with pytest.raises(InvalidInputError, match="shape"):
        frames.push(np.zeros((4, 4, 4), np.uint8))


def test_open_source_picks_the_kind_of_source(tmp_path):
    assert isinstance(open_source("0"), CameraSource)
    assert isinstance(open_source(2), CameraSource)
    assert isinstance(open_source(tmp_path), ImageFolderSource)
    assert isinstance(open_source(tmp_path / "game.mp4"), VideoFileSource)
    assert all(issubclass(c, FrameSource) for c in (CameraSource, PushedFrames))
