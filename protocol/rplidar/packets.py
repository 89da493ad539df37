"""The RPLIDAR protocol's constants, command and data-type codes, and the records a request or a
response carries (device info, health, sample rate, a measurement node, a batch of nodes)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
import numpy.typing as npt

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
# [s] the A1M8's turn at 7.43 Hz (REFERENCE: LiDAR scan period): the host's scan stamps and
# silence tests and the twin's emulator all take it from here
A1M8_SCAN_PERIOD_S = 0.13465


class Command(IntEnum):
    """Request command bytes (Slamtec's protocol, A1 series)."""

    STOP = 0x25
    SCAN = 0x20
    RESET = 0x40
    GET_INFO = 0x50
    GET_HEALTH = 0x52
    GET_SAMPLERATE = 0x59
    FORCE_SCAN = 0x21  # SCAN whether or not the motor has reached its speed
    EXPRESS_SCAN = 0x82  # payload: working mode, flags, param (firmware 1.17 and later)
    GET_LIDAR_CONF = 0x84  # payload: entry type, argument (firmware 1.24 and later)


class SendMode(IntEnum):
    """Descriptor bits 30-31: one response, or a unit repeated until STOP."""

    SINGLE = 0
    MULTIPLE = 1


class DataType(IntEnum):
    """Descriptor data types (answer types) of the responses this codec encodes and decodes."""

    DEVICE_INFO = 0x04
    DEVICE_HEALTH = 0x06
    SAMPLE_RATE = 0x15
    LIDAR_CONF = 0x20
    MEASUREMENT = 0x81
    MEASUREMENT_CAPSULED = 0x82  # express scan, legacy capsules
    MEASUREMENT_ULTRA_CAPSULED = 0x84  # boost, sensitivity and stability modes
    MEASUREMENT_DENSE_CAPSULED = 0x85  # dense capsules (S1's DenseBoost; not the A1's)


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
