"""The HELLO/INFO exchange: what the host sends first and how it judges the answer."""

from __future__ import annotations

from jackson.protocol.errors import ProtocolMismatchError
from jackson.protocol.messages import PROTOCOL_VERSION, SCHEMA_HASH, Hello, Info


def hello() -> Hello:
    """The HELLO this build sends: its protocol version and schema hash."""
    return Hello(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH)


def check_peer(info: Info) -> None:
    """Refuse a device whose protocol version or schema hash differs from this build's.

    Raises
    ------
    ProtocolMismatchError
        Naming both versions and hashes.
    """
    if info.protocol_version != PROTOCOL_VERSION or info.schema_hash != SCHEMA_HASH:
        raise ProtocolMismatchError(
            info.protocol_version, info.schema_hash, PROTOCOL_VERSION, SCHEMA_HASH
        )
