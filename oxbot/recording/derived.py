"""Files made from recorded sessions (models, metrics, plots, exports): how the database names
them, and deleting them when a session is forgotten without ever touching anything else.

A file inside the data folder is named by its path relative to the folder, so that a copied
folder forgets its own copies. A file outside it (an export, `learn --out`) is named by its
absolute path with a *seal*: an HMAC, keyed by `derived.key` (random, 0600, in the data folder),
of the data folder's resolved path, the file's path, the session and the kind. `forget` deletes
a file only when it resolves inside the data folder (and is not the database or the key) or its
seal checks out; so a crafted database, or a copy of the folder, cannot name a file elsewhere
for deletion. Each file's temporary siblings (`.NAME.*.tmp`, what `oxbot.atomic` leaves when it
is killed mid-write) go with it.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import logging
import os
import secrets
from pathlib import Path

log = logging.getLogger(__name__)

KEY_NAME = "derived.key"
"""The data folder's sealing key."""
PRIVATE_FILE = 0o600
PRIVATE_DIR = 0o700


def private_dir(path: Path) -> None:
    """Make folder `path` (and missing parents) readable by its owner only, if it is new."""
    if not path.is_dir():
        path.mkdir(mode=PRIVATE_DIR, parents=True, exist_ok=True)
        os.chmod(path, PRIVATE_DIR)  # mkdir's mode is filtered by the umask


def make_private(paths: list[Path]) -> None:
    """Make the files among `paths` readable by their owner only (0600)."""
    for path in paths:
        with contextlib.suppress(FileNotFoundError):
            os.chmod(path, PRIVATE_FILE)


class DerivedFiles:
    """The derived files' names and their deletion, for the data folder `data_dir`."""

    def __init__(self, data_dir: Path, protected: tuple[str, ...]) -> None:
        self.root = data_dir.resolve()
        self.protected = {self.root / name for name in (*protected, KEY_NAME)}

    def _key(self, create: bool) -> bytes | None:
        path = self.root / KEY_NAME
        try:
            return path.read_bytes()
        except FileNotFoundError:
            if not create:
                return None
        key = secrets.token_bytes(32)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, PRIVATE_FILE)
        with os.fdopen(fd, "wb") as handle:
            handle.write(key)
        return key

    def _seal(self, key: bytes, path: str, session_id: int, kind: str) -> str:
        text = f"{self.root}\0{path}\0{session_id}\0{kind}".encode()
        return hmac.new(key, text, hashlib.sha256).hexdigest()

    def inside(self, path: Path) -> Path | None:
        """`path` relative to the data folder if it resolves inside it (and is not the
        database or the key), else None."""
        resolved = (self.root / path).resolve()
        if resolved == self.root or resolved in self.protected:
            return None
        if not resolved.is_relative_to(self.root):
            return None
        return resolved.relative_to(self.root)

    def name(self, path: Path, session_id: int, kind: str) -> tuple[str, str]:
        """The (path, seal) the database stores for `path`; makes the folders up to a file
        inside the data folder private."""
        relative = self.inside(Path(path).absolute())
        if relative is not None:
            private_dir((self.root / relative).parent)
            return relative.as_posix(), ""
        resolved = str(Path(path).resolve())
        key = self._key(create=True)
        assert key is not None
        return resolved, self._seal(key, resolved, session_id, kind)

    def target(self, stored: str, session_id: int, kind: str, seal: str) -> Path | None:
        """The file a stored name may delete, or None when it must not be touched."""
        path = Path(stored)
        if not path.is_absolute() or (self.root / path).resolve().is_relative_to(self.root):
            relative = self.inside(path)
            return self.root / relative if relative is not None else None
        key = self._key(create=False)
        if key is None or not seal:
            return None
        if not hmac.compare_digest(seal, self._seal(key, stored, session_id, kind)):
            return None
        return path

    def delete(self, path: Path) -> list[Path]:
        """Delete file `path` and its temporary siblings; the files deleted (never a folder)."""
        deleted = []
        candidates = [path]
        with contextlib.suppress(OSError):
            prefix = f".{path.name}."
            candidates += [
                p
                for p in path.parent.iterdir()
                if p.name.startswith(prefix) and p.name.endswith(".tmp")
            ]
        for candidate in candidates:
            try:
                if candidate.is_dir() and not candidate.is_symlink():
                    log.warning("%s is a folder, not a file made from a session: kept", candidate)
                    continue
                candidate.unlink()
                deleted.append(candidate)
            except FileNotFoundError:
                continue
            except OSError as exc:
                log.warning("cannot delete %s: %s", candidate, exc)
        return deleted
