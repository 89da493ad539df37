"""The twin's MCU as its runner sees it: one interface, two implementations.

The runner (:class:`~jackson.sim.runner.TwinRunner`) drives the MCU the way ros2_control's
controller manager drives a hardware interface: it never asks which MCU it has. It brings the
MCU to an instant of the twin (:meth:`McuPort.tick`), learns the next instant it must stop at
(:meth:`McuPort.next_deadline`), waits for the host's HEARTBEAT of a telemetry frame
(:meth:`McuPort.await_heartbeat`, :meth:`McuPort.acknowledged`) and reads the outputs it
applies to the twin: the motor interlock line, the TB6612 duties the MCU drives itself, and the
MPU-6050 ranges the twin scales the IMU registers by. Two MCUs implement it:

- :class:`~jackson.sim.core_port.CorePort`: the firmware core compiled into this process
  (:class:`~jackson.sim.mcu.Mcu`) behind a pty the runner serves;
- :class:`~jackson.sim.fil.FirmwarePort`: the POSIX firmware process, which serves its own
  pty and is fed sensor records (:class:`~jackson.sim.fil.FirmwareProcess`).

Both are fed the same sensor values at the same instants and send the host the same bytes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple, Protocol

from jackson.protocol.messages import TELEMETRY_RATE_HZ_DEFAULT

DEFAULT_PERIOD_US = 1_000_000 // TELEMETRY_RATE_HZ_DEFAULT
"""The telemetry period at the device's power-up rate (protocol/schema.yaml ``defaults``) [us]:
the runner's step while the MCU has no deadline (before a session)."""


class Selectable(Protocol):
    """Something a selector can wait on."""

    def fileno(self) -> int: ...


class Tick(NamedTuple):
    """What the MCU did at one instant (:meth:`McuPort.tick`).

    Attributes
    ----------
    frame : bool
        A TELEMETRY frame went out.
    lost : bool
        It was lost or damaged on the line: no HEARTBEAT will acknowledge it.
    """

    frame: bool
    lost: bool = False


class McuPort(Protocol):
    """The twin's MCU behind the interface its runner drives (see the module notes)."""

    @property
    def serial_path(self) -> str:
        """The host's end of the MCU's serial link (a pty)."""
        ...

    @property
    def host_link(self) -> Selectable | None:
        """The pty this process serves for the MCU (its selector wakes :meth:`receive`);
        None when the MCU serves its own link, or while the link is unplugged."""
        ...

    def receive(self, now_us: int) -> None:
        """Hand the bytes the host wrote on :attr:`host_link` to the MCU at ``now_us``."""
        ...

    def tick(self, now_us: int) -> Tick:
        """Bring the MCU to the twin's time ``now_us`` [us]: every deadline before it at its
        own time, then the host's bytes that arrived, then what is due at ``now_us``."""
        ...

    def next_deadline(self, now_us: int) -> int | None:
        """The next instant the twin must stop at, ahead of ``now_us`` [us, 32-bit]; None
        while the MCU has none (before a session)."""
        ...

    @property
    def session(self) -> bool:
        """A host's HELLO was accepted."""
        ...

    @property
    def last_telemetry_seq(self) -> int:
        """SEQ of the last TELEMETRY frame sent."""
        ...

    def acknowledged(self, seq: int) -> bool:
        """The newest HEARTBEAT acknowledges telemetry frame ``seq``, or no HEARTBEAT will: a
        new session began after it (its host is gone)."""
        ...

    def heartbeat_mark(self) -> int:
        """A value that changes when a new HEARTBEAT arrives, or (the in-process core) a HELLO
        begins a session (a host gone silent is back when it differs from the one taken when
        it went)."""
        ...

    def await_heartbeat(
        self, seq: int | None, timeout_s: float, serve: Callable[[float], bool]
    ) -> bool:
        """Let the host's bytes reach the MCU for at most ``timeout_s`` of wall time, or until
        a HEARTBEAT acknowledges ``seq`` (None: until the time is up).

        ``serve(t)`` serves the twin's other links (the I2C bus, the LiDAR and
        :attr:`host_link`) for at most ``t`` seconds and returns whether the I2C bus answered
        a request. Returns that, when known (else False).
        """
        ...

    @property
    def motor_enable(self) -> bool:
        """The interlock line (docs/firmware.md, "Motor interlock"): asserted while a
        session's HEARTBEATs arrive within failsafe_ms and the newest is not SHUTDOWN."""
        ...

    def wheel_duty(self) -> tuple[float, float, bool]:
        """The TB6612 outputs the MCU drives itself: signed duty per wheel (-1..1) and whether
        both are braked."""
        ...

    def imu_ranges(self) -> tuple[int, int] | None:
        """The MPU-6050's accelerometer and gyro ranges (0-3) as the firmware's driver set
        them; None before the MCU has reported them."""
        ...

    def unplug(self) -> None:
        """Remove the host's serial port (a pulled USB cable): nothing reaches the host."""
        ...

    def plug(self) -> None:
        """Bring the serial port back, at the same link path."""
        ...

    def close(self) -> None:
        """Release the link (and stop the MCU's process)."""
        ...
