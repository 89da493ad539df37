"""Message classes generated from protocol/schema.yaml (schema 0xd0cfa9fd).

Do not edit: change the schema and run ``python -m jackson.protocol.codegen``.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass
from typing import ClassVar

Buffer = bytes | bytearray | memoryview

PROTOCOL_VERSION = 1
SCHEMA_HASH = 0xd0cfa9fd
MAX_PAYLOAD = 120
PARTIAL_TIMEOUT_US = 20000


class NackError(enum.IntEnum):
    """nack_error values."""

    BAD_LENGTH = 1
    BAD_VALUE = 2
    UNKNOWN_TYPE = 3
    VERSION_MISMATCH = 4
    NOT_SUPPORTED = 5
    STORAGE = 6


class LogLevel(enum.IntEnum):
    """log_level values."""

    DEBUG = 0
    INFO = 1
    WARN = 2
    ERROR = 3


class HostState(enum.IntEnum):
    """host_state values."""

    IDLE = 0
    ACTIVE = 1
    SHUTDOWN = 2


class TelemetryFlags(enum.IntFlag):
    """telemetry_flags bits."""

    IMU_OK = 1 << 0
    IMU_CALIBRATED = 1 << 1
    HOST_LOST = 1 << 2
    FAILSAFE_ACTIVE = 1 << 3
    PCNT_OVERFLOW = 1 << 4
    RX_ERRORS = 1 << 5
    I2C_ERRORS = 1 << 6
    TX_DROPPED = 1 << 7
    MOTOR_OUTPUT = 1 << 12
    MOTOR_ENABLE = 1 << 13


class Capabilities(enum.IntFlag):
    """capabilities bits."""

    IMU_PRESENT = 1 << 0
    MOTOR_OUTPUT = 1 << 1
    CALIBRATION_STORED = 1 << 2

ACCEL_FS_SHIFT = 8
GYRO_FS_SHIFT = 10
ACCEL_LSB_PER_G = (16384.0, 8192.0, 4096.0, 2048.0)
GYRO_LSB_PER_DPS = (131.0, 65.5, 32.8, 16.4)
GRAVITY_M_S2 = 9.81
TEMP_LSB_PER_C = 340.0
TEMP_OFFSET_C = 36.53
TELEMETRY_RATE_HZ_RANGE = (1, 500)
FAILSAFE_MS_RANGE = (50, 10000)
DUTY_RANGE = (-10000, 10000)
GYRO_BIAS_RAD_S_RANGE = (-0.5, 0.5)
ACCEL_SCALE_RANGE = (0.5, 2.0)
TELEMETRY_RATE_HZ_DEFAULT = 20
FAILSAFE_MS_DEFAULT = 200


def accel_fs(flags: int) -> int:
    """ACCEL_FS of a telemetry_flags word: bits 8-9."""
    return (flags >> 8) & 0x3


def gyro_fs(flags: int) -> int:
    """GYRO_FS of a telemetry_flags word: bits 10-11."""
    return (flags >> 10) & 0x3

_TELEMETRY = struct.Struct("<IiiH3hh3h")
_STATUS = struct.Struct("<IIIIIIIHH")
_INFO = struct.Struct("<BI3BHHBBBB9f3ffI")
_ACK = struct.Struct("<BBI")
_NACK = struct.Struct("<BBBI")
_LOG = struct.Struct("<B")
_HELLO = struct.Struct("<BII")
_HEARTBEAT = struct.Struct("<BB")
_SET_RATE = struct.Struct("<H")
_ZERO_COUNTERS = struct.Struct("<B")
_SET_IMU_CALIBRATION = struct.Struct("<9f3ffB")
_MOTOR_PWM = struct.Struct("<hhH")
_SET_CONFIG = struct.Struct("<BBBHB")


@dataclass(frozen=True, slots=True)
class Telemetry:
    """Sensor snapshot, sent at the telemetry rate (20 Hz by default) once the host has sent HELLO. Encoder counts are cumulative since boot or the last ZERO_COUNTERS, so a lost frame loses no distance."""

    TYPE: ClassVar[int] = 0x01
    NAME: ClassVar[str] = 'telemetry'
    SIZE: ClassVar[int] = 28
    t_us: int = 0
    enc_left: int = 0
    enc_right: int = 0
    flags: int = 0
    accel: tuple[int, int, int] = (0, 0, 0)
    temp: int = 0
    gyro: tuple[int, int, int] = (0, 0, 0)

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _TELEMETRY.pack(self.t_us, self.enc_left, self.enc_right, self.flags, *self.accel, self.temp, *self.gyro)

    @classmethod
    def unpack(cls, payload: Buffer) -> Telemetry:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 28:
            payload = bytes(payload) + bytes(28 - len(payload))
        v = _TELEMETRY.unpack_from(payload)
        return cls(v[0], v[1], v[2], v[3], (v[4], v[5], v[6]), v[7], (v[8], v[9], v[10]))


@dataclass(frozen=True, slots=True)
class Status:
    """Link and health counters, sent at 1 Hz and after REQUEST_INFO. All counters are cumulative since boot."""

    TYPE: ClassVar[int] = 0x02
    NAME: ClassVar[str] = 'status'
    SIZE: ClassVar[int] = 32
    t_us: int = 0
    rx_frames_ok: int = 0
    rx_crc_errors: int = 0
    rx_bad_commands: int = 0
    tx_dropped: int = 0
    i2c_errors: int = 0
    pcnt_overflows: int = 0
    telemetry_rate_hz: int = 0
    flags: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _STATUS.pack(self.t_us, self.rx_frames_ok, self.rx_crc_errors, self.rx_bad_commands, self.tx_dropped, self.i2c_errors, self.pcnt_overflows, self.telemetry_rate_hz, self.flags)

    @classmethod
    def unpack(cls, payload: Buffer) -> Status:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 32:
            payload = bytes(payload) + bytes(32 - len(payload))
        v = _STATUS.unpack_from(payload)
        return cls(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8])


@dataclass(frozen=True, slots=True)
class Info:
    """Identity and configuration, the answer to HELLO and REQUEST_INFO. The host refuses a device whose protocol_version or schema_hash differs from its own."""

    TYPE: ClassVar[int] = 0x03
    NAME: ClassVar[str] = 'info'
    SIZE: ClassVar[int] = 72
    protocol_version: int = 0
    schema_hash: int = 0
    firmware_version: tuple[int, int, int] = (0, 0, 0)
    telemetry_rate_hz: int = 0
    failsafe_ms: int = 0
    accel_fs: int = 0
    gyro_fs: int = 0
    direction_flags: int = 0
    capabilities: int = 0
    imu_rotation: tuple[float, float, float, float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    gyro_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_scale: float = 0.0
    boot_id: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _INFO.pack(self.protocol_version, self.schema_hash, *self.firmware_version, self.telemetry_rate_hz, self.failsafe_ms, self.accel_fs, self.gyro_fs, self.direction_flags, self.capabilities, *self.imu_rotation, *self.gyro_bias, self.accel_scale, self.boot_id)

    @classmethod
    def unpack(cls, payload: Buffer) -> Info:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 72:
            payload = bytes(payload) + bytes(72 - len(payload))
        v = _INFO.unpack_from(payload)
        return cls(v[0], v[1], (v[2], v[3], v[4]), v[5], v[6], v[7], v[8], v[9], v[10], (v[11], v[12], v[13], v[14], v[15], v[16], v[17], v[18], v[19]), (v[20], v[21], v[22]), v[23], v[24])


@dataclass(frozen=True, slots=True)
class Ack:
    """A host command was carried out."""

    TYPE: ClassVar[int] = 0x04
    NAME: ClassVar[str] = 'ack'
    SIZE: ClassVar[int] = 6
    acked_type: int = 0
    acked_seq: int = 0
    acked_crc: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _ACK.pack(self.acked_type, self.acked_seq, self.acked_crc)

    @classmethod
    def unpack(cls, payload: Buffer) -> Ack:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 6:
            payload = bytes(payload) + bytes(6 - len(payload))
        v = _ACK.unpack_from(payload)
        return cls(v[0], v[1], v[2])


@dataclass(frozen=True, slots=True)
class Nack:
    """A host command was refused; nothing changed on the device."""

    TYPE: ClassVar[int] = 0x05
    NAME: ClassVar[str] = 'nack'
    SIZE: ClassVar[int] = 7
    acked_type: int = 0
    acked_seq: int = 0
    error: int = 0
    acked_crc: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _NACK.pack(self.acked_type, self.acked_seq, self.error, self.acked_crc)

    @classmethod
    def unpack(cls, payload: Buffer) -> Nack:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 7:
            payload = bytes(payload) + bytes(7 - len(payload))
        v = _NACK.unpack_from(payload)
        return cls(v[0], v[1], v[2], v[3])


@dataclass(frozen=True, slots=True)
class Log:
    """Human-readable text from the device."""

    TYPE: ClassVar[int] = 0x06
    NAME: ClassVar[str] = 'log'
    SIZE: ClassVar[int] = 1
    level: int = 0
    text: str = ""

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        text = self.text.encode("utf-8")
        if len(text) > 100:
            raise ValueError(f"text is {len(text)} bytes, at most 100")
        return _LOG.pack(self.level) + text

    @classmethod
    def unpack(cls, payload: Buffer) -> Log:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 1:
            payload = bytes(payload) + bytes(1 - len(payload))
        v = _LOG.unpack_from(payload)
        return cls(v[0], bytes(payload[1:]).decode("utf-8", "replace"))


@dataclass(frozen=True, slots=True)
class Hello:
    """First message of a session. The device answers INFO and ACK (NACK VERSION_MISMATCH when version or hash differ) and starts telemetry. A HELLO carrying the session in progress resumes it: answered the same way, nothing restarts (the host's HELLO after a silence on a link it still holds)."""

    TYPE: ClassVar[int] = 0x80
    NAME: ClassVar[str] = 'hello'
    SIZE: ClassVar[int] = 9
    protocol_version: int = 0
    schema_hash: int = 0
    session: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _HELLO.pack(self.protocol_version, self.schema_hash, self.session)

    @classmethod
    def unpack(cls, payload: Buffer) -> Hello:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 9:
            payload = bytes(payload) + bytes(9 - len(payload))
        v = _HELLO.unpack_from(payload)
        return cls(v[0], v[1], v[2])


@dataclass(frozen=True, slots=True)
class Heartbeat:
    """Sent by the host after it has processed each telemetry frame (20 Hz). Keeps the device's failsafe from firing; not acknowledged. The twin's lockstep clock advances when it sees ack_seq of the frame it last sent."""

    TYPE: ClassVar[int] = 0x81
    NAME: ClassVar[str] = 'heartbeat'
    SIZE: ClassVar[int] = 2
    ack_seq: int = 0
    host_state: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _HEARTBEAT.pack(self.ack_seq, self.host_state)

    @classmethod
    def unpack(cls, payload: Buffer) -> Heartbeat:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 2:
            payload = bytes(payload) + bytes(2 - len(payload))
        v = _HEARTBEAT.unpack_from(payload)
        return cls(v[0], v[1])


@dataclass(frozen=True, slots=True)
class SetRate:
    """Telemetry rate. NACK BAD_VALUE outside 1-500 Hz."""

    TYPE: ClassVar[int] = 0x82
    NAME: ClassVar[str] = 'set_rate'
    SIZE: ClassVar[int] = 2
    rate_hz: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _SET_RATE.pack(self.rate_hz)

    @classmethod
    def unpack(cls, payload: Buffer) -> SetRate:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 2:
            payload = bytes(payload) + bytes(2 - len(payload))
        v = _SET_RATE.unpack_from(payload)
        return cls(v[0])


@dataclass(frozen=True, slots=True)
class ZeroCounters:
    """Sets the software offset so the selected cumulative counts read 0."""

    TYPE: ClassVar[int] = 0x83
    NAME: ClassVar[str] = 'zero_counters'
    SIZE: ClassVar[int] = 1
    mask: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _ZERO_COUNTERS.pack(self.mask)

    @classmethod
    def unpack(cls, payload: Buffer) -> ZeroCounters:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 1:
            payload = bytes(payload) + bytes(1 - len(payload))
        v = _ZERO_COUNTERS.unpack_from(payload)
        return cls(v[0])


@dataclass(frozen=True, slots=True)
class SetImuCalibration:
    """IMU calibration applied on the device: omega_base = R omega_sensor - gyro_bias, a_base = accel_scale R a_sensor. persist = 1 also stores it in NVS."""

    TYPE: ClassVar[int] = 0x84
    NAME: ClassVar[str] = 'set_imu_calibration'
    SIZE: ClassVar[int] = 53
    imu_rotation: tuple[float, float, float, float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    gyro_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_scale: float = 0.0
    persist: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _SET_IMU_CALIBRATION.pack(*self.imu_rotation, *self.gyro_bias, self.accel_scale, self.persist)

    @classmethod
    def unpack(cls, payload: Buffer) -> SetImuCalibration:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 53:
            payload = bytes(payload) + bytes(53 - len(payload))
        v = _SET_IMU_CALIBRATION.unpack_from(payload)
        return cls((v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]), (v[9], v[10], v[11]), v[12], v[13])


@dataclass(frozen=True, slots=True)
class RequestInfo:
    """Asks for INFO and STATUS."""

    TYPE: ClassVar[int] = 0x85
    NAME: ClassVar[str] = 'request_info'
    SIZE: ClassVar[int] = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return b""

    @classmethod
    def unpack(cls, payload: Buffer) -> RequestInfo:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        return cls()


@dataclass(frozen=True, slots=True)
class MotorPwm:
    """Signed duty per wheel for firmware that drives the motors (1e-4 units, clamped to +-10000). Expires after timeout_ms (0: the failsafe time), then the device brakes."""

    TYPE: ClassVar[int] = 0x86
    NAME: ClassVar[str] = 'motor_pwm'
    SIZE: ClassVar[int] = 6
    left: int = 0
    right: int = 0
    timeout_ms: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _MOTOR_PWM.pack(self.left, self.right, self.timeout_ms)

    @classmethod
    def unpack(cls, payload: Buffer) -> MotorPwm:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 6:
            payload = bytes(payload) + bytes(6 - len(payload))
        v = _MOTOR_PWM.unpack_from(payload)
        return cls(v[0], v[1], v[2])


@dataclass(frozen=True, slots=True)
class SetConfig:
    """Device configuration. persist = 1 also stores it in NVS."""

    TYPE: ClassVar[int] = 0x87
    NAME: ClassVar[str] = 'set_config'
    SIZE: ClassVar[int] = 6
    accel_fs: int = 0
    gyro_fs: int = 0
    direction_flags: int = 0
    failsafe_ms: int = 0
    persist: int = 0

    def pack(self) -> bytes:
        """Payload bytes of this message."""
        return _SET_CONFIG.pack(self.accel_fs, self.gyro_fs, self.direction_flags, self.failsafe_ms, self.persist)

    @classmethod
    def unpack(cls, payload: Buffer) -> SetConfig:
        """Decode a payload; missing trailing bytes read as zero, extra bytes are ignored."""
        if len(payload) < 6:
            payload = bytes(payload) + bytes(6 - len(payload))
        v = _SET_CONFIG.unpack_from(payload)
        return cls(v[0], v[1], v[2], v[3], v[4])


Message = (
    Telemetry
    | Status
    | Info
    | Ack
    | Nack
    | Log
    | Hello
    | Heartbeat
    | SetRate
    | ZeroCounters
    | SetImuCalibration
    | RequestInfo
    | MotorPwm
    | SetConfig
)

MESSAGES: dict[int, type[Message]] = {
    Telemetry.TYPE: Telemetry,
    Status.TYPE: Status,
    Info.TYPE: Info,
    Ack.TYPE: Ack,
    Nack.TYPE: Nack,
    Log.TYPE: Log,
    Hello.TYPE: Hello,
    Heartbeat.TYPE: Heartbeat,
    SetRate.TYPE: SetRate,
    ZeroCounters.TYPE: ZeroCounters,
    SetImuCalibration.TYPE: SetImuCalibration,
    RequestInfo.TYPE: RequestInfo,
    MotorPwm.TYPE: MotorPwm,
    SetConfig.TYPE: SetConfig,
}
"""Message class by TYPE id."""
