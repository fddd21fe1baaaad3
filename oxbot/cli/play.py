"""The commands that play noughts and crosses: against the game strategy alone in the terminal
(`oxbot game`), and with the whole robot on the web page or in the terminal (`oxbot play`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from oxbot.cli.context import config_of, err_console
from oxbot.config import OxbotConfig, RobotConfig, with_overrides


def game(
    ctx: typer.Context,
    opponent: Annotated[
        str | None,
        typer.Option(help="The robot's strategy: random, blocker or minimax (default: config)."),
    ] = None,
    robot_starts: Annotated[
        bool | None,
        typer.Option("--robot-starts/--person-starts", help="Who draws first, with circles."),
    ] = None,
    seed: Annotated[int | None, typer.Option(help="Seed for the robot's tie-breaking.")] = None,
) -> None:
    """Play noughts and crosses in the terminal against the robot's game strategy."""
    import numpy as np

    from oxbot.game.opponents import as_robot, make_opponent
    from oxbot.game.terminal import TerminalGame

    cfg = config_of(ctx).game
    rng = np.random.default_rng(seed)
    robot = as_robot(make_opponent(opponent or cfg.opponent, rng))
    starts = cfg.robot_starts if robot_starts is None else robot_starts
    TerminalGame(robot, robot_starts=starts).play_session()


def play(
    ctx: typer.Context,
    terminal: Annotated[
        bool, typer.Option("--terminal", help="Play in this terminal instead of the web page.")
    ] = False,
    camera: Annotated[
        str | None,
        typer.Option(help="Watch real paper: a camera index (0), a video or an image folder."),
    ] = None,
    robot_starts: Annotated[
        bool | None,
        typer.Option("--robot-starts/--person-starts", help="Who draws first (default: config)."),
    ] = None,
    mute: Annotated[bool, typer.Option("--mute", help="Print the robot's words only.")] = False,
    host: Annotated[
        str | None, typer.Option(help="Web page: the address to listen on (default: config).")
    ] = None,
    port: Annotated[
        int | None, typer.Option(help="Web page: the port to listen on (default: config).")
    ] = None,
    speed: Annotated[
        float | None,
        typer.Option(help="Run speech, the arm and the waits this much faster (default: 1)."),
    ] = None,
    https: Annotated[
        bool | None,
        typer.Option(
            "--https/--http",
            help="Web page: HTTPS with a self-signed certificate, so that a phone's browser "
            "lends the page its camera (default: HTTPS when --host is not a loopback address).",
        ),
    ] = None,
    record: Annotated[
        bool, typer.Option("--record", help="Keep what the robot saw and heard (oxbot data).")
    ] = False,
    record_audio: Annotated[
        bool, typer.Option("--record-audio", help="With --record: keep the recordings too.")
    ] = False,
    data_dir: Annotated[
        Path | None, typer.Option(help="Folder of the recordings (default: user data folder).")
    ] = None,
    manager: Annotated[
        str | None,
        typer.Option(
            help="Who decides what the robot says: dqn (the trained policy), rules or script "
            "(the baselines it is compared with); default: config."
        ),
    ] = None,
    policy: Annotated[
        str | None,
        typer.Option(
            help="The trained policy to play with: a file (or the folder) `oxbot train agent "
            "--out` wrote, or an SB3 DQN / MaskablePPO model's .zip (default: the shipped one)."
        ),
    ] = None,
    domain: Annotated[
        str | None,
        typer.Option(
            help="A folder of domain files (dialogues.txt, templates.txt, user_responses.txt) "
            "to play instead of the shipped one; its policy must be trained on it."
        ),
    ] = None,
    voice: Annotated[
        str | None,
        typer.Option(help="The robot's voice: piper (neural) or espeak (default: config)."),
    ] = None,
) -> None:
    """Play with the whole robot: the web page at http(s)://HOST:PORT, or --terminal."""
    changes = {
        "game": {"robot_starts": robot_starts},
        "speech": {"voice": voice},
        "robot": {"speed_factor": speed, "manager": manager, "policy": policy},
        "dialogue": {"domain": domain},
        "web": {"host": host, "port": port, "https": {True: "on", False: "off"}.get(https)},
    }
    config = with_overrides(
        config_of(ctx),
        {
            section: {k: v for k, v in values.items() if v is not None}
            for section, values in changes.items()
        },
    )
    from oxbot.robot.session import shared_policy

    shared_policy(config.robot.manager, config)  # a policy that does not fit: said before serving
    if terminal:
        _play_in_the_terminal(config, camera, record, data_dir, record_audio, mute)
        return
    _serve_the_page(config, record, data_dir, record_audio)


def _play_in_the_terminal(
    config: OxbotConfig,
    camera: str | None,
    record: bool,
    data_dir: Path | None,
    record_audio: bool,
    mute: bool,
) -> None:
    """The whole robot in the terminal: typed or spoken answers, a sheet camera if given."""
    from oxbot.perception.sources import open_source
    from oxbot.robot.session import Robot, prepare_voice
    from oxbot.robot.terminal import Speakers, TerminalRobot

    source = open_source(camera) if camera is not None else None
    if config.robot.pause_timeout == RobotConfig().pause_timeout:
        # a line being typed cannot be seen: wait for an answer the whole answer_timeout
        config = with_overrides(config, {"robot": {"pause_timeout": 0.0}})
    joining = []
    if record:  # opt-in, and the person is told what is kept
        from oxbot.recording import RecordingStore, notice
        from oxbot.recording.recorder import joining as recorder

        store = RecordingStore(data_dir)
        err_console.print(notice(store, record_audio), highlight=False)
        joining.append(recorder(store, "terminal", keep_audio=record_audio))
    robot = Robot(config, sheet_camera=source, joining=joining)
    prepare_voice(config)  # every sentence made in the background: none waits in a game
    TerminalRobot(robot, speakers=Speakers(not mute)).run()


def _serve_the_page(
    config: OxbotConfig, record: bool, data_dir: Path | None, record_audio: bool
) -> None:
    """The web page; every sentence the robot can say made in the background once it starts."""
    from oxbot.robot.session import prepare_voice
    from oxbot.web.server import serve

    def announce(text: str) -> None:  # the server is about to start: its port was free
        typer.echo(text)
        prepare_voice(config)  # every sentence made in the background: none waits in a game

    serve(
        config,
        announce=announce,
        record=record,
        data_dir=data_dir,
        record_audio=record_audio,
    )
