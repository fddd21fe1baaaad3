"""The `--set SECTION.FIELD=VALUE` option of the board benches: config settings for one run, as
`oxbot --set` takes them; the bench passes `args.set` to `oxbot.config.load_config`."""

from __future__ import annotations

import argparse


def add_set_option(parser: argparse.ArgumentParser, example: str) -> None:
    """--set, given any number of times; `example` is shown in the help."""
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="SECTION.FIELD=VALUE",
        help=f"a config setting, e.g. {example}",
    )
