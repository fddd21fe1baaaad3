"""The robot across processes and machines, on Zenoh: one component in this process
(`oxbot component`), or a whole robot launched and driven from here (`oxbot robot`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

from oxbot.cli.context import config_of

_CONNECT = typer.Option("--connect", help="A Zenoh peer or router to reach: tcp/HOST:PORT.")
_LISTEN = typer.Option("--listen", help="Accept connections here: tcp/0.0.0.0:PORT.")
_SCOUTING = typer.Option("--scouting/--no-scouting", help="Find peers by multicast on the LAN.")
_ROBOT = typer.Option("--robot", help="The robot's name: key expressions oxbot/ROBOT/...")
_SECURITY = typer.Option(
    "--security",
    help="A TOML file with a [security] table (ca, certificate, key, allowed): Zenoh TLS with "
    "mutual authentication and access control; endpoints tls/HOST:PORT.",
)


def component_command(
    ctx: typer.Context,
    name: Annotated[
        str,
        typer.Argument(
            help="manager, perception, recognition, voice, arm, head-tracking or head-movement."
        ),
    ],
    robot: Annotated[str, _ROBOT] = "oxbot",
    connect: Annotated[list[str] | None, _CONNECT] = None,
    listen: Annotated[list[str] | None, _LISTEN] = None,
    scouting: Annotated[bool, _SCOUTING] = True,
    camera: Annotated[str | None, typer.Option(help="perception, head-tracking: a camera.")] = None,
    security: Annotated[Path | None, _SECURITY] = None,
) -> None:
    """Run one component of a robot in this process, over Zenoh, until Ctrl-C."""
    from oxbot.robot.launch import endpoints_of, run_component

    endpoints = endpoints_of(connect, listen, scouting, security)
    run_component(name, robot, endpoints, config_of(ctx), camera)


def robot_command(
    ctx: typer.Context,
    launch: Annotated[
        Path | None, typer.Option("--launch", help="Start these components, respawning them.")
    ] = None,
    robot: Annotated[str, _ROBOT] = "oxbot",
    connect: Annotated[list[str] | None, _CONNECT] = None,
    listen: Annotated[list[str] | None, _LISTEN] = None,
    scouting: Annotated[bool, _SCOUTING] = True,
    terminal: Annotated[bool, typer.Option("--terminal", help="Drive it from here.")] = False,
    web: Annotated[bool, typer.Option("--web", help="Serve the page for it ([web]).")] = False,
    security: Annotated[Path | None, _SECURITY] = None,
    voice: Annotated[
        str | None,
        typer.Option(help="The voice component's: piper (neural) or espeak (default: config)."),
    ] = None,
) -> None:
    """A robot as processes: --launch FILE starts them; --terminal / --web drive one."""
    from oxbot.config import with_overrides
    from oxbot.robot.launch import endpoints_of, load_launch_file, run_robot

    config = config_of(ctx)
    if voice is not None:
        config = with_overrides(config, {"speech": {"voice": voice}})
    plan = load_launch_file(launch) if launch is not None else None
    drive: Callable[[Any], None] | None = None
    if terminal:
        from oxbot.robot.terminal import TerminalRobot

        def drive(remote: Any) -> None:
            TerminalRobot(remote).run()
    elif web:
        from oxbot.web.server import serve

        def drive(remote: Any) -> None:
            serve(config, announce=print, robot_factory=lambda: remote)

    run_robot(config, plan, robot, endpoints_of(connect, listen, scouting, security), drive)
