"""Hostile inputs for the hardening tests and the soak benchmark: what a careless or malicious
client might send the robot.

    decompression_bomb(20_000)      # a ~48 KB PNG that decodes to 20000x20000 pixels
    nested_json(100_000)            # '[[[[...]]]]' 100,000 deep
    break_an_index(db)              # a recordings file still readable, failing integrity_check
"""

from __future__ import annotations

import sqlite3
import struct
import zlib

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _chunk(kind: bytes, data: bytes) -> bytes:
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))


def decompression_bomb(side: int = 20_000) -> bytes:
    """A valid, all-black 1-bit PNG of `side` x `side` pixels: tiny on disk, huge decoded."""
    header = struct.pack(">IIBBBBB", side, side, 1, 0, 0, 0, 0)  # 1-bit gray, no interlace
    row = bytes(1 + (side + 7) // 8)  # filter byte 0, then zero bits
    packer = zlib.compressobj(9)
    pixels = b"".join(packer.compress(row) for _ in range(side)) + packer.flush()
    return PNG_SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", pixels) + _chunk(b"IEND", b"")


def nested_json(depth: int) -> str:
    """A JSON array nested `depth` deep: valid JSON that blows Python's recursion limit."""
    return "[" * depth + "]" * depth


HTTP_ROUTES = (
    "/",
    "/static/app.js",
    "/health",
    "/tls",
    "/learned",
    "/recording/status",
    "/recording/learned",
    "/recording/record.js",
)
"""The page's HTTP routes a page from another site (DNS rebinding) would read."""


def break_an_index(db: sqlite3.Connection) -> None:
    """Inside an open transaction on a recordings file with session 1: three crops, then an
    index whose stored definition no longer matches its table. The file still reads, and fails
    `PRAGMA integrity_check`."""
    db.executemany(
        "INSERT INTO crops VALUES (1, ?, 0, ?, x'89', 'cross', 1.0, 2, 'cross')",
        [(i, 10.0 - i) for i in range(3)],
    )
    db.execute("CREATE INDEX extra ON crops(label)")
    db.execute("PRAGMA writable_schema=ON")
    db.execute("UPDATE sqlite_master SET sql='CREATE INDEX extra ON crops(t)' WHERE name='extra'")


__all__ = ["HTTP_ROUTES", "break_an_index", "decompression_bomb", "nested_json"]
