import shutil
from pathlib import Path

import pytest

from oxbot.dialogue.domain import default_domain_dir


@pytest.fixture
def domain_dir(tmp_path: Path) -> Path:
    """A writable copy of the shipped domain files, to break one at a time."""
    target = tmp_path / "dialogue"
    shutil.copytree(default_domain_dir(), target)
    return target


def replace_line(path: Path, old: str, new: str) -> int:
    """Replace the first line containing `old` with `new`; return its 1-based line number."""
    lines = path.read_text(encoding="utf-8").splitlines()
    for n, line in enumerate(lines, start=1):
        if old in line:
            lines[n - 1] = new
            path.write_text("\n".join(lines) + "\n", encoding="utf-8")
            return n
    raise AssertionError(f"{old!r} not in {path}")
