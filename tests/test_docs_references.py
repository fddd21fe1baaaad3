"""The docs, the README and `oxbot config` cite only what a clone has: no paper source, spec
or issue kept outside the repository."""

import re
from pathlib import Path

from oxbot.config import OxbotConfig, to_toml

ROOT = Path(__file__).resolve().parents[1]
OUTSIDE = re.compile(r"seed/paper|paper\.tex|SPEC( §|'s)|[Ii]ssue \d")


def test_the_docs_and_the_readme_cite_nothing_outside_the_repository():
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for n, line in enumerate(path.read_text().splitlines(), 1):
            assert not OUTSIDE.search(line), f"{path.name}:{n}: {line}"


def test_oxbot_config_cites_nothing_outside_the_repository():
    assert not OUTSIDE.search(to_toml(OxbotConfig()))
