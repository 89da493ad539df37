"""The host's side of the stream: :class:`ResponseDecoder`, descriptors, responses and nodes
out of the device's bytes."""

from __future__ import annotations

import numpy as np

from jackson.protocol.rplidar.nodes import _batch, _valid_nodes
from jackson.protocol.rplidar.packets import (
    DESCRIPTOR_BYTES,
    NODE_BYTES,
    SYNC_BYTE,
    SYNC_BYTE2,
    DataType,
    Descriptor,
    DeviceHealth,
    DeviceInfo,
    ResponseItem,
    SampleRate,
    SendMode,
)
from jackson.protocol.rplidar.responses import (
    KNOWN_RESPONSES,
    decode_descriptor,
    decode_health,
    decode_info,
    decode_samplerate,
)


class ResponseDecoder:
    """The host's side: descriptors, responses and measurement nodes out of the device's bytes.

    Outside a response it looks for a descriptor of a known (data type, length, send mode)
    (:data:`KNOWN_RESPONSES`); a single response's payload follows it, and after the SCAN
    descriptor nodes follow until another descriptor. Bytes that fit nothing — a node with a
    bad start flag pair or check bit, a descriptor of an unknown kind, anything before the
    first descriptor — are skipped one at a time and counted, and decoding carries on at the
    next byte, so a lost or corrupted byte costs the nodes it touched and no more.

    Parameters
    ----------
    streaming : bool
        Start past a SCAN descriptor: the first bytes are nodes (a stream picked up while
        scanning, as the daemon's core is handed it).

    Attributes
    ----------
    malformed_bytes : int
        Bytes skipped.
    nodes : int
        Valid nodes decoded.
    descriptors : int
        Descriptors decoded.
    """

    def __init__(self, *, streaming: bool = False) -> None:
        self._buf = bytearray()
        self._pending: Descriptor | None = None  # a single response whose payload is due
        self._streaming = streaming  # after the SCAN descriptor: nodes
        self.malformed_bytes = 0
        self.nodes = 0
        self.descriptors = 0

    @property
    def streaming(self) -> bool:
        """Whether a SCAN descriptor came and nodes are expected."""
        return self._streaming

    def reset(self) -> None:
        """Forget partial data and the stream state (counters stay)."""
        self._buf.clear()
        self._pending = None
        self._streaming = False

    def feed(self, data: bytes) -> list[ResponseItem]:
        """Decode what ``data`` completes; a partial item waits for the next chunk.

        Parameters
        ----------
        data : bytes
            The next bytes of the stream, any length.

        Returns
        -------
        list
            :class:`Descriptor`, :class:`DeviceInfo`, :class:`DeviceHealth`,
            :class:`SampleRate` and :class:`NodeBatch` items in stream order (each run of
            valid nodes is one batch).
        """
        buf = self._buf
        buf += data
        out: list[ResponseItem] = []
        pos, end = 0, len(buf)
        while pos < end:
            if self._pending is not None:
                n = self._pending.length
                if end - pos < n:
                    break
                out.append(self._single(self._pending.data_type, bytes(buf[pos : pos + n])))
                pos += n
                self._pending = None
                continue
            if self._streaming:
                count = (end - pos) // NODE_BYTES
                if count:
                    chunk = bytes(buf[pos : pos + count * NODE_BYTES])
                    rows = np.frombuffer(chunk, dtype=np.uint8).reshape(count, NODE_BYTES)
                    valid = _valid_nodes(rows)
                    good = count if bool(valid.all()) else int(np.argmin(valid))
                    if good:
                        out.append(_batch(rows[:good]))
                        self.nodes += good
                        pos += good * NODE_BYTES
                        continue
            if buf[pos] != SYNC_BYTE:
                if self._streaming:
                    if end - pos < NODE_BYTES:
                        break  # maybe the start of a node
                    self.malformed_bytes += 1
                    pos += 1
                else:
                    nxt = buf.find(SYNC_BYTE, pos)
                    nxt = end if nxt < 0 else nxt
                    self.malformed_bytes += nxt - pos
                    pos = nxt
                continue
            if end - pos < 2 or (buf[pos + 1] == SYNC_BYTE2 and end - pos < DESCRIPTOR_BYTES):
                break  # maybe the start of a descriptor
            d = decode_descriptor(bytes(buf[pos : pos + DESCRIPTOR_BYTES]))
            if d is None or KNOWN_RESPONSES.get(d.data_type) != (d.length, d.send_mode):
                if self._streaming and end - pos < NODE_BYTES:
                    break
                self.malformed_bytes += 1
                pos += 1
                continue
            out.append(d)
            self.descriptors += 1
            pos += DESCRIPTOR_BYTES
            self._streaming = d.send_mode == SendMode.MULTIPLE
            if not self._streaming:
                self._pending = d
        del buf[:pos]
        return out

    @staticmethod
    def _single(data_type: int, payload: bytes) -> DeviceInfo | DeviceHealth | SampleRate:
        if data_type == DataType.DEVICE_INFO:
            return decode_info(payload)
        if data_type == DataType.DEVICE_HEALTH:
            return decode_health(payload)
        return decode_samplerate(payload)
