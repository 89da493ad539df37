"""The HELLO/INFO exchange: what the host sends first and how it judges the answer."""

from __future__ import annotations

import secrets

from jackson.protocol.errors import ProtocolMismatchError
from jackson.protocol.messages import PROTOCOL_VERSION, SCHEMA_HASH, Hello, Info


def hello(session: int = 0) -> Hello:
    """The HELLO this build sends: its protocol version and schema hash, and ``session``, the
    connection's id (spec §6.3): a device already in that session resumes it instead of starting
    over; 0 always starts a new session."""
    return Hello(protocol_version=PROTOCOL_VERSION, schema_hash=SCHEMA_HASH, session=session)


def new_session_id() -> int:
    """A connection's session id: random, never 0 (a HELLO's 0 means no session to resume)."""
    return secrets.randbits(32) or 1


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
