"""Slamtec's RPLIDAR serial protocol (A1 series, standard scan mode), both directions, no I/O.

The packaged RPLIDAR libraries (``rplidar``, ``pyrplidar``, ``adafruit-circuitpython-rplidar``)
own the serial port and read it in blocking loops, so they can neither be fed bytes by the
host's non-blocking poll and the twin's lockstep loop nor speak the device's side; this module
is the codec both ends share instead.

Requests (host to device)::

    0xA5 CMD                                   commands without payload (bit 7 of CMD clear)
    0xA5 CMD SIZE PAYLOAD[SIZE] CHECKSUM       commands with payload (bit 7 of CMD set);
                                               CHECKSUM = XOR of every byte before it

Responses (device to host) start with a 7-byte descriptor::

    0xA5 0x5A  u32 LE: length (bits 0-29) | send mode (bits 30-31)  DATA_TYPE

followed by ``length`` bytes once (send mode 0, single) or by units of ``length`` bytes until
the host sends STOP (send mode 1, multiple). The ones the A1 driver uses:

=============== ====== ====================== ======== ====== ==========================
request         CMD    descriptor             mode     length payload
=============== ====== ====================== ======== ====== ==========================
STOP            0x25   none                                    -
RESET           0x40   none                                    -
SCAN            0x20   A5 5A 05 00 00 40 81   multiple 5      measurement nodes
GET_INFO        0x50   A5 5A 14 00 00 00 04   single   20     model u8, firmware minor u8,
                                                               major u8, hardware u8,
                                                               serial number 16 bytes
GET_HEALTH      0x52   A5 5A 03 00 00 00 06   single   3      status u8 (0 good,
                                                               1 warning, 2 error),
                                                               error code u16 LE
GET_SAMPLERATE  0x59   A5 5A 04 00 00 00 15   single   4      T standard u16 LE [us],
                                                               T express u16 LE [us]
=============== ====== ====================== ======== ====== ==========================

A standard measurement node is 5 bytes::

    byte 0  quality (bits 2-7) | !S (bit 1) | S (bit 0)     S: first node of a new turn
    byte 1  angle_q6 bits 0-6 (bits 1-7) | C (bit 0)        C: check bit, always 1
    byte 2  angle_q6 bits 7-14
    byte 3  distance_q2 LE low byte                          distance [mm] * 4; 0: no return
    byte 4  distance_q2 LE high byte

with ``angle_q6`` the heading [deg] * 64, measured clockwise seen from above. A node is valid
when exactly one of S and !S is set and C is 1; a node never begins with ``A5 5A`` (C would be
0), so a descriptor inside a node stream is unambiguous.

:class:`ResponseDecoder` (host side) and :class:`RequestDecoder` (device side) take arbitrary
chunks of a byte stream, return what they completed, count and skip the bytes that fit
nothing, and never raise on garbage. Nodes come out in :class:`NodeBatch` arrays, decoded
with numpy, as the host decodes about 8000 of them a second.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
import numpy.typing as npt

from jackson.protocol.errors import EncodeError

__all__ = [
    "DESCRIPTOR_BYTES",
    "HEALTH_DESCRIPTOR",
    "INFO_DESCRIPTOR",
    "NODE_BYTES",
    "SAMPLERATE_DESCRIPTOR",
    "SCAN_DESCRIPTOR",
    "Command",
    "DataType",
    "Descriptor",
    "DeviceHealth",
    "DeviceInfo",
    "HealthStatus",
    "MeasurementNode",
    "NodeBatch",
    "Request",
    "RequestDecoder",
    "ResponseDecoder",
    "SampleRate",
    "SendMode",
    "decode_descriptor",
    "decode_health",
    "decode_info",
    "decode_node",
    "decode_nodes",
    "decode_samplerate",
    "encode_descriptor",
    "encode_health",
    "encode_info",
    "encode_node",
    "encode_nodes",
    "encode_request",
    "encode_samplerate",
    "response",
]

SYNC_BYTE = 0xA5
"""First byte of every request and of every response descriptor."""
SYNC_BYTE2 = 0x5A
"""Second byte of a response descriptor."""
CMDFLAG_HAS_PAYLOAD = 0x80
"""Bit 7 of a command byte: SIZE, PAYLOAD and CHECKSUM follow."""
DESCRIPTOR_BYTES = 7
NODE_BYTES = 5
LENGTH_MASK = 0x3FFFFFFF
"""Bits 0-29 of the descriptor's 32-bit word: the response length [bytes]."""
SEND_MODE_SHIFT = 30
ANGLE_Q6_MAX = 0x7FFF  # 15 bits
DISTANCE_Q2_MAX = 0xFFFF  # 16 bits
QUALITY_MAX = 0x3F  # 6 bits
SERIAL_BYTES = 16


class Command(IntEnum):
    """Request command bytes (Slamtec's protocol, A1 series)."""

    STOP = 0x25
    SCAN = 0x20
    RESET = 0x40
    GET_INFO = 0x50
    GET_HEALTH = 0x52
    GET_SAMPLERATE = 0x59


class SendMode(IntEnum):
    """Descriptor bits 30-31: one response, or a unit repeated until STOP."""

    SINGLE = 0
    MULTIPLE = 1


class DataType(IntEnum):
    """Descriptor data types of the responses this codec decodes."""

    DEVICE_INFO = 0x04
    DEVICE_HEALTH = 0x06
    SAMPLE_RATE = 0x15
    MEASUREMENT = 0x81


class HealthStatus(IntEnum):
    """GET_HEALTH status byte."""

    GOOD = 0
    WARNING = 1
    ERROR = 2  # the device is in its Protection Stop state


@dataclass(frozen=True)
class Request:
    """One request packet.

    Attributes
    ----------
    command : int
        The command byte (:class:`Command`; bit 7 set when a payload follows).
    payload : bytes
        The payload of a command with bit 7 set (may be empty), else empty.
    """

    command: int
    payload: bytes = b""


@dataclass(frozen=True)
class Descriptor:
    """A response descriptor.

    Attributes
    ----------
    length : int
        Bytes of one response (single) or of each unit (multiple), 30 bits.
    send_mode : int
        :class:`SendMode`, 2 bits.
    data_type : int
        :class:`DataType` byte.
    """

    length: int
    send_mode: int
    data_type: int


@dataclass(frozen=True)
class DeviceInfo:
    """GET_INFO response.

    Attributes
    ----------
    model : int
        Model byte: series in the high nibble, variant in the low one (0x18: A1M8).
    firmware_minor, firmware_major : int
        Firmware version ``major.minor``.
    hardware : int
        Hardware revision.
    serial : bytes
        The 16-byte serial number.
    """

    model: int
    firmware_minor: int
    firmware_major: int
    hardware: int
    serial: bytes

    @property
    def model_name(self) -> str:
        """``A<series>M<variant>`` as Slamtec names its A series (``A1M8`` for 0x18)."""
        return f"A{self.model >> 4}M{self.model & 0x0F}"

    @property
    def firmware(self) -> str:
        """Firmware version as Slamtec prints it (``1.29``)."""
        return f"{self.firmware_major}.{self.firmware_minor:02d}"

    @property
    def serial_hex(self) -> str:
        """The serial number as 32 upper-case hex digits (how Slamtec's tools print it)."""
        return self.serial.hex().upper()


@dataclass(frozen=True)
class DeviceHealth:
    """GET_HEALTH response.

    Attributes
    ----------
    status : int
        :class:`HealthStatus` value (other values are passed through as received).
    error_code : int
        The device's error code (u16), meaningful when the status is not good.
    """

    status: int
    error_code: int = 0


@dataclass(frozen=True)
class SampleRate:
    """GET_SAMPLERATE response.

    Attributes
    ----------
    standard_us : int
        Time of one measurement in SCAN mode [us].
    express_us : int
        Time of one measurement in EXPRESS_SCAN mode [us].
    """

    standard_us: int
    express_us: int


@dataclass(frozen=True)
class MeasurementNode:
    """One standard-mode measurement.

    Attributes
    ----------
    quality : int
        Signal quality, 6 bits (0 for no return).
    start : bool
        S flag: the first measurement of a new turn.
    angle_q6 : int
        Heading [deg] * 64, clockwise seen from above, 15 bits.
    distance_q2 : int
        Distance [mm] * 4, 16 bits; 0 is no return.
    """

    quality: int
    start: bool
    angle_q6: int
    distance_q2: int

    @property
    def angle_deg(self) -> float:
        """Heading [deg], clockwise."""
        return self.angle_q6 / 64.0

    @property
    def distance_mm(self) -> float:
        """Distance [mm]; 0 is no return."""
        return self.distance_q2 / 4.0


U8Array = npt.NDArray[np.uint8]
U16Array = npt.NDArray[np.uint16]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class NodeBatch:
    """Consecutive valid measurement nodes, as arrays of one length.

    Attributes
    ----------
    start : ndarray of bool
        S flags.
    quality : ndarray of uint8
        Qualities (6 bits).
    angle_q6 : ndarray of uint16
        Headings [deg] * 64, clockwise.
    distance_q2 : ndarray of uint16
        Distances [mm] * 4; 0 is no return.
    """

    start: BoolArray
    quality: U8Array
    angle_q6: U16Array
    distance_q2: U16Array

    def __len__(self) -> int:
        return len(self.start)

    def nodes(self) -> list[MeasurementNode]:
        """The batch as one :class:`MeasurementNode` each (slow: for tests and tools)."""
        return [
            MeasurementNode(int(q), bool(s), int(a), int(d))
            for s, q, a, d in zip(
                self.start, self.quality, self.angle_q6, self.distance_q2, strict=True
            )
        ]


ResponseItem = Descriptor | DeviceInfo | DeviceHealth | SampleRate | NodeBatch

# ----------------------------------------------------------------------------- requests


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


# ----------------------------------------------------------------------------- responses

_DESCRIPTOR = struct.Struct("<BBIB")
_INFO = struct.Struct("<BBBB16s")
_HEALTH = struct.Struct("<BH")
_SAMPLERATE = struct.Struct("<HH")

KNOWN_RESPONSES: dict[int, tuple[int, int]] = {
    DataType.DEVICE_INFO: (_INFO.size, SendMode.SINGLE),
    DataType.DEVICE_HEALTH: (_HEALTH.size, SendMode.SINGLE),
    DataType.SAMPLE_RATE: (_SAMPLERATE.size, SendMode.SINGLE),
    DataType.MEASUREMENT: (NODE_BYTES, SendMode.MULTIPLE),
}
"""(length, send mode) of each data type this codec decodes."""


def encode_descriptor(d: Descriptor) -> bytes:
    """The 7 bytes of a response descriptor.

    Raises
    ------
    EncodeError
        A length above 30 bits, a send mode above 2 bits or a data type above a byte.
    """
    if not 0 <= d.length <= LENGTH_MASK:
        raise EncodeError(f"RPLIDAR descriptor length must fit 30 bits, got {d.length}")
    if not 0 <= d.send_mode <= 3:
        raise EncodeError(f"RPLIDAR send mode must fit 2 bits, got {d.send_mode}")
    if not 0 <= d.data_type <= 0xFF:
        raise EncodeError(f"RPLIDAR data type must be a byte, got {d.data_type}")
    word = d.length | (d.send_mode << SEND_MODE_SHIFT)
    return _DESCRIPTOR.pack(SYNC_BYTE, SYNC_BYTE2, word, d.data_type)


def decode_descriptor(data: bytes) -> Descriptor | None:
    """The descriptor in the first 7 bytes of ``data``; None without the ``A5 5A`` start."""
    if len(data) < DESCRIPTOR_BYTES:
        return None
    s1, s2, word, data_type = _DESCRIPTOR.unpack_from(data)
    if s1 != SYNC_BYTE or s2 != SYNC_BYTE2:
        return None
    return Descriptor(word & LENGTH_MASK, word >> SEND_MODE_SHIFT, data_type)


def _descriptor_of(data_type: DataType) -> bytes:
    length, mode = KNOWN_RESPONSES[data_type]
    return encode_descriptor(Descriptor(length, mode, data_type))


SCAN_DESCRIPTOR = _descriptor_of(DataType.MEASUREMENT)
"""``A5 5A 05 00 00 40 81``: the answer to SCAN, followed by nodes."""
INFO_DESCRIPTOR = _descriptor_of(DataType.DEVICE_INFO)
HEALTH_DESCRIPTOR = _descriptor_of(DataType.DEVICE_HEALTH)
SAMPLERATE_DESCRIPTOR = _descriptor_of(DataType.SAMPLE_RATE)


def _byte(value: int, what: str, top: int = 0xFF) -> int:
    if not 0 <= value <= top:
        raise EncodeError(f"RPLIDAR {what} must be in 0..{top}, got {value}")
    return value


def encode_info(info: DeviceInfo) -> bytes:
    """The 20-byte GET_INFO payload.

    Raises
    ------
    EncodeError
        A field out of its byte, or a serial number that is not 16 bytes.
    """
    if len(info.serial) != SERIAL_BYTES:
        raise EncodeError(f"RPLIDAR serial number is 16 bytes, got {len(info.serial)}")
    return _INFO.pack(
        _byte(info.model, "model"),
        _byte(info.firmware_minor, "firmware minor"),
        _byte(info.firmware_major, "firmware major"),
        _byte(info.hardware, "hardware"),
        bytes(info.serial),
    )


def decode_info(payload: bytes) -> DeviceInfo:
    """A GET_INFO payload (20 bytes) as :class:`DeviceInfo`."""
    model, minor, major, hardware, serial = _INFO.unpack_from(payload)
    return DeviceInfo(model, minor, major, hardware, serial)


def encode_health(health: DeviceHealth) -> bytes:
    """The 3-byte GET_HEALTH payload.

    Raises
    ------
    EncodeError
        A status out of a byte or an error code out of 16 bits.
    """
    return _HEALTH.pack(
        _byte(health.status, "health status"), _byte(health.error_code, "error code", 0xFFFF)
    )


def decode_health(payload: bytes) -> DeviceHealth:
    """A GET_HEALTH payload (3 bytes) as :class:`DeviceHealth`."""
    status, code = _HEALTH.unpack_from(payload)
    return DeviceHealth(status, code)


def encode_samplerate(rate: SampleRate) -> bytes:
    """The 4-byte GET_SAMPLERATE payload.

    Raises
    ------
    EncodeError
        A time out of 16 bits.
    """
    return _SAMPLERATE.pack(
        _byte(rate.standard_us, "standard sample time", 0xFFFF),
        _byte(rate.express_us, "express sample time", 0xFFFF),
    )


def decode_samplerate(payload: bytes) -> SampleRate:
    """A GET_SAMPLERATE payload (4 bytes) as :class:`SampleRate`."""
    standard, express = _SAMPLERATE.unpack_from(payload)
    return SampleRate(standard, express)


def response(answer: DeviceInfo | DeviceHealth | SampleRate) -> bytes:
    """Descriptor and payload of a single response, as the device sends them."""
    if isinstance(answer, DeviceInfo):
        return INFO_DESCRIPTOR + encode_info(answer)
    if isinstance(answer, DeviceHealth):
        return HEALTH_DESCRIPTOR + encode_health(answer)
    return SAMPLERATE_DESCRIPTOR + encode_samplerate(answer)


# ----------------------------------------------------------------------------- nodes


def encode_node(node: MeasurementNode) -> bytes:
    """The 5 bytes of one measurement node (C = 1, !S = not S).

    Raises
    ------
    EncodeError
        A quality above 6 bits, an angle above 15 bits or a distance above 16 bits.
    """
    q = _byte(node.quality, "quality", QUALITY_MAX)
    a = _byte(node.angle_q6, "angle_q6", ANGLE_Q6_MAX)
    d = _byte(node.distance_q2, "distance_q2", DISTANCE_Q2_MAX)
    flags = 0b01 if node.start else 0b10
    return struct.pack("<BHH", (q << 2) | flags, (a << 1) | 1, d)


def decode_node(data: bytes) -> MeasurementNode | None:
    """The node in the first 5 bytes of ``data``; None when its check bits are wrong
    (S and !S equal, or C = 0) or fewer than 5 bytes are given."""
    if len(data) < NODE_BYTES:
        return None
    b0, angle, distance = struct.unpack_from("<BHH", data)
    if not ((b0 ^ (b0 >> 1)) & 1) or not angle & 1:
        return None
    return MeasurementNode(b0 >> 2, bool(b0 & 1), angle >> 1, distance)


def encode_nodes(
    start: npt.ArrayLike,
    quality: npt.ArrayLike,
    angle_q6: npt.ArrayLike,
    distance_q2: npt.ArrayLike,
) -> bytes:
    """Many nodes at once (the arrays broadcast to one length): their bytes back to back.

    Parameters
    ----------
    start : array_like of bool
        S flags.
    quality : array_like of int
        Qualities, 0..63.
    angle_q6 : array_like of int
        Headings [deg] * 64, 0..32767.
    distance_q2 : array_like of int
        Distances [mm] * 4, 0..65535.

    Returns
    -------
    bytes
        ``5 * n`` bytes.

    Raises
    ------
    EncodeError
        A value out of its field.
    """
    s, q, a, d = np.broadcast_arrays(
        np.asarray(start, dtype=bool),
        np.asarray(quality, dtype=np.int64),
        np.asarray(angle_q6, dtype=np.int64),
        np.asarray(distance_q2, dtype=np.int64),
    )
    for values, top, what in ((q, QUALITY_MAX, "quality"), (a, ANGLE_Q6_MAX, "angle_q6")):
        if values.size and (values.min() < 0 or values.max() > top):
            raise EncodeError(f"RPLIDAR {what} must be in 0..{top}")
    if d.size and (d.min() < 0 or d.max() > DISTANCE_Q2_MAX):
        raise EncodeError(f"RPLIDAR distance_q2 must be in 0..{DISTANCE_Q2_MAX}")
    out = np.empty((s.size, NODE_BYTES), dtype=np.uint8)
    out[:, 0] = (q.ravel() << 2) | np.where(s.ravel(), 0b01, 0b10)
    word = (a.ravel() << 1) | 1
    out[:, 1] = word & 0xFF
    out[:, 2] = word >> 8
    out[:, 3] = d.ravel() & 0xFF
    out[:, 4] = d.ravel() >> 8
    return out.tobytes()


def _valid_nodes(rows: U8Array) -> BoolArray:
    """Which ``(n, 5)`` rows pass the check bits (S != !S and C = 1)."""
    b0, b1 = rows[:, 0], rows[:, 1]
    valid: BoolArray = (((b0 ^ (b0 >> 1)) & b1 & 1) == 1).astype(np.bool_)
    return valid


def _batch(rows: U8Array) -> NodeBatch:
    rows16 = rows.astype(np.uint16)
    return NodeBatch(
        start=(rows[:, 0] & 1).astype(np.bool_),
        quality=(rows[:, 0] >> 2).astype(np.uint8),
        angle_q6=((rows16[:, 1] | (rows16[:, 2] << 8)) >> 1).astype(np.uint16),
        distance_q2=(rows16[:, 3] | (rows16[:, 4] << 8)).astype(np.uint16),
    )


def decode_nodes(data: bytes) -> NodeBatch:
    """Whole nodes in ``data`` (a multiple of 5 bytes) with no check: use
    :class:`ResponseDecoder` for a stream, which checks and resynchronises.

    Raises
    ------
    ValueError
        ``data`` is not a multiple of 5 bytes.
    """
    if len(data) % NODE_BYTES:
        raise ValueError(f"nodes are 5 bytes each, got {len(data)} bytes")
    rows = np.frombuffer(data, dtype=np.uint8).reshape(-1, NODE_BYTES)
    return _batch(rows)


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
