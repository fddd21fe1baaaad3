"""Learning from real interactions (issue 18): what the robot saw and heard, kept when the
person agrees (`oxbot play --record`), and the data it learns from (`oxbot learn`).

    from oxbot.recording import RecordingStore, Recorder
    store = RecordingStore("~/oxbot-data")     # recordings.sqlite3 inside
    robot = Robot(config, recorder=store)      # a Recorder component joins the robot's bus
"""

from oxbot.recording.recorder import Recorder, notice
from oxbot.recording.store import RecordingStore, default_data_dir

__all__ = ["Recorder", "RecordingStore", "default_data_dir", "notice"]
