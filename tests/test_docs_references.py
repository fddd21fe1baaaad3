"""The docs, the README, the package and `oxbot config` cite only what a clone has: no paper
source, spec or issue kept outside the repository; and the docs' commands exist."""

import re
from pathlib import Path

from oxbot.config import OxbotConfig, to_toml

ROOT = Path(__file__).resolve().parents[1]
OUTSIDE = re.compile(r"seed/paper|paper\.tex|SPEC( §|'s)|[Ii]ssue \d")


def test_the_docs_and_the_readme_cite_nothing_outside_the_repository():
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for n, line in enumerate(path.read_text().splitlines(), 1):
            assert not OUTSIDE.search(line), f"{path.name}:{n}: {line}"


def test_the_package_cites_nothing_outside_the_repository():
    suffixes = {".py", ".js", ".html", ".txt", ".toml", ".md"}
    for path in sorted((ROOT / "oxbot").rglob("*")):
        if path.suffix in suffixes:
            for n, line in enumerate(path.read_text().splitlines(), 1):
                assert not OUTSIDE.search(line), f"{path.relative_to(ROOT)}:{n}: {line}"


def test_oxbot_config_cites_nothing_outside_the_repository():
    assert not OUTSIDE.search(to_toml(OxbotConfig()))


def test_every_oxbot_command_in_the_how_tos_names_options_that_exist():
    import shlex

    from typer.testing import CliRunner

    from oxbot.cli import app

    lines = [
        part.strip()
        for doc in ("robot.md", "perception.md", "extending.md", "dialogue.md")
        for block in re.findall(r"```sh\n(.*?)```", (ROOT / "docs" / doc).read_text(), re.S)
        for line in block.splitlines()
        for part in line.split("#")[0].split("&&")
        if part.strip().startswith(".venv/bin/oxbot ")
    ]
    assert len(lines) > 20
    for line in lines:
        # --help last: the options before it are parsed (an unknown one fails), nothing runs
        result = CliRunner().invoke(app, [*shlex.split(line)[1:], "--help"])
        assert result.exit_code == 0 and "Usage:" in result.output, f"{line}\n{result.output}"
