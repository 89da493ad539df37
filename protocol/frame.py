"""Frame layer of the wire protocol: encoder and streaming decoder (protocol/spec.md).

A frame is ``A5 5A VER TYPE SEQ LEN PAYLOAD CRC32C``; the CRC covers VER..PAYLOAD.
The decoder follows the receiver rules of the spec byte for byte, exactly as the
C++ decoder in ``include/jackson/protocol/frame.hpp`` does, so both keep the same
counters on the same input (the shared vectors check this).
"""

from __future__ import annotations

import copy
import struct
from dataclasses import asdict, dataclass
from typing import NamedTuple

from jackson.protocol.crc import crc32c
from jackson.protocol.errors import EncodeError
from jackson.protocol.messages import (
    MAX_PAYLOAD,
    MESSAGES,
    PARTIAL_TIMEOUT_US,
    PROTOCOL_VERSION,
    Buffer,
    Message,
)

SYNC0 = 0xA5
SYNC1 = 0x5A
HEADER_SIZE = 6  # SYNC0 SYNC1 VER TYPE SEQ LEN
CRC_SIZE = 4
MAX_FRAME = HEADER_SIZE + MAX_PAYLOAD + CRC_SIZE

_U32 = struct.Struct("<I")
_SYNC0_BYTES = bytes((SYNC0,))


class Frame(NamedTuple):
    """A frame that passed every check of the decoder."""

    type: int
    seq: int
    payload: bytes
    crc: int = 0  # the frame's CRC-32C; ACK and NACK echo it as acked_crc


@dataclass(slots=True)
class DecoderCounters:
    """What a decoder saw. Every byte fed is in a delivered frame, in bytes_skipped, or pending."""

    frames_ok: int = 0  # frames delivered
    crc_errors: int = 0  # complete candidates whose CRC failed
    bytes_skipped: int = 0  # bytes not part of a delivered frame
    oversize: int = 0  # LEN above MAX_PAYLOAD
    unknown_version: int = 0  # VER other than PROTOCOL_VERSION
    unknown_type: int = 0  # CRC-valid frames of a TYPE the schema lacks (skipped whole)
    seq_gaps: int = 0  # discontinuities in SEQ
    seq_lost: int = 0  # frames missing according to SEQ
    timeouts: int = 0  # partial frames dropped after PARTIAL_TIMEOUT_US of silence

    def as_dict(self) -> dict[str, int]:
        return asdict(self)


def encode_frame(msg: Message, seq: int) -> bytes:
    """One complete frame carrying ``msg`` with sequence number ``seq`` (0-255)."""
    try:
        payload = msg.pack()
    except (struct.error, ValueError) as exc:
        raise EncodeError(f"cannot encode {msg.NAME}: {exc}") from exc
    if not 0 <= seq <= 0xFF:
        raise EncodeError(f"cannot encode {msg.NAME}: seq {seq} outside 0-255")
    body = bytes((PROTOCOL_VERSION, msg.TYPE, seq, len(payload))) + payload
    return bytes((SYNC0, SYNC1)) + body + _U32.pack(crc32c(body))


def decode_message(frame: Frame) -> Message:
    """The message a frame carries (its type is known: the decoder delivers no other)."""
    return MESSAGES[frame.type].unpack(frame.payload)


class FrameDecoder:
    """Streaming decoder over bytes, bytearray or memoryview chunks.

    On any failure it discards one byte and rescans from the next SYNC0, so a real
    frame that starts inside a corrupt one is not lost. Malformed input is counted in
    :attr:`counters`, never raised.
    """

    def __init__(self, deliver_unknown: bool = False) -> None:
        """With ``deliver_unknown``, CRC-valid frames of an unknown TYPE are also returned (still
        counted in unknown_type and bytes_skipped), so a device can NACK them."""
        self.deliver_unknown = deliver_unknown
        self.counters = DecoderCounters()
        self._buf = bytearray()
        self._last_us: int | None = None
        self._last_seq: int | None = None
        # the VER byte of the newest candidate rejected for its version (to name it to a user)
        self.last_unknown_version: int | None = None
        # SEQ continuity is tracked from the first frame of this TYPE on (None: from the first
        # frame): a host's session starts at the INFO answering its HELLO, and frames a device
        # buffered before it are not losses (protocol/spec.md section 6.3)
        self.seq_from_type: int | None = None

    def copy(self) -> FrameDecoder:
        """An independent decoder in the same state (to try input and roll back)."""
        twin = FrameDecoder(self.deliver_unknown)
        twin.counters = copy.copy(self.counters)
        twin._buf = bytearray(self._buf)
        twin._last_us = self._last_us
        twin._last_seq = self._last_seq
        twin.last_unknown_version = self.last_unknown_version
        twin.seq_from_type = self.seq_from_type
        return twin

    @property
    def pending(self) -> int:
        """Bytes held while waiting for the rest of a candidate frame."""
        return len(self._buf)

    def feed(self, data: Buffer, now_us: int | None = None) -> list[Frame]:
        """Add bytes received at ``now_us`` (microseconds); return the frames they complete.

        Without ``now_us`` the partial-frame timeout is not applied.
        """
        frames: list[Frame] = []
        if now_us is not None:
            self._expire(now_us, frames)
            self._last_us = now_us
        self._buf += data
        self._scan(False, frames)
        return frames

    def poll(self, now_us: int) -> list[Frame]:
        """Apply the partial-frame timeout without new bytes."""
        frames: list[Frame] = []
        self._expire(now_us, frames)
        return frames

    def flush(self) -> list[Frame]:
        """End of input: drop any partial frame as a timeout, delivering frames behind it."""
        frames: list[Frame] = []
        if self._buf:
            self.counters.timeouts += 1
            self._scan(True, frames)
        return frames

    def _expire(self, now_us: int, frames: list[Frame]) -> None:
        if self._buf and self._last_us is not None and now_us - self._last_us >= PARTIAL_TIMEOUT_US:
            self.counters.timeouts += 1
            self._scan(True, frames)

    def _scan(self, final: bool, frames: list[Frame]) -> None:
        """One pass over the buffer; ``final`` treats an incomplete candidate as failed."""
        buf = self._buf
        c = self.counters
        n = len(buf)
        pos = 0
        skipped = 0
        while pos < n:
            if buf[pos] != SYNC0:
                k = buf.find(_SYNC0_BYTES, pos)
                if k < 0:
                    k = n
                skipped += k - pos
                pos = k
                continue
            avail = n - pos
            if avail < HEADER_SIZE:
                # check what can be checked now, exactly as a byte-by-byte receiver does
                if avail >= 2 and buf[pos + 1] != SYNC1:
                    skipped += 1
                    pos += 1
                    continue
                if avail >= 3 and buf[pos + 2] != PROTOCOL_VERSION:
                    c.unknown_version += 1
                    self.last_unknown_version = buf[pos + 2]
                    skipped += 1
                    pos += 1
                    continue
                if final:
                    skipped += 1
                    pos += 1
                    continue
                break
            if buf[pos + 1] != SYNC1:
                skipped += 1
                pos += 1
                continue
            if buf[pos + 2] != PROTOCOL_VERSION:
                c.unknown_version += 1
                self.last_unknown_version = buf[pos + 2]
                skipped += 1
                pos += 1
                continue
            length = buf[pos + 5]
            if length > MAX_PAYLOAD:
                c.oversize += 1
                skipped += 1
                pos += 1
                continue
            end = pos + HEADER_SIZE + length
            if end + CRC_SIZE > n:
                if final:
                    skipped += 1
                    pos += 1
                    continue
                break
            crc = _U32.unpack_from(buf, end)[0]
            if crc32c(buf[pos + 2 : end]) != crc:
                c.crc_errors += 1
                skipped += 1
                pos += 1
                continue
            ftype = buf[pos + 3]
            seq = buf[pos + 4]
            last = self._last_seq
            if self.seq_from_type is not None:
                if ftype == self.seq_from_type:  # SEQ is tracked from here on
                    self.seq_from_type = None
                    self._last_seq = seq
            else:
                if last is not None and seq != (last + 1) & 0xFF:
                    c.seq_gaps += 1
                    c.seq_lost += (seq - last - 1) & 0xFF
                self._last_seq = seq
            if ftype not in MESSAGES:
                c.unknown_type += 1
                if self.deliver_unknown:
                    frames.append(Frame(ftype, seq, bytes(buf[pos + HEADER_SIZE : end]), crc))
                skipped += end + CRC_SIZE - pos
                pos = end + CRC_SIZE
                continue
            c.frames_ok += 1
            frames.append(Frame(ftype, seq, bytes(buf[pos + HEADER_SIZE : end]), crc))
            pos = end + CRC_SIZE
        c.bytes_skipped += skipped
        if pos:
            del buf[:pos]
