"""HELLO/INFO: a peer with another protocol version or schema hash is refused by name."""

from __future__ import annotations

import pytest

from jackson.protocol import (
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    Info,
    ProtocolMismatchError,
    check_peer,
    hello,
)


def test_hello_carries_this_builds_version_and_hash() -> None:
    h = hello()
    assert (h.protocol_version, h.schema_hash) == (PROTOCOL_VERSION, SCHEMA_HASH)


def test_matching_peer_is_accepted() -> None:
    check_peer(Info(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH))


def test_other_version_is_refused_naming_both() -> None:
    with pytest.raises(ProtocolMismatchError) as err:
        check_peer(Info(protocol_version=PROTOCOL_VERSION + 1, schema_hash=0xDEADBEEF))
    text = str(err.value)
    assert f"v{PROTOCOL_VERSION + 1}" in text
    assert f"v{PROTOCOL_VERSION}" in text
    assert "0xdeadbeef" in text
    assert f"{SCHEMA_HASH:#010x}" in text


def test_same_version_other_schema_is_refused() -> None:
    with pytest.raises(ProtocolMismatchError):
        check_peer(Info(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH ^ 1))
