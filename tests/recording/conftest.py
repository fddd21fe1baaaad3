"""One real recorded game (headless robot, the page's sheet, the real tracker), shared."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import torch

from oxbot.recording import RecordingStore
from oxbot.testing.recorded_game import RecordedGame, play_recorded_game


@pytest.fixture(scope="session")
def recorded(tmp_path_factory) -> tuple[Path, RecordedGame]:
    """A folder holding the recordings of one game the scripted person played, and the game."""
    torch.set_num_threads(1)
    folder = tmp_path_factory.mktemp("recorded")
    with RecordingStore(folder) as store:
        game = play_recorded_game(store, seed=3, robot_starts=True)
    assert game.ended, game
    return folder, game


@pytest.fixture
def recordings(recorded, tmp_path) -> tuple[Path, RecordedGame]:
    """A copy of `recorded` that a test may change."""
    folder, game = recorded
    copy = tmp_path / "data"
    shutil.copytree(folder, copy)
    return copy, game
