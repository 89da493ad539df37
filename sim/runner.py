"""Runs the twin against a host: the serial link, the virtual I2C bus and the clock.

**Lockstep** (the default for tests and campaigns): before the host's HELLO the clock stands
still; then the twin emits telemetry frame k, serves the host (serial commands and I2C register
writes) until its HEARTBEAT acknowledges frame k, applies the motor outputs and advances the
physics to the next frame. A host that does not answer within ``heartbeat_timeout_s`` of wall
time does not stop the world: the twin moves on, and the MCU's failsafe sees the silence in
simulated time. **Real time** paces the same steps on the wall clock and never waits.

**Stall.** After ``stall_s`` of wall time waiting for one HEARTBEAT (:data:`STALL_S` by default)
the twin looks at the host's liveness, and gives up only when the host is gone, stopped, or
does no work (:mod:`jackson.sim.lockstep`): :attr:`TwinRunner.stalled` holds one line,
:meth:`TwinRunner.run` returns, and the clock never moves again. A host that is slow but
working is waited for. The default
``heartbeat_timeout_s`` (1 s) is shorter than the default ``stall_s``: such a twin moves on in
real time before it could stall.

**One loop, either MCU.** The MCU is reached through :class:`~jackson.sim.port.McuPort`: the
firmware core compiled into this process (:class:`~jackson.sim.core_port.CorePort`) or, with
``firmware=True``, the same core as the POSIX firmware process
(:class:`~jackson.sim.fil.FirmwarePort`), fed the same sensor values at the same instants. At
each instant the runner serves what has arrived, writes the LiDAR's revolutions, ticks the
MCU, waits for the HEARTBEAT of a telemetry frame it sent, applies the MCU's outputs
(:mod:`jackson.sim.drive`) and advances the twin to the MCU's next deadline: the next telemetry
instant and, in this process while the interlock line is asserted, the instant it would drop.
Before a session the step is one telemetry period at the schema's default rate
(:data:`~jackson.sim.port.DEFAULT_PERIOD_US`).

The MCU's motor interlock line drives the pin ``wiring.interlock`` names before the bridge
outputs are computed (:mod:`jackson.sim.drive`), so a host that stops sending heartbeats has
its last PCA9685 duty cut at the instant the MCU drops the line (the in-process MCU's next
deadline includes it; the firmware process's status line shows it at the next telemetry
instant, at most one period later).

An optional ``observer`` is called with the twin after each advance of its clock (in real
time, once the wall clock has caught up); ``jackson sim --ros`` publishes from it
(:mod:`jackson.sim.ros`).

When the twin has a LiDAR, an emulated RPLIDAR A1M8 answers on a pty of its own
(``lidar_path``), served with the serial link and the I2C bus in every wait
(:mod:`jackson.sim.lidar_feed`).

The twin's link faults (``frame_loss``, ``corrupt_bytes``: :mod:`jackson.sim.faults`) act on
the line between the in-process MCU and its pty (:class:`~jackson.sim.core_port.TelemetryLine`):
a telemetry frame the MCU sent is lost, or reaches the host with one bit flipped. In lockstep
the runner does not wait for the heartbeat of such a frame (the host cannot acknowledge what it
never decoded). The firmware process writes its own pty, so these faults need the in-process
MCU (:class:`FaultError` otherwise).

With ``truth`` the runner streams the twin's ground truth to a file
(:class:`~jackson.sim.truth.TruthStream`, read back by :func:`~jackson.sim.truth.read_truth`):
one CSV row per advance of the clock, written and flushed before the MCU acts at that instant.
"""

from __future__ import annotations

import secrets
import selectors
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from threading import Event

from jackson.common.errors import JacksonError
from jackson.common.liveness import PROBE_S, Peer, ProcessPeer, ThreadPeer, Verdict, pty_peers
from jackson.common.spin import contention, spin_poll
from jackson.common.threads import ThreadFailedError, ThreadFailure
from jackson.sim.core_port import CorePort, TelemetryLine
from jackson.sim.drive import Drive
from jackson.sim.faults import LINK_KINDS, FaultError, format_fault
from jackson.sim.fil import FirmwarePort
from jackson.sim.i2c_server import I2cSocketServer
from jackson.sim.lidar_feed import STILL_WAIT_S, LidarFeed
from jackson.sim.lockstep import HostWatch
from jackson.sim.mcu import Mcu, SensorSample
from jackson.sim.pca9685 import Pca9685
from jackson.sim.port import DEFAULT_PERIOD_US, McuPort
from jackson.sim.rplidar import RplidarEmulator
from jackson.sim.tb6612 import BridgeOutput
from jackson.sim.truth import (
    TRUTH_COLUMNS,
    TRUTH_MAGIC,
    TruthFileError,
    TruthStream,
    TruthTrack,
    read_truth,
)
from jackson.sim.twin import Twin

__all__ = [
    "STALL_S",
    "TRUTH_COLUMNS",
    "TRUTH_MAGIC",
    "RunnerStats",
    "TruthFileError",
    "TruthStream",
    "TruthTrack",
    "TwinRunner",
    "read_truth",
]

STALL_S = 10.0  # [s] of wall time waiting for one HEARTBEAT before the host is looked at
WAKE_S = 0.05  # [s] longest single wait, so that a stop is seen


@dataclass(frozen=True)
class RunnerStats:
    """What a run did."""

    sim_s: float
    wall_s: float
    frames: int
    heartbeat_timeouts: int
    cpu_s: float = 0.0  # this process's CPU time since the HELLO
    spun_s: float = 0.0  # of it, polling for the host (jackson.common.spin)
    stalled: str | None = None  # the stall line, when a lockstep stall ended the run

    @property
    def real_time_factor(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else float("inf")


@dataclass
class Outage:
    """Test hook: the serial port removed for a while (a USB cable pulled and plugged back).

    Attributes
    ----------
    request_s : float or None
        Wall seconds asked for, until the next instant takes the port away.
    until : float or None
        Monotonic time the port comes back, while it is away.
    outputs : list
        The bridges' outputs at each return of the port.
    """

    request_s: float | None = None
    until: float | None = None
    outputs: list[tuple[BridgeOutput, BridgeOutput]] = field(default_factory=list)


def _no_ranges() -> tuple[int, int] | None:
    return None


class TwinRunner:
    """The twin behind a pty and an I2C socket, as the host sees the robot."""

    def __init__(
        self,
        twin: Twin,
        *,
        i2c_path: str | Path,
        lockstep: bool = True,
        firmware: bool = False,
        mcu_motors: bool = False,
        heartbeat_timeout_s: float = 1.0,
        serial_link: str | None = None,
        drop_telemetry: Callable[[int], bool] | None = None,
        observer: Callable[[Twin], None] | None = None,
        spin_s: float = 0.0,
        boot_id: int | None = None,
        lidar: bool = True,
        lidar_link: str | None = None,
        lidar_twin_beams: bool = False,
        truth: str | Path | None = None,
        stall_s: float | None = STALL_S,
        host_waiting: Callable[[], float | None] | None = None,
    ) -> None:
        faults = twin.faults
        if firmware and faults is not None and faults.link:
            names = ", ".join(format_fault(f) for f in faults.faults if f.kind in LINK_KINDS)
            raise FaultError(
                f"{names}: link faults act between the in-process MCU and its pty; the firmware "
                "process writes its own pty (drop --firmware)"
            )
        self.twin = twin
        self.truth: TruthStream | None = None  # the ground-truth file, with ``truth``
        # INFO's boot_id (protocol/spec.md §8.6): random like the ESP32's unless given
        self.boot_id = boot_id if boot_id else (secrets.randbits(32) | 1)
        # lockstep waits poll this long before blocking (jackson.common.spin); only worth it
        # when the host is another process
        self.spin_s = spin_s
        self.observer = observer  # called with the twin after each advance (and its pacing)
        self.lockstep = lockstep
        self.watch = HostWatch(heartbeat_timeout_s, stall_s, host_waiting)
        self.watch.peer.peer = Peer(self._find_host)
        wiring = twin.robot_spec.wiring
        pca = Pca9685()
        self.i2c = I2cSocketServer(i2c_path, {wiring.pca9685_address: pca})
        self.drive = Drive(twin, pca, wiring, mcu_motors=mcu_motors)
        self._sample: tuple[int, SensorSample] | None = None
        self._ranges: Callable[[], tuple[int, int] | None] = _no_ranges  # the port's, once made
        # the in-process MCU's line to its pty; drop_telemetry, a test hook: lose frame n there
        self.line = TelemetryLine(
            faults if faults is not None and faults.link else None, drop_telemetry
        )
        self.port: McuPort
        if firmware:
            self.port = FirmwarePort(
                self.sensors,
                motors=mcu_motors,
                imu_present=twin.robot_spec.imu.present,
                boot_id=self.boot_id,
            )
        else:
            self.port = CorePort(
                twin,
                self.sensors,
                self.line,
                serial_link=serial_link,
                motor_output=mcu_motors,
                boot_id=self.boot_id,
            )
        self._ranges = self.port.imu_ranges  # the MCU's MPU-6050 ranges scale its registers
        self.frames = 0
        self._outage = Outage()
        self._stop: Event | None = None
        self._host_thread: int | None = None  # a host in this process: its thread's native id
        self._session0 = (0.0, 0.0, 0.0)  # wall time, CPU time and time spun at the HELLO
        self._sel = selectors.DefaultSelector()
        self._sel.register(self.i2c, selectors.EVENT_READ, "i2c")
        self._register_link()
        self._lidar: LidarFeed | None = None  # the emulated RPLIDAR, when wanted and there
        if lidar and twin._lidar is not None:
            try:
                self._lidar = LidarFeed(
                    twin,
                    twin._lidar.spec,
                    self._sel,
                    link=lidar_link,
                    twin_beams=lidar_twin_beams,
                    seed=self.boot_id,
                )
            except OSError:
                self.close()
                raise
        if truth is not None:
            try:
                self.truth = TruthStream(truth, twin, self.boot_id)
            except OSError:
                self.close()
                raise

    # ------------------------------------------------------------------ what others read

    @property
    def serial_path(self) -> str:
        """The host's serial port (a pty)."""
        return self.port.serial_path

    @property
    def mcu(self) -> Mcu | None:
        """The firmware core in this process (None with the firmware process)."""
        return self.port.mcu if isinstance(self.port, CorePort) else None

    @property
    def pca(self) -> Pca9685:
        """The PCA9685 on the virtual I2C bus."""
        return self.drive.pca

    @property
    def lidar(self) -> RplidarEmulator | None:
        """The emulated RPLIDAR (None without one, or once a fault closed it)."""
        return None if self._lidar is None else self._lidar.emulator

    @property
    def lidar_path(self) -> str | None:
        """The emulated RPLIDAR's pty."""
        return None if self._lidar is None else self._lidar.path

    @property
    def lidar_scans_missing(self) -> int:
        """Revolutions with no scan of the twin's (sent empty)."""
        return 0 if self._lidar is None else self._lidar.scans_missing

    @property
    def stalled(self) -> str | None:
        """The stall line, once the twin gave up."""
        return self.watch.stalled

    @property
    def waiting_since(self) -> float | None:
        """Since when the twin waits for the host's HEARTBEAT (monotonic s), None otherwise."""
        return self.watch.waiting_since

    @property
    def stall_s(self) -> float | None:
        """Wall seconds of waiting for one HEARTBEAT before the twin gives up (None: never)."""
        return self.watch.stall_s

    @stall_s.setter
    def stall_s(self, value: float | None) -> None:
        self.watch.stall_s = value

    @property
    def host_waiting(self) -> Callable[[], float | None] | None:
        """A host in this process: since when it waits for a frame (None while it works)."""
        return self.watch.host_waiting

    @host_waiting.setter
    def host_waiting(self, value: Callable[[], float | None] | None) -> None:
        self.watch.host_waiting = value

    def _find_host(self) -> Sequence[ProcessPeer | ThreadPeer] | None:
        """Who the host is, looked up when a wait first gets long: the thread
        :meth:`host_thread` named, else the other processes that hold the serial pty (none:
        gone); unknown for a host in this process that named no thread."""
        if self._host_thread is not None:
            return [ThreadPeer(self._host_thread)]
        if self.watch.host_waiting is not None:
            return None
        return pty_peers(self.serial_path, master=False)

    def host_thread(self, native_id: int) -> None:
        """A host in this process runs in the thread ``native_id``
        (``threading.get_native_id()``): its CPU time tells whether it works."""
        self._host_thread = native_id

    @property
    def drop_telemetry(self) -> Callable[[int], bool] | None:
        """Test hook: lose telemetry frame n on the line (in-process MCU)."""
        return self.line.drop

    @drop_telemetry.setter
    def drop_telemetry(self, value: Callable[[int], bool] | None) -> None:
        self.line.drop = value

    @property
    def dropped(self) -> list[int]:
        """The telemetry frames lost on the line (their numbers, from 0)."""
        return self.line.dropped

    @property
    def outage_outputs(self) -> list[tuple[BridgeOutput, BridgeOutput]]:
        """The bridges' outputs at each return of the serial port (:meth:`request_outage`)."""
        return self._outage.outputs

    # ------------------------------------------------------------------ the serial port

    def _register_link(self) -> None:
        link = self.port.host_link
        if link is not None:
            self._sel.register(link, selectors.EVENT_READ, "serial")

    def request_outage(self, seconds: float) -> None:
        """Test hook: remove the serial port for ``seconds`` of wall time, then bring it back
        at the same path (``serial_link``), like a USB cable pulled and plugged back."""
        self._outage.request_s = seconds

    def _check_outage(self) -> None:
        out = self._outage
        if out.request_s is not None and out.until is None:
            link = self.port.host_link
            if link is not None:
                self._sel.unregister(link)
            self.port.unplug()
            out.until = time.monotonic() + out.request_s
            self.watch.pace_origin = (time.monotonic(), self.twin.t_s)  # the world runs on
            out.request_s = None
        elif out.until is not None and time.monotonic() >= out.until:
            out.outputs.append(self.bridges())
            self.port.plug()
            self._register_link()
            out.until = None

    # ------------------------------------------------------------------ sensors and actuation

    def sensors(self) -> SensorSample:
        """The sensors at the current instant (read once per instant, then cached)."""
        now = self.twin.t_us
        if self._sample is None or self._sample[0] != now:
            ranges = self._ranges()  # the ranges the MCU set the MPU-6050 to scale its registers
            if ranges is not None:
                self.twin.imu.accel_fs, self.twin.imu.gyro_fs = ranges
            self._sample = (now, self.twin.sensors())
        return self._sample[1]

    def motor_enable(self) -> bool:
        """The MCU's interlock line (docs/firmware.md, "Motor interlock")."""
        return self.port.motor_enable

    def bridges(self) -> tuple[BridgeOutput, BridgeOutput]:
        """Both TB6612 bridges' outputs now, under the MCU's interlock line."""
        return self.drive.bridges(self.port.motor_enable)

    def _line_changed(self) -> bool:
        return self.drive.line_changed(self.port.motor_enable)

    def _actuate(self) -> None:
        self.drive.actuate(self.port)

    # ------------------------------------------------------------------ serving the host

    def _serve(self, timeout_s: float) -> bool:
        """Serve the serial link (when this process serves it), the I2C bus and the LiDAR for
        at most ``timeout_s``; whether the bus answered a request."""
        sel = self._sel
        events = spin_poll(lambda: sel.select(0), min(self.spin_s, timeout_s))
        if not events and timeout_s > 0:
            events = sel.select(timeout_s)
        bus = False
        for key, _ in events:
            if key.data == "i2c":
                bus = self.i2c.service(0.0) > 0 or bus
            elif key.data == "lidar":
                assert self._lidar is not None
                self._lidar.serve()
            elif self._outage.until is None:
                self.port.receive(self.twin.t_us)
        return bus

    def _wait_heartbeat(self, seq: int) -> None:
        """Lockstep: serve the host until it acknowledges frame ``seq``. After a timeout the
        host counts as gone: the twin then runs in real time until a heartbeat comes back, or
        a HELLO begins a session; this frame is then waited for in lockstep."""
        port, watch = self.port, self.watch
        if watch.gone is not None:
            port.await_heartbeat(seq, 0.0, self._serve)
            if port.heartbeat_mark() == watch.gone:
                self._pace(*watch.pace_origin)
                return
            watch.gone = None  # the host is back: lockstep again, from this frame
            if watch.tell is not None:
                watch.tell(
                    f"the host is back (a HEARTBEAT or a new session's HELLO) at sim time "
                    f"{self.twin.t_s:.2f} s, after {self.twin.t_s - watch.pace_origin[1]:.2f} "
                    "s in real time: lockstep again"
                )
        start = began = time.monotonic()
        watch.waiting_since = start
        deadline = start + watch.timeout_s
        watch.peer.reset()
        # the host was judged gone, stopped or idle: the link is served once more before it counts
        reason: Verdict | None = None
        while not port.acknowledged(seq):
            if self._stop is not None and self._stop.is_set():
                return
            now = time.monotonic()
            left = deadline - now
            if left <= 0:
                busy = watch.peer.busy(now)
                if busy is not False:  # a slow host, or a first look: wait on, in lockstep
                    deadline = now + (watch.timeout_s if busy else PROBE_S)
                    continue
                watch.timeouts += 1
                watch.gone = port.heartbeat_mark()
                watch.pace_origin = (time.monotonic(), self.twin.t_s)
                watch.waiting_since = None
                if watch.tell is not None:
                    watch.tell(
                        f"no HEARTBEAT for {now - began:.1f} s after frame {self.frames} (sim "
                        f"time {self.twin.t_s:.2f} s) and the host {watch.peer.seen}: the twin "
                        "runs on in real time until the host answers"
                    )
                return
            wait = min(left, WAKE_S)
            stalled_for = watch.stalled_for(start, now)
            if stalled_for is not None and watch.stall_s is not None:
                if stalled_for < watch.stall_s:
                    reason = None
                    wait = min(wait, watch.stall_s - stalled_for)
                elif reason is not None:  # served once more after the verdict: it stands
                    watch.give_up(reason, now - began, self.frames, self.twin.t_s)
                    return
                else:
                    verdict = watch.judge(now)
                    if verdict == "working":
                        start = now  # slow, not stalled: the wait starts over
                    elif verdict is not None:
                        reason, wait = verdict, 0.0
            if port.await_heartbeat(seq, wait, self._serve) and not self.drive.mcu_motors:
                # the host wrote the PCA9685 and now sends its HEARTBEAT: the bridges' outputs
                # are worked out while it does (the step after the HEARTBEAT finds them cached)
                self.bridges()
        watch.waiting_since = None

    def serve(self, stop: Event) -> None:
        """Serve the host's links (serial, I2C, LiDAR) without moving the clock until ``stop``:
        after a stall, a host in this process still brakes through the PCA9685 and says
        SHUTDOWN to the MCU on its way out."""
        while not stop.is_set():
            self._serve(WAKE_S)

    # ------------------------------------------------------------------ the loop

    def run(self, duration_s: float | None = None, stop: Event | None = None) -> RunnerStats:
        """Run until ``duration_s`` of simulated time after the HELLO, or until ``stop``.

        The wall time in the returned stats counts from the HELLO (the clock stands still
        before it), so its real-time factor is the loop's own.
        """
        self._start_session(time.monotonic())  # again at the HELLO
        start_s = self.twin.t_s
        self._stop = stop
        try:
            if self._await_hello(stop):
                self._loop(duration_s, stop)
        except (JacksonError, OSError):  # a user's error or the machine's: told as before
            raise
        except Exception as exc:  # a bug in the twin, its MCU, LiDAR or I2C: one line, exit 1
            raise ThreadFailedError(ThreadFailure("twin", exc).line) from exc
        wall0, cpu0, spun0 = self._session0
        return RunnerStats(
            self.twin.t_s - start_s,
            time.monotonic() - wall0,
            self.frames,
            self.watch.timeouts,
            time.process_time() - cpu0,
            contention.spun_s - spun0,
            self.watch.stalled,
        )

    def _start_session(self, wall0: float) -> None:
        """Count run()'s statistics from now: wall time ``wall0``, CPU time, time spun."""
        self._session0 = (wall0, time.process_time(), contention.spun_s)

    def _done(self, end_s: float | None, stop: Event | None) -> bool:
        return (
            (stop is not None and stop.is_set())
            or self.watch.stalled is not None
            or (end_s is not None and self.twin.t_s >= end_s - 1e-9)
        )

    def _await_hello(self, stop: Event | None) -> bool:
        """Serve the host until its HELLO, the clock standing still (the LiDAR streams the
        world standing still meanwhile); False when ``stop`` came first."""
        port, lidar = self.port, self._lidar
        while not port.session:
            if stop is not None and stop.is_set():
                return False
            wait_s = STILL_WAIT_S if lidar is None else lidar.advance_still()
            port.await_heartbeat(None, wait_s, self._serve)
        if lidar is not None:  # the LiDAR goes on with the twin's clock
            lidar.session_starts()
        return True

    def _loop(self, duration_s: float | None, stop: Event | None) -> None:
        """The session: at each instant the MCU acts, then the twin advances to its next
        deadline."""
        port = self.port
        end_s = None if duration_s is None else self.twin.t_s + duration_s
        wall0, sim0 = time.monotonic(), self.twin.t_s
        self._start_session(wall0)
        while not self._done(end_s, stop):
            now = self.twin.t_us
            self._check_outage()
            self._serve(0.0)  # like the firmware's tick: what has arrived is handled first
            if self._lidar is not None:
                self._lidar.advance()
            tick = port.tick(now)
            if tick.frame:
                self.frames += 1
                if tick.lost:
                    self._serve(0.0)  # nobody will acknowledge a frame lost on the line
                elif self.lockstep:
                    self._wait_heartbeat(port.last_telemetry_seq)
                    if self.watch.stalled is not None:
                        return  # the clock stands still for good
                else:
                    self._serve(0.0)
                self._actuate()
            elif self.drive.mcu_motors or self._line_changed():
                self._actuate()  # the MCU's own failsafe, or the interlock line, on time
            self._advance(port.next_deadline(now), now, end_s)
            if self._outage.until is not None or self.watch.gone is not None:
                self._pace(*self.watch.pace_origin)  # nobody to wait for: real time
            elif not self.lockstep:
                self._pace(wall0, sim0)
            if self.truth is not None:
                self.truth.write(self.twin)  # before the MCU acts at this instant
            if self.observer is not None:
                self.observer(self.twin)

    def _advance(self, deadline_us: int | None, now_us: int, end_s: float | None) -> None:
        """Advance the twin from ``now_us`` to the MCU's next deadline (one default telemetry
        period without one), or to ``end_s`` if that comes first."""
        step_us = DEFAULT_PERIOD_US if deadline_us is None else (deadline_us - now_us) & 0xFFFFFFFF
        if end_s is not None:
            step_us = min(step_us, max(1, round((end_s - self.twin.t_s) * 1e6)))
        self.twin.advance(step_us / 1e6)

    def _pace(self, wall0: float, sim0: float) -> None:
        """Real time: serve the host until the wall clock catches up with the twin."""
        while not (self._stop is not None and self._stop.is_set()):
            ahead = (self.twin.t_s - sim0) - (time.monotonic() - wall0)
            if ahead <= 0:
                return
            self._serve(ahead)

    def close(self) -> None:
        if self.truth is not None:
            self.truth.close()
        self.i2c.close()
        self.port.close()
        if self._lidar is not None:
            self._lidar.close()
        self._sel.close()
