"""The firmware core in the twin's process behind its pty, as the runner's :class:`McuPort`.

:class:`CorePort` holds the compiled core (:class:`~jackson.sim.mcu.Mcu`) and the pty the host
opens (:class:`~jackson.sim.link.PtyLink`). The runner's selector serves the pty and hands
what the host wrote to the core (:meth:`CorePort.receive`); the core's frames go out through
:class:`TelemetryLine`, the line between the MCU and its pty, where a test hook and the twin's
link faults (``frame_loss``, ``corrupt_bytes``: :mod:`jackson.sim.faults`) lose a telemetry
frame or flip one of its bits. A frame lost or damaged there is never acknowledged by the
host, so :meth:`CorePort.tick` says so and the runner does not wait for its HEARTBEAT.

The core's next deadline is the next telemetry frame or, sooner, the instant the interlock
line drops if no HEARTBEAT comes; its other deadlines (its IMU polls, STATUS) run at their own
times inside the next :meth:`CorePort.tick`.
"""

from __future__ import annotations

from collections.abc import Callable

from jackson.sim.faults import FaultInjector
from jackson.sim.link import PtyLink
from jackson.sim.mcu import TELEMETRY_TYPE, Mcu, SensorSample
from jackson.sim.port import Selectable, Tick
from jackson.sim.twin import Twin

__all__ = ["CorePort", "TelemetryLine"]


class TelemetryLine:
    """The line between the in-process MCU and its pty, as telemetry frames cross it.

    Parameters
    ----------
    faults : FaultInjector or None
        The twin's faults when it has link faults (they draw on a stream of their own).
    drop : callable or None
        Test hook: ``drop(n)`` true loses the n-th telemetry frame (from 0) on the line. An
        attribute: a test may set it while the twin runs.
    """

    def __init__(
        self, faults: FaultInjector | None, drop: Callable[[int], bool] | None = None
    ) -> None:
        self.faults = faults
        self.drop = drop
        self.written = 0  # telemetry frames the MCU wrote
        self.dropped: list[int] = []  # the numbers of those lost on the line
        self.lost = False  # a frame was lost or damaged since the runner cleared it

    def carry(self, frame: bytes, t_s: float) -> bytes | None:
        """What reaches the pty of telemetry ``frame`` written at ``t_s``: the frame, a
        damaged copy, or None (lost: the MCU sent it, the host never sees it)."""
        n = self.written
        self.written += 1
        if self.drop is not None and self.drop(n):
            self.dropped.append(n)
            self.lost = True
            return None
        if self.faults is not None:
            line = self.faults.telemetry(t_s, frame)
            if line is None:
                self.dropped.append(n)
                self.lost = True
                return None
            if line is not frame:
                self.lost = True  # the host drops it: no heartbeat will acknowledge it
            return line
        return frame


class CorePort:
    """The firmware core compiled into this process, with a pty for the host.

    Parameters
    ----------
    twin : Twin
        The twin (its clock and robot).
    sensors : callable
        The twin's sensors at the current instant, as the core reads them.
    line : TelemetryLine
        The line the core's telemetry crosses to the pty.
    serial_link : str or None
        A symlink to make at the pty (and again when it is plugged back).
    motor_output : bool
        The MCU drives the TB6612 itself (MOTOR_PWM accepted).
    boot_id : int
        INFO's boot_id.

    Raises
    ------
    McuBuildError
        The compiled core of the present sources is missing (run ``make setup``).
    OSError
        The pty or its link cannot be made.
    """

    def __init__(
        self,
        twin: Twin,
        sensors: Callable[[], SensorSample],
        line: TelemetryLine,
        *,
        serial_link: str | None = None,
        motor_output: bool = False,
        boot_id: int = 1,
    ) -> None:
        self._twin = twin
        self.line = line
        self._serial_link = serial_link
        self.link: PtyLink | None = PtyLink(serial_link)
        self._path = self.link.path
        self.mcu = Mcu(
            self._write,
            sensors,
            motor_output=motor_output,
            imu_present=twin.robot_spec.imu.present,
            boot_us=twin.t_us,
            boot_id=boot_id,
        )

    def _write(self, frame: bytes) -> bool:
        link = self.link
        if link is None:
            return False  # the port is gone: nothing reaches the host
        if frame[3] == TELEMETRY_TYPE:
            carried = self.line.carry(frame, self._twin.t_s)
            if carried is None:
                return True  # sent by the MCU, lost on the line
            frame = carried
        return link.write(frame)

    # ------------------------------------------------------------------ the host link

    @property
    def serial_path(self) -> str:
        """The pty's path (a new pty's after :meth:`plug` without ``serial_link``)."""
        return self._path

    @property
    def host_link(self) -> Selectable | None:
        """The pty, None while unplugged."""
        return self.link

    def receive(self, now_us: int) -> None:
        """Read what the host wrote and hand it to the core at ``now_us``."""
        if self.link is None:
            return
        data = self.link.read()
        if data:
            self.mcu.receive(data, now_us)  # handled now, or at the next tick

    def unplug(self) -> None:
        """Close the pty: the core's frames go nowhere until :meth:`plug`."""
        if self.link is not None:
            self.link.close()
        self.link = None

    def plug(self) -> None:
        """A new pty, at the same ``serial_link``."""
        self.link = PtyLink(self._serial_link)
        self._path = self.link.path

    # ------------------------------------------------------------------ time

    def tick(self, now_us: int) -> Tick:
        """Run the core up to ``now_us`` (:meth:`Mcu.tick`); whether a telemetry frame went
        out, and whether the line lost or damaged it."""
        mcu = self.mcu
        frames_before = mcu.telemetry_frames
        self.line.lost = False
        mcu.tick(now_us)  # the host's bytes that waited for this instant first
        return Tick(mcu.telemetry_frames != frames_before, self.line.lost)

    def next_deadline(self, now_us: int) -> int | None:
        """The core's next stop (:meth:`Mcu.next_deadline`); one telemetry period on should it
        not lie ahead of ``now_us``."""
        nxt = self.mcu.next_deadline(now_us)
        if nxt is None:
            return None
        step_us = (nxt - now_us) & 0xFFFFFFFF
        if step_us == 0 or step_us >= 0x80000000:
            return (now_us + self.mcu.period_us) & 0xFFFFFFFF
        return nxt

    # ------------------------------------------------------------------ the host's heartbeats

    @property
    def session(self) -> bool:
        return self.mcu.session

    @property
    def last_telemetry_seq(self) -> int:
        return self.mcu.last_telemetry_seq

    def acknowledged(self, seq: int) -> bool:
        mcu = self.mcu
        if not mcu.telemetry_sent:
            # a HELLO began a new session since frame ``seq`` went out: the host of the old one
            # is gone (a calibration's next run, a reconnect) and the new one never acknowledges
            # it; its own first frame is waited for instead
            return True
        return mcu.heartbeat_seen and mcu.heartbeat_ack == seq

    def heartbeat_mark(self) -> int:
        """HEARTBEATs taken since boot, plus the sessions HELLOs began: a host that starts a
        session is there, and its first frames are waited for in lockstep (a daemon slow to
        start on a busy machine would otherwise see them come in real time and fall behind)."""
        mcu = self.mcu
        return mcu.heartbeats + mcu.sessions  # both counted by the firmware core

    def await_heartbeat(
        self, seq: int | None, timeout_s: float, serve: Callable[[float], bool]
    ) -> bool:
        """The runner's selector serves the pty with the other links: one ``serve``."""
        return serve(timeout_s)

    # ------------------------------------------------------------------ outputs

    @property
    def motor_enable(self) -> bool:
        return self.mcu.motor_enable

    def wheel_duty(self) -> tuple[float, float, bool]:
        return self.mcu.wheel_duty()

    def imu_ranges(self) -> tuple[int, int] | None:
        return self.mcu.accel_fs, self.mcu.gyro_fs

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
