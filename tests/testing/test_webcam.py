"""The fake webcam's video maker: symbols stroke by stroke, frame indices, Y4M."""

import cv2
import numpy as np

from oxbot.perception.board import default_reader
from oxbot.testing.webcam import PaperVideo, frame_index


def test_a_symbol_appears_stroke_by_stroke_and_each_frame_knows_its_index(tmp_path):
    video = PaperVideo(seed=5)
    video.hold(0.3)
    cross = video.draw("middle", "cross", stroke_seconds=0.4, lift_seconds=0.3)
    video.hold(0.3)
    frames = list(video.frames())
    assert (cross.start_frame, cross.complete_frame) == (3, 13)  # 4 + 3 + 4 frames
    readings = []
    for k, frame in enumerate(frames):
        small = cv2.resize(frame, (320, 240), interpolation=cv2.INTER_AREA)
        assert frame_index(small) == k
        readings.append(default_reader().read(small).readings[4].label)
    assert readings[:3] == ["nothing"] * 3
    assert readings[7:10] == ["partial"] * 3  # the first stroke alone, the pen lifted
    assert readings[cross.complete_frame :] == ["cross"] * (len(frames) - cross.complete_frame)
    path = video.write_y4m(tmp_path / "v.y4m")
    data = path.read_bytes()
    header, _, rest = data.partition(b"\n")
    assert header == b"YUV4MPEG2 W640 H480 F10:1 Ip A1:1 C420jpeg"
    assert len(rest) == len(frames) * (6 + 640 * 480 * 3 // 2)
    last = np.frombuffer(rest[-640 * 480 * 3 // 2 : -640 * 480 // 2], np.uint8)
    assert frame_index(last.reshape(480, 640)) == len(frames) - 1
