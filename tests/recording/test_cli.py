"""`oxbot data list|show|export|forget` on a real recorded game."""

from __future__ import annotations

from typer.testing import CliRunner

from oxbot.cli import app

runner = CliRunner()


def test_data_list_show_export_and_forget(recordings, tmp_path):
    folder, game = recordings
    listed = runner.invoke(app, ["data", "list", "--data-dir", str(folder)])
    assert listed.exit_code == 0, listed.output
    assert "1 sessions" in listed.output and game.outcome in listed.output
    shown = runner.invoke(app, ["data", "show", "1", "--data-dir", str(folder)])
    assert shown.exit_code == 0, shown.output
    assert "yes let's play" in shown.output and "Confirm(playGame=yes)" in shown.output
    out = tmp_path / "parquet"
    exported = runner.invoke(app, ["data", "export", str(out), "--data-dir", str(folder)])
    assert exported.exit_code == 0, exported.output
    assert (out / "crops.parquet").exists()
    forgot = runner.invoke(app, ["data", "forget", "1", "--data-dir", str(folder)])
    assert forgot.exit_code == 0, forgot.output
    assert "deleted 4 files" in forgot.output and not (out / "crops.parquet").exists()
    again = runner.invoke(app, ["data", "show", "1", "--data-dir", str(folder)])
    assert again.exit_code != 0
