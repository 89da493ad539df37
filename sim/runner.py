"""Runs the twin against a host: the serial link, the virtual I2C bus and the clock.

**Lockstep** (the default for tests and campaigns): before the host's HELLO the clock stands
still; then the twin emits telemetry frame k, serves the host (serial commands and I2C register
writes) until its HEARTBEAT acknowledges frame k, applies the motor outputs and advances the
physics to the next frame. A host that does not answer within ``heartbeat_timeout_s`` of wall
time does not stop the world: the twin moves on, and the MCU's failsafe sees the silence in
simulated time. **Real time** paces the same steps on the wall clock and never waits.

**Stall.** A twin that waits longer than ``heartbeat_timeout_s`` (campaign trials wait without
a limit) can wait for ever for a host that stopped. After ``stall_s`` of wall time waiting for
one HEARTBEAT, its clock standing still, the twin gives up: :attr:`TwinRunner.stalled` holds one
line (``lockstep stalled: the twin waited 10.0 s for the host's HEARTBEAT after frame N (sim time
T s)``), :meth:`TwinRunner.run` returns, and the clock never moves again. Only the wait counts:
a host that answers each frame, however late, never stalls it. The link is served once more
after the limit before the stall counts, so a HEARTBEAT that arrived while this process was
kept from running is taken. With ``host_waiting`` (a host in this process) only the time both
ends wait counts: a host that is working on a frame, however slowly (a starved process), is not
stalled. The default ``heartbeat_timeout_s`` (1 s) is shorter than the default ``stall_s``
(:data:`STALL_S`): such a twin moves on in real time before it could stall.

The MCU is the firmware core compiled into this process (:mod:`jackson.sim.mcu`) or, with
``firmware=True``, the same core as the POSIX firmware process (:mod:`jackson.sim.fil`), fed the
same sensor values at the same instants. In this process the twin stops at every telemetry
instant and, while the interlock line is asserted, at the instant it would drop; the core's
other deadlines (its IMU polls, STATUS) run at their own times inside the stop that follows.

The MCU's motor interlock line (docs/firmware.md, "Motor interlock") drives the pin the robot
file's ``wiring.interlock`` names, the PCA9685's OE or the TB6612's STBY, before the bridge
outputs are computed; so a host that stops sending heartbeats has its last PCA9685 duty cut at
the instant the MCU drops the line (the in-process MCU's next deadline includes it; the
firmware process's status line shows it at the next telemetry instant, at most one period
later).
An optional ``observer`` is called with the twin after each advance of its clock (in real
time, once the wall clock has caught up); ``jackson sim --ros`` publishes from it
(:mod:`jackson.sim.ros`).

When the twin has a LiDAR, an emulated RPLIDAR A1M8 (:mod:`jackson.sim.rplidar`) answers on a
pty of its own (``lidar_path``), served with the serial link and the I2C bus in every wait.
Its revolutions are the twin's own scans (same noise, same dropout), written before the MCU
acts at each instant: a revolution that ended at or before a telemetry frame reaches the
host ahead of that frame. Before the MCU's session the LiDAR does not wait for it, as a real
A1M8 does not: it answers, and a scan streams revolutions of the world standing still on the
wall clock (its own noise stream, so the twin's are not drawn from); at the HELLO the scan
goes on with the twin's clock (:meth:`~jackson.sim.rplidar.RplidarEmulator.resume`), and the
session's revolutions are the ones a scan asked for at that instant would give.

The twin's link faults (``frame_loss``, ``corrupt_bytes``: :mod:`jackson.sim.faults`) act on
the line between the in-process MCU and its pty: a telemetry frame the MCU sent is lost, or
reaches the host with one bit flipped. In lockstep the runner does not wait for the heartbeat
of such a frame (the host cannot acknowledge what it never decoded). The firmware process
writes its own pty, so these faults need the in-process MCU (:class:`FaultError` otherwise).

With ``truth`` the runner streams the twin's ground truth to a file (:class:`TruthStream`,
read back by :func:`read_truth`): one CSV row per advance of the clock, written and flushed
before the MCU acts at that instant, so the row of every telemetry frame is in the file
before the frame is on the wire. This is the "tape measure" of ``jackson calibrate
--twin-truth`` in another process.
"""

from __future__ import annotations

import io
import secrets
import selectors
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from threading import Event
from typing import TextIO

import numpy as np
from numpy.typing import NDArray

from jackson.common.errors import JacksonError
from jackson.common.spin import contention, spin_poll
from jackson.sim.faults import LINK_KINDS, FaultError, format_fault
from jackson.sim.fil import FeedStatus, FirmwareProcess
from jackson.sim.i2c_server import I2cSocketServer
from jackson.sim.lidar import Lidar
from jackson.sim.link import PtyLink
from jackson.sim.mcu import Mcu, SensorSample
from jackson.sim.pca9685 import Pca9685
from jackson.sim.robot import WheelDrive
from jackson.sim.rplidar import RplidarEmulator
from jackson.sim.tb6612 import BridgeOutput, bridge_outputs
from jackson.sim.twin import Twin

STALL_S = 10.0  # [s] of wall time waiting for one HEARTBEAT before the twin gives up


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


def _wheel(b: BridgeOutput) -> WheelDrive:
    return WheelDrive(b.drive, abs(b.drive) + b.brake_fraction)


TRUTH_MAGIC = "# jackson twin ground truth"
TRUTH_COLUMNS = ("t_us", "t_s", "x_m", "y_m", "yaw_rad")


class TruthFileError(JacksonError, ValueError):
    """A ground-truth file that cannot be read (one line naming the file)."""


class TruthStream:
    """The twin's ground truth as a CSV file that grows while the twin runs.

    The file starts with one comment line naming the session (``# jackson twin ground truth:
    boot_id 0x........, robot NAME, world NAME``; the boot_id is the one the MCU reports in
    INFO, so a run folder can be matched to its twin session), then the header
    ``t_us,t_s,x_m,y_m,yaw_rad`` and one row per advance of the twin's clock: the 64-bit
    simulated time (which the MCU's 32-bit telemetry clock is, modulo 2^32) [us], the same in
    seconds, the axle midpoint in the world frame [m] and the heading, continuous (not
    wrapped) [rad]. Each row is flushed as it is written. The file is replaced at each start.

    Parameters
    ----------
    path : str or Path
        Where to write.
    twin : Twin
        The twin whose truth is written (its current instant is the first row).
    boot_id : int
        The MCU's boot_id for this session.

    Raises
    ------
    OSError
        The file cannot be created.
    """

    def __init__(self, path: str | Path, twin: Twin, boot_id: int) -> None:
        self.path = Path(path)
        self._file: TextIO = self.path.open("w", encoding="ascii", newline="\n")
        self._last_us: int | None = None
        self.rows = 0
        self._file.write(
            f"{TRUTH_MAGIC}: boot_id {boot_id:#010x}, robot {twin.robot_spec.name}, "
            f"world {twin.world_spec.name}\n{','.join(TRUTH_COLUMNS)}\n"
        )
        self.write(twin)

    def write(self, twin: Twin) -> None:
        """Append the twin's pose at its current instant (once per instant) and flush."""
        t_us = twin.t_us
        if t_us == self._last_us or self._file.closed:
            return
        self._last_us = t_us
        s = twin.truth()
        self._file.write(f"{t_us},{t_us / 1e6:.6f},{s.x:.9f},{s.y:.9f},{s.yaw:.9f}\n")
        self._file.flush()
        self.rows += 1

    def close(self) -> None:
        self._file.close()


@dataclass(frozen=True)
class TruthTrack:
    """A ground-truth file read back (:func:`read_truth`).

    Attributes
    ----------
    path : Path
        The file.
    boot_id : int or None
        The MCU's boot_id of the session that wrote it (None: the file does not say).
    t_us : numpy.ndarray
        Simulated time of each row, int64, rising [us].
    x_m : numpy.ndarray
        Axle midpoint x in the world frame [m].
    y_m : numpy.ndarray
        Axle midpoint y [m].
    yaw_rad : numpy.ndarray
        Heading, unwrapped [rad].
    """

    path: Path
    boot_id: int | None
    t_us: NDArray[np.int64]
    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    yaw_rad: NDArray[np.float64]


def read_truth(path: str | Path) -> TruthTrack:
    """Read a ground-truth file that :class:`TruthStream` writes (possibly still growing: a
    last row without its newline is left out).

    Parameters
    ----------
    path : str or Path
        The file ``jackson sim --truth PATH`` writes.

    Returns
    -------
    TruthTrack
        Its rows.

    Raises
    ------
    TruthFileError
        A missing file, another format, or fewer than two rows.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="ascii")
    except OSError as exc:
        raise TruthFileError(f"twin truth {p}: cannot read it ({exc.strerror})") from exc
    except UnicodeDecodeError as exc:
        raise TruthFileError(f"twin truth {p}: not a ground-truth file (not text)") from exc
    first, _, rest = text.partition("\n")
    header, _, body = rest.partition("\n")
    if not first.startswith(TRUTH_MAGIC) or header.strip() != ",".join(TRUTH_COLUMNS):
        raise TruthFileError(
            f"twin truth {p}: not a ground-truth file of jackson sim --truth (expected "
            f"{TRUTH_MAGIC!r} and the header {','.join(TRUTH_COLUMNS)})"
        )
    boot_id: int | None = None
    if "boot_id " in first:
        try:
            boot_id = int(first.split("boot_id ", 1)[1].split(",", 1)[0], 16)
        except ValueError:
            boot_id = None
    body = body[: body.rfind("\n") + 1]  # a row still being written is not a row yet
    try:
        data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise TruthFileError(f"twin truth {p}: a damaged row ({exc})") from exc
    if data.shape[0] < 2 or data.shape[1] != len(TRUTH_COLUMNS):
        raise TruthFileError(f"twin truth {p}: needs two or more rows of 5 numbers")
    t_us = data[:, 0].astype(np.int64)
    if np.any(np.diff(t_us) <= 0) or not np.all(np.isfinite(data)):
        raise TruthFileError(f"twin truth {p}: times must rise and every number be finite")
    yaw = np.asarray(np.unwrap(data[:, 4]), dtype=np.float64)
    return TruthTrack(p, boot_id, t_us, data[:, 2], data[:, 3], yaw)


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
        self._faults = faults if faults is not None and faults.link else None
        self.truth: TruthStream | None = None  # the ground-truth file, with ``truth``
        # INFO's boot_id (protocol/spec.md §8.6): random like the ESP32's unless given
        self.boot_id = boot_id if boot_id else (secrets.randbits(32) | 1)
        # lockstep waits poll this long before blocking (jackson.common.spin); only worth it
        # when the host is another process
        self.spin_s = spin_s
        self.observer = observer  # called with the twin after each advance (and its pacing)
        self.lockstep = lockstep
        self.mcu_motors = mcu_motors
        self.heartbeat_timeout_s = heartbeat_timeout_s
        # lockstep stall (module notes): wall seconds of waiting for one HEARTBEAT before the
        # twin gives up (None: never); ``host_waiting``, a host in this process: since when it
        # waits for a telemetry frame (monotonic s), None while it works on one
        self.stall_s = stall_s
        self.host_waiting = host_waiting
        self.stalled: str | None = None  # the stall line, once the twin gave up
        # since when the twin waits for the host's HEARTBEAT (monotonic s), None otherwise; it
        # stays set after a stall (the twin will never send again)
        self.waiting_since: float | None = None
        wiring = twin.robot_spec.wiring
        self.pca = Pca9685()
        self.i2c = I2cSocketServer(i2c_path, {wiring.pca9685_address: self.pca})
        self._wiring = wiring
        # bridge outputs of the last PCA9685 state (generation, which counts register writes and
        # OE changes) and STBY level, recomputed when either changes
        self._bridges: (
            tuple[tuple[int, bool, bool | None], tuple[BridgeOutput, BridgeOutput]] | None
        ) = None
        self._line_applied: bool | None = None  # the interlock level the models last saw
        self._sample: tuple[int, SensorSample] | None = None
        self.firmware: FirmwareProcess | None = None
        self.link: PtyLink | None = None
        self.mcu: Mcu | None = None
        if firmware:
            self.firmware = FirmwareProcess(
                motors=mcu_motors, imu_present=twin.robot_spec.imu.present, boot_id=self.boot_id
            )
            self.serial_path = self.firmware.serial_path
        else:
            self.link = PtyLink(serial_link)
            self.serial_path = self.link.path
            self.mcu = Mcu(
                self._write,
                self.sensors,
                motor_output=mcu_motors,
                imu_present=twin.robot_spec.imu.present,
                boot_us=twin.t_us,
                boot_id=self.boot_id,
            )
        self.frames = 0
        self.heartbeat_timeouts = 0
        self.drop_telemetry = drop_telemetry  # test hook: lose telemetry frame n on the line
        self.telemetry_written = 0
        self.dropped: list[int] = []
        self._lost = False
        self._serial_link = serial_link
        self._outage_request: float | None = None
        self._outage_until: float | None = None
        self.outage_outputs: list[tuple[BridgeOutput, BridgeOutput]] = []
        self._stop: Event | None = None
        # heartbeats seen (in-process MCU) or the last heartbeat_ack (firmware process) when
        # the host went silent; None while it answers
        self._host_gone: int | None = None
        self._pace_origin = (0.0, 0.0)
        self._session_wall0 = 0.0  # wall time of the HELLO (run() statistics)
        self._session_cpu0 = (0.0, 0.0)  # CPU time and time spun by then
        self._sel = selectors.DefaultSelector()
        self._sel.register(self.i2c, selectors.EVENT_READ, "i2c")
        if self.link is not None:
            self._sel.register(self.link, selectors.EVENT_READ, "serial")
        # the emulated RPLIDAR, when the twin has a LiDAR and it is wanted
        self.lidar: RplidarEmulator | None = None
        self.lidar_path: str | None = None
        self.lidar_scans_missing = 0  # revolutions with no scan of the twin's (sent empty)
        # before the MCU's session the LiDAR scans the world standing still on the wall clock
        # (since this monotonic time; None once the session started), with its own noise
        self._still_since: float | None = time.monotonic()
        self._still_lidar: Lidar | None = None
        if lidar and twin._lidar is not None:
            try:
                # an A1M8's SCAN at 508 us a sample; lidar_twin_beams: the twin's exact 1080
                # beams instead (RplidarEmulator's device_standard_scan=False)
                self.lidar = RplidarEmulator(
                    twin._lidar.spec, lidar_link, device_standard_scan=not lidar_twin_beams
                )
            except OSError:
                self.close()
                raise
            self.lidar_path = self.lidar.path
            self._sel.register(self.lidar, selectors.EVENT_READ, "lidar")
            self._still_lidar = Lidar(twin._lidar.spec, np.random.default_rng(self.boot_id))
        if truth is not None:
            try:
                self.truth = TruthStream(truth, twin, self.boot_id)
            except OSError:
                self.close()
                raise

    def _write(self, frame: bytes) -> bool:
        if self.link is None or self._outage_until is not None:
            return False  # the port is gone: nothing reaches the host
        if frame[3] == 0x01:  # telemetry
            n = self.telemetry_written
            self.telemetry_written += 1
            if self.drop_telemetry is not None and self.drop_telemetry(n):
                self.dropped.append(n)
                self._lost = True
                return True  # sent by the MCU, lost on the line
            if self._faults is not None:
                line = self._faults.telemetry(self.twin.t_s, frame)
                if line is None:
                    self.dropped.append(n)
                    self._lost = True
                    return True
                if line is not frame:
                    self._lost = True  # the host drops it: no heartbeat will acknowledge it
                frame = line
        return self.link.write(frame)

    def request_outage(self, seconds: float) -> None:
        """Test hook: remove the serial port for ``seconds`` of wall time, then bring it back
        at the same path (``serial_link``), like a USB cable pulled and plugged back."""
        self._outage_request = seconds

    def _check_outage(self) -> None:
        if self._outage_request is not None and self._outage_until is None:
            assert self.link is not None
            self._sel.unregister(self.link)
            self.link.close()
            self._outage_until = time.monotonic() + self._outage_request
            self._pace_origin = (time.monotonic(), self.twin.t_s)  # the world runs on meanwhile
            self._outage_request = None
        elif self._outage_until is not None and time.monotonic() >= self._outage_until:
            self.outage_outputs.append(self.bridges())
            self.link = PtyLink(self._serial_link)
            self.serial_path = self.link.path
            self._sel.register(self.link, selectors.EVENT_READ, "serial")
            self._outage_until = None

    # ------------------------------------------------------------------ sensors and actuation

    def sensors(self) -> SensorSample:
        """The sensors at the current instant (read once per instant, then cached)."""
        now = self.twin.t_us
        if self._sample is None or self._sample[0] != now:
            # the ranges the MCU set the MPU-6050 to scale its registers
            if self.mcu is not None:
                self.twin.imu.accel_fs, self.twin.imu.gyro_fs = self.mcu.accel_fs, self.mcu.gyro_fs
            elif self.firmware is not None and self.firmware.last_status is not None:
                st = self.firmware.last_status
                self.twin.imu.accel_fs, self.twin.imu.gyro_fs = st.accel_fs, st.gyro_fs
            self._sample = (now, self.twin.sensors())
        return self._sample[1]

    def motor_enable(self, fw: FeedStatus | None = None) -> bool:
        """The MCU's interlock line (docs/firmware.md, "Motor interlock"): the in-process
        MCU's, or the firmware process's as its status line ``fw`` (else its last one) reports
        it."""
        if self.mcu is not None:
            return self.mcu.motor_enable
        if fw is None and self.firmware is not None:
            fw = self.firmware.last_status
        return fw is not None and fw.motor_enable

    def bridges(self, fw: FeedStatus | None = None) -> tuple[BridgeOutput, BridgeOutput]:
        """Both TB6612 bridges' outputs now: the MCU's interlock line applied to the pin it is
        wired to (``wiring.interlock``), then the PCA9685's channels through the truth table."""
        enable = self.motor_enable(fw)
        w, pca = self._wiring, self.pca
        self._line_applied = enable
        # OE is pulled up: released (False) disables the outputs; unwired, OE is tied low
        pca.output_enable = enable if w.interlock == "pca9685_oe" else True
        stby = enable if w.interlock == "tb6612_stby" else None  # pulled down: released = low
        key = (pca.generation, pca.output_enable, stby)
        if self._bridges is None or self._bridges[0] != key:
            outputs = bridge_outputs(pca, w.left, w.right, w.stby_channel, stby)
            self._bridges = (key, outputs)
        return self._bridges[1]

    def _line_changed(self) -> bool:
        return self.motor_enable() != self._line_applied

    def _actuate(self, fw: FeedStatus | None = None) -> None:
        if self.mcu_motors:
            self._line_applied = self.motor_enable(fw)
            if fw is not None:
                duties = (fw.motor_left / 1e4, fw.motor_right / 1e4, fw.braked)
            else:
                assert self.mcu is not None
                duties = self.mcu.wheel_duty()
            left, right, braked = duties
            if braked:
                self.twin.command(WheelDrive.brake(), WheelDrive.brake())
            else:
                self.twin.command(WheelDrive(left, 1.0), WheelDrive(right, 1.0))
            return
        b_left, b_right = self.bridges(fw)
        self.twin.command(_wheel(b_left), _wheel(b_right))

    # ------------------------------------------------------------------ the LiDAR

    def _scan_for(self, end_s: float) -> NDArray[np.float32] | None:
        """The twin's scan for the revolution ending at ``end_s``: the one it took at the
        first physics step at or after that instant (the two share one schedule); None when a
        ``lidar_dropout`` fault lost it (nothing goes on the line)."""
        dt = self.twin.dt
        for scan in reversed(self.twin.scans):
            if end_s - 1e-6 <= scan.t_s < end_s + dt - 1e-9:
                return scan.ranges
            if scan.t_s < end_s - 1e-6:
                break
        if any(end_s - 1e-6 <= t < end_s + dt - 1e-9 for t in self.twin.lost_scans):
            return None
        assert self.lidar is not None
        self.lidar_scans_missing += 1
        return np.full(self.lidar.spec.beams, np.inf, dtype=np.float32)

    def _advance_lidar(self) -> None:
        """Write the LiDAR revolutions that ended by now (before the MCU acts at this
        instant, so they reach the host ahead of this instant's telemetry frame). A
        ``lidar_garbage`` fault puts random bytes before each; ``lidar_closed`` closes the
        LiDAR's port for good (its pty gone, as a pulled USB cable)."""
        lidar = self.lidar
        if lidar is None:
            return
        faults = self.twin.faults
        if faults is not None and faults.lidar_line_faults:
            due = lidar.next_revolution_end_s()
            if due is not None and due <= self.twin.t_s + 1e-9:
                garbage, closed = faults.lidar_line(self.twin.t_s, 5 * lidar.spec.beams)
                if closed:
                    self._sel.unregister(lidar)
                    lidar.close()
                    self.lidar = None
                    return
                if garbage:
                    lidar.inject(garbage)
        lidar.advance(self.twin.t_s, self._scan_for)

    def _lidar_t(self) -> float:
        """The LiDAR's clock [s]: the twin's once the MCU's session started; before, the
        twin's standing time plus the wall time since the twin started (its head turns)."""
        if self._still_since is None:
            return self.twin.t_s
        return self.twin.t_s + (time.monotonic() - self._still_since)

    def _still_ranges(self, end_s: float) -> NDArray[np.float32]:
        """Before the session: a revolution of the world standing still, from where the robot
        stands (its own noise stream: the twin's scans are not drawn from)."""
        assert self._still_lidar is not None
        s = self.twin.truth()
        return self._still_lidar.scan(s.x, s.y, s.yaw, self.twin.world.obstacles)

    def _advance_still_lidar(self) -> float:
        """Before the session: write the revolutions that ended by the wall clock; the wall
        seconds until the next one ends (at most 0.05)."""
        lidar = self.lidar
        if lidar is None or self._still_since is None:
            return 0.05
        now = self._lidar_t()
        lidar.advance(now, self._still_ranges)
        due = lidar.next_revolution_end_s()
        return 0.05 if due is None else max(0.0, min(0.05, due - now))

    def _session_starts(self) -> None:
        """The host's HELLO: the LiDAR goes on with the twin's clock (RplidarEmulator.resume)."""
        self._still_since = None
        if self.lidar is not None:
            self.lidar.resume(self.twin.t_s)

    def _service_side(self) -> None:
        """Serve the I2C bus and the LiDAR's requests without blocking (the compiled
        firmware's waits)."""
        self.i2c.service(0.0)
        if self.lidar is not None:
            self.lidar.serve(self._lidar_t())

    # ------------------------------------------------------------------ serving the host

    def _serve(self, timeout_s: float) -> bool:
        """Serve the serial link and the I2C bus for at most ``timeout_s``; whether the bus
        answered a request."""
        sel = self._sel
        events = spin_poll(lambda: sel.select(0), min(self.spin_s, timeout_s))
        if not events and timeout_s > 0:
            events = sel.select(timeout_s)
        bus = False
        for key, _ in events:
            if key.data == "i2c":
                bus = self.i2c.service(0.0) > 0 or bus
            elif key.data == "lidar":
                assert self.lidar is not None
                self.lidar.serve(self._lidar_t())
            elif self.link is not None and self.mcu is not None and self._outage_until is None:
                data = self.link.read()
                if data:
                    self.mcu.receive(data, self.twin.t_us)
        return bus

    def _wait_heartbeat(self, seq: int) -> None:
        """Lockstep: serve the host until it acknowledges frame ``seq``. After a timeout the
        host counts as gone: the twin then runs in real time until a heartbeat comes back."""
        mcu = self.mcu
        assert mcu is not None
        if self._host_gone is not None:
            self._serve(0.0)
            if mcu.heartbeats != self._host_gone:
                self._host_gone = None  # the host is back: lockstep again
            else:
                self._pace(*self._pace_origin)
            return
        start = time.monotonic()
        self.waiting_since = start
        deadline = start + self.heartbeat_timeout_s
        armed = False  # the stall limit passed: the link is served once more before it counts
        while not (mcu.heartbeat_seen and mcu.heartbeat_ack == seq):
            if self._stop is not None and self._stop.is_set():
                return
            now = time.monotonic()
            left = deadline - now
            if left <= 0:
                self.heartbeat_timeouts += 1
                self._host_gone = mcu.heartbeats
                self._pace_origin = (time.monotonic(), self.twin.t_s)
                self.waiting_since = None
                return
            wait = min(left, 0.05)  # wakes to see a stop
            stalled_for = self._stalled_for(start, now)
            if stalled_for is not None and self.stall_s is not None:
                if stalled_for < self.stall_s:
                    armed = False
                    wait = min(wait, self.stall_s - stalled_for)
                elif armed:
                    self._give_up(stalled_for)
                    return
                else:
                    armed, wait = True, 0.0
            if self._serve(wait) and not self.mcu_motors:
                # the host wrote the PCA9685 and now sends its HEARTBEAT: the bridges' outputs
                # are worked out while it does (the step after the HEARTBEAT finds them cached)
                self.bridges()
        self.waiting_since = None

    def _stalled_for(self, start: float, now: float) -> float | None:
        """How long the lockstep has stood still waiting for the host, since ``start``
        (monotonic s): the wait itself, or with ``host_waiting`` the time both ends have
        waited; None while the host works on a frame (slow, not stalled)."""
        if self.host_waiting is None:
            return now - start
        host = self.host_waiting()
        return None if host is None else now - max(start, host)

    def _give_up(self, waited_s: float) -> None:
        self.stalled = (
            f"lockstep stalled: the twin waited {waited_s:.1f} s for the host's HEARTBEAT after "
            f"frame {self.frames} (sim time {self.twin.t_s:.2f} s)"
        )

    def serve(self, stop: Event) -> None:
        """Serve the host's links (serial, I2C, LiDAR) without moving the clock until ``stop``:
        after a stall, a host in this process still brakes through the PCA9685 and says
        SHUTDOWN to the MCU on its way out."""
        while not stop.is_set():
            self._serve(0.05)

    # ------------------------------------------------------------------ the loop

    def run(self, duration_s: float | None = None, stop: Event | None = None) -> RunnerStats:
        """Run until ``duration_s`` of simulated time after the HELLO, or until ``stop``.

        The wall time in the returned stats counts from the HELLO (the clock stands still
        before it), so its real-time factor is the loop's own.
        """
        self._start_session(time.monotonic())  # again at the HELLO
        start_s = self.twin.t_s
        self._stop = stop
        if self.firmware is not None:
            self._run_firmware(duration_s, stop)
        else:
            self._run_in_process(duration_s, stop)
        cpu0, spun0 = self._session_cpu0
        return RunnerStats(
            self.twin.t_s - start_s,
            time.monotonic() - self._session_wall0,
            self.frames,
            self.heartbeat_timeouts,
            time.process_time() - cpu0,
            contention.spun_s - spun0,
            self.stalled,
        )

    def _start_session(self, wall0: float) -> None:
        """Count run()'s statistics from now: wall time ``wall0``, CPU time, time spun."""
        self._session_wall0 = wall0
        self._session_cpu0 = (time.process_time(), contention.spun_s)

    def _done(self, end_s: float | None, stop: Event | None) -> bool:
        return (
            (stop is not None and stop.is_set())
            or self.stalled is not None
            or (end_s is not None and self.twin.t_s >= end_s - 1e-9)
        )

    def _run_in_process(self, duration_s: float | None, stop: Event | None) -> None:
        mcu = self.mcu
        assert mcu is not None
        while not mcu.session:  # the clock stands still until the host says HELLO
            if stop is not None and stop.is_set():
                return
            self._serve(self._advance_still_lidar())
        self._session_starts()
        end_s = None if duration_s is None else self.twin.t_s + duration_s
        wall0, sim0 = time.monotonic(), self.twin.t_s
        self._start_session(wall0)
        while not self._done(end_s, stop):
            now = self.twin.t_us
            self._check_outage()
            self._serve(0.0)  # like the firmware's tick: what has arrived is handled first
            self._advance_lidar()
            frames_before = mcu.telemetry_frames
            self._lost = False
            mcu.tick(now)
            if mcu.telemetry_frames != frames_before:
                self.frames += 1
                if self._lost:
                    self._serve(0.0)  # nobody will acknowledge a frame lost on the line
                elif self.lockstep:
                    self._wait_heartbeat(mcu.last_telemetry_seq)
                    if self.stalled is not None:
                        return  # the clock stands still for good
                else:
                    self._serve(0.0)
                self._actuate()
            elif self.mcu_motors or self._line_changed():
                self._actuate()  # the MCU's own failsafe, or the interlock line, on time
            nxt = mcu.next_deadline(now)
            step_us = ((nxt - now) & 0xFFFFFFFF) if nxt is not None else 50_000
            if step_us == 0 or step_us >= 0x80000000:
                step_us = mcu.period_us
            if end_s is not None:
                step_us = min(step_us, max(1, round((end_s - self.twin.t_s) * 1e6)))
            self.twin.advance(step_us / 1e6)
            if self._outage_until is not None or self._host_gone is not None:
                self._pace(*self._pace_origin)  # nobody to wait for: the world runs in real time
            elif not self.lockstep:
                self._pace(wall0, sim0)
            if self.truth is not None:
                self.truth.write(self.twin)  # before the MCU acts at this instant
            if self.observer is not None:
                self.observer(self.twin)

    def _pace(self, wall0: float, sim0: float) -> None:
        """Real time: serve the host until the wall clock catches up with the twin."""
        while not (self._stop is not None and self._stop.is_set()):
            ahead = (self.twin.t_s - sim0) - (time.monotonic() - wall0)
            if ahead <= 0:
                return
            self._serve(ahead)

    def _run_firmware(self, duration_s: float | None, stop: Event | None) -> None:
        fw = self.firmware
        assert fw is not None
        status = fw.wait_heartbeat(256, 0)
        while not status.session:  # time stands still until HELLO, as in process
            if stop is not None and stop.is_set():
                return
            wait_ms = max(1, round(1000 * self._advance_still_lidar()))
            status = fw.wait_heartbeat(256, wait_ms, on_wait=self._service_side)
        self._session_starts()
        end_s = None if duration_s is None else self.twin.t_s + duration_s
        wall0, sim0 = time.monotonic(), self.twin.t_s
        self._start_session(wall0)
        last_seq = status.telemetry_seq
        while not self._done(end_s, stop):
            now = self.twin.t_us
            step_us = (status.next_telemetry_us - now) & 0xFFFFFFFF
            if step_us == 0 or step_us >= 0x80000000:
                step_us = 50_000
            if end_s is not None:
                step_us = min(step_us, max(1, round((end_s - self.twin.t_s) * 1e6)))
            self.twin.advance(step_us / 1e6)
            # as in process: paced and observed with the outputs of the step just run,
            # before the MCU acts at the new instant
            if self._host_gone is not None:
                self._pace(*self._pace_origin)
            elif not self.lockstep:
                self._pace(wall0, sim0)
            if self.truth is not None:
                self.truth.write(self.twin)  # before the MCU acts at this instant
            if self.observer is not None:
                self.observer(self.twin)
            self._advance_lidar()
            status = fw.step(self.twin.t_us, self.sensors())
            if status.telemetry_seq != last_seq:
                last_seq = status.telemetry_seq
                self.frames += 1
                if self.lockstep and self._host_gone is None:
                    status = self._wait_firmware_heartbeat(fw, status)
                    if self.stalled is not None or (stop is not None and stop.is_set()):
                        return  # a stall: the clock stands still for good
                    if status.heartbeat_ack != last_seq:
                        # the host is gone: run in real time until its heartbeats come back
                        self.heartbeat_timeouts += 1
                        self._host_gone = status.heartbeat_ack
                        self._pace_origin = (time.monotonic(), self.twin.t_s)
                elif self._host_gone is not None:
                    self._service_side()
                    status = fw.wait_heartbeat(last_seq, 0)  # serves the link once
                    if status.heartbeat_ack != self._host_gone:
                        self._host_gone = None  # the host is back: lockstep again
                else:
                    self._service_side()
                self._actuate(status)
            elif self._line_changed():
                self._actuate(status)

    def _wait_firmware_heartbeat(self, fw: FirmwareProcess, status: FeedStatus) -> FeedStatus:
        """Lockstep with the compiled firmware: wait for the HEARTBEAT of ``status``'s frame
        (at most ``heartbeat_timeout_s``, an hour when infinite), or until a stall or a stop;
        the last status (its ``heartbeat_ack`` tells which)."""
        seq = status.telemetry_seq
        start = time.monotonic()
        self.waiting_since = start
        deadline = start + min(self.heartbeat_timeout_s, 3600.0)
        armed = False
        while True:
            now = time.monotonic()
            wait = max(0.0, min(deadline - now, 0.5))  # wakes to see a stop
            stalled_for = self._stalled_for(start, now)
            if stalled_for is not None and self.stall_s is not None:
                if stalled_for < self.stall_s:
                    armed = False
                    wait = min(wait, self.stall_s - stalled_for)
                elif armed:
                    self._give_up(stalled_for)
                    return status
                else:
                    armed, wait = True, 0.0
            status = fw.wait_heartbeat(seq, round(wait * 1000), on_wait=self._service_side)
            if status.heartbeat_ack == seq:
                break
            if time.monotonic() >= deadline or (self._stop is not None and self._stop.is_set()):
                break
        self.waiting_since = None
        return status

    def close(self) -> None:
        if self.truth is not None:
            self.truth.close()
        self.i2c.close()
        if self.link is not None:
            self.link.close()
        if self.lidar is not None:
            self.lidar.close()
        if self.firmware is not None:
            self.firmware.close()
        self._sel.close()
