"""Single responses, device to host: the 7-byte descriptor and the device info, health and
sample-rate payloads."""

from __future__ import annotations

import struct

from jackson.protocol.errors import EncodeError
from jackson.protocol.rplidar.packets import (
    DESCRIPTOR_BYTES,
    LENGTH_MASK,
    NODE_BYTES,
    SEND_MODE_SHIFT,
    SERIAL_BYTES,
    SYNC_BYTE,
    SYNC_BYTE2,
    DataType,
    Descriptor,
    DeviceHealth,
    DeviceInfo,
    SampleRate,
    SendMode,
)

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
"""(length, send mode) of each data type :class:`ResponseDecoder` decodes: the standard scan's.
Capsule streams (EXPRESS_SCAN) go to :class:`CapsuleDecoder`, and GET_LIDAR_CONF answers (of
variable length) to :func:`decode_lidar_conf`."""


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
