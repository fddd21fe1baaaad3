"""Model and checkpoint files: a `torch.save` payload behind a header with its checksum.

Every file oxbot trains or ships (the perceiver, the policy, both trainers' checkpoints) is one
header line followed by the payload exactly as `torch.save` wrote it:

    oxbot-artifact {"kind": "policy", "format_version": 2, "bytes": 281000, "sha256": "…"}
    <payload>

The SHA-256 of the payload is checked before anything is unpickled, so a flipped byte or a
cut-off download is refused with a `ModelFileError` instead of loading weights that behave
differently; the payload is then read with `torch.load(weights_only=True)` (tensors and plain
types only). Each loader checks the payload's contents inside `checked(...)`, which turns a
missing key or a value of the wrong type into a `ModelFileError` as well.

Files written before this header existed ("legacy") carry no checksum. A loader may accept them
when its `legacy` test recognises the old payload; they load with a warning saying how to re-save
them, since the old format cannot show whether they were damaged.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import logging
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from oxbot.atomic import atomic_write
from oxbot.errors import DataError, ModelFileError

log = logging.getLogger(__name__)

MAGIC = b"oxbot-artifact "
MAX_HEADER_BYTES = 4096
"""A longer first line is not an oxbot header (this one is about 150 bytes)."""


def save(path: str | Path, kind: str, version: int, payload: dict[str, Any]) -> Path:
    """Write `payload` as a `kind` file of format `version`, with its checksum; atomically."""
    import torch

    buffer = io.BytesIO()
    torch.save(payload, buffer)
    data = buffer.getvalue()
    header = {
        "kind": kind,
        "format_version": version,
        "bytes": len(data),
        "sha256": hashlib.sha256(data).hexdigest(),
    }
    path = Path(path)
    with atomic_write(path) as handle:
        handle.write(MAGIC + json.dumps(header).encode("ascii") + b"\n")
        handle.write(data)
    return path


def load(
    path: str | Path,
    kind: str,
    version: int,
    what: str,
    remedy: str,
    legacy: Callable[[Any], bool] | None = None,
) -> dict[str, Any]:
    """The payload of the `kind` file at `path`, its checksum and format version checked.

    `what` names the file in messages ("policy file"); `remedy` says what to do about a bad
    one ("retrain it with `oxbot train agent`"). `legacy`, if given, recognises a payload saved
    before the header existed; such a file loads with a warning.
    """
    path = Path(path)
    data = _read(path, what, remedy)
    if not data.startswith(MAGIC):
        return _load_legacy(path, data, what, remedy, legacy)
    end = data.find(b"\n", 0, MAX_HEADER_BYTES)
    header = _header(data[len(MAGIC) : end] if end > 0 else b"")
    if header is None:
        raise ModelFileError(f"{what} {path} has a damaged header; {remedy}")
    if header["kind"] != kind:
        raise ModelFileError(f"{path} is an oxbot {header['kind']} file, not a {what}")
    if header["format_version"] != version:
        newer = header["format_version"] > version
        raise ModelFileError(
            f"{what} {path} has format version {header['format_version']}, but this oxbot "
            f"reads version {version}; " + ("update oxbot, or " if newer else "") + remedy
        )
    body = data[end + 1 :]
    if len(body) != header["bytes"]:
        raise ModelFileError(
            f"{what} {path} is truncated or padded: {len(body)} bytes of payload where "
            f"{header['bytes']} were saved; {remedy}"
        )
    if hashlib.sha256(body).hexdigest() != header["sha256"]:
        raise ModelFileError(
            f"{what} {path} is corrupt: its SHA-256 does not match the one saved with it (the "
            f"file changed after it was written); {remedy}"
        )
    payload = _unpickle(body)
    if not isinstance(payload, dict):
        raise ModelFileError(f"{what} {path} holds no oxbot payload; {remedy}")
    return payload


@contextlib.contextmanager
def checked(path: str | Path, what: str, remedy: str) -> Iterator[None]:
    """Turn a missing key or a wrongly typed value met while reading a payload into a
    `ModelFileError` naming the file."""
    try:
        yield
    except ModelFileError:
        raise
    except RecursionError:  # before RuntimeError, its base class
        raise ModelFileError(f"{what} {path} is nested too deeply; {remedy}") from None
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, RuntimeError) as exc:
        detail = f"missing {exc}" if isinstance(exc, KeyError) else str(exc).strip()
        first = detail.splitlines()[0] if detail else type(exc).__name__
        raise ModelFileError(f"{what} {path} is malformed ({first}); {remedy}") from None


def load_json(path: str | Path, what: str, remedy: str) -> Any:
    """The JSON file beside a model (its metrics); a `DataError` saying what is wrong with it,
    deep nesting included, rather than a traceback."""
    path = Path(path)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataError(f"{what} {path} does not exist; {remedy}") from None
    except OSError as exc:
        raise DataError(f"{what} {path} cannot be read ({exc.strerror or exc}); {remedy}") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise DataError(f"{what} {path} is not valid JSON ({exc}); {remedy}") from None
    except RecursionError:
        raise DataError(f"{what} {path} nests its JSON too deeply; {remedy}") from None


def _read(path: Path, what: str, remedy: str) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise ModelFileError(f"{what} {path} does not exist; {remedy}") from None
    except IsADirectoryError:
        raise ModelFileError(f"{what} {path} is a folder; give the file inside it") from None
    except OSError as exc:
        raise ModelFileError(f"{what} {path} cannot be read ({exc.strerror or exc})") from None


def _header(line: bytes) -> dict[str, Any] | None:
    """The header's fields, or None when the line is not a well-formed header."""
    try:
        header = json.loads(line.decode("ascii"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        return None
    types = {"kind": str, "format_version": int, "bytes": int, "sha256": str}
    if not isinstance(header, dict) or any(type(header.get(k)) is not t for k, t in types.items()):
        return None
    return header


def _unpickle(data: bytes) -> Any:
    """`torch.load` of tensors and plain types, any failure as None (not a payload)."""
    import torch

    try:
        with warnings.catch_warnings():  # torch warns about odd pickles it then refuses
            warnings.simplefilter("ignore")
            return torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception:  # garbage fails in many ways: zip, pickle, EOF, recursion, ...
        return None


def _load_legacy(
    path: Path, data: bytes, what: str, remedy: str, legacy: Callable[[Any], bool] | None
) -> dict[str, Any]:
    payload = _unpickle(data) if legacy is not None else None
    if payload is None or not legacy(payload):  # type: ignore[misc]
        raise ModelFileError(
            f"{what} {path} is truncated or not a model file (no oxbot header); {remedy}"
        )
    log.warning(
        "%s %s was saved before oxbot checksummed its files, so it cannot be checked for "
        "damage; it loads, but re-save it (load it and call save) to add a checksum",
        what,
        path,
    )
    return payload
