"""Requests, host to device: encoding one and the device side's :class:`RequestDecoder`."""

from __future__ import annotations

from jackson.protocol.errors import EncodeError
from jackson.protocol.rplidar.packets import CMDFLAG_HAS_PAYLOAD, SYNC_BYTE, Request


def encode_request(command: int, payload: bytes = b"") -> bytes:
    """The request packet of ``command``.

    Parameters
    ----------
    command : int
        Command byte; with bit 7 set the packet carries SIZE, ``payload`` and CHECKSUM.
    payload : bytes
        Payload of a command with bit 7 set (at most 255 bytes).

    Returns
    -------
    bytes
        ``A5 CMD`` or ``A5 CMD SIZE PAYLOAD CHECKSUM``.

    Raises
    ------
    EncodeError
        A command out of 0..255, a payload for a command without bit 7, or above 255 bytes.
    """
    if not 0 <= command <= 0xFF:
        raise EncodeError(f"RPLIDAR command must be a byte, got {command}")
    if not command & CMDFLAG_HAS_PAYLOAD:
        if payload:
            raise EncodeError(f"RPLIDAR command {command:#04x} carries no payload (bit 7 clear)")
        return bytes((SYNC_BYTE, command))
    if len(payload) > 0xFF:
        raise EncodeError(f"RPLIDAR payload is at most 255 bytes, got {len(payload)}")
    packet = bytes((SYNC_BYTE, command, len(payload))) + bytes(payload)
    checksum = 0
    for b in packet:
        checksum ^= b
    return packet + bytes((checksum,))


class RequestDecoder:
    """The device's side: requests out of the bytes the host wrote.

    A byte that does not start a request (not 0xA5) and a packet with payload whose checksum
    does not match are skipped one byte at a time and counted; decoding resumes at the next
    0xA5.

    Attributes
    ----------
    malformed_bytes : int
        Bytes skipped.
    requests : int
        Requests decoded.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self.malformed_bytes = 0
        self.requests = 0

    def feed(self, data: bytes) -> list[Request]:
        """Decode what ``data`` completes; a partial packet waits for the next chunk.

        Parameters
        ----------
        data : bytes
            The next bytes of the stream, any length.

        Returns
        -------
        list of Request
            The requests completed, in stream order.
        """
        buf = self._buf
        buf += data
        out: list[Request] = []
        pos, end = 0, len(buf)
        while pos < end:
            if buf[pos] != SYNC_BYTE:
                nxt = buf.find(SYNC_BYTE, pos)
                nxt = end if nxt < 0 else nxt
                self.malformed_bytes += nxt - pos
                pos = nxt
                continue
            if end - pos < 2:
                break
            cmd = buf[pos + 1]
            if not cmd & CMDFLAG_HAS_PAYLOAD:
                out.append(Request(cmd))
                pos += 2
                continue
            if end - pos < 3:
                break
            size = buf[pos + 2]
            if end - pos < 4 + size:
                break
            checksum = 0
            for b in buf[pos : pos + 3 + size]:
                checksum ^= b
            if checksum != buf[pos + 3 + size]:
                self.malformed_bytes += 1
                pos += 1
                continue
            out.append(Request(cmd, bytes(buf[pos + 3 : pos + 3 + size])))
            pos += 4 + size
        del buf[:pos]
        self.requests += len(out)
        return out
