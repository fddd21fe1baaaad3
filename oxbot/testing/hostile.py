"""Hostile inputs for the hardening tests and the soak benchmark: what a careless or malicious
client might send the robot.

    decompression_bomb(20_000)      # a ~48 KB PNG that decodes to 20000x20000 pixels
    nested_json(100_000)            # '[[[[...]]]]' 100,000 deep
"""

from __future__ import annotations

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


__all__ = ["decompression_bomb", "nested_json"]
