"""oxbot's messages on the wire between processes: the bytes of a Zenoh sample and back.

A message without bytes travels as its JSON (`messages.to_json`, encoding application/json),
readable by any Zenoh client; one carrying bytes (a camera frame, audio) as a line of that
JSON with each bytes field replaced by `{"blob": i}`, followed by the raw bytes (`BLOBS`).
Every sample's attachment carries the message format's version (`FORMAT`), which changes with
any message type's fields, so that processes of different oxbot versions refuse each other.
What arrives is checked before it becomes a message (oxbot.robot.message_checks).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import typing

import zenoh

from oxbot.errors import InvalidInputError
from oxbot.robot.message_checks import check_json, check_message
from oxbot.robot.messages import MESSAGE_TYPES, Message, from_json, to_json

FORMAT_VERSION = 1
"""Bumped by hand when the envelope changes; the fingerprint below follows the messages."""


def message_format() -> str:
    """`<FORMAT_VERSION>-<fingerprint>`: the fingerprint hashes every message type's name and
    fields, so two processes built from different oxbot versions refuse each other."""
    hints = {
        name: [(f.name, str(typing.get_type_hints(cls)[f.name])) for f in dataclasses.fields(cls)]
        for name, cls in sorted(MESSAGE_TYPES.items())
    }
    digest = hashlib.sha256(json.dumps(hints, sort_keys=True).encode()).hexdigest()
    return f"{FORMAT_VERSION}-{digest[:10]}"


FORMAT = message_format()
TOPICS: dict[str, type[Message]] = {cls.topic: cls for cls in MESSAGE_TYPES.values()}
"""Every message type by topic: the key expression names the type before any decoding."""
BLOBS = zenoh.Encoding.APPLICATION_OCTET_STREAM.with_schema("oxbot-blobs")


def encode(message: Message) -> tuple[bytes, zenoh.Encoding]:
    """The message on the wire: its JSON (`to_json`) when it carries no bytes; else, since
    base64 in JSON costs about 12 ms a camera frame each way, the blob layout: one line of
    JSON whose bytes fields are replaced by `{"blob": i}`, with `"blobs": [sizes]`, then the
    blobs themselves, raw, one after another."""
    pieces, encoding = encode_pieces(message)
    return b"".join(pieces), encoding


def encode_pieces(message: Message) -> tuple[list[bytes], zenoh.Encoding]:
    """`encode`'s payload in the pieces it is made of, for writing them straight into shared
    memory without joining them first."""
    blobs: list[bytes] = []

    def pack(value: typing.Any) -> typing.Any:
        if isinstance(value, bytes):
            blobs.append(value)
            return {"blob": len(blobs) - 1}
        if isinstance(value, tuple):
            return [pack(v) for v in value]
        return value

    data = {f.name: pack(getattr(message, f.name)) for f in dataclasses.fields(message)}
    if not blobs:
        return [to_json(message).encode()], zenoh.Encoding.APPLICATION_JSON
    header = {"type": type(message).__name__, "topic": message.topic, "data": data}
    header["blobs"] = [len(b) for b in blobs]
    return [json.dumps(header).encode() + b"\n", *blobs], BLOBS


@functools.cache
def _hints(cls: type[Message]) -> dict[str, typing.Any]:
    return typing.get_type_hints(cls)


def decode(payload: bytes, blobs: bool) -> Message:
    """The message `encode` made; InvalidInputError if it is not one."""
    if not blobs:
        return from_json(payload)
    try:
        end = payload.index(b"\n")
        check_json(payload[:end], "a message's header")
        header = json.loads(payload[:end])
        cls = MESSAGE_TYPES[header["type"]]
        data, sizes = dict(header["data"]), [int(n) for n in header["blobs"]]
        sent = len(payload) - end - 1
        if sum(sizes) != sent or any(n < 0 for n in sizes):
            raise ValueError(f"blobs of {sum(sizes)} bytes announced, {sent} sent")
        view = memoryview(payload)  # each blob copied once, out of the payload
        starts = [end + 1 + sum(sizes[:i]) for i in range(len(sizes))]
        pieces = [bytes(view[a : a + n]) for a, n in zip(starts, sizes, strict=True)]

        def unpack(value: typing.Any) -> typing.Any:
            if isinstance(value, dict) and set(value) == {"blob"}:
                return pieces[value["blob"]]
            if isinstance(value, list):
                return tuple(unpack(v) for v in value)
            return value

        fields = {k: unpack(v) for k, v in data.items()}
        hints = _hints(cls)
        for name, value in fields.items():
            if hints.get(name) is bytes and not isinstance(value, bytes):
                raise TypeError(f"field {name!r} of a {cls.__name__} message is not bytes")
        return check_message(cls(**fields))
    except (ValueError, KeyError, TypeError, IndexError, RecursionError) as exc:
        raise InvalidInputError(
            f"not a message of oxbot's bus ({type(exc).__name__}: {exc})"
        ) from None
