"""Errors of the wire protocol package."""

from __future__ import annotations

from jackson.common.errors import JacksonError


class ProtocolError(JacksonError):
    """Base class of every protocol error."""


class EncodeError(ProtocolError):
    """A message could not be encoded (a field out of range, text too long)."""


class ProtocolMismatchError(ProtocolError):
    """The peer speaks another protocol version or message schema."""

    def __init__(self, peer_version: int, peer_hash: int, own_version: int, own_hash: int) -> None:
        self.peer_version = peer_version
        self.peer_hash = peer_hash
        self.own_version = own_version
        self.own_hash = own_hash
        super().__init__(
            f"device speaks protocol v{peer_version} (schema {peer_hash:#010x}) but this host "
            f"speaks v{own_version} (schema {own_hash:#010x}); flash the firmware built from "
            "this release (make flash) or install the host release that matches the firmware"
        )


class FrameVersionError(ProtocolError):
    """The peer's frames carry another VER byte: no frame of it can be decoded at all."""

    def __init__(self, peer_version: int | None, own_version: int, where: str = "device") -> None:
        self.peer_version = peer_version
        self.own_version = own_version
        theirs = "?" if peer_version is None else str(peer_version)
        super().__init__(
            f"{where} speaks frame version {theirs}, this host {own_version}: flash the "
            "firmware from this checkout (make flash)"
        )
