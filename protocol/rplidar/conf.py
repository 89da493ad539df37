"""GET_LIDAR_CONF: the scan modes a device offers and the entries that describe them."""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum

from jackson.protocol.rplidar.packets import DataType, Descriptor, SendMode
from jackson.protocol.rplidar.responses import _byte, encode_descriptor


class ConfType(IntEnum):
    """GET_LIDAR_CONF entry types about scan modes (protocol v2.x, firmware 1.24 and later)."""

    SCAN_MODE_COUNT = 0x70  # u16: the modes, ids 0 .. count - 1
    SCAN_MODE_US_PER_SAMPLE = 0x71  # u32, Q8 [us]: time of one sample, per mode
    SCAN_MODE_MAX_DISTANCE = 0x74  # u32, Q8 [m], per mode
    SCAN_MODE_ANS_TYPE = 0x75  # u8: the answer type (DataType) of the mode's stream, per mode
    SCAN_MODE_TYPICAL = 0x7C  # u16: id of the mode Slamtec recommends for the model
    SCAN_MODE_NAME = 0x7F  # ASCII, NUL-terminated, per mode


PER_MODE_CONF_TYPES = frozenset(
    {
        ConfType.SCAN_MODE_US_PER_SAMPLE,
        ConfType.SCAN_MODE_MAX_DISTANCE,
        ConfType.SCAN_MODE_ANS_TYPE,
        ConfType.SCAN_MODE_NAME,
    }
)
"""Entry types whose request names a scan mode (its id, u16 LE, after the entry type)."""

Q8 = 256
"""Scale of the Q8 fixed-point values of GET_LIDAR_CONF (value * 256)."""
_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")


@dataclass(frozen=True)
class ScanMode:
    """One scan mode as GET_LIDAR_CONF describes it.

    Attributes
    ----------
    id : int
        The mode's id: GET_LIDAR_CONF's argument and EXPRESS_SCAN's working mode.
    name : str
        Slamtec's name (``Standard``, ``Express``, ``Boost``, ``Sensitivity``, ``Stability``).
    us_per_sample_q8 : int
        Time of one sample [us] * 256.
    max_distance_q8 : int
        Longest distance the mode measures [m] * 256.
    answer_type : int
        :class:`DataType` of the mode's stream: 0x81 standard nodes (SCAN), else a capsule
        format (EXPRESS_SCAN, :data:`CAPSULE_FORMATS`).
    """

    id: int
    name: str
    us_per_sample_q8: int
    max_distance_q8: int
    answer_type: int

    @property
    def us_per_sample(self) -> float:
        """Time of one sample [us]."""
        return self.us_per_sample_q8 / Q8

    @property
    def samples_per_s(self) -> float:
        """Samples a second (the SDK's "sample rate")."""
        return 1e6 / self.us_per_sample

    @property
    def max_distance_m(self) -> float:
        """Longest distance [m]."""
        return self.max_distance_q8 / Q8


@dataclass(frozen=True)
class LidarConfQuery:
    """A GET_LIDAR_CONF request's payload.

    Attributes
    ----------
    conf_type : int
        The entry asked for (:class:`ConfType`, u32).
    argument : bytes
        What follows the type: the scan mode id (u16 LE) for a per-mode entry. Hosts may send
        more (SDK 2.0 pads it to 32 bytes); only the first two count.
    """

    conf_type: int
    argument: bytes = b""

    @property
    def mode_id(self) -> int | None:
        """The scan mode named by the argument; None when it is shorter than 2 bytes."""
        if len(self.argument) < _U16.size:
            return None
        return int(_U16.unpack_from(self.argument)[0])


def encode_lidar_conf_query(conf_type: int, mode_id: int | None = None) -> bytes:
    """The payload of a GET_LIDAR_CONF request: the entry type, then the mode id if given.

    Raises
    ------
    EncodeError
        A type out of 32 bits or a mode id out of 16.
    """
    out = _U32.pack(_byte(conf_type, "conf type", 0xFFFFFFFF))
    if mode_id is not None:
        out += _U16.pack(_byte(mode_id, "scan mode id", 0xFFFF))
    return out


def decode_lidar_conf_query(payload: bytes) -> LidarConfQuery | None:
    """A GET_LIDAR_CONF request's payload; None when it is shorter than the 4-byte type."""
    if len(payload) < _U32.size:
        return None
    return LidarConfQuery(int(_U32.unpack_from(payload)[0]), bytes(payload[_U32.size :]))


@dataclass(frozen=True)
class LidarConf:
    """A GET_LIDAR_CONF answer: the entry type (repeated from the request) and its value.

    Attributes
    ----------
    conf_type : int
        :class:`ConfType` (u32).
    value : bytes
        The value, little-endian: u8, u16, u32 (Q8 for times and distances) or text.
    """

    conf_type: int
    value: bytes

    @property
    def u8(self) -> int:
        return self.value[0]

    @property
    def u16(self) -> int:
        return int(_U16.unpack_from(self.value)[0])

    @property
    def u32(self) -> int:
        return int(_U32.unpack_from(self.value)[0])

    @property
    def text(self) -> str:
        """The value as text, up to its NUL."""
        return self.value.split(b"\x00", 1)[0].decode("ascii", "replace")


def encode_lidar_conf(conf: LidarConf) -> bytes:
    """The payload of a GET_LIDAR_CONF answer: the type (u32 LE), then the value."""
    return _U32.pack(_byte(conf.conf_type, "conf type", 0xFFFFFFFF)) + bytes(conf.value)


def decode_lidar_conf(payload: bytes) -> LidarConf:
    """A GET_LIDAR_CONF answer's payload (at least the 4-byte type).

    Raises
    ------
    ValueError
        A payload shorter than 4 bytes.
    """
    if len(payload) < _U32.size:
        raise ValueError(f"a GET_LIDAR_CONF answer is at least 4 bytes, got {len(payload)}")
    return LidarConf(int(_U32.unpack_from(payload)[0]), bytes(payload[_U32.size :]))


def lidar_conf_response(conf: LidarConf) -> bytes:
    """Descriptor (single, type 0x20, length 4 + value) and payload of a GET_LIDAR_CONF answer."""
    payload = encode_lidar_conf(conf)
    descriptor = Descriptor(len(payload), SendMode.SINGLE, DataType.LIDAR_CONF)
    return encode_descriptor(descriptor) + payload


def scan_mode_conf(
    query: LidarConfQuery, modes: tuple[ScanMode, ...], typical_id: int
) -> LidarConf | None:
    """What a device offering ``modes`` answers to ``query``.

    Parameters
    ----------
    query : LidarConfQuery
        The request's payload.
    modes : tuple of ScanMode
        The device's modes, ``modes[i].id == i``.
    typical_id : int
        The id of its typical mode.

    Returns
    -------
    LidarConf or None
        The answer; None for an entry type these facts do not cover, or a per-mode entry
        without a mode id or with one the device does not have.
    """
    t = query.conf_type
    if t == ConfType.SCAN_MODE_COUNT:
        return LidarConf(t, _U16.pack(len(modes)))
    if t == ConfType.SCAN_MODE_TYPICAL:
        return LidarConf(t, _U16.pack(typical_id))
    if t not in PER_MODE_CONF_TYPES:
        return None
    i = query.mode_id
    if i is None or not 0 <= i < len(modes):
        return None
    mode = modes[i]
    if t == ConfType.SCAN_MODE_US_PER_SAMPLE:
        return LidarConf(t, _U32.pack(mode.us_per_sample_q8))
    if t == ConfType.SCAN_MODE_MAX_DISTANCE:
        return LidarConf(t, _U32.pack(mode.max_distance_q8))
    if t == ConfType.SCAN_MODE_ANS_TYPE:
        return LidarConf(t, bytes((mode.answer_type,)))
    return LidarConf(t, mode.name.encode("ascii") + b"\x00")
