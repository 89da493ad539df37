"""The Python codec against the shared golden vectors (the C++ suite checks the same files)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from jackson.protocol import (
    MESSAGES,
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    FrameDecoder,
    decode_message,
    encode_frame,
)
from jackson.protocol.make_vectors import fields_of

VECTORS = Path(__file__).resolve().parents[2] / "protocol" / "vectors"
MESSAGE_VECTORS = json.loads((VECTORS / "messages.json").read_text())
STREAM_VECTORS = json.loads((VECTORS / "streams.json").read_text())
BY_NAME = {cls.NAME: cls for cls in MESSAGES.values()}


def _build(name: str, fields: dict[str, Any]) -> Any:
    return BY_NAME[name](**{k: tuple(v) if isinstance(v, list) else v for k, v in fields.items()})


def test_vectors_were_made_for_this_schema() -> None:
    for doc in (MESSAGE_VECTORS, STREAM_VECTORS):
        assert doc["protocol_version"] == PROTOCOL_VERSION
        assert int(doc["schema_hash"], 16) == SCHEMA_HASH


def test_every_message_type_has_a_vector() -> None:
    assert {v["message"] for v in MESSAGE_VECTORS["vectors"]} == set(BY_NAME)


@pytest.mark.parametrize("vector", MESSAGE_VECTORS["vectors"], ids=lambda v: v["name"])
def test_message_encodes_to_golden_bytes(vector: dict[str, Any]) -> None:
    msg = _build(vector["message"], vector["fields"])
    assert encode_frame(msg, vector["seq"]).hex() == vector["hex"]


@pytest.mark.parametrize("vector", MESSAGE_VECTORS["vectors"], ids=lambda v: v["name"])
def test_message_decodes_to_golden_fields(vector: dict[str, Any]) -> None:
    dec = FrameDecoder()
    frames = dec.feed(bytes.fromhex(vector["hex"]))
    assert len(frames) == 1
    assert frames[0].seq == vector["seq"]
    msg = decode_message(frames[0])
    assert msg.NAME == vector["message"]
    assert fields_of(msg) == vector["fields"]
    assert dec.pending == 0


@pytest.mark.parametrize("vector", STREAM_VECTORS["vectors"], ids=lambda v: v["name"])
def test_stream_gives_golden_frames_and_counters(vector: dict[str, Any]) -> None:
    dec = FrameDecoder()
    frames = []
    for chunk in vector["chunks"]:
        frames += dec.feed(bytes.fromhex(chunk["hex"]), chunk["at_us"])
    if vector["poll_at_us"] is not None:
        frames += dec.poll(vector["poll_at_us"])
    got = [
        {"message": MESSAGES[f.type].NAME, "seq": f.seq, "fields": fields_of(decode_message(f))}
        for f in frames
    ]
    assert got == vector["frames"]
    assert dec.counters.as_dict() == vector["counters"]
    assert dec.pending == vector["pending"]


def test_stream_vectors_are_fed_identically_as_one_chunk_or_bytewise() -> None:
    """Chunking must not change the result (the C++ decoder is fed byte by byte)."""
    for vector in STREAM_VECTORS["vectors"]:
        if len({c["at_us"] for c in vector["chunks"]}) != 1 or vector["poll_at_us"] is not None:
            continue
        data = b"".join(bytes.fromhex(c["hex"]) for c in vector["chunks"])
        whole, bytewise = FrameDecoder(), FrameDecoder()
        a = whole.feed(data, 0)
        b = [f for i in range(len(data)) for f in bytewise.feed(data[i : i + 1], 0)]
        assert a == b, vector["name"]
        assert whole.counters == bytewise.counters, vector["name"]
