"""The twin's MCU: the firmware core itself, with the twin as its hardware.

:class:`Mcu` runs ``firmware/core`` (the code the ESP32-S3 runs, built by ``make setup`` into a
Python extension module: :mod:`jackson.sim.firmware_core`, ``firmware/twin/module.cpp``) behind
a HAL made of the twin:

- **clock**: the twin's. :meth:`Mcu.tick` brings the core to an instant of the twin, running
  every deadline of the core on the way (its 100 Hz MPU-6050 polls, STATUS, the failsafe
  instants) at its own time, as the firmware's loop would;
- **PCNT**: the twin's true cumulative wheel counts, read when the core reads them (each
  telemetry frame, ZERO_COUNTERS) and presented as the ESP32's 16-bit counter with its limit
  events;
- **MPU-6050**: a register file fed the twin's IMU sample at each telemetry instant, before the
  polls of that period run (so the firmware's mean of the period's polls is that sample: the
  twin's IMU model gives one averaged sample per period); a chip that stops answering (the
  sensors' ``imu_ok`` clears, the ``imu_dead`` fault) fails the polls of the period;
- **host link**: frames go out through ``write`` (False: no room, the frame is dropped whole and
  counted, as on the device), bytes from the host are handed in by :meth:`Mcu.receive`;
- **motor outputs and the interlock line**: recorded, read by the twin's runner.

Firmware behaviour is changed in C++ once: there is no other copy of its rules in the project.
The runner drives it behind :class:`~jackson.sim.core_port.CorePort`, with its pty, as a
:class:`~jackson.sim.port.McuPort`; ``jackson sim --firmware`` runs the same core as its own
process (the POSIX build, :mod:`jackson.sim.fil`) behind the same interface.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from jackson.sim.firmware_core import McuBuildError, load

__all__ = ["Mcu", "McuBuildError", "SensorSample", "imu_register_bytes"]

TELEMETRY_TYPE = 0x01  # a frame's TYPE byte (offset 3) for TELEMETRY


@dataclass(frozen=True)
class SensorSample:
    """What the MCU's sensors read at one instant (true cumulative counts, register values)."""

    enc_left: int
    enc_right: int
    imu_ok: bool
    accel: tuple[int, int, int]
    temp: int
    gyro: tuple[int, int, int]


def imu_register_bytes(accel: tuple[int, int, int], temp: int, gyro: tuple[int, int, int]) -> bytes:
    """The MPU-6050's 14 bytes at 0x3B..0x48 as the MCU reads them: big-endian, accel xyz,
    temperature, gyro xyz."""
    return b"".join(v.to_bytes(2, "big", signed=True) for v in (*accel, temp, *gyro))


def _reached(now: int, t: int) -> bool:
    """``now`` is at or after ``t`` on the 32-bit microsecond clock (the firmware's test)."""
    return ((now - t) & 0xFFFFFFFF) < 0x80000000


class Mcu:
    """One ESP32-S3 of the twin.

    Parameters
    ----------
    write : callable
        Sends one frame's bytes to the host; False when the link has no room (the frame is
        dropped). An attribute: a fault may wrap it.
    sensors : callable
        The twin's sensors at the current instant (:class:`SensorSample`; the runner reads
        them once per instant). An attribute: a fault may wrap it.
    motor_output : bool
        The MCU drives the TB6612 itself (MOTOR_PWM accepted).
    imu_present : bool
        An MPU-6050 is on the bus.
    boot_us : int
        The twin's time at boot [us].
    boot_id : int
        INFO's boot_id (non-zero).

    Raises
    ------
    McuBuildError
        The compiled core of the present sources is missing (run ``make setup``).
    """

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
        self.write = write
        self.sensors = sensors
        self.motor_output = motor_output
        self.imu_present = imu_present
        self.telemetry_frames = 0  # TELEMETRY frames the link took
        self._offset = (0, 0)  # the counts at the last reset: the PCNT restarts at 0 with the chip
        self._boot(boot_us, boot_id)

    def _boot(self, boot_us: int, boot_id: int) -> None:
        self.boot_id = boot_id
        self._core: Any = load().Core(
            self._line, self._counts, self.motor_output, self.imu_present, boot_us, boot_id
        )
        self._pending: list[bytes] = []  # host bytes waiting for the core to reach their instant
        self._fed_us: int | None = None  # the telemetry instant the IMU registers were fed for

    def reset(self, boot_us: int, boot_id: int) -> None:
        """The MCU resets and boots again at ``boot_us`` (its state, session and configuration
        gone; the PCNT counters restart at 0)."""
        s = self.sensors()
        self._offset = (s.enc_left, s.enc_right)
        self._boot(boot_us, boot_id)

    # ------------------------------------------------------------------ the HAL's Python side

    def _line(self, frame: bytes) -> bool:
        ok = bool(self.write(frame))
        if ok and frame[3] == TELEMETRY_TYPE:
            self.telemetry_frames += 1
        return ok

    def _counts(self) -> tuple[int, int]:
        s = self.sensors()
        return s.enc_left - self._offset[0], s.enc_right - self._offset[1]

    # ------------------------------------------------------------------ time and the host

    def receive(self, data: bytes, now: int) -> None:
        """Bytes from the host at the twin's time ``now`` [us]: handled at once when the core is
        at ``now``, else at the start of :meth:`tick` (``now``), before anything else due then
        (the firmware's tick reads the link first)."""
        core = self._core
        if core.now_us == now and not self._pending:
            core.push(data)
            core.tick()
        else:
            self._pending.append(data)

    def tick(self, now: int) -> None:
        """Bring the core to the twin's time ``now`` [us]: every deadline before it at its own
        time, then the host's bytes that arrived, then everything due at ``now``."""
        core = self._core
        if core.session and self._fed_us != now and _reached(now, core.next_telemetry_us):
            s = self.sensors()  # the IMU sample of the period that ends with this frame
            regs = imu_register_bytes(s.accel, s.temp, s.gyro)
            core.set_imu(self.imu_present and s.imu_ok, regs)
            self._fed_us = now
        if core.now_us != now:
            core.advance_before(now)
        if self._pending:
            core.push(b"".join(self._pending))
            self._pending.clear()
        core.tick()

    def next_deadline(self, now: int) -> int | None:
        """The next instant the twin must stop at [us], or None before a session: the next
        telemetry frame, or sooner the instant the interlock line drops if no HEARTBEAT comes
        (the core's other deadlines run inside :meth:`tick`)."""
        core = self._core
        if not core.session:
            return None
        t: int = core.next_telemetry_us
        if core.motor_enable:
            lost: int = core.host_lost_us
            if not _reached(now, lost) and not _reached(lost, t):
                t = lost
        return t

    # ------------------------------------------------------------------ what the core shows

    @property
    def session(self) -> bool:
        """A host's HELLO was accepted."""
        return bool(self._core.session)

    @property
    def rate_hz(self) -> int:
        """The telemetry rate [Hz]."""
        return int(self._core.telemetry_rate_hz)

    @property
    def period_us(self) -> int:
        """The telemetry period [us]."""
        return 1_000_000 // self.rate_hz

    @property
    def failsafe_ms(self) -> int:
        """The HEARTBEAT silence after which the motors brake and the interlock drops [ms]."""
        return int(self._core.failsafe_ms)

    @property
    def accel_fs(self) -> int:
        """The MPU-6050's accelerometer range (0-3) as the firmware's driver sets it."""
        return int(self._core.accel_fs)

    @property
    def gyro_fs(self) -> int:
        """The MPU-6050's gyro range (0-3) as the firmware's driver sets it."""
        return int(self._core.gyro_fs)

    @property
    def i2c_errors(self) -> int:
        """Failed MPU-6050 transactions since boot."""
        return int(self._core.i2c_errors)

    @property
    def heartbeats(self) -> int:
        """HEARTBEATs taken in sessions since boot."""
        return int(self._core.heartbeats)

    @property
    def sessions(self) -> int:
        """Sessions a HELLO began since boot (a new session id, or the first HELLO)."""
        return int(self._core.sessions)

    @property
    def heartbeat_seen(self) -> bool:
        """A HEARTBEAT arrived in this session."""
        return self._core.heartbeat_ack is not None

    @property
    def heartbeat_ack(self) -> int:
        """The newest HEARTBEAT's ack_seq (0 before one)."""
        ack = self._core.heartbeat_ack
        return 0 if ack is None else int(ack)

    @property
    def last_heartbeat_us(self) -> int:
        """When the newest HEARTBEAT (or the HELLO) arrived [us, 32-bit]."""
        return int(self._core.last_heartbeat_us)

    @property
    def telemetry_sent(self) -> bool:
        """A TELEMETRY frame was sent in this session (False again at a new session's HELLO)."""
        return self._core.last_telemetry_seq is not None

    @property
    def last_telemetry_seq(self) -> int:
        """SEQ of the last TELEMETRY frame the link took (0 before one)."""
        seq = self._core.last_telemetry_seq
        return 0 if seq is None else int(seq)

    @property
    def motor_enable(self) -> bool:
        """The interlock line: asserted (PCA9685 OE low / TB6612 STBY high) exactly while a
        session's HEARTBEATs arrive within failsafe_ms and the newest is not SHUTDOWN."""
        return bool(self._core.motor_enable)

    def wheel_duty(self) -> tuple[float, float, bool]:
        """The H-bridge output per wheel as signed duty (-1..1, direction flags applied) and
        whether both are braked."""
        left, right, braked = self._core.motors
        return left / 10_000.0, right / 10_000.0, bool(braked)

    def telemetry_flags(self, t_us: int) -> int:
        """The flags a TELEMETRY or STATUS frame sent at ``t_us`` would carry."""
        return int(self._core.telemetry_flags(t_us & 0xFFFFFFFF))
