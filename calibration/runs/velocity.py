"""Velocity runs: the daemon driving a calibration mission (straight, turns, IMU, excitation)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from jackson.calibration.runs.folders import RunError, write_notes
from jackson.calibration.runs.link import (
    Link,
    _meta,
    _open_link,
    _progress,
    _stopped,
    _write_config,
    wall_backstop_s,
)
from jackson.host.actuation.output import McuOutput, MotorOutput, Pca9685Output
from jackson.host.config import ImuCalibration
from jackson.host.control import NavState, wrap_angle
from jackson.host.daemon import Daemon
from jackson.protocol import (
    Message,
)


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

    Raises
    ------
    RunError
        The port, the bus, no telemetry, or a mission that timed out.
    ProtocolMismatchError
        Firmware of another protocol version.
    """
    cfg = link.config
    transport, bus, pca = _open_link(link)

    def output(send: Callable[[Message], object]) -> MotorOutput:
        if pca is not None:
            p = cfg.pca9685
            return Pca9685Output(pca, p.left, p.right, p.stby_channel)
        return McuOutput(send)

    _write_config(folder, cfg)
    daemon = Daemon(cfg, output, transport, run_folder=folder, meta=meta)
    daemon.core.mission = mission
    wall_limit_s = wall_backstop_s(mission.timeout_s + cfg.ekf.gyro_bias_window_s)
    try:
        with _progress(link.console, label, expected_s) as progress:
            mission.on_progress = progress
            transport.send_hello()  # the session starts once the daemon is set up
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
        hit = wall_limit_s if daemon.wall_limit_hit else None
        raise _stopped(label, daemon.core.frames, link.port, hit)
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
