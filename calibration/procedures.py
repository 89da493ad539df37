"""The calibration maths: pure functions over recorded runs (Appendix A and B of the paper).

Every function here takes recorded data (a :class:`RunData` per run folder, or plain arrays)
and returns a small frozen result; nothing reads files, talks to the robot or prints. The
recorders live in :mod:`jackson.calibration.runs`, the command line in
:mod:`jackson.calibration.cli`.

1. **Encoder resolution** per wheel from straight runs and a tape measurement (Eq. A4, A6):
   ``C_cal = C_0 d_odom / d_meas``.
2. **Wheel separation** from in-place rotations (Eq. A12): ``B = r (dphi_R - dphi_L) / dtheta``.
3. **IMU static profile**: gyro bias, accelerometer gravity scale ``9.81 / |mean a|``, the
   REP-103 yaw-sign audit against wheel odometry, and the datasheet noise sigmas of Sec. 2.2.4.
4. **PWM deadband** per wheel and direction from slow duty staircases, and the step
   **characterisation** (top speed, time to 90 %, stopping distance).
5. **Twin fit**: effective wheel radius, wheel separation and IMU yaw scale (the paper's
   V16/V17 values) by least squares of dead-reckoned against reference trajectories.

Every failure a user can cause (a robot that did not move, a zero tape measurement) raises
:class:`CalibrationError` with one line naming the run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from jackson.host.config import IDENTITY, MAX_GYRO_BIAS_RAD_S, RobotGeometry, Rotation
from jackson.protocol.messages import GRAVITY_M_S2  # the nominal gravity of host, twin, Table 3

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

STANDARD_GRAVITY_M_S2 = 9.80665  # 1 g of the datasheet's micro-g (what the paper's digits use)
PAPER_STATIC_GRAVITY_M_S2 = 9.299  # Table 3: the MPU-6050 at rest on the physical robot
PAPER_ACCEL_SCALE = 1.054  # Table 3 quotes x1.054; 9.81 / 9.299 = 1.05495 (truncated there)

GYRO_DENSITY_DEG_S_RT_HZ = 0.005  # MPU-6050 datasheet rate noise spectral density
ACCEL_DENSITY_UG_RT_HZ = 400.0  # MPU-6050 datasheet accelerometer noise density
DLPF_BANDWIDTH_HZ = 21.0  # DLPF_CFG = 4: 21 Hz accelerometer / 20 Hz gyro (Sec. 2.2.4: "21 Hz")
FIRST_ORDER_NOISE_FACTOR = math.pi / 2.0  # noise bandwidth / -3 dB bandwidth of one pole

MOTION_MARGIN_FRAMES = 5  # frames before the first count change that may already be moving
MIN_TRAVEL_TICKS = 50  # a wheel that moved less did not drive (about 1.7 cm at 621 TPR)


class CalibrationError(ValueError):
    """Recorded data that cannot give the result (one line for the user, naming the run)."""


# ------------------------------------------------------------------------- recorded data


@dataclass(frozen=True)
class RunData:
    """One recorded run, as the calibration reads it (one row per telemetry frame).

    Attributes:
        name: The run folder's name, for messages.
        t_s: MCU time of each frame [s] (unwrapped).
        enc_left: Cumulative left counts, unwrapped to int64 (no 32-bit wrap) [ticks].
        enc_right: Cumulative right counts [ticks].
        gyro_rad_s: Gyro rate in the *sensor* frame, shape (n, 3) [rad/s]; a calibration the
            device applied is undone; NaN where the IMU sample is missing or unusable.
        accel_m_s2: Specific force in the sensor frame, shape (n, 3) [m/s^2], 1 g = 9.81.
        duty_left: Signed left duty written after the frame (commands.csv), NaN if unknown.
        duty_right: Signed right duty written after the frame.
        notes: What the user measured for this run (``calibration.json``), e.g.
            ``measured_distance_m`` or ``true_rotation_rad``.
    """

    name: str
    t_s: FloatArray
    enc_left: IntArray
    enc_right: IntArray
    gyro_rad_s: FloatArray
    accel_m_s2: FloatArray
    duty_left: FloatArray
    duty_right: FloatArray
    notes: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.t_s)
        shapes = {
            "enc_left": self.enc_left.shape,
            "enc_right": self.enc_right.shape,
            "duty_left": self.duty_left.shape,
            "duty_right": self.duty_right.shape,
        }
        for key, shape in shapes.items():
            if shape != (n,):
                raise ValueError(f"RunData.{key}: expected shape ({n},), got {shape}")
        for key, arr in (("gyro_rad_s", self.gyro_rad_s), ("accel_m_s2", self.accel_m_s2)):
            if arr.shape != (n, 3):
                raise ValueError(f"RunData.{key}: expected shape ({n}, 3), got {arr.shape}")

    @property
    def frames(self) -> int:
        return len(self.t_s)

    @property
    def still_frames(self) -> int:
        """Frames at rest before the wheels first move, less a margin of
        :data:`MOTION_MARGIN_FRAMES` (all frames when they never move)."""
        if self.frames == 0:
            return 0
        moving = np.flatnonzero(
            (self.enc_left != self.enc_left[0]) | (self.enc_right != self.enc_right[0])
        )
        return self.frames if len(moving) == 0 else max(0, int(moving[0]) - MOTION_MARGIN_FRAMES)

    @property
    def moved(self) -> bool:
        """Whether either wheel turned during the run (any count changed)."""
        if self.frames == 0:
            return False
        return bool(
            np.any(self.enc_left != self.enc_left[0]) or np.any(self.enc_right != self.enc_right[0])
        )


def wheel_angle_rad(ticks: float | FloatArray, ticks_per_rev: float) -> FloatArray:
    """Wheel rotation of a tick count: dphi = 2 pi N / C_e [rad] (Eq. 9 without r)."""
    return np.asarray(2.0 * math.pi * np.asarray(ticks, dtype=np.float64) / ticks_per_rev)


def wheel_travel_m(ticks: float, ticks_per_rev: float, wheel_radius_m: float) -> float:
    """Wheel travel of a tick count: d_s = 2 pi r N / C_e [m] (Eq. A4)."""
    return 2.0 * math.pi * wheel_radius_m * ticks / ticks_per_rev


# ------------------------------------------------------------------------- 1. encoders


def encoder_resolution(ticks_per_rev_0: float, d_odom_m: float, d_meas_m: float) -> float:
    """The corrected encoder resolution C_cal = C_0 d_odom / d_meas (Eq. A6).

    Since d_odom = 2 pi r N / C_0 (Eq. A4), this is C_cal = 2 pi r N / d_meas: the resolution
    that makes the wheel's counts read the measured floor distance with the wheel radius r.

    Args:
        ticks_per_rev_0: C_0, the resolution the odometry used [ticks/rev].
        d_odom_m: Distance the odometry reported with C_0 [m].
        d_meas_m: Distance measured on the floor [m].

    Returns:
        C_cal [ticks/rev]. The paper: 652 x 0.9525 = 621 (Eq. A7-A8).

    Raises:
        CalibrationError: A measured distance that is not > 0, or no odometry distance.
    """
    if not (math.isfinite(d_meas_m) and d_meas_m > 0.0):
        raise CalibrationError(f"the measured distance must be > 0 m, got {d_meas_m:g}")
    if not (math.isfinite(d_odom_m) and d_odom_m > 0.0):
        raise CalibrationError(f"the odometry distance must be > 0 m, got {d_odom_m:g}")
    return ticks_per_rev_0 * d_odom_m / d_meas_m


@dataclass(frozen=True)
class StraightRun:
    """One straight floor run: the count change of each wheel and the tape measurement."""

    name: str
    ticks_left: int
    ticks_right: int
    measured_m: float


@dataclass(frozen=True)
class EncoderCalibration:
    """C_cal per wheel averaged over runs (Eq. A6), with each run's value and ratio.

    Attributes:
        ticks_per_rev_left: Mean C_cal of the left wheel [ticks/rev].
        ticks_per_rev_right: Mean C_cal of the right wheel.
        per_run: (C_left, C_right) of each run.
        ratio_left: Mean d_odom / d_meas of the left wheel with C_0 (the paper: 0.9525).
        ratio_right: The same for the right wheel.
        spread_left: Sample standard deviation of the runs' C_left (0 for one run).
        spread_right: The same for the right wheel.
    """

    ticks_per_rev_left: float
    ticks_per_rev_right: float
    per_run: tuple[tuple[float, float], ...]
    ratio_left: float
    ratio_right: float
    spread_left: float
    spread_right: float


def straight_run(run: RunData, measured_m: float) -> StraightRun:
    """The count change of each wheel over a run (first to last frame) and its measurement.

    Raises:
        CalibrationError: The run has fewer than two frames.
    """
    return StraightRun(run.name, *_count_change(run), measured_m)


def _count_change(run: RunData) -> tuple[int, int]:
    """Left and right count change from the run's first to its last telemetry frame."""
    if run.frames < 2:
        raise CalibrationError(f"run {run.name}: fewer than two telemetry frames")
    return int(run.enc_left[-1] - run.enc_left[0]), int(run.enc_right[-1] - run.enc_right[0])


def calibrate_encoders(runs: Sequence[StraightRun], geometry: RobotGeometry) -> EncoderCalibration:
    """Encoder resolution per wheel from straight runs (Eq. A4, A6), averaged over the runs.

    Per run and wheel i: d_odom,i = 2 pi r_i |N_i| / C_0,i (Eq. A4) with the configured
    resolution C_0,i and radius r_i, then C_cal,i = C_0,i d_odom,i / d_meas (Eq. A6). Runs may
    go forwards or backwards (the sign of the counts is dropped). On a straight run both wheels
    travel the distance of the axle midpoint, so one tape measurement serves both.

    Args:
        runs: The straight runs, each with its measured floor distance d_meas.
        geometry: The configured radii and C_0 per wheel.

    Returns:
        The mean C_cal per wheel and the details.

    Raises:
        CalibrationError: No runs, a non-positive measurement, or a wheel that did not move.
    """
    if not runs:
        raise CalibrationError("no straight runs to calibrate the encoders from")
    per_run: list[tuple[float, float]] = []
    ratios: list[tuple[float, float]] = []
    for run in runs:
        if not (math.isfinite(run.measured_m) and run.measured_m > 0.0):
            raise CalibrationError(
                f"run {run.name}: the measured distance must be > 0 m, got {run.measured_m:g}"
            )
        out = []
        for side, ticks, c0, r in (
            ("left", run.ticks_left, geometry.ticks_per_rev_left, geometry.wheel_radius_left_m),
            ("right", run.ticks_right, geometry.ticks_per_rev_right, geometry.wheel_radius_right_m),
        ):
            if abs(ticks) < MIN_TRAVEL_TICKS:
                raise CalibrationError(
                    f"run {run.name}: the {side} wheel moved {abs(ticks)} ticks: the robot did "
                    "not drive (is the motor rail switched on?)"
                )
            d_odom = wheel_travel_m(abs(ticks), c0, r)
            out.append((encoder_resolution(c0, d_odom, run.measured_m), d_odom / run.measured_m))
        per_run.append((out[0][0], out[1][0]))
        ratios.append((out[0][1], out[1][1]))
    left = np.array([c[0] for c in per_run])
    right = np.array([c[1] for c in per_run])
    ddof = 1 if len(per_run) > 1 else 0
    return EncoderCalibration(
        ticks_per_rev_left=float(left.mean()),
        ticks_per_rev_right=float(right.mean()),
        per_run=tuple(per_run),
        ratio_left=float(np.mean([r[0] for r in ratios])),
        ratio_right=float(np.mean([r[1] for r in ratios])),
        spread_left=float(left.std(ddof=ddof)),
        spread_right=float(right.std(ddof=ddof)),
    )


# ------------------------------------------------------------------------- 2. track width


def wheel_separation(
    wheel_radius_m: float, dphi_right_rad: float, dphi_left_rad: float, dtheta_rad: float
) -> float:
    """B = r (dphi_R - dphi_L) / dtheta (Eq. A12).

    Args:
        wheel_radius_m: r [m].
        dphi_right_rad: Accumulated right wheel rotation [rad].
        dphi_left_rad: Accumulated left wheel rotation [rad].
        dtheta_rad: True chassis rotation [rad], CCW positive.

    Returns:
        B [m]. The paper: 0.033 x 37.70 / 2 pi = 0.198 (Eq. A15).

    Raises:
        CalibrationError: A zero rotation.
    """
    if not (math.isfinite(dtheta_rad) and dtheta_rad != 0.0):
        raise CalibrationError(f"the true rotation must be nonzero, got {dtheta_rad:g} rad")
    return wheel_radius_m * (dphi_right_rad - dphi_left_rad) / dtheta_rad


@dataclass(frozen=True)
class RotationRun:
    """One in-place rotation: the count change of each wheel and the true rotation."""

    name: str
    ticks_left: int
    ticks_right: int
    true_rotation_rad: float


@dataclass(frozen=True)
class TrackCalibration:
    """Wheel separation B averaged over rotation runs (Eq. A12).

    Attributes:
        wheel_separation_m: Mean B [m].
        per_run: B of each run [m].
        wheel_rotation_difference_rad: dphi_R - dphi_L of each run (the paper: 37.70 rad).
        spread_m: Sample standard deviation of the runs' B (0 for one run).
    """

    wheel_separation_m: float
    per_run: tuple[float, ...]
    wheel_rotation_difference_rad: tuple[float, ...]
    spread_m: float


def rotation_run(run: RunData, true_rotation_rad: float) -> RotationRun:
    """The count change of each wheel over a run and the true rotation the user confirmed.

    Raises:
        CalibrationError: The run has fewer than two frames.
    """
    return RotationRun(run.name, *_count_change(run), true_rotation_rad)


def calibrate_track(runs: Sequence[RotationRun], geometry: RobotGeometry) -> TrackCalibration:
    """Wheel separation from in-place rotations (Eq. A12), averaged over the runs.

    dphi_i = 2 pi N_i / C_i with the (already calibrated) resolution of each wheel, and with
    per-wheel radii Eq. A12 reads B = (r_R dphi_R - r_L dphi_L) / dtheta. The true rotation is
    the user's count of full turns (or the twin's ground truth); its sign is taken from the
    wheels, so "2 turns" serves clockwise and counter-clockwise runs alike.

    Args:
        runs: The rotation runs with their true rotation |dtheta| (the sign is ignored).
        geometry: Radii and resolutions per wheel.

    Returns:
        The mean B and the details.

    Raises:
        CalibrationError: No runs, a zero rotation, or wheels that did not turn in place.
    """
    if not runs:
        raise CalibrationError("no rotation runs to calibrate the wheel separation from")
    values: list[float] = []
    diffs: list[float] = []
    for run in runs:
        if not (math.isfinite(run.true_rotation_rad) and run.true_rotation_rad != 0.0):
            raise CalibrationError(
                f"run {run.name}: the true rotation must be nonzero, got {run.true_rotation_rad:g}"
            )
        phi_l = float(wheel_angle_rad(run.ticks_left, geometry.ticks_per_rev_left))
        phi_r = float(wheel_angle_rad(run.ticks_right, geometry.ticks_per_rev_right))
        if min(abs(run.ticks_left), abs(run.ticks_right)) < MIN_TRAVEL_TICKS or phi_l * phi_r > 0:
            raise CalibrationError(
                f"run {run.name}: the wheels did not turn in opposite directions "
                f"({run.ticks_left} and {run.ticks_right} ticks): not an in-place rotation"
            )
        arc = geometry.wheel_radius_right_m * phi_r - geometry.wheel_radius_left_m * phi_l
        values.append(abs(arc) / abs(run.true_rotation_rad))
        diffs.append(phi_r - phi_l)
    arr = np.array(values)
    return TrackCalibration(
        wheel_separation_m=float(arr.mean()),
        per_run=tuple(values),
        wheel_rotation_difference_rad=tuple(diffs),
        spread_m=float(arr.std(ddof=1)) if len(values) > 1 else 0.0,
    )


# ------------------------------------------------------------------------- 3. IMU


@dataclass(frozen=True)
class DatasheetNoise:
    """White-noise sigma of the MPU-6050 from its noise densities: sigma = density sqrt(BW).

    Attributes:
        bandwidth_hz: The noise bandwidth used [Hz].
        gyro_sigma_rad_s: sigma_w [rad/s].
        accel_sigma_m_s2: sigma_a [m/s^2].
    """

    bandwidth_hz: float
    gyro_sigma_rad_s: float
    accel_sigma_m_s2: float


def noise_sigma(density_per_rt_hz: float, bandwidth_hz: float) -> float:
    """sigma = density x sqrt(bandwidth) (white noise integrated over the noise bandwidth)."""
    if not bandwidth_hz > 0.0:
        raise ValueError(f"bandwidth must be > 0 Hz, got {bandwidth_hz}")
    return density_per_rt_hz * math.sqrt(bandwidth_hz)


def datasheet_noise(
    bandwidth_hz: float = DLPF_BANDWIDTH_HZ,
    gyro_density_deg_s_rt_hz: float = GYRO_DENSITY_DEG_S_RT_HZ,
    accel_density_ug_rt_hz: float = ACCEL_DENSITY_UG_RT_HZ,
) -> DatasheetNoise:
    """The IMU noise sigmas of Sec. 2.2.4 from the datasheet densities.

    With the 21 Hz DLPF bandwidth taken as the noise bandwidth itself (no first-order factor)
    and 1 g = 9.80665 m/s^2 for the micro-g, this gives the paper's digits:
    0.005 deg/s/sqrt(Hz) x sqrt(21) = 3.999e-4 rad/s and 400 ug/sqrt(Hz) x sqrt(21) =
    1.7976e-2 m/s^2. A one-pole noise bandwidth (pi/2 x 21 = 33.0 Hz) would give 5.012e-4 rad/s
    and 2.253e-2 m/s^2, and 1 g = 9.81 would give 1.7982e-2: neither is what the paper printed.

    Args:
        bandwidth_hz: Noise bandwidth [Hz] (default 21 Hz, as the paper).
        gyro_density_deg_s_rt_hz: Rate noise spectral density [deg/s/sqrt(Hz)].
        accel_density_ug_rt_hz: Accelerometer noise density [micro-g/sqrt(Hz)].

    Returns:
        Both sigmas in SI units.
    """
    return DatasheetNoise(
        bandwidth_hz=bandwidth_hz,
        gyro_sigma_rad_s=noise_sigma(math.radians(gyro_density_deg_s_rt_hz), bandwidth_hz),
        accel_sigma_m_s2=noise_sigma(
            accel_density_ug_rt_hz * 1e-6 * STANDARD_GRAVITY_M_S2, bandwidth_hz
        ),
    )


def rotation_matrix(rotation: Sequence[float]) -> FloatArray:
    """A row-major 3x3 rotation (sensor to base) as an array; refuses a non-rotation."""
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape != (9,):
        raise CalibrationError(f"a rotation needs 9 numbers row by row, got {len(r)}")
    m = r.reshape(3, 3)
    if not np.allclose(m @ m.T, np.eye(3), atol=1e-3) or abs(np.linalg.det(m) - 1.0) > 1e-3:
        raise CalibrationError(
            f"not a rotation (orthonormal, determinant +1): {[float(x) for x in r]}"
        )
    return m


@dataclass(frozen=True)
class ImuProfile:
    """The static IMU profile: what SET_IMU_CALIBRATION needs, and the measured noise.

    Attributes:
        rotation: Sensor to base frame, row-major (identity unless given).
        gyro_bias_rad_s: Mean rate at rest in the base frame (R times the sensor mean) [rad/s].
        accel_scale: 9.81 / |mean a| (the paper: 9.81 / 9.299 = 1.0549, quoted as x1.054).
        gravity_measured_m_s2: |mean a| at rest [m/s^2].
        gravity_base_m_s2: R times the mean specific force; REP-103 wants (0, 0, +g).
        gyro_sigma_rad_s: Sample standard deviation of each gyro axis at rest [rad/s].
        accel_sigma_m_s2: Sample standard deviation of each accelerometer axis [m/s^2].
        samples: Frames averaged.
    """

    rotation: Rotation
    gyro_bias_rad_s: tuple[float, float, float]
    accel_scale: float
    gravity_measured_m_s2: float
    gravity_base_m_s2: tuple[float, float, float]
    gyro_sigma_rad_s: tuple[float, float, float]
    accel_sigma_m_s2: tuple[float, float, float]
    samples: int

    @property
    def gravity_on_z(self) -> bool:
        """Whether gravity reads along +z of the base frame (within about 25 degrees)."""
        return self.gravity_base_m_s2[2] > 0.9 * self.gravity_measured_m_s2


def _v3(v: FloatArray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _rotation_tuple(m: FloatArray) -> Rotation:
    f = [float(x) for x in m.reshape(9)]
    return (f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7], f[8])


def imu_profile(
    gyro_rad_s: FloatArray, accel_m_s2: FloatArray, rotation: Sequence[float] = IDENTITY
) -> ImuProfile:
    """Gyro bias and gravity scale from samples taken with the robot at rest (Eq. 7-8).

    At rest omega_true = 0 and a_true = (0, 0, g), so by Eq. 7-8 the mean rate is the bias
    b_w and the mean specific force has the length the sensor reads for g. The firmware applies
    omega = R omega_s - b and a = s R a_s, hence b = R mean(omega_s) and
    s = 9.81 / |mean(a_s)| (a rotation keeps lengths).

    Args:
        gyro_rad_s: Sensor-frame rates at rest, shape (n, 3) [rad/s]; NaN rows are skipped.
        accel_m_s2: Sensor-frame specific force at rest, shape (n, 3) [m/s^2].
        rotation: Sensor to base frame, row-major.

    Returns:
        The profile.

    Raises:
        CalibrationError: Too few samples, no gravity, or a bias the firmware would refuse.
    """
    r = rotation_matrix(rotation)
    g = np.asarray(gyro_rad_s, dtype=np.float64)
    a = np.asarray(accel_m_s2, dtype=np.float64)
    ok = np.all(np.isfinite(g), axis=1) & np.all(np.isfinite(a), axis=1)
    g, a = g[ok], a[ok]
    if len(g) < 20:
        raise CalibrationError(
            f"only {len(g)} IMU samples at rest: record at least 20 frames (1 s) standing still"
        )
    g_mean = g.mean(axis=0)
    a_mean = a.mean(axis=0)
    length = float(np.linalg.norm(a_mean))
    if length < 0.5 * GRAVITY_M_S2 or length > 2.0 * GRAVITY_M_S2:
        raise CalibrationError(
            f"the accelerometer reads {length:.3f} m/s^2 at rest: not gravity (is the IMU wired?)"
        )
    bias = r @ g_mean
    if float(np.max(np.abs(bias))) >= MAX_GYRO_BIAS_RAD_S:
        raise CalibrationError(
            f"gyro bias {_v3(bias)} rad/s: {MAX_GYRO_BIAS_RAD_S} or more is refused by the "
            "firmware (was the robot still?)"
        )
    return ImuProfile(
        rotation=_rotation_tuple(r),
        gyro_bias_rad_s=_v3(bias),
        accel_scale=GRAVITY_M_S2 / length,
        gravity_measured_m_s2=length,
        gravity_base_m_s2=_v3(r @ a_mean),
        gyro_sigma_rad_s=_v3(g.std(axis=0, ddof=1)),
        accel_sigma_m_s2=_v3(a.std(axis=0, ddof=1)),
        samples=len(g),
    )


@dataclass(frozen=True)
class YawAudit:
    """REP-103 audit of the gyro z axis against the wheel odometry's yaw rate.

    Attributes:
        correlation: Pearson correlation of gyro z with the odometry yaw rate.
        slope: Least-squares gyro z / odometry yaw rate (about 1 for a good IMU and B).
        samples: Frames used.
    """

    correlation: float
    slope: float
    samples: int

    @property
    def ok(self) -> bool:
        """A counter-clockwise turn reads positive on both: the correlation is positive."""
        return self.correlation > 0.0


def odometry_yaw_rate(run: RunData, geometry: RobotGeometry) -> FloatArray:
    """Per-frame yaw rate of the wheel odometry, (r_R dphi_R - r_L dphi_L) / (B dt) (Eq. 3).

    Element k covers the interval ending at frame k; element 0 is 0.
    """
    if run.frames < 2:
        return np.zeros(run.frames)
    dt = np.diff(run.t_s)
    dt[dt <= 0.0] = np.nan
    dl = wheel_angle_rad(np.diff(run.enc_left), geometry.ticks_per_rev_left)
    dr = wheel_angle_rad(np.diff(run.enc_right), geometry.ticks_per_rev_right)
    w = (
        geometry.wheel_radius_right_m * dr - geometry.wheel_radius_left_m * dl
    ) / geometry.wheel_separation_m
    return np.concatenate(([0.0], w / dt))


def yaw_sign_audit(gyro_z_rad_s: FloatArray, odometry_w_rad_s: FloatArray) -> YawAudit:
    """The sign of the correlation of the gyro's yaw rate with the odometry's (REP-103).

    REP-103 puts z up, so a counter-clockwise turn seen from above must read a positive gyro z,
    as it gives a positive odometry yaw rate (Eq. 3). A negative correlation means the IMU's
    z axis points down in the base frame (or the encoders are swapped).

    Args:
        gyro_z_rad_s: Base-frame gyro z per frame, bias removed [rad/s]; NaN is skipped.
        odometry_w_rad_s: Odometry yaw rate per frame [rad/s].

    Returns:
        The audit.

    Raises:
        CalibrationError: The robot did not turn (no yaw rate to compare with).
    """
    gz = np.asarray(gyro_z_rad_s, dtype=np.float64)
    w = np.asarray(odometry_w_rad_s, dtype=np.float64)
    ok = np.isfinite(gz) & np.isfinite(w)
    gz, w = gz[ok], w[ok]
    if len(w) < 10 or float(np.max(np.abs(w), initial=0.0)) < 0.05:
        raise CalibrationError(
            "the robot did not turn: the yaw-sign audit needs a rotation run (wheels turning)"
        )
    if float(np.std(gz)) == 0.0 or float(np.std(w)) == 0.0:
        raise CalibrationError("the gyro or the odometry yaw rate is constant: nothing to audit")
    corr = float(np.corrcoef(gz, w)[0, 1])
    slope = float(np.dot(gz, w) / np.dot(w, w))
    return YawAudit(correlation=corr, slope=slope, samples=len(w))


# ------------------------------------------------------------------------- 4. deadband


@dataclass(frozen=True)
class Bracket:
    """The breakaway duty lies in (lo, hi]; hi is inf when the wheel never moved."""

    lo: float
    hi: float

    @property
    def width(self) -> float:
        return self.hi - self.lo

    @property
    def mid(self) -> float:
        return 0.5 * (self.lo + self.hi)


def breakaway_bracket(
    duty: Sequence[float] | FloatArray,
    counts: Sequence[int] | IntArray,
    persist_frames: int = 3,
) -> Bracket:
    """Where one wheel breaks away during one duty ramp of one sign.

    ``duty[k]`` is written after frame k and acts until frame k + 1, so a count change first
    seen at frame m was caused by ``duty[m - 1]``. The wheel *moved* at the first frame m
    whose count differs from the count at the ramp's start in the ramp's direction and keeps
    differing for ``persist_frames`` frames (a one-tick jitter that returns is not motion).
    The breakaway duty is then above the last lower duty level held before ``duty[m - 1]``
    and at most ``|duty[m - 1]|``. On a staircase held long enough for one tick at any excess
    torque, that bracket is one step wide; on a continuous ramp the response lag biases it up.

    Args:
        duty: Signed duty of this wheel per frame of the ramp (one sign, |duty| rising).
        counts: The wheel's cumulative counts per frame, one frame longer than ``duty`` or as
            long (the frame after the last duty, when present, shows that duty's effect).
        persist_frames: N, frames the change must persist.

    Returns:
        The bracket; ``hi`` is inf and ``lo`` the largest duty held when it never moved.

    Raises:
        ValueError: Empty ramp, mixed signs, or counts shorter than the duties.
    """
    d = np.asarray(duty, dtype=np.float64)
    c = np.asarray(counts, dtype=np.int64)
    if len(d) == 0:
        raise ValueError("empty ramp")
    if len(c) < len(d):
        raise ValueError("need a count for every frame of the ramp")
    sign = float(np.sign(d[np.argmax(np.abs(d))]))
    if sign == 0.0 or np.any(d * sign < 0.0):
        raise ValueError("a ramp has one sign of duty")
    mag = np.abs(d)
    moved = sign * (c - c[0]) >= 1
    n = len(c)
    last = min(n, len(d) + 1)  # counts that can show an effect of this ramp's duties
    for m in range(1, last):
        end = min(m + persist_frames, last)
        if end - m < persist_frames:
            break  # too few frames left to see a change persist
        if np.all(moved[m:end]):
            hi = float(mag[m - 1])
            lower = mag[: m - 1][mag[: m - 1] < hi]
            lo = float(lower.max()) if len(lower) else 0.0
            return Bracket(lo, hi)
    return Bracket(float(mag.max()), math.inf)


def combine_brackets(brackets: Sequence[Bracket]) -> Bracket:
    """The intersection of the ramps' brackets, or the narrowest one if they disagree."""
    if not brackets:
        raise ValueError("no brackets")
    lo = max(b.lo for b in brackets)
    hi = min(b.hi for b in brackets)
    if lo < hi:
        return Bracket(lo, hi)
    return min(brackets, key=lambda b: b.width)


@dataclass(frozen=True)
class Ramp:
    """One ramp of one wheel in one direction: frames [start, stop) of a run."""

    side: Literal["left", "right"]
    direction: Literal["forward", "reverse"]
    start: int
    stop: int


def find_ramps(run: RunData) -> list[Ramp]:
    """Blocks of frames in which exactly one wheel has a nonzero duty of one sign."""
    out: list[Ramp] = []
    dl = np.nan_to_num(run.duty_left)
    dr = np.nan_to_num(run.duty_right)
    key: list[tuple[str, str] | None] = []
    for a, b in zip(dl, dr, strict=True):
        if a != 0.0 and b == 0.0:
            key.append(("left", "forward" if a > 0 else "reverse"))
        elif b != 0.0 and a == 0.0:
            key.append(("right", "forward" if b > 0 else "reverse"))
        else:
            key.append(None)
    k = 0
    while k < len(key):
        kk = key[k]
        if kk is None:
            k += 1
            continue
        j = k
        while j < len(key) and key[j] == kk:
            j += 1
        side: Literal["left", "right"] = "left" if kk[0] == "left" else "right"
        direction: Literal["forward", "reverse"] = "forward" if kk[1] == "forward" else "reverse"
        out.append(Ramp(side, direction, k, j))
        k = j
    return out


@dataclass(frozen=True)
class DeadbandCalibration:
    """Breakaway duty per wheel and direction: the midpoints of the combined brackets."""

    forward_left: float
    reverse_left: float
    forward_right: float
    reverse_right: float
    brackets: Mapping[str, Bracket]


def calibrate_deadband(runs: Sequence[RunData], persist_frames: int = 3) -> DeadbandCalibration:
    """The PWM deadband of each wheel and direction from raw duty ramps (Sec. 2.2.3).

    Every ramp (:func:`find_ramps`) gives a bracket (:func:`breakaway_bracket`); the brackets
    of one wheel and direction are intersected (:func:`combine_brackets`), so a coarse ramp
    followed by a fine one narrows the answer to the fine step. The result is the midpoint.

    Args:
        runs: Runs with raw duties (commands.csv) and counts.
        persist_frames: N of :func:`breakaway_bracket`.

    Returns:
        The four breakaway duties.

    Raises:
        CalibrationError: A wheel/direction without a ramp, or one that never moved.
    """
    found: dict[str, list[Bracket]] = {}
    for run in runs:
        for ramp in find_ramps(run):
            counts = run.enc_left if ramp.side == "left" else run.enc_right
            duty = run.duty_left if ramp.side == "left" else run.duty_right
            stop = min(ramp.stop + 1, run.frames)
            b = breakaway_bracket(
                duty[ramp.start : ramp.stop], counts[ramp.start : stop], persist_frames
            )
            found.setdefault(f"{ramp.direction}_{ramp.side}", []).append(b)
    out: dict[str, Bracket] = {}
    for key in ("forward_left", "reverse_left", "forward_right", "reverse_right"):
        direction, side = key.split("_")
        if key not in found:
            raise CalibrationError(f"no {side} {direction} duty ramp in the runs")
        b = combine_brackets(found[key])
        if math.isinf(b.hi):
            raise CalibrationError(
                f"the {side} wheel never moved {direction} up to duty {b.lo:.3f}: is the motor "
                "rail on? (raise --max-duty)"
            )
        out[key] = b
    return DeadbandCalibration(
        forward_left=out["forward_left"].mid,
        reverse_left=out["reverse_left"].mid,
        forward_right=out["forward_right"].mid,
        reverse_right=out["reverse_right"].mid,
        brackets=out,
    )


@dataclass(frozen=True)
class Characterisation:
    """The response to a duty step on both wheels, then a short brake.

    Attributes:
        duty: The step's duty (signed).
        top_wheel_speed_left_rad_s: Mean left wheel speed once settled [rad/s].
        top_wheel_speed_right_rad_s: The same for the right wheel.
        top_speed_m_s: Mean robot speed once settled, (r_L w_L + r_R w_R) / 2 [m/s] (Eq. 2).
        time_to_90_s: From the step to the chassis reaching 90 % of the top speed, by the
            accelerometer [s] (NaN without IMU samples).
        stopping_distance_m: Travel of the chassis from the brake to standstill, by the
            accelerometer [m] (NaN without IMU samples).
        stopping_time_s: From the brake to standstill by the accelerometer [s] (NaN without).
        wheel_time_to_90_s: The same as ``time_to_90_s`` by the encoders [s]; shorter when
            the wheels spin up faster than the chassis, as at a full-duty launch.
        wheel_stopping_distance_m: The same by the encoders [m]; shorter when the braked
            wheels skid, as a short brake from full speed does.
        wheel_stopping_time_s: From the brake to the last count change [s].
    """

    duty: float
    top_wheel_speed_left_rad_s: float
    top_wheel_speed_right_rad_s: float
    top_speed_m_s: float
    time_to_90_s: float
    stopping_distance_m: float
    stopping_time_s: float
    wheel_time_to_90_s: float
    wheel_stopping_distance_m: float
    wheel_stopping_time_s: float


def _crossing(t: FloatArray, v: FloatArray, target: float) -> float:
    """The time a piecewise-linear v(t) first reaches ``target`` (NaN if it never does)."""
    above = np.flatnonzero(v >= target)
    if len(above) == 0:
        return math.nan
    k = int(above[0])
    if k == 0:
        return float(t[0])
    v0, v1 = float(v[k - 1]), float(v[k])
    return float(t[k - 1] + (target - v0) / (v1 - v0) * (t[k] - t[k - 1]))


def braking_distance(
    v0_m_s: float, accel_m_s2: FloatArray, dt_s: FloatArray
) -> tuple[float, float]:
    """Distance and time to standstill from speed v0, integrating interval-mean accelerations.

    Each element of ``accel_m_s2`` is the mean longitudinal acceleration over an interval of
    ``dt_s`` (the MCU averages its IMU samples over the telemetry period), so the speed at the
    interval's end is exact: v' = v + a dt. Within an interval the acceleration is taken as
    constant: s += v dt + a dt^2 / 2; in the interval where the speed reaches zero the robot
    stops after tau = -v / a and s += v tau / 2.

    Args:
        v0_m_s: Speed at the brake [m/s] (either sign).
        accel_m_s2: Interval-mean acceleration along the direction of travel's axis [m/s^2].
        dt_s: Interval lengths [s].

    Returns:
        (distance [m], time [s]), both NaN when the speed never reaches zero.
    """
    sign = 1.0 if v0_m_s >= 0 else -1.0
    v = abs(v0_m_s)
    s = t = 0.0
    for a_raw, dt in zip(accel_m_s2, dt_s, strict=True):
        a = sign * float(a_raw)
        if not math.isfinite(a) or dt <= 0.0:
            return math.nan, math.nan
        if v + a * dt <= 0.0:
            tau = v / -a if a < 0.0 else 0.0
            return s + 0.5 * v * tau, t + tau
        s += v * dt + 0.5 * a * dt * dt
        t += dt
        v += a * dt
    return math.nan, math.nan


def characterise(
    run: RunData,
    geometry: RobotGeometry,
    rotation: Sequence[float] = IDENTITY,
    settled_fraction: float = 0.5,
) -> Characterisation:
    """Top speed, time to 90 % and stopping distance of a duty step (the step response).

    The step starts at the first frame with the same nonzero duty on both wheels (its duty
    acts from that frame's time t_a) and ends at the next frame with both duties zero (the
    short brake acts from t_b). Wheel speeds are count differences over frame intervals; the
    top speed is the mean over the last ``settled_fraction`` of the step; the time to 90 % is
    where the robot speed, placed at interval midpoints and interpolated linearly from
    (t_a, 0), first reaches 0.9 of the top speed. Wheels slip at a hard launch and skid under
    a short brake, so the chassis is followed by the accelerometer as well (x bias taken
    before the step): its interval means integrate exactly to the chassis speed at the frame
    times, which gives the chassis' time to 90 % and, from the top speed at the brake, its
    stopping distance (:func:`braking_distance`); the encoders' own figures are reported
    beside them. The run must end at rest. Record it at a high telemetry rate (the recorder
    uses 200 Hz): launch and stop last a few tens of milliseconds.

    Args:
        run: A run with raw duties (commands.csv).
        geometry: Radii and resolutions per wheel.
        rotation: The IMU's sensor-to-base rotation, row-major.
        settled_fraction: The part of the step taken as settled.

    Returns:
        The characterisation.

    Raises:
        CalibrationError: No step, no brake after it, or a robot that did not move.
    """
    dl = np.nan_to_num(run.duty_left)
    dr = np.nan_to_num(run.duty_right)
    step = np.flatnonzero((dl != 0.0) & (dl == dr))
    if len(step) == 0:
        raise CalibrationError(f"run {run.name}: no duty step on both wheels")
    a = int(step[0])
    after = np.flatnonzero((dl[a:] == 0.0) & (dr[a:] == 0.0))
    if len(after) == 0:
        raise CalibrationError(f"run {run.name}: the step never ends in a brake")
    b = a + int(after[0])
    if b - a < 4:
        raise CalibrationError(f"run {run.name}: the step lasts only {b - a} frames")
    t = run.t_s
    g = geometry
    phi_l = wheel_angle_rad(run.enc_left - run.enc_left[0], g.ticks_per_rev_left)
    phi_r = wheel_angle_rad(run.enc_right - run.enc_right[0], g.ticks_per_rev_right)
    s = 0.5 * (g.wheel_radius_left_m * phi_l + g.wheel_radius_right_m * phi_r)  # travel [m]
    c = int(np.searchsorted(t, t[a] + (1.0 - settled_fraction) * (t[b] - t[a])))
    c = min(max(c, a + 1), b - 1)
    span = t[b] - t[c]
    w_l = float((phi_l[b] - phi_l[c]) / span)
    w_r = float((phi_r[b] - phi_r[c]) / span)
    v_top = float((s[b] - s[c]) / span)
    if abs(v_top) < 1e-3:
        raise CalibrationError(
            f"run {run.name}: the robot did not move at duty {dl[a]:.2f} (motor rail off?)"
        )
    # wheel speed per interval, at the interval midpoints, starting from rest at t_a
    mids = np.concatenate(([t[a]], 0.5 * (t[a:b] + t[a + 1 : b + 1])))
    v = np.concatenate(([0.0], np.diff(s[a : b + 1]) / np.diff(t[a : b + 1])))
    wheel_t90 = _crossing(mids, np.abs(v), 0.9 * abs(v_top))
    if math.isnan(wheel_t90):
        raise CalibrationError(f"run {run.name}: never reached 90 % of the top speed")
    moving = np.flatnonzero((np.diff(run.enc_left[b:]) != 0) | (np.diff(run.enc_right[b:]) != 0))
    last = b + int(moving[-1]) + 1 if len(moving) else b
    if len(moving) and last >= run.frames - 1:
        raise CalibrationError(f"run {run.name}: the robot was still moving when the run ended")
    ax = (run.accel_m_s2 @ rotation_matrix(rotation).T)[:, 0]
    rest = ax[1:a]
    t90 = stop_s = stop_t = math.nan
    if np.isfinite(rest).sum() >= 5 and np.all(np.isfinite(ax[a + 1 :])):
        bias = float(np.nanmean(rest))
        # chassis speed at the frame times from rest at t_a: exact for interval-mean samples
        v_imu = np.concatenate(
            ([0.0], np.cumsum((ax[a + 1 : b + 1] - bias) * np.diff(t[a : b + 1])))
        )
        t90 = _crossing(t[a : b + 1], np.sign(v_top) * v_imu, 0.9 * abs(v_top))
        stop_s, stop_t = braking_distance(v_top, ax[b + 1 :] - bias, np.diff(t[b:]))
    return Characterisation(
        duty=float(dl[a]),
        top_wheel_speed_left_rad_s=w_l,
        top_wheel_speed_right_rad_s=w_r,
        top_speed_m_s=v_top,
        time_to_90_s=float(t90 - t[a]),
        stopping_distance_m=stop_s,
        stopping_time_s=stop_t,
        wheel_time_to_90_s=float(wheel_t90 - t[a]),
        wheel_stopping_distance_m=float(abs(s[last] - s[b])),
        wheel_stopping_time_s=float(t[last] - t[b]),
    )


# ------------------------------------------------------------------------- 5. twin fit


@dataclass(frozen=True)
class FitSegment:
    """One run on common frame times: wheel angles, gyro and the reference trajectory.

    The reference is anchored like the paper's trajectories: its pose at the first frame is
    the origin (0, 0, 0), the frame the dead reckoning starts in.

    Attributes:
        name: The run, for messages.
        t_s: Frame times [s].
        phi_left_rad: Left wheel angle since the first frame [rad].
        phi_right_rad: Right wheel angle [rad].
        gyro_z_rad_s: Base-frame yaw rate over the interval ending at each frame, bias
            removed [rad/s] (element 0 unused).
        ref_x_m: Reference x in the anchored frame [m].
        ref_y_m: Reference y [m].
        ref_yaw_rad: Reference heading, unwrapped [rad].
    """

    name: str
    t_s: FloatArray
    phi_left_rad: FloatArray
    phi_right_rad: FloatArray
    gyro_z_rad_s: FloatArray
    ref_x_m: FloatArray
    ref_y_m: FloatArray
    ref_yaw_rad: FloatArray


@dataclass(frozen=True)
class Reference:
    """A reference trajectory (ground truth of the twin, or a measured path)."""

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray


def fit_segment(
    run: RunData,
    reference: Reference,
    ticks_per_rev: tuple[float, float],
    rotation: Sequence[float] = IDENTITY,
) -> FitSegment:
    """Put a run and its reference on the run's frame times, anchored at the first frame.

    The reference is interpolated at the frames inside its time span (its clock must be the
    MCU's, as the twin's ground truth is). The gyro bias is the mean yaw rate over the frames
    before the wheels first move (:attr:`RunData.still_frames`, the host's start-up
    standstill); fewer than 5 such frames: no bias is removed.

    Raises:
        CalibrationError: Fewer than 10 frames overlap, or the IMU samples are missing.
    """
    t = run.t_s
    inside = (t >= reference.t_s[0]) & (t <= reference.t_s[-1])
    idx = np.flatnonzero(inside)
    if len(idx) < 10:
        raise CalibrationError(
            f"run {run.name}: only {len(idx)} frames inside the reference's time span "
            f"{reference.t_s[0]:.2f}-{reference.t_s[-1]:.2f} s (is it on the MCU clock?)"
        )
    r = rotation_matrix(rotation)
    gz_all = (run.gyro_rad_s @ r.T)[:, 2]
    if np.isnan(gz_all[idx[1:]]).any():
        raise CalibrationError(f"run {run.name}: IMU samples are missing in the fitted span")
    still = gz_all[1 : run.still_frames]
    bias = float(np.nanmean(still)) if np.isfinite(still).sum() >= 5 else 0.0
    t_sel = t[idx]
    yaw_u = np.unwrap(reference.yaw_rad)
    x = np.interp(t_sel, reference.t_s, reference.x_m)
    y = np.interp(t_sel, reference.t_s, reference.y_m)
    yaw = np.interp(t_sel, reference.t_s, yaw_u)
    c, s = math.cos(yaw[0]), math.sin(yaw[0])
    dx, dy = x - x[0], y - y[0]
    return FitSegment(
        name=run.name,
        t_s=t_sel,
        phi_left_rad=wheel_angle_rad(run.enc_left[idx] - run.enc_left[idx[0]], ticks_per_rev[0]),
        phi_right_rad=wheel_angle_rad(run.enc_right[idx] - run.enc_right[idx[0]], ticks_per_rev[1]),
        gyro_z_rad_s=gz_all[idx] - bias,
        ref_x_m=c * dx + s * dy,
        ref_y_m=-s * dx + c * dy,
        ref_yaw_rad=yaw - yaw[0],
    )


Heading = Literal["wheel", "gyro"]


@dataclass(frozen=True)
class DeadReckoning:
    """Poses of a dead-reckoned trajectory and both heading estimates, per frame."""

    x_m: FloatArray
    y_m: FloatArray
    yaw_wheel_rad: FloatArray
    yaw_gyro_rad: FloatArray


def dead_reckon(
    seg: FitSegment,
    wheel_radius_m: float,
    wheel_separation_m: float,
    yaw_scale: float,
    heading: Heading = "wheel",
) -> DeadReckoning:
    """Integrate a segment with candidate parameters (Eq. 1-3, 9).

    Per frame interval: d_s = r (dphi_L + dphi_R) / 2, the wheel heading change
    r (dphi_R - dphi_L) / B and the gyro heading change yaw_scale x omega_g x dt. The position
    follows the midpoint rule x += d_s cos(theta + d_theta / 2) with theta from the ``heading``
    source; both headings are returned.
    """
    dphi_l = np.diff(seg.phi_left_rad)
    dphi_r = np.diff(seg.phi_right_rad)
    ds = wheel_radius_m * 0.5 * (dphi_l + dphi_r)
    dth_w = wheel_radius_m * (dphi_r - dphi_l) / wheel_separation_m
    dth_g = yaw_scale * seg.gyro_z_rad_s[1:] * np.diff(seg.t_s)
    yaw_w = np.concatenate(([0.0], np.cumsum(dth_w)))
    yaw_g = np.concatenate(([0.0], np.cumsum(dth_g)))
    yaw = yaw_w if heading == "wheel" else yaw_g
    mid = yaw[:-1] + 0.5 * np.diff(yaw)
    x = np.concatenate(([0.0], np.cumsum(ds * np.cos(mid))))
    y = np.concatenate(([0.0], np.cumsum(ds * np.sin(mid))))
    return DeadReckoning(x, y, yaw_w, yaw_g)


@dataclass(frozen=True)
class TwinFit:
    """Effective parameters of the twin's odometry (the paper's V16/V17 values).

    Attributes:
        wheel_radius_m: Effective r (for the given ticks per revolution) [m].
        wheel_separation_m: Effective B [m].
        yaw_scale: Factor on the gyro's yaw rate (the paper: 0.6953).
        sigma: One-sigma uncertainty of (r, B, yaw_scale) from the Jacobian.
        rms_position_m: RMS position residual (Eq. 13 form) with the fitted values [m].
        rms_yaw_wheel_rad: RMS wheel-heading residual [rad].
        rms_yaw_gyro_rad: RMS gyro-heading residual [rad].
        initial_rms_position_m: RMS position residual with the starting values [m].
        samples: Frames fitted over all runs.
        heading: Which heading the positions were integrated with.
    """

    wheel_radius_m: float
    wheel_separation_m: float
    yaw_scale: float
    sigma: tuple[float, float, float]
    rms_position_m: float
    rms_yaw_wheel_rad: float
    rms_yaw_gyro_rad: float
    initial_rms_position_m: float
    samples: int
    heading: Heading


def _residuals(
    segments: Sequence[FitSegment],
    r: float,
    b: float,
    k: float,
    heading: Heading,
    yaw_weight_m_per_rad: float,
) -> tuple[FloatArray, float, float, float]:
    parts: list[FloatArray] = []
    pos: list[FloatArray] = []
    yw: list[FloatArray] = []
    yg: list[FloatArray] = []
    for seg in segments:
        dr = dead_reckon(seg, r, b, k, heading)
        ex, ey = dr.x_m - seg.ref_x_m, dr.y_m - seg.ref_y_m
        ew, eg = dr.yaw_wheel_rad - seg.ref_yaw_rad, dr.yaw_gyro_rad - seg.ref_yaw_rad
        parts += [ex, ey, yaw_weight_m_per_rad * ew, yaw_weight_m_per_rad * eg]
        pos.append(np.hypot(ex, ey))
        yw.append(ew)
        yg.append(eg)

    def rms(v: list[FloatArray]) -> float:
        return float(np.sqrt(np.mean(np.concatenate(v) ** 2)))

    return np.concatenate(parts), rms(pos), rms(yw), rms(yg)


def fit_twin(
    segments: Sequence[FitSegment],
    wheel_radius_m: float = 0.033,
    wheel_separation_m: float = 0.198,
    yaw_scale: float = 1.0,
    *,
    heading: Heading = "wheel",
    yaw_weight_m_per_rad: float = 0.5,
) -> TwinFit:
    """Effective r, B and IMU yaw scale by least squares against reference trajectories.

    The model (see :func:`dead_reckon`): the wheels give the travel r (dphi_L + dphi_R) / 2
    and a heading r (dphi_R - dphi_L) / B; the gyro gives a second heading yaw_scale x the
    integrated bias-free yaw rate. The residuals per frame are the position error of the
    dead-reckoned track (Eq. 13's terms) and both heading errors (Eq. 14's terms) weighted by
    ``yaw_weight_m_per_rad``; the travel fixes r, the wheel heading then B, the gyro heading
    the yaw scale. scipy's ``least_squares`` (trust-region reflective, bounds at 1/2 and 2 of
    the start values, 0.1-10 for the yaw scale) minimises them over all runs together.

    Args:
        segments: The runs with their references (:func:`fit_segment`).
        wheel_radius_m: Starting r [m].
        wheel_separation_m: Starting B [m].
        yaw_scale: Starting yaw scale.
        heading: Heading the positions are integrated with: the wheels' (joint-state
            odometry, as the paper's twin) or the gyro's.
        yaw_weight_m_per_rad: How many metres of position residual one radian of heading
            residual counts as.

    Returns:
        The fitted parameters and residuals.

    Raises:
        CalibrationError: No data, or a trajectory that does not determine the parameters.
    """
    if not segments:
        raise CalibrationError("no runs to fit")
    r0, b0 = wheel_radius_m, wheel_separation_m
    turned = max(float(np.ptp(s.ref_yaw_rad)) for s in segments)
    travelled = max(float(np.ptp(s.phi_left_rad) + np.ptp(s.phi_right_rad)) for s in segments)
    if travelled < 1.0:
        raise CalibrationError("the robot did not move in the runs: nothing to fit")
    if turned < 0.5:
        raise CalibrationError(
            "the reference turns by less than 0.5 rad: B and the yaw scale need turning runs"
        )

    def fun(p: FloatArray) -> FloatArray:
        return _residuals(segments, p[0] * r0, p[1] * b0, p[2], heading, yaw_weight_m_per_rad)[0]

    p0 = np.array([1.0, 1.0, yaw_scale])
    sol = least_squares(
        fun, p0, bounds=([0.5, 0.5, 0.1], [2.0, 2.0, 10.0]), x_scale=[1.0, 1.0, 1.0], method="trf"
    )
    p = sol.x
    res, rms_p, rms_w, rms_g = _residuals(
        segments, p[0] * r0, p[1] * b0, p[2], heading, yaw_weight_m_per_rad
    )
    _, rms_p0, _, _ = _residuals(segments, r0, b0, yaw_scale, heading, yaw_weight_m_per_rad)
    jac = np.asarray(sol.jac, dtype=np.float64)
    dof = max(1, len(res) - 3)
    try:
        cov = np.linalg.inv(jac.T @ jac) * float(res @ res) / dof
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        sd = np.full(3, np.nan)
    return TwinFit(
        wheel_radius_m=float(p[0] * r0),
        wheel_separation_m=float(p[1] * b0),
        yaw_scale=float(p[2]),
        sigma=(float(sd[0] * r0), float(sd[1] * b0), float(sd[2])),
        rms_position_m=rms_p,
        rms_yaw_wheel_rad=rms_w,
        rms_yaw_gyro_rad=rms_g,
        initial_rms_position_m=rms_p0,
        samples=sum(len(s.t_s) for s in segments),
        heading=heading,
    )
