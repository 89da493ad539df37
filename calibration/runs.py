"""Recording the runs each calibration needs, and reading run folders back.

Every run is an ordinary run folder of the host (``log.jrec``, ``odometry.csv``, ``ekf.csv``,
``commands.csv``, ``config.yaml``, ``meta.json``; see docs/host.md), plus ``calibration.json``
with what the user measured (the tape distance, the true number of turns). Runs are recorded
through the host's own classes, on the robot or on the twin alike:

- **Velocity runs** (straight runs, in-place rotations, standing still, spins, excitation
  profiles) are the daemon itself (:class:`~jackson.host.daemon.Daemon` over
  :class:`~jackson.host.transport.SerialTransport` and the PCA9685) driving a small
  calibration mission: the EKF, the limits and the deadband compensation act as in any run.
  Missions steer by the EKF (whose yaw is the gyro's) and wait for its start-up gyro bias.
- **Raw duty runs** (deadband staircases, the step characterisation) must bypass the host's
  deadband compensation: the same daemon with the script as its command source
  (:class:`~jackson.host.core.DutySource`), whose duties go straight to the PCA9685
  (:class:`~jackson.host.actuation.output.Pca9685Output`); the run folder records the frames
  received and the raw duties in ``commands.csv`` (``v_cmd`` and ``w_cmd`` are 0 there). One
  per-frame loop serves every run.

:func:`load_run` turns a folder into a :class:`~jackson.calibration.procedures.RunData`.
"""

from __future__ import annotations

import csv
import dataclasses
import datetime as dt
import itertools
import json
import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import yaml
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn

from jackson.calibration.procedures import CalibrationError, Reference, RunData
from jackson.host.actuation.output import McuOutput, MotorOutput, Pca9685Output
from jackson.host.actuation.pca9685 import Pca9685
from jackson.host.config import HostConfig, ImuCalibration, dump_config
from jackson.host.control import NavState, wrap_angle
from jackson.host.core import (
    CoreListener,
    DutySource,
    FrameResult,
    HostCore,
)
from jackson.host.daemon import Daemon
from jackson.host.i2c import I2cBus, I2cError, open_bus
from jackson.host.odometry import tick_delta
from jackson.host.recording import KIND_RX, KIND_TX, RecordingError, read_log
from jackson.host.transport import LinkError, SerialTransport
from jackson.protocol import (
    FrameDecoder,
    Message,
    SetImuCalibration,
    Telemetry,
    TelemetryFlags,
    TimestampUnwrapper,
    decode_message,
)
from jackson.protocol.messages import (
    ACCEL_LSB_PER_G,
    GRAVITY_M_S2,
    GYRO_LSB_PER_DPS,
    accel_fs,
    gyro_fs,
)

NOTES_FILE = "calibration.json"
CALIBRATION_SETTLE_FRAMES = 2  # frames after a SET_IMU_CALIBRATION still in flight


class RunError(RuntimeError):
    """A calibration run could not be recorded (link, bus, a robot that does not move)."""


# ------------------------------------------------------------------------- reading runs


def _imu_si(t: Telemetry) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
    """Gyro [rad/s] and specific force [m/s^2] of a frame at the ranges its flags name."""
    gyro = np.radians(np.array(t.gyro, dtype=np.float64) / GYRO_LSB_PER_DPS[gyro_fs(t.flags)])
    accel = np.array(t.accel, dtype=np.float64) / ACCEL_LSB_PER_G[accel_fs(t.flags)] * GRAVITY_M_S2
    return gyro, accel


def _read_notes(folder: Path) -> dict[str, float]:
    path = folder / NOTES_FILE
    if not path.exists():
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise CalibrationError(f"run {folder.name}: {NOTES_FILE} is not readable JSON") from exc
    if not isinstance(data, dict):
        raise CalibrationError(f"run {folder.name}: {NOTES_FILE} is not a JSON object")
    return {
        str(k): float(v)
        for k, v in data.items()
        if isinstance(v, (int, float)) and not isinstance(v, bool)
    }


def _read_duties(folder: Path, t_s: Sequence[float]) -> tuple[list[float], list[float]]:
    """commands.csv duties matched to the frames by their time (NaN where missing)."""
    left = [math.nan] * len(t_s)
    right = [math.nan] * len(t_s)
    path = folder / "commands.csv"
    if not path.exists():
        return left, right
    rows: dict[float, tuple[float, float]] = {}
    try:
        with path.open(newline="", encoding="utf-8") as f:
            for row in csv.DictReader(f):
                rows[float(row["t_s"])] = (float(row["duty_left"]), float(row["duty_right"]))
    except (OSError, KeyError, ValueError) as exc:
        raise CalibrationError(f"run {folder.name}: commands.csv is damaged ({exc})") from exc
    for i, t in enumerate(t_s):
        if t in rows:
            left[i], right[i] = rows[t]
    return left, right


def load_run(folder: str | Path) -> RunData:
    """Read a run folder: telemetry from ``log.jrec``, duties, and the user's measurements.

    Frames the device sent calibrated (``IMU_CALIBRATED``) are turned back into sensor-frame
    values with the SET_IMU_CALIBRATION the host sent before them (omega_s = R^T (omega + b),
    a_s = R^T a / s); frames calibrated by a calibration the log does not show (one stored in
    the device's flash) have no usable IMU values (NaN).

    Args:
        folder: A run folder written by ``jackson daemon`` or by this module.

    Returns:
        The run's data.

    Raises:
        CalibrationError: The folder is missing, not a run, or holds no telemetry.
    """
    path = Path(folder)
    if not path.is_dir():
        raise CalibrationError(f"run folder {path} does not exist")
    if not (path / "log.jrec").exists():
        raise CalibrationError(f"{path} is not a run folder (no log.jrec)")
    unwrapper = TimestampUnwrapper()
    t_s: list[float] = []
    enc: list[tuple[int, int]] = []
    gyro: list[np.ndarray[Any, Any]] = []
    accel: list[np.ndarray[Any, Any]] = []
    nan3 = np.full(3, np.nan)
    calibration: SetImuCalibration | None = None
    since_calibration = 0
    raw_left = raw_right = 0
    try:
        for rec in read_log(path):
            if rec.kind == KIND_TX:
                for frame in FrameDecoder().feed(rec.payload):
                    msg = decode_message(frame)
                    if isinstance(msg, SetImuCalibration):
                        calibration = msg
                        since_calibration = 0
                continue
            if rec.kind != KIND_RX or len(rec.payload) < 2 or rec.payload[0] != Telemetry.TYPE:
                continue
            t = Telemetry.unpack(rec.payload[2:])
            since_calibration += 1
            t_s.append(unwrapper.unwrap(t.t_us) / 1e6)
            if enc:
                enc.append(
                    (
                        enc[-1][0] + tick_delta(raw_left, t.enc_left),
                        enc[-1][1] + tick_delta(raw_right, t.enc_right),
                    )
                )
            else:
                enc.append((t.enc_left, t.enc_right))
            raw_left, raw_right = t.enc_left, t.enc_right
            if not t.flags & TelemetryFlags.IMU_OK:
                gyro.append(nan3)
                accel.append(nan3)
                continue
            g, a = _imu_si(t)
            if t.flags & TelemetryFlags.IMU_CALIBRATED:
                if calibration is None or since_calibration <= CALIBRATION_SETTLE_FRAMES:
                    gyro.append(nan3)
                    accel.append(nan3)
                    continue
                r = np.array(calibration.imu_rotation, dtype=np.float64).reshape(3, 3)
                g = r.T @ (g + np.array(calibration.gyro_bias, dtype=np.float64))
                a = r.T @ a / calibration.accel_scale
            gyro.append(g)
            accel.append(a)
    except RecordingError as exc:
        raise CalibrationError(str(exc)) from exc
    if not t_s:
        raise CalibrationError(f"run {path.name}: no telemetry frames in log.jrec")
    duty_left, duty_right = _read_duties(path, t_s)
    return RunData(
        name=path.name,
        t_s=np.array(t_s, dtype=np.float64),
        enc_left=np.array([e[0] for e in enc], dtype=np.int64),
        enc_right=np.array([e[1] for e in enc], dtype=np.int64),
        gyro_rad_s=np.array(gyro, dtype=np.float64),
        accel_m_s2=np.array(accel, dtype=np.float64),
        duty_left=np.array(duty_left, dtype=np.float64),
        duty_right=np.array(duty_right, dtype=np.float64),
        notes=_read_notes(path),
    )


def load_reference(path: str | Path) -> Reference:
    """A reference trajectory: CSV with a header ``t_s,x_m,y_m,yaw_rad`` (MCU clock, metres,
    radians; other columns are ignored), sorted by time.

    Raises:
        CalibrationError: Missing file or columns, non-numbers, or fewer than two rows.
    """
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except OSError as exc:
        raise CalibrationError(f"reference {p}: cannot read it ({exc.strerror})") from exc
    except (UnicodeDecodeError, csv.Error) as exc:
        raise CalibrationError(f"reference {p}: not a CSV text file ({exc})") from exc
    cols = ("t_s", "x_m", "y_m", "yaw_rad")
    if not rows or any(c not in rows[0] for c in cols):
        raise CalibrationError(f"reference {p}: expected a CSV header with {', '.join(cols)}")
    try:
        data = np.array([[float(r[c]) for c in cols] for r in rows], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CalibrationError(f"reference {p}: not a number ({exc})") from exc
    if not np.all(np.isfinite(data)):
        raise CalibrationError(f"reference {p}: nan or inf among the numbers")
    if len(data) < 2 or np.any(np.diff(data[:, 0]) <= 0):
        raise CalibrationError(f"reference {p}: needs two or more rows with rising t_s")
    return Reference(data[:, 0], data[:, 1], data[:, 2], data[:, 3])


def write_notes(folder: Path, notes: dict[str, Any]) -> None:
    """Store what the user measured for a run in its ``calibration.json``."""
    (folder / NOTES_FILE).write_text(json.dumps(notes, indent=2) + "\n", encoding="utf-8")


# ------------------------------------------------------------------------- the link


@dataclass(frozen=True)
class Link:
    """A robot (or the twin) to record on, and what the host believes about it.

    Attributes:
        port: The MCU's serial port (the twin prints its pty).
        config: The host configuration; ``pca9685.bus`` names the PCA9685's bus (``--i2c``).
        console: Where progress bars go; None: no progress display.
    """

    port: str
    config: HostConfig
    console: Console | None = field(default=None, compare=False)


@contextmanager
def _progress(
    console: Console | None, label: str, total_s: float
) -> Iterator[Callable[[float], None]]:
    """A rich progress bar in seconds of MCU time; a no-op without a console."""
    if console is None:
        yield lambda elapsed_s: None
        return
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:5.1f}/{task.total:.0f} s"),
        console=console,
        transient=True,
    ) as progress:
        task = progress.add_task(label, total=total_s)
        yield lambda elapsed_s: progress.update(task, completed=min(elapsed_s, total_s))


def _meta(link: Link, procedure: str, **extra: Any) -> dict[str, Any]:
    return {
        "mission": None,  # commands came from a calibration script
        "calibration": procedure,
        "port": link.port,
        "started": dt.datetime.now().isoformat(),
        **extra,
    }


def _write_config(folder: Path, cfg: HostConfig) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yaml").write_text(
        yaml.safe_dump(dump_config(cfg), sort_keys=False), encoding="utf-8"
    )


def _open_pca(cfg: HostConfig) -> tuple[I2cBus, Pca9685]:
    p = cfg.pca9685
    try:
        bus = open_bus(p.bus)
        pca = Pca9685(bus, p.address)
        pca.init(p.frequency_hz)
    except (I2cError, OSError) as exc:
        raise RunError(f"PCA9685 at {p.address:#04x} on {p.bus}: {exc}") from exc
    return bus, pca


# ------------------------------------------------------------------------- velocity runs


class CalibrationMission:
    """A velocity script for the daemon (the host's Mission protocol), timed on MCU time.

    Subclasses implement :meth:`step`; this class adds the start time, a timeout after which
    the mission ends as ``timed_out`` (a robot that does not move), a still settle period at
    the end so the run ends at rest, and a progress callback.
    """

    name = "calibration"

    def __init__(self, timeout_s: float, settle_s: float = 1.0) -> None:
        self.done = False
        self.timed_out = False
        self.timeout_s = timeout_s
        self.settle_s = settle_s
        self.on_progress: Callable[[float], None] = lambda elapsed_s: None
        self._t0: float | None = None
        self._stopped_at: float | None = None

    def command(self, s: NavState) -> tuple[float, float]:
        if self.done:
            return 0.0, 0.0
        if self._t0 is None:
            self._t0 = s.t_s
        elapsed = s.t_s - self._t0
        self.on_progress(elapsed)
        if self._stopped_at is not None:
            if elapsed - self._stopped_at >= self.settle_s:
                self.done = True
            return 0.0, 0.0
        if elapsed > self.timeout_s:
            self.timed_out = self.done = True
            return 0.0, 0.0
        out = self.step(s, elapsed)
        if out is None:
            self._stopped_at = elapsed
            return 0.0, 0.0
        return out

    def step(self, s: NavState, elapsed_s: float) -> tuple[float, float] | None:
        """(v, w) for this frame, or None when the motion is over (then settle)."""
        raise NotImplementedError


class StraightMission(CalibrationMission):
    """Drive ``distance_m`` along the start heading (by the odometry), heading held by the EKF.

    v = direction x max(v_min, min(speed, sqrt(2 a_stop remaining))) and a PI heading hold
    w = -(k_yaw e + k_i integral e dt) with e = yaw - yaw_0: the integral takes out the steady
    pull of two wheels with different breakaway duties, so the run ends on its start heading.
    """

    def __init__(
        self,
        distance_m: float,
        speed_m_s: float = 0.15,
        direction: int = 1,
        *,
        k_yaw: float = 3.0,
        k_i: float = 3.0,
        a_stop_m_s2: float = 0.5,
        v_min_m_s: float = 0.05,
    ) -> None:
        super().__init__(timeout_s=10.0 + 3.0 * distance_m / speed_m_s)
        self.distance_m = distance_m
        self.speed_m_s = speed_m_s
        self.direction = 1 if direction >= 0 else -1
        self.k_yaw = k_yaw
        self.k_i = k_i
        self.a_stop = a_stop_m_s2
        self.v_min = v_min_m_s
        self._start: NavState | None = None
        self._last_t: float | None = None
        self._integral = 0.0

    def step(self, s: NavState, elapsed_s: float) -> tuple[float, float] | None:
        if self._start is None:
            self._start = s
        s0 = self._start
        along = (s.x_m - s0.x_m) * math.cos(s0.yaw_rad) + (s.y_m - s0.y_m) * math.sin(s0.yaw_rad)
        remaining = self.distance_m - self.direction * along
        if remaining <= 0.0:
            return None
        err = wrap_angle(s.yaw_rad - s0.yaw_rad)
        if self._last_t is not None:
            self._integral += err * (s.t_s - self._last_t)
        self._last_t = s.t_s
        v = max(self.v_min, min(self.speed_m_s, math.sqrt(2.0 * self.a_stop * remaining)))
        w = -(self.k_yaw * err + self.k_i * self._integral)
        return self.direction * v, max(-0.5, min(0.5, w))


class RotationMission(CalibrationMission):
    """Turn in place by ``turns`` full turns of the EKF's (gyro) yaw, slowing near the end."""

    def __init__(
        self,
        turns: float,
        w_rad_s: float = 1.0,
        direction: int = 1,
        *,
        alpha_stop_rad_s2: float = 1.5,
        w_min_rad_s: float = 0.4,
    ) -> None:
        super().__init__(timeout_s=10.0 + 3.0 * turns * 2.0 * math.pi / w_rad_s)
        self.target_rad = turns * 2.0 * math.pi
        self.w_rad_s = w_rad_s
        self.direction = 1 if direction >= 0 else -1
        self.alpha = alpha_stop_rad_s2
        self.w_min = w_min_rad_s
        self.turned_rad = 0.0
        self._last_yaw: float | None = None

    def step(self, s: NavState, elapsed_s: float) -> tuple[float, float] | None:
        if self._last_yaw is not None:
            self.turned_rad += wrap_angle(s.yaw_rad - self._last_yaw)
        self._last_yaw = s.yaw_rad
        remaining = self.target_rad - self.direction * self.turned_rad
        if remaining <= 0.0:
            return None
        w = max(self.w_min, min(self.w_rad_s, math.sqrt(2.0 * self.alpha * remaining)))
        return 0.0, self.direction * w


class ProfileMission(CalibrationMission):
    """Open-loop (v, w, seconds) segments one after another (stand still: (0, 0, s))."""

    def __init__(
        self, segments: Sequence[tuple[float, float, float]], settle_s: float = 1.0
    ) -> None:
        total = sum(seg[2] for seg in segments)
        super().__init__(timeout_s=total + 5.0, settle_s=settle_s)
        self.segments = list(segments)
        self.total_s = total

    def step(self, s: NavState, elapsed_s: float) -> tuple[float, float] | None:
        t = 0.0
        for v, w, seconds in self.segments:
            t += seconds
            if elapsed_s < t:
                return v, w
        return None


def drive_run(
    link: Link,
    folder: Path,
    mission: CalibrationMission,
    *,
    label: str,
    expected_s: float,
    meta: dict[str, Any],
) -> Path:
    """Record one velocity run: the daemon (its EKF, limits, deadband compensation, PCA9685
    output and recorder) driving ``mission`` until it is done.

    Raises:
        RunError: The port, the bus, no telemetry, or a mission that timed out.
        ProtocolMismatchError: Firmware of another protocol version.
    """
    cfg = link.config
    bus: I2cBus | None = None
    pca: Pca9685 | None = None
    transport = SerialTransport(link.port, cfg.serial.baudrate)
    try:
        transport.open()
    except LinkError as exc:
        raise RunError(str(exc)) from exc
    if cfg.actuator == "pca9685":
        try:
            bus, pca = _open_pca(cfg)
        except RunError:
            transport.close()
            raise

    def output(send: Callable[[Message], object]) -> MotorOutput:
        if pca is not None:
            p = cfg.pca9685
            return Pca9685Output(pca, p.left, p.right, p.stby_channel)
        return McuOutput(send)

    _write_config(folder, cfg)
    daemon = Daemon(cfg, output, transport, run_folder=folder, meta=meta)
    daemon.core.mission = mission
    wall_limit_s = 30.0 + 2.0 * (mission.timeout_s + cfg.ekf.gyro_bias_window_s)
    try:
        with _progress(link.console, label, expected_s) as progress:
            mission.on_progress = progress
            daemon.run(max_s=wall_limit_s)
    finally:
        transport.close()
        if bus is not None:
            bus.close()
    if mission.timed_out:
        raise RunError(
            f"{label}: not finished after {mission.timeout_s:.0f} s: is the robot moving "
            "(motor rail, wheels on the floor)?"
        )
    if not mission.done:
        frames = daemon.core.frames
        raise RunError(
            f"{label}: stopped after {frames} telemetry frames from {link.port}"
            + (" (no telemetry: is the firmware running?)" if frames == 0 else "")
        )
    return folder


Measure = Callable[[Path, int], float]


def record_straight_runs(
    link: Link,
    out: Path,
    measure: Measure,
    *,
    count: int = 3,
    distance_m: float = 1.0,
    speed_m_s: float = 0.15,
) -> list[Path]:
    """Straight floor runs for the encoder calibration (Eq. A6), alternately forwards and back.

    After each run ``measure(folder, index)`` returns the floor distance the axle midpoint
    moved (the user's tape measurement); it is stored in the run's ``calibration.json``.
    """
    folders = []
    for i in range(count):
        direction = 1 if i % 2 == 0 else -1
        folder = out / f"straight-{i + 1}"
        word = "forward" if direction > 0 else "backward"
        drive_run(
            link,
            folder,
            StraightMission(distance_m, speed_m_s, direction),
            label=f"straight run {i + 1}/{count} ({word} {distance_m:g} m)",
            expected_s=link.config.ekf.gyro_bias_window_s + distance_m / speed_m_s + 2.0,
            meta=_meta(link, "encoders", run=i + 1, direction=word),
        )
        d = measure(folder, i)
        write_notes(folder, {"procedure": "encoders", "measured_distance_m": d})
        folders.append(folder)
    return folders


def record_rotation_runs(
    link: Link,
    out: Path,
    true_rotation: Measure,
    *,
    count: int = 2,
    turns: float = 2.0,
    w_rad_s: float = 1.0,
) -> list[Path]:
    """In-place rotations for the wheel separation (Eq. A12), alternately CCW and CW.

    The robot turns ``turns`` full turns by its gyro; then ``true_rotation(folder, index)``
    returns the rotation it really made [rad] (the user's count, or the twin's truth),
    stored in the run's ``calibration.json``.
    """
    folders = []
    for i in range(count):
        direction = 1 if i % 2 == 0 else -1
        folder = out / f"rotation-{i + 1}"
        word = "counter-clockwise" if direction > 0 else "clockwise"
        drive_run(
            link,
            folder,
            RotationMission(turns, w_rad_s, direction),
            label=f"rotation {i + 1}/{count} ({turns:g} turns {word})",
            expected_s=link.config.ekf.gyro_bias_window_s + turns * 2 * math.pi / w_rad_s + 2.0,
            meta=_meta(link, "track", run=i + 1, direction=word),
        )
        rot = true_rotation(folder, i)
        write_notes(folder, {"procedure": "track", "true_rotation_rad": rot})
        folders.append(folder)
    return folders


def record_imu_runs(
    link: Link, out: Path, *, still_s: float = 10.0, spin_s: float = 4.0, w_rad_s: float = 1.0
) -> list[Path]:
    """A still run (bias, gravity, noise) and a CCW spin (the yaw-sign audit).

    The device is sent an identity calibration first (rotation I, bias 0, scale 1), so a
    calibration stored in its flash does not hide the raw sensor; the spin is timed, not
    steered by the gyro, so a gyro of the wrong sign still turns the robot CCW.
    """
    cfg = dataclasses.replace(
        link.config, imu=dataclasses.replace(link.config.imu, calibration=ImuCalibration())
    )
    raw = dataclasses.replace(link, config=cfg)
    bias_s = cfg.ekf.gyro_bias_window_s
    still = drive_run(
        raw,
        out / "imu-still",
        ProfileMission([(0.0, 0.0, still_s)], settle_s=0.0),
        label=f"standing still {still_s:g} s",
        expected_s=bias_s + still_s,
        meta=_meta(link, "imu", run="still"),
    )
    spin = drive_run(
        raw,
        out / "imu-spin",
        ProfileMission([(0.0, w_rad_s, spin_s)]),
        label=f"spinning counter-clockwise {spin_s:g} s",
        expected_s=bias_s + spin_s + 1.0,
        meta=_meta(link, "imu", run="spin"),
    )
    return [still, spin]


def record_excitation_run(
    link: Link,
    out: Path,
    segments: Sequence[tuple[float, float, float]] = (
        (0.15, 0.0, 3.0),
        (0.12, 0.6, 6.0),
        (0.12, -0.6, 6.0),
        (0.0, 1.2, 3.0),
        (0.15, 0.0, 2.0),
    ),
) -> Path:
    """A run that excites translation, both turning directions and a spin, for the twin fit."""
    mission = ProfileMission(segments)
    return drive_run(
        link,
        out / "excitation",
        mission,
        label="excitation profile",
        expected_s=link.config.ekf.gyro_bias_window_s + mission.total_s + 1.0,
        meta=_meta(link, "twin-fit", segments=[list(s) for s in segments]),
    )


# ------------------------------------------------------------------------- raw duty runs


class DutyScript(DutySource, Protocol):
    """Raw duties per telemetry frame (:class:`jackson.host.core.DutySource`) with a length."""

    total_s: float


class _Progress(CoreListener):
    """Moves a progress bar on MCU time."""

    def __init__(self, update: Callable[[float], None]) -> None:
        self.update = update
        self.t0: float | None = None

    def on_result(self, core: HostCore, result: FrameResult) -> None:
        self.t0 = result.t_s if self.t0 is None else self.t0
        self.update(result.t_s - self.t0)


def duty_run(
    link: Link, folder: Path, script: DutyScript, *, label: str, meta: dict[str, Any]
) -> Path:
    """Record one raw duty run: the daemon with ``script`` as its command source, so the duties
    go to the PCA9685 as they are (no limits, no deadband compensation) and the device sends
    raw IMU registers (no calibration: the procedures read raw values).

    Raises:
        RunError: The port, the bus, no telemetry, or an actuator other than the PCA9685.
        ProtocolMismatchError: Firmware of another protocol version.
    """
    cfg = link.config
    if cfg.actuator != "pca9685":
        raise RunError("raw duty runs drive the PCA9685: the config needs actuator: pca9685")
    transport = SerialTransport(link.port, cfg.serial.baudrate)
    try:
        transport.open()
    except LinkError as exc:
        raise RunError(str(exc)) from exc
    try:
        bus, pca = _open_pca(cfg)
    except RunError:
        transport.close()
        raise
    p = cfg.pca9685

    def output(send: Callable[[Message], object]) -> MotorOutput:
        return Pca9685Output(pca, p.left, p.right, p.stby_channel)

    _write_config(folder, cfg)
    daemon = Daemon(
        cfg,
        output,
        transport,
        run_folder=folder,
        meta=meta,
        duty_source=script,
        imu_calibration=False,
    )
    try:
        with _progress(link.console, label, script.total_s) as progress:
            daemon.core.listeners.append(_Progress(progress))
            daemon.run(max_s=30.0 + 2.0 * script.total_s)
    finally:
        transport.close()
        bus.close()
    if not script.done:
        frames = daemon.core.frames
        raise RunError(
            f"{label}: stopped after {frames} telemetry frames from {link.port}"
            + (" (no telemetry: is the firmware running?)" if frames == 0 else "")
        )
    return folder


class DeadbandScript:
    """Duty staircases per wheel and direction: coarse, then finer around the breakaway.

    For each of left forward, left reverse, right forward, right reverse: brake for
    ``settle_s``, then for each stage (step, hold): raise the duty of that wheel alone in
    ``step`` increments held ``hold`` seconds, from ``start`` to at most ``max_duty``, until
    its counts move in the ramp's direction for ``persist_frames`` frames; brake, and begin
    the next (finer) stage two of the previous steps below the duty that moved the wheel.
    """

    ORDER = (("left", 1), ("left", -1), ("right", 1), ("right", -1))

    def __init__(
        self,
        *,
        stages: Sequence[tuple[float, float]] = ((0.02, 0.25), (0.004, 0.5), (0.001, 0.8)),
        start_duty: float = 0.0,
        max_duty: float = 0.6,
        persist_frames: int = 3,
        settle_s: float = 0.5,
    ) -> None:
        self.stages = list(stages)
        self.start_duty = start_duty
        self.max_duty = max_duty
        self.persist = persist_frames
        self.settle_s = settle_s
        self.done = False
        coarse_levels = max_duty / stages[0][0]
        fine = sum(3 * prev[0] / st[0] * st[1] for prev, st in itertools.pairwise(stages))
        self.total_s = 4 * (coarse_levels * stages[0][1] / 3 + fine + len(stages) * settle_s)
        self.results: dict[tuple[str, int], float | None] = {}
        self._segment = 0
        self._stage = 0
        self._phase = "settle"
        self._t_phase: float | None = None
        self._from = start_duty
        self._ref = 0
        self._moved_run = 0
        self._written: list[float] = []

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        if self.done:
            return 0.0, 0.0
        side, sign = self.ORDER[self._segment]
        count = enc_left if side == "left" else enc_right
        if self._t_phase is None:
            self._t_phase = t_s
        if self._phase == "settle":
            if t_s - self._t_phase < self.settle_s:
                return 0.0, 0.0
            self._phase, self._t_phase = "ramp", t_s
            self._ref, self._moved_run, self._written = count, 0, []
        step, hold = self.stages[self._stage]
        moved = sign * (count - self._ref) >= 1
        self._moved_run = self._moved_run + 1 if moved else 0
        if self._moved_run >= self.persist:  # moved at frame m: the duty written before it
            hi = self._written[len(self._written) - self.persist]
            self._end_ramp(hi, t_s)
            return 0.0, 0.0
        level = math.floor((t_s - self._t_phase) / hold + 1e-9)
        duty = self._from + (level + 1) * step
        if duty > self.max_duty + 1e-12:
            self.results[(side, sign)] = None  # never moved
            self._next_segment(t_s)
            return 0.0, 0.0
        self._written.append(duty)
        d = sign * round(duty, 6)
        return (d, 0.0) if side == "left" else (0.0, d)

    def _end_ramp(self, hi: float, t_s: float) -> None:
        side, sign = self.ORDER[self._segment]
        step = self.stages[self._stage][0]
        if self._stage + 1 < len(self.stages):
            self._stage += 1
            self._from = max(self.start_duty, hi - 2.0 * step)
            self._phase, self._t_phase = "settle", t_s
        else:
            self.results[(side, sign)] = hi
            self._next_segment(t_s)

    def _next_segment(self, t_s: float) -> None:
        self._segment += 1
        self._stage = 0
        self._from = self.start_duty
        self._phase, self._t_phase = "settle", t_s
        if self._segment >= len(self.ORDER):
            self.done = True


class StepScript:
    """Brake ``settle_s``, both wheels at ``duty`` for ``drive_s``, then brake until the counts
    have stood still for ``still_s`` (at most ``max_stop_s``)."""

    def __init__(
        self,
        duty: float = 1.0,
        drive_s: float = 3.0,
        *,
        settle_s: float = 1.0,
        still_s: float = 0.5,
        max_stop_s: float = 3.0,
    ) -> None:
        self.duty = duty
        self.drive_s = drive_s
        self.settle_s = settle_s
        self.still_s = still_s
        self.max_stop_s = max_stop_s
        self.total_s = settle_s + drive_s + 1.0 + still_s
        self.done = False
        self._t0: float | None = None
        self._last_counts: tuple[int, int] | None = None
        self._last_change = 0.0

    def step(self, t_s: float, enc_left: int, enc_right: int) -> tuple[float, float]:
        if self._t0 is None:
            self._t0 = t_s
        e = t_s - self._t0
        if e < self.settle_s:
            return 0.0, 0.0
        if e < self.settle_s + self.drive_s:
            return self.duty, self.duty
        counts = (enc_left, enc_right)
        if counts != self._last_counts:
            self._last_counts, self._last_change = counts, e
        braking = e - self.settle_s - self.drive_s
        if e - self._last_change >= self.still_s or braking >= self.max_stop_s:
            self.done = True
        return 0.0, 0.0


def record_deadband_run(link: Link, out: Path, script: DeadbandScript | None = None) -> Path:
    """The deadband staircases of all four wheel directions, in one raw duty run."""
    script = script or DeadbandScript()
    return duty_run(
        link,
        out / "deadband",
        script,
        label="deadband staircases",
        meta=_meta(link, "deadband", stages=[list(s) for s in script.stages]),
    )


def record_step_run(
    link: Link, out: Path, script: StepScript | None = None, *, rate_hz: int = 200
) -> Path:
    """A duty step on both wheels and the brake after it, in one raw duty run.

    The telemetry runs at ``rate_hz`` for this run (SET_RATE; the next session of the
    daemon sets the configured rate back): the stop lasts only a few frames at 20 Hz.
    """
    script = script or StepScript()
    cfg = link.config
    fast = dataclasses.replace(
        cfg, serial=dataclasses.replace(cfg.serial, telemetry_rate_hz=rate_hz)
    )
    return duty_run(
        dataclasses.replace(link, config=fast),
        out / "characterise",
        script,
        label=f"duty step {script.duty:g} for {script.drive_s:g} s",
        meta=_meta(link, "characterise", duty=script.duty, drive_s=script.drive_s, rate_hz=rate_hz),
    )
