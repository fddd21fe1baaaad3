"""Imported by the launcher's fork server, and only there (`Launcher.start` preloads it): from
then on the fork server dies with the launcher (oxbot.robot.children), so that `kill -9` of the
launcher leaves no fork server behind, and its children see their parent go."""

from __future__ import annotations

from oxbot.robot.children import hold_fork_server

hold_fork_server()
