"""IMU static profile, datasheet noise and the REP-103 yaw-sign audit (Sec. 2.2.4)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from jackson.calibration.procedures.base import (
    ACCEL_DENSITY_UG_RT_HZ,
    DLPF_BANDWIDTH_HZ,
    GYRO_DENSITY_DEG_S_RT_HZ,
    STANDARD_GRAVITY_M_S2,
    CalibrationError,
    FloatArray,
    RunData,
    wheel_angle_rad,
)
from jackson.host.config import IDENTITY, MAX_GYRO_BIAS_RAD_S, Rotation
from jackson.host.estimation.odometry import RobotGeometry
from jackson.protocol.messages import GRAVITY_M_S2  # the nominal gravity of host, twin, Table 3


@dataclass(frozen=True)
class DatasheetNoise:
    """White-noise sigma of the MPU-6050 from its noise densities: sigma = density sqrt(BW).

    Attributes
    ----------
    bandwidth_hz : float
        The noise bandwidth used [Hz].
    gyro_sigma_rad_s : float
        sigma_w [rad/s].
    accel_sigma_m_s2 : float
        sigma_a [m/s^2].
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

    Parameters
    ----------
    bandwidth_hz : float
        Noise bandwidth [Hz] (default 21 Hz, as the paper).
    gyro_density_deg_s_rt_hz : float
        Rate noise spectral density [deg/s/sqrt(Hz)].
    accel_density_ug_rt_hz : float
        Accelerometer noise density [micro-g/sqrt(Hz)].

    Returns
    -------
    DatasheetNoise
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

    Attributes
    ----------
    rotation : Rotation
        Sensor to base frame, row-major (identity unless given).
    gyro_bias_rad_s : tuple of float
        Mean rate at rest in the base frame (R times the sensor mean) [rad/s].
    accel_scale : float
        9.81 / |mean a| (the paper: 9.81 / 9.299 = 1.0549, quoted as x1.054).
    gravity_measured_m_s2 : float
        |mean a| at rest [m/s^2].
    gravity_base_m_s2 : tuple of float
        R times the mean specific force; REP-103 wants (0, 0, +g).
    gyro_sigma_rad_s : tuple of float
        Sample standard deviation of each gyro axis at rest [rad/s].
    accel_sigma_m_s2 : tuple of float
        Sample standard deviation of each accelerometer axis [m/s^2].
    samples : int
        Frames averaged.
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

    Parameters
    ----------
    gyro_rad_s : numpy.ndarray
        Sensor-frame rates at rest, shape (n, 3) [rad/s]; NaN rows are skipped.
    accel_m_s2 : numpy.ndarray
        Sensor-frame specific force at rest, shape (n, 3) [m/s^2].
    rotation : sequence of float
        Sensor to base frame, row-major.

    Returns
    -------
    ImuProfile
        The profile.

    Raises
    ------
    CalibrationError
        Too few samples, no gravity, or a bias the firmware would refuse.
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

    Attributes
    ----------
    correlation : float
        Pearson correlation of gyro z with the odometry yaw rate.
    slope : float
        Least-squares gyro z / odometry yaw rate (about 1 for a good IMU and B).
    samples : int
        Frames used.
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

    Parameters
    ----------
    gyro_z_rad_s : numpy.ndarray
        Base-frame gyro z per frame, bias removed [rad/s]; NaN is skipped.
    odometry_w_rad_s : numpy.ndarray
        Odometry yaw rate per frame [rad/s].

    Returns
    -------
    YawAudit
        The audit.

    Raises
    ------
    CalibrationError
        The robot did not turn (no yaw rate to compare with).
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
