"""The twin's MCU emulator: the firmware's behaviour in Python, frame for frame.

It follows ``firmware/core/firmware.cpp`` rule by rule (handshake, telemetry scheduler, every
command with its ACK or NACK, the heartbeat and motor-command failsafe, STATUS at 1 Hz, the
telemetry flags, the PCNT's 16-bit limit events), so a host cannot tell it from the real
firmware; ``tests/sim/test_firmware_in_the_loop.py`` runs one scenario against both and compares
the frames. Where the firmware samples the IMU at 100 Hz and averages, the emulator takes the
twin's per-period sample directly: the twin holds the registers constant within a period, so
the firmware's mean is that same sample.

The MPU-6050 driver (``firmware/core/mpu6050.cpp``) is followed as well: an IMU absent from
boot, or one that stops answering (the sensors' ``imu_ok`` clears: the twin's ``imu_dead``
fault), fails its polls at the firmware's 100 Hz schedule, each failure an I2C error, three in
a row or any init failure making it wait 50 ms, 100 ms, ... 2 s before it tries again; one that
answers again is back (IMU_OK) at its next attempt. As the compiled firmware reads its sensor
feed, the ``imu_ok`` of a telemetry instant holds for the polls since the one before.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jackson.protocol import (
    MESSAGES,
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    Ack,
    Capabilities,
    Frame,
    FrameDecoder,
    Heartbeat,
    Hello,
    HostState,
    Info,
    Message,
    MotorPwm,
    Nack,
    NackError,
    RequestInfo,
    SetConfig,
    SetImuCalibration,
    SetRate,
    Status,
    Telemetry,
    TelemetryFlags,
    ZeroCounters,
    decode_message,
    encode_frame,
)
from jackson.protocol.messages import (
    ACCEL_FS_SHIFT,
    ACCEL_SCALE_RANGE,
    DUTY_RANGE,
    FAILSAFE_MS_RANGE,
    GYRO_BIAS_RAD_S_RANGE,
    GYRO_FS_SHIFT,
    GYRO_LSB_PER_DPS,
    TELEMETRY_RATE_HZ_RANGE,
)

FIRMWARE_VERSION = (0, 1, 0)
PCNT_LIMIT = 30000  # as firmware/esp32/board_config.hpp
STATUS_PERIOD_US = 1_000_000
IMU_PERIOD_US = 10_000  # 100 Hz MPU-6050 polling (faster with faster telemetry), firmware.hpp
IMU_FIRST_BACKOFF_US = 50_000  # retry schedule of an absent MPU-6050, mpu6050.hpp
IMU_MAX_BACKOFF_US = 2_000_000
IMU_FAILURES_BEFORE_REINIT = 3  # failed reads in a row before the driver backs off
MIN_RATE_HZ, MAX_RATE_HZ = TELEMETRY_RATE_HZ_RANGE
MIN_FAILSAFE_MS, MAX_FAILSAFE_MS = FAILSAFE_MS_RANGE


@dataclass(frozen=True)
class SensorSample:
    """What the MCU's sensors read at one instant (true cumulative counts, register values)."""

    enc_left: int
    enc_right: int
    imu_ok: bool
    accel: tuple[int, int, int]
    temp: int
    gyro: tuple[int, int, int]


@dataclass(frozen=True)
class MotorOutput:
    """The MCU's TB6612 output (when it drives the motors): duty in 1e-4, braked or not."""

    left: int = 0
    right: int = 0
    braked: bool = True
    failsafe: bool = False


def _reached(now: int, t: int) -> bool:
    d = (now - t) & 0xFFFFFFFF
    return d < 0x80000000


class _Encoder:
    """PCNT limit events and the firmware's accumulator: direction flag and zero offset."""

    def __init__(self) -> None:
        self.raw = 0
        self.offset = 0
        self.inverted = False
        self.last_events = 0
        self.overflows = 0
        self.flag = False

    def update(self, total: int) -> int:
        events = int(total / PCNT_LIMIT) if total >= 0 else -int(-total / PCNT_LIMIT)
        if events != self.last_events:
            self.flag = True
            self.overflows += abs(events - self.last_events)
            self.last_events = events
        self.raw = total & 0xFFFFFFFF
        return self.value()

    def value(self) -> int:
        signed = (-self.raw if self.inverted else self.raw) & 0xFFFFFFFF
        v = (signed - self.offset) & 0xFFFFFFFF
        return v - (1 << 32) if v >= 1 << 31 else v

    def zero(self) -> None:
        self.offset = (-self.raw if self.inverted else self.raw) & 0xFFFFFFFF

    def set_inverted(self, inverted: bool) -> None:
        if inverted != self.inverted:
            self.inverted = inverted
            self.zero()

    def take_flag(self) -> bool:
        f, self.flag = self.flag, False
        return f


class McuEmulator:
    """One emulated ESP32-S3. ``write`` sends bytes to the host and returns False when the
    link's buffer is full (the frame is then dropped and counted, as on the device)."""

    def __init__(
        self,
        write: Callable[[bytes], bool],
        sensors: Callable[[], SensorSample],
        *,
        motor_output: bool = False,
        imu_present: bool = True,
        boot_us: int = 0,
        boot_id: int = 1,
    ) -> None:
        self._write = write
        self._sensors = sensors
        self.motor_output = motor_output
        self.imu_present = imu_present
        self.boot_id = boot_id  # INFO's boot_id: a new one means the MCU was reset
        self.decoder = FrameDecoder(deliver_unknown=True)
        self.rate_hz = 20
        self.failsafe_ms = 600
        self.accel_fs = 0
        self.gyro_fs = 0
        self.direction_flags = 0
        self.left = _Encoder()
        self.right = _Encoder()
        self.calibrated = False
        self.calibration_stored = False
        self.rotation: NDArray[np.float32] = np.eye(3, dtype=np.float32)
        self.gyro_bias: NDArray[np.float32] = np.zeros(3, dtype=np.float32)
        self.accel_scale = np.float32(1.0)
        self.session = False
        self.tx_seq = 0
        self.frames_sent = 0
        self.tx_dropped = 0
        self.rx_bad_commands = 0
        self.rx_errors_at_status = 0
        self.tx_dropped_flag = False
        self.telemetry_sent = False
        self.last_telemetry_seq = 0
        self.heartbeat_seen = False
        self.heartbeat_ack = 0
        self.last_heartbeat_us = 0
        self.next_telemetry_us = 0
        self.next_status_us = 0
        self.motor_commanded = False
        self.cmd = (0, 0)
        self.cmd_expiry_us = 0
        self.motors = MotorOutput()
        self.host_shutdown = False  # the newest HEARTBEAT said SHUTDOWN
        # the motor interlock line (firmware.cpp update_interlock, docs/firmware.md "Motor
        # interlock"): True while asserted (PCA9685 OE low / TB6612 STBY high)
        self.motor_enable = False
        self.telemetry_frames = 0
        self.heartbeats = 0
        # The MPU-6050 driver (firmware/core/mpu6050.cpp): polls at the firmware's IMU schedule
        # (every IMU_PERIOD_US from boot), evaluated lazily up to the MCU time of each tick and
        # each received frame. While the chip answers and the driver is up, every poll reads a
        # sample; otherwise each failed attempt counts an I2C error and the driver backs off
        # 50 ms, 100 ms, ... 2 s between init attempts.
        self._imu_answering = imu_present  # the chip answers on the bus (the sensors' imu_ok)
        self._imu_initialised = imu_present
        self._imu_ok = imu_present  # the newest poll read a sample (IMU_OK)
        self._imu_sampled = imu_present  # a poll read a sample since the last telemetry frame
        self._imu_failures = 0  # consecutive failed reads of an initialised driver
        self.i2c_errors = 0
        self.i2c_error_flag = False
        self._i2c_errors_seen = 0
        self._imu_next_us = (boot_us + IMU_PERIOD_US) & 0xFFFFFFFF
        self._imu_waiting = False
        self._imu_retry_us = 0
        self._imu_backoff_us = IMU_FIRST_BACKOFF_US
        if not imu_present:
            self._imu_poll(boot_us)  # the firmware learns presence at boot
        self._last_imu: tuple[tuple[int, int, int], tuple[int, int, int], int] = (
            (0, 0, 0),
            (0, 0, 0),
            0,
        )

    # ------------------------------------------------------------------ scheduling

    @property
    def period_us(self) -> int:
        return 1_000_000 // self.rate_hz

    @property
    def imu_period_us(self) -> int:
        return min(IMU_PERIOD_US, self.period_us)

    def _imu_poll(self, t: int) -> None:
        """One poll of the MPU-6050 driver at MCU time ``t`` (mpu6050.cpp ``poll``)."""
        if self._imu_waiting and not _reached(t, self._imu_retry_us):
            return
        self._imu_waiting = False
        if not self._imu_initialised:
            if not self._imu_answering:
                self._imu_fail(t)
                return
            self._imu_initialised = True
            self._imu_failures = 0
        if not self._imu_answering:
            self._imu_fail(t)
            return
        self._imu_ok = True
        self._imu_sampled = True
        self._imu_failures = 0
        self._imu_backoff_us = IMU_FIRST_BACKOFF_US

    def _imu_fail(self, t: int) -> None:
        """A failed init or read (mpu6050.cpp ``fail``): an I2C error; an init failure or the
        third failed read in a row starts the backoff."""
        self.i2c_errors += 1
        self._imu_ok = False
        if self._imu_initialised:
            self._imu_failures += 1
        if not self._imu_initialised or self._imu_failures >= IMU_FAILURES_BEFORE_REINIT:
            self._imu_initialised = False
            self._imu_waiting = True
            self._imu_retry_us = (t + self._imu_backoff_us) & 0xFFFFFFFF
            half = IMU_MAX_BACKOFF_US // 2
            b = self._imu_backoff_us
            self._imu_backoff_us = IMU_MAX_BACKOFF_US if b >= half else b * 2

    def _imu_polls_until(self, now: int, *, inclusive: bool) -> None:
        """Run the IMU polls due before ``now`` (and at ``now`` if ``inclusive``)."""
        nxt = self._imu_next_us
        if not _reached(now, nxt) or (not inclusive and nxt == now):
            return
        period = self.imu_period_us
        if self._imu_answering and self._imu_initialised and self._imu_ok:
            # a healthy IMU: every poll reads a sample; only the schedule moves on
            n = ((now - nxt) & 0xFFFFFFFF) // period + 1
            if not inclusive and ((now - nxt) & 0xFFFFFFFF) % period == 0:
                n -= 1
            self._imu_next_us = (nxt + n * period) & 0xFFFFFFFF
            self._imu_sampled = self._imu_sampled or n > 0
            return
        while _reached(now, self._imu_next_us) and (inclusive or self._imu_next_us != now):
            t = self._imu_next_us
            self._imu_poll(t)
            if self.i2c_errors != self._i2c_errors_seen:
                self._i2c_errors_seen = self.i2c_errors
                self.i2c_error_flag = True
            self._imu_next_us = (t + self.imu_period_us) & 0xFFFFFFFF

    def next_deadline(self, now: int) -> int | None:
        """The next instant tick() has something to do, or None before a session."""
        if not self.session:
            return None
        t = self.next_telemetry_us
        deadlines = [self.next_status_us]
        if self.motor_enable:  # the instant the interlock drops, if no heartbeat comes
            lost = (self.last_heartbeat_us + 1000 * self.failsafe_ms) & 0xFFFFFFFF
            if not _reached(now, lost):
                deadlines.append(lost)
        for d in deadlines:
            if ((d - t) & 0xFFFFFFFF) >= 0x80000000:
                t = d
        return t

    def receive(self, data: bytes, now: int) -> None:
        """Bytes from the host, handled at MCU time ``now`` [us].

        The firmware handles each frame the moment its last byte arrives, before it looks at
        the bytes after it (which STATUS counters can show). A chunk that is exactly one frame
        is decoded at once (nothing can follow it); anything else is fed byte by byte.
        """
        self._imu_polls_until(now, inclusive=False)  # those ran in earlier firmware ticks
        dec = self.decoder
        if not dec.pending and len(data) >= 10 and data[0] == 0xA5 and len(data) == data[5] + 10:
            for frame in dec.feed(data, now):
                self._handle(frame, now)
            return
        for i in range(len(data)):
            for frame in dec.feed(data[i : i + 1], now):
                self._handle(frame, now)

    def tick(self, now: int) -> None:
        """Everything scheduled at or before ``now`` (the firmware's tick)."""
        self.decoder.poll(now)
        if self.session and _reached(now, self.next_telemetry_us):
            # the chip's state for the polls since the last instant, as the compiled
            # firmware's sensor feed gives it (the twin reads its sensors once per instant)
            self._imu_answering = self.imu_present and self._sensors().imu_ok
        self._imu_polls_until(now, inclusive=True)
        self._update_motors(now)
        self._update_interlock(now)
        if not self.session:
            return
        if _reached(now, self.next_telemetry_us):
            self._send_telemetry(now)
            self.next_telemetry_us = (self.next_telemetry_us + self.period_us) & 0xFFFFFFFF
            if _reached(now, self.next_telemetry_us):
                self.next_telemetry_us = (now + self.period_us) & 0xFFFFFFFF
        if _reached(now, self.next_status_us):
            self._send_status(now)
            self.next_status_us = (now + STATUS_PERIOD_US) & 0xFFFFFFFF

    # ------------------------------------------------------------------ output

    def _send(self, msg: Message) -> None:
        frame = encode_frame(msg, self.tx_seq)
        self.tx_seq = (self.tx_seq + 1) & 0xFF
        if self._write(frame):
            self.frames_sent += 1
        else:
            self.tx_dropped += 1
            self.tx_dropped_flag = True

    def _flags(self, now: int, imu_ok: bool) -> int:
        f = 0
        if imu_ok:
            f |= TelemetryFlags.IMU_OK
        if self.calibrated:
            f |= TelemetryFlags.IMU_CALIBRATED
        if self.session and (
            not self.heartbeat_seen
            or _reached(now, self.last_heartbeat_us + 1000 * self.failsafe_ms)
        ):
            f |= TelemetryFlags.HOST_LOST
        if self.motors.failsafe:
            f |= TelemetryFlags.FAILSAFE_ACTIVE
        if self.decoder.counters.crc_errors + self.rx_bad_commands != self.rx_errors_at_status:
            f |= TelemetryFlags.RX_ERRORS
        if self.i2c_error_flag:
            f |= TelemetryFlags.I2C_ERRORS
        if self.tx_dropped_flag:
            f |= TelemetryFlags.TX_DROPPED
        if self.motor_output:
            f |= TelemetryFlags.MOTOR_OUTPUT
        if self.motor_enable:
            f |= TelemetryFlags.MOTOR_ENABLE
        return int(f) | (self.accel_fs << ACCEL_FS_SHIFT) | (self.gyro_fs << GYRO_FS_SHIFT)

    def _calibrate(
        self, accel: tuple[int, int, int], gyro: tuple[int, int, int]
    ) -> tuple[tuple[int, int, int], tuple[int, int, int]]:
        """The firmware's float32 calibration maths (firmware/core/imu_calibration.cpp)."""
        f32 = np.float32
        lsb_per_rad_s = f32(GYRO_LSB_PER_DPS[self.gyro_fs]) / (f32(3.14159265358979) / f32(180.0))
        w = self.rotation @ np.array(gyro, dtype=f32) - self.gyro_bias * lsb_per_rad_s
        a = self.accel_scale * (self.rotation @ np.array(accel, dtype=f32))

        def sat(v: np.floating) -> int:
            return max(-32768, min(32767, int(np.rint(v))))

        return (sat(a[0]), sat(a[1]), sat(a[2])), (sat(w[0]), sat(w[1]), sat(w[2]))

    def _send_telemetry(self, now: int) -> None:
        s = self._sensors()
        imu_ok = self._imu_ok
        accel, gyro, temp = s.accel, s.gyro, s.temp
        if not self._imu_sampled:  # no sample since the last frame: the last one again
            accel, gyro, temp = self._last_imu
        elif self.calibrated:
            accel, gyro = self._calibrate(accel, gyro)
        self._imu_sampled = False
        self._last_imu = (accel, gyro, temp)
        flags = self._flags(now, imu_ok)
        enc_l = self.left.update(s.enc_left)
        enc_r = self.right.update(s.enc_right)
        if self.left.take_flag() | self.right.take_flag():
            flags |= TelemetryFlags.PCNT_OVERFLOW
        seq = self.tx_seq
        dropped = self.tx_dropped
        self._send(Telemetry(now & 0xFFFFFFFF, enc_l, enc_r, flags, accel, temp, gyro))
        if self.tx_dropped == dropped:
            self.tx_dropped_flag = False
            self.i2c_error_flag = False
            self.telemetry_sent = True
            self.last_telemetry_seq = seq
            self.telemetry_frames += 1

    def _send_status(self, now: int) -> None:
        c = self.decoder.counters
        imu_ok = self._imu_ok
        self._send(
            Status(
                t_us=now & 0xFFFFFFFF,
                rx_frames_ok=c.frames_ok,
                rx_crc_errors=c.crc_errors,
                rx_bad_commands=self.rx_bad_commands,
                tx_dropped=self.tx_dropped,
                i2c_errors=self.i2c_errors,
                pcnt_overflows=self.left.overflows + self.right.overflows,
                telemetry_rate_hz=self.rate_hz,
                flags=self._flags(now, imu_ok),
            )
        )
        self.rx_errors_at_status = c.crc_errors + self.rx_bad_commands

    def _send_info(self) -> None:
        caps = 0
        if self.imu_present:
            caps |= Capabilities.IMU_PRESENT
        if self.motor_output:
            caps |= Capabilities.MOTOR_OUTPUT
        if self.calibration_stored:
            caps |= Capabilities.CALIBRATION_STORED
        r = self.rotation
        self._send(
            Info(
                protocol_version=PROTOCOL_VERSION,
                schema_hash=SCHEMA_HASH,
                firmware_version=FIRMWARE_VERSION,
                telemetry_rate_hz=self.rate_hz,
                failsafe_ms=self.failsafe_ms,
                accel_fs=self.accel_fs,
                gyro_fs=self.gyro_fs,
                direction_flags=self.direction_flags,
                capabilities=int(caps),
                imu_rotation=tuple(float(r[i, j]) for i in range(3) for j in range(3)),  # type: ignore[arg-type]
                gyro_bias=(
                    float(self.gyro_bias[0]),
                    float(self.gyro_bias[1]),
                    float(self.gyro_bias[2]),
                ),
                accel_scale=float(self.accel_scale),
                boot_id=self.boot_id,
            )
        )

    # ------------------------------------------------------------------ motors

    def _host_alive(self, now: int) -> bool:
        """A session's HEARTBEATs arrive within failsafe_ms (firmware.cpp host_alive)."""
        return (
            self.session
            and self.heartbeat_seen
            and not _reached(now, self.last_heartbeat_us + 1000 * self.failsafe_ms)
        )

    def _update_motors(self, now: int) -> None:
        if not self.motor_output:
            return
        live = self.motor_commanded and not _reached(now, self.cmd_expiry_us)
        if live and self._host_alive(now):
            self.motors = MotorOutput(self.cmd[0], self.cmd[1], False, False)
        else:
            self.motors = MotorOutput(0, 0, True, self.motor_commanded)

    def _update_interlock(self, now: int) -> None:
        """The motor interlock line (firmware.cpp update_interlock): asserted exactly while the
        host is alive and its newest HEARTBEAT is not SHUTDOWN."""
        self.motor_enable = self._host_alive(now) and not self.host_shutdown

    def wheel_duty(self) -> tuple[float, float, bool]:
        """The H-bridge output per wheel as signed duty (-1..1), with direction flags applied."""
        m = self.motors
        left = -m.left if self.direction_flags & 1 else m.left
        right = -m.right if self.direction_flags & 2 else m.right
        return left / 10_000.0, right / 10_000.0, m.braked

    # ------------------------------------------------------------------ commands

    def _ack(self, f: Frame) -> None:
        self._send(Ack(acked_type=f.type, acked_seq=f.seq, acked_crc=f.crc))

    def _nack(self, f: Frame, e: NackError) -> None:
        self.rx_bad_commands += 1
        self._send(Nack(acked_type=f.type, acked_seq=f.seq, error=int(e), acked_crc=f.crc))

    def _handle(self, f: Frame, now: int) -> None:
        if f.type not in MESSAGES or f.type < 0x80:
            self._nack(f, NackError.UNKNOWN_TYPE)
            return
        cls = MESSAGES[f.type]
        if f.type == Heartbeat.TYPE:
            if len(f.payload) < Heartbeat.SIZE or not self.session:
                return
            hb = Heartbeat.unpack(f.payload)
            self.heartbeats += 1
            self.heartbeat_seen = True
            self.heartbeat_ack = hb.ack_seq
            self.last_heartbeat_us = now
            self.host_shutdown = hb.host_state == HostState.SHUTDOWN
            if self.host_shutdown:
                self.motor_commanded = False
                self.motors = MotorOutput()
            self._update_interlock(now)  # the firmware's tick that received it does the same
            return
        if len(f.payload) < cls.SIZE:
            self._nack(f, NackError.BAD_LENGTH)
            return
        msg = decode_message(f)
        if isinstance(msg, Hello):
            if msg.protocol_version != PROTOCOL_VERSION or msg.schema_hash != SCHEMA_HASH:
                self._send_info()
                self._nack(f, NackError.VERSION_MISMATCH)
                self.session = False
                return
            self.session = True
            self.heartbeat_seen = False  # the interlock drops until this session's first HEARTBEAT
            self.host_shutdown = False
            self._update_interlock(now)  # as the firmware's tick that handles the HELLO
            self.telemetry_sent = False
            self.last_heartbeat_us = now
            self.next_telemetry_us = (now + self.period_us) & 0xFFFFFFFF
            self.next_status_us = (now + STATUS_PERIOD_US) & 0xFFFFFFFF
            self._send_info()
            self._ack(f)
        elif isinstance(msg, SetRate):
            if not MIN_RATE_HZ <= msg.rate_hz <= MAX_RATE_HZ:
                self._nack(f, NackError.BAD_VALUE)
                return
            self.rate_hz = msg.rate_hz
            self.next_telemetry_us = (now + self.period_us) & 0xFFFFFFFF
            self._ack(f)
        elif isinstance(msg, ZeroCounters):
            if msg.mask == 0 or msg.mask > 3:
                self._nack(f, NackError.BAD_VALUE)
                return
            s = self._sensors()
            self.left.update(s.enc_left)
            self.right.update(s.enc_right)
            if msg.mask & 1:
                self.left.zero()
            if msg.mask & 2:
                self.right.zero()
            self._ack(f)
        elif isinstance(msg, SetImuCalibration):
            r = np.array(msg.imu_rotation, dtype=np.float32).reshape(3, 3)
            b = np.array(msg.gyro_bias, dtype=np.float32)
            if not _calibration_valid(r, b, msg.accel_scale) or msg.persist > 1:
                self._nack(f, NackError.BAD_VALUE)
                return
            self.rotation, self.gyro_bias = r, b
            self.accel_scale = np.float32(msg.accel_scale)
            if msg.persist == 1:
                self.calibration_stored = True
            self.calibrated = True
            self._ack(f)
        elif isinstance(msg, RequestInfo):
            self._send_info()
            self._send_status(now)
            self._ack(f)
        elif isinstance(msg, MotorPwm):
            if not self.motor_output:
                self._nack(f, NackError.NOT_SUPPORTED)
                return
            lo, hi = DUTY_RANGE
            self.cmd = (max(lo, min(hi, msg.left)), max(lo, min(hi, msg.right)))
            self.motor_commanded = True
            timeout = msg.timeout_ms if msg.timeout_ms else self.failsafe_ms
            self.cmd_expiry_us = (now + 1000 * timeout) & 0xFFFFFFFF
            self._ack(f)
            self._update_motors(now)
        elif isinstance(msg, SetConfig):
            ok = (
                msg.accel_fs <= 3
                and msg.gyro_fs <= 3
                and msg.direction_flags <= 3
                and MIN_FAILSAFE_MS <= msg.failsafe_ms <= MAX_FAILSAFE_MS
                and msg.persist <= 1
            )
            if not ok:
                self._nack(f, NackError.BAD_VALUE)
                return
            if (msg.accel_fs, msg.gyro_fs) != (self.accel_fs, self.gyro_fs) or not self.imu_present:
                self._imu_initialised = False  # the driver re-initialises at its next poll
                self._imu_waiting = False
            self._imu_sampled = False  # samples of the old range do not enter the next mean
            self.accel_fs, self.gyro_fs = msg.accel_fs, msg.gyro_fs
            self.direction_flags = msg.direction_flags
            self.failsafe_ms = msg.failsafe_ms
            self.left.set_inverted(bool(msg.direction_flags & 1))
            self.right.set_inverted(bool(msg.direction_flags & 2))
            self._ack(f)
        else:
            self._nack(f, NackError.UNKNOWN_TYPE)


def _calibration_valid(r: NDArray[np.float32], b: NDArray[np.float32], scale: float) -> bool:
    """The firmware's check: a proper rotation, a bias under 0.5 rad/s, scale 0.5-2."""
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(b)) and math.isfinite(scale)):
        return False
    ortho = float(np.max(np.abs(r @ r.T - np.eye(3, dtype=np.float32))))
    return (
        ortho < 1e-3
        and abs(float(np.linalg.det(r)) - 1.0) < 1e-3
        and float(np.max(np.abs(b))) < GYRO_BIAS_RAD_S_RANGE[1]
        and ACCEL_SCALE_RANGE[0] <= scale <= ACCEL_SCALE_RANGE[1]
    )
