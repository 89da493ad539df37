"""What the daemon watches of its link to the MCU, of the motor path and of itself, and tells
the operator: a HELLO nobody answers, frames of another protocol version, the PCA9685's I2C path
failing and coming back, someone else writing the PCA9685's registers (the mission ends), the
daemon's own frame loop stalled; and the state of the link and the motor path now
(:class:`LinkHealth`) for /diagnostics, health.json and ``jackson status``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from jackson.common.lazy import instance_of
from jackson.protocol import PROTOCOL_VERSION, FrameVersionError, HostState, TelemetryFlags

if TYPE_CHECKING:
    from jackson.host.actuation.output import MotorOutput
    from jackson.host.commands import CommandTracker
    from jackson.host.core import HostCore
    from jackson.host.transport import Link

VERSION_SILENCE_S = 1.0  # [s] frames of another version and no INFO: report the mismatch
# [s] the frame loop not turning this long (ten 20 Hz frames; it waits at most 0.1 s for a
# frame) is a stall of the daemon itself: stopped (SIGSTOP), starved of CPU, or busy
HOST_STALL_S = 0.5
# telemetry frames' worth of bytes waiting after it: fewer, and the device waited for the
# daemon (a twin in lockstep holds its clock until the daemon's HEARTBEAT; what waits is one
# frame, and maybe a STATUS and a few ACKs): nothing went on without it, so nothing is told. A
# device that went on through a 0.5 s stall has sent ten frames.
HOST_STALL_BACKLOG = 4
HOST_STALL_RECORD = "daemon stalled "  # its link record: "daemon stalled 1.30 s: ..."
FOREIGN_WRITE = (
    "PCA9685 registers rewritten by someone else (a foreign I2C write, or the chip reset): "
    "re-initialised; find what else drives the motor driver"
)


def host_stall_line(stalled_s: float) -> str:
    """The operator's line (and the run log's link record) for a stall of ``stalled_s`` [s],
    rounded to 10 ms as :func:`host_stall_s` reads it back."""
    return (
        f"{HOST_STALL_RECORD}{stalled_s:.2f} s: its frame loop did not run (stopped, starved of "
        "CPU, or busy); the LiDAR's silence meanwhile is not the LiDAR's"
    )


def host_stall_s(text: str) -> float | None:
    """The stall [s] a link record of :func:`host_stall_line` tells, or None for another."""
    if not text.startswith(HOST_STALL_RECORD):
        return None
    try:
        return float(text[len(HOST_STALL_RECORD) :].split(" ", 1)[0])
    except ValueError:
        return None


@dataclass(frozen=True)
class LinkHealth:
    """What the link and the motor path went through, for /diagnostics and the run folder.

    Attributes
    ----------
    link_up : bool
        The serial port is open.
    reconnects, silences : int
        Port reopened after a loss; HELLO re-sent after a silent second on an open port.
    frames_lost, crc_errors, resyncs, unknown_version : int
        From the host's decoder: frames missing by SEQ, candidates failing their CRC, partial
        frames dropped after 20 ms of silence, candidates of another frame version.
    mcu_resets : int
        INFO with another boot_id (counts and clock re-anchored).
    nacks, retries, unanswered_motor : int
        Commands refused, sent again, MOTOR_PWM without an ACK.
    i2c_errors, i2c_reinits, i2c_foreign_writes : int
        The PCA9685 path's faults (0 with the MCU driving the motors).
    i2c_bus_up : bool
        The PCA9685 path is working.
    motor_enable : bool
        The MCU's interlock line (telemetry MOTOR_ENABLE).
    """

    link_up: bool = False
    reconnects: int = 0
    silences: int = 0
    frames_lost: int = 0
    crc_errors: int = 0
    resyncs: int = 0
    unknown_version: int = 0
    mcu_resets: int = 0
    nacks: int = 0
    retries: int = 0
    unanswered_motor: int = 0
    i2c_errors: int = 0
    i2c_reinits: int = 0
    i2c_foreign_writes: int = 0
    i2c_bus_up: bool = True
    motor_enable: bool = False

    def problems(self) -> list[str]:
        """What an operator should look at, one phrase each (empty when all is well)."""
        out = [] if self.link_up else ["serial link down"]
        for name, text in (
            ("frames_lost", "frames lost"),
            ("crc_errors", "CRC errors"),
            ("resyncs", "partial frames dropped"),
            ("mcu_resets", "MCU resets"),
            ("nacks", "commands refused"),
            ("i2c_errors", "I2C errors"),
            ("i2c_foreign_writes", "PCA9685 registers changed by someone else"),
        ):
            n = getattr(self, name)
            if n:
                out.append(f"{n} {text}")
        if not self.i2c_bus_up:
            out.append("PCA9685 bus down: braked by the MCU interlock")
        return out


class LinkWatch:
    """The daemon's watch over its link and its motor path, called from the frame loop.

    Parameters
    ----------
    transport : Link
        The link to the MCU.
    output : MotorOutput
        The motor path (the MCU's PWM, or the PCA9685 over I2C).
    core : HostCore
        The core: its INFO, telemetry and host state (SHUTDOWN while the I2C bus is down).
    commands : CommandTracker
        The commands sent and their answers (counted in :class:`LinkHealth`).
    tell : callable
        One line for the operator (printed and in the run's log).
    """

    def __init__(
        self,
        transport: Link,
        output: MotorOutput,
        core: HostCore,
        commands: CommandTracker,
        tell: Callable[[str], None],
    ) -> None:
        self.transport = transport
        self.output = output
        self.core = core
        self.commands = commands
        self.tell = tell
        self.downs = 0  # times the link went down
        self.bus_up = True  # the PCA9685 path worked at the last look
        self._started_s = 0.0  # the frame loop started (monotonic s)
        self._hello_retries = 0  # HELLOs re-sent before the first INFO
        self._i2c_told = (0, 0)  # the PCA9685 path's (errors, re-inits) told so far
        self._i2c_failing = False  # an I2C outage was told and has not ended
        self._foreign_told = 0  # foreign register writes told so far
        self._turned_s: float | None = None  # the frame loop's last turn (monotonic s)

    def started(self, now_s: float) -> None:
        """The frame loop starts at ``now_s`` (monotonic s), the motor path taken as up."""
        self._started_s = now_s
        self._turned_s = None
        self.bus_up = True

    def turn(self, now_s: float) -> None:
        """The frame loop turns at ``now_s`` (monotonic s). After :data:`HOST_STALL_S` or more
        without a turn, once frames came, the daemon itself stalled: one line, logged as a link
        record before the next frame (``jackson replay`` applies it there), and the core told
        (:meth:`HostCore.host_stalled`), so the LiDAR's checks do not blame the sensor. A device
        that waited for the daemon meanwhile (fewer than :data:`HOST_STALL_BACKLOG` frames came:
        a twin in lockstep, whose clock stood still) saw no stall: the same run on an idle and
        on a busy machine logs the same records."""
        last, self._turned_s = self._turned_s, now_s
        if last is None or now_s - last < HOST_STALL_S or self.core.t_s is None:
            return
        if self.transport.backlog_frames() < HOST_STALL_BACKLOG:
            return
        stalled_s = round(now_s - last, 2)
        self.tell(host_stall_line(stalled_s))
        self.core.host_stalled(stalled_s)

    def foreign_write(self) -> bool:
        """After a frame: the PCA9685's registers were found rewritten by someone else (the
        output re-initialised them). Told on the console; a running mission ends with the
        reason (True), as another writer on the motor driver is not safe to drive beside; the
        navigation service and teleoperation go on, told."""
        n = self.output.health().foreign_writes
        if n <= self._foreign_told:
            return False
        self._foreign_told = n
        self.tell(f"I2C: {FOREIGN_WRITE}")
        mission = self.core.mission
        if mission is None or mission.done or _is_service(mission):
            return False
        self.core.abort(FOREIGN_WRITE)
        return True

    def health(self) -> LinkHealth:
        """The link's and the motor path's state now."""
        c = self.transport.decoder.counters
        h = self.output.health()
        last = self.core.last_telemetry
        return LinkHealth(
            link_up=bool(self.transport.link_up),
            reconnects=self.transport.reconnects,
            silences=self.transport.silences,
            frames_lost=c.seq_lost,
            crc_errors=c.crc_errors,
            resyncs=c.timeouts,
            unknown_version=c.unknown_version,
            mcu_resets=self.core.mcu_resets,
            nacks=self.commands.counters.nacked,
            retries=self.commands.counters.retried,
            unanswered_motor=self.commands.counters.motor_unacked,
            i2c_errors=h.i2c_errors,
            i2c_reinits=h.reinits,
            i2c_foreign_writes=h.foreign_writes,
            i2c_bus_up=not h.bus_down,
            motor_enable=bool(last is not None and last.flags & TelemetryFlags.MOTOR_ENABLE),
        )

    def check_version(self) -> None:
        """Frames of another frame version and no INFO for a second: say so, once (raises
        FrameVersionError)."""
        dec = self.transport.decoder
        if self.core.info is not None or dec.counters.unknown_version == 0:
            return
        if time.monotonic() - self._started_s < VERSION_SILENCE_S:
            return
        where = f"device on {self.transport.port_name}"
        raise FrameVersionError(dec.last_unknown_version, PROTOCOL_VERSION, where)

    def unanswered(self, detail: str) -> None:
        """HELLO got no INFO yet: one line at once, then one per retry that doubles the count
        (1, 2, 4, 8, ... retries), so the operator sees the retries without a flood."""
        self._hello_retries += 1
        n = self._hello_retries
        port = self.transport.port_name
        if n == 1:
            self.tell(
                f"no answer on {port}: is the firmware flashed? (make flash); is it the MCU's "
                f"port? HELLO is sent again every {self.transport.silence_s:g} s ({detail})"
            )
        elif n & (n - 1) == 0:
            self.tell(f"still no answer on {port}: HELLO sent {n + 1} times ({detail})")

    def motor_path(self) -> None:
        """Follow the PCA9685 path's health; while its bus is down the heartbeats say SHUTDOWN,
        so the MCU drops the interlock line and the bridge brakes without the bus."""
        h = self.output.health()
        up = not h.bus_down
        errors, reinits = h.i2c_errors, h.reinits
        if errors > self._i2c_told[0] and not self._i2c_failing:
            # the first failed write of an outage: say it at once, not only in health.json
            self._i2c_failing = True
            self.tell(
                f"I2C: PCA9685 write failed ({h.last_error}): retrying; the "
                "MCU interlock brakes if it lasts 0.5 s"
            )
        if reinits > self._i2c_told[1] and self._i2c_failing:
            self._i2c_failing = False
            self.tell(
                f"I2C: PCA9685 back and re-initialised ({errors - self._i2c_told[0]} failed writes)"
            )
            self._i2c_told = (errors, reinits)
        if up != self.bus_up:
            if up:
                self.core.host_state = HostState.ACTIVE
                self.tell("PCA9685 bus back: motor output re-initialised")
            else:
                self.core.host_state = HostState.SHUTDOWN
                self.tell(f"PCA9685 bus down ({h.last_error}): braking through the MCU interlock")
        self.bus_up = up


def _is_service(mission: object) -> bool:
    return instance_of(mission, "jackson.host.service.navigation", "NavigationService")
