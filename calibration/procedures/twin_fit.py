"""Twin fit: effective wheel radius, wheel separation and IMU yaw scale (V16/V17)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import least_squares

from jackson.calibration.procedures.base import (
    CalibrationError,
    FloatArray,
    RunData,
    wheel_angle_rad,
)
from jackson.calibration.procedures.imu import rotation_matrix
from jackson.common.robot import WHEEL_RADIUS_M, WHEEL_SEPARATION_M
from jackson.host.config import IDENTITY


@dataclass(frozen=True)
class FitSegment:
    """One run on common frame times: wheel angles, gyro and the reference trajectory.

    The reference is anchored like the paper's trajectories: its pose at the first frame is
    the origin (0, 0, 0), the frame the dead reckoning starts in.

    Attributes
    ----------
    name : str
        The run, for messages.
    t_s : numpy.ndarray
        Frame times [s].
    phi_left_rad : numpy.ndarray
        Left wheel angle since the first frame [rad].
    phi_right_rad : numpy.ndarray
        Right wheel angle [rad].
    gyro_z_rad_s : numpy.ndarray
        Base-frame yaw rate over the interval ending at each frame, bias
        removed [rad/s] (element 0 unused).
    ref_x_m : numpy.ndarray
        Reference x in the anchored frame [m].
    ref_y_m : numpy.ndarray
        Reference y [m].
    ref_yaw_rad : numpy.ndarray
        Reference heading, unwrapped [rad].
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
    standstill); fewer than 5 such frames: no bias is removed. Frames without an IMU sample
    during that standstill (while a new IMU calibration takes over on the device) move the
    segment's first frame past them.

    Raises
    ------
    CalibrationError
        Fewer than 10 frames overlap, or IMU samples are missing once the robot moves.
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
    gaps = np.flatnonzero(np.isnan(gz_all[idx[1:]]))
    if len(gaps):
        # a gap while the robot still stands at the start (a calibration taking over) only
        # moves the fit's first frame past it; a gap once it has moved is missing data
        first = int(gaps[-1]) + 1
        if idx[first] > run.still_frames or len(idx) - first < 10:
            t_gap = t[idx[int(gaps[0]) + 1]]
            raise CalibrationError(
                f"run {run.name}: IMU samples are missing in the fitted span (at {t_gap:.2f} s)"
            )
        idx = idx[first:]
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

    Attributes
    ----------
    wheel_radius_m : float
        Effective r (for the given ticks per revolution) [m].
    wheel_separation_m : float
        Effective B [m].
    yaw_scale : float
        Factor on the gyro's yaw rate (the paper: 0.6953).
    sigma : tuple of float
        One-sigma uncertainty of (r, B, yaw_scale) from the Jacobian.
    rms_position_m : float
        RMS position residual (Eq. 13 form) with the fitted values [m].
    rms_yaw_wheel_rad : float
        RMS wheel-heading residual [rad].
    rms_yaw_gyro_rad : float
        RMS gyro-heading residual [rad].
    initial_rms_position_m : float
        RMS position residual with the starting values [m].
    samples : int
        Frames fitted over all runs.
    heading : Heading
        Which heading the positions were integrated with.
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
    wheel_radius_m: float = WHEEL_RADIUS_M,
    wheel_separation_m: float = WHEEL_SEPARATION_M,
    yaw_scale: float = 1.0,
    *,
    heading: Heading = "wheel",
    yaw_weight_m_per_rad: float = 0.5,
    fit_radius: bool = True,
) -> TwinFit:
    """Effective r, B and IMU yaw scale by least squares against reference trajectories.

    The model (see :func:`dead_reckon`): the wheels give the travel r (dphi_L + dphi_R) / 2
    and a heading r (dphi_R - dphi_L) / B; the gyro gives a second heading yaw_scale x the
    integrated bias-free yaw rate. The residuals per frame are the position error of the
    dead-reckoned track (Eq. 13's terms) and both heading errors (Eq. 14's terms) weighted by
    ``yaw_weight_m_per_rad``; the travel fixes r, the wheel heading then B, the gyro heading
    the yaw scale. scipy's ``least_squares`` (trust-region reflective, bounds at 1/2 and 2 of
    the start values, 0.1-10 for the yaw scale) minimises them over all runs together.

    Parameters
    ----------
    segments : sequence of FitSegment
        The runs with their references (:func:`fit_segment`).
    wheel_radius_m : float
        Starting r [m].
    wheel_separation_m : float
        Starting B [m].
    yaw_scale : float
        Starting yaw scale.
    heading : Heading
        Heading the positions are integrated with: the wheels' (joint-state
        odometry, as the paper's twin) or the gyro's.
    yaw_weight_m_per_rad : float
        How many metres of position residual one radian of heading
        residual counts as.
    fit_radius : bool
        Fit r; False holds it at ``wheel_radius_m`` (the distance per count that
        ``calibrate encoders`` measured against a tape stays as it is) and fits B and the
        yaw scale only (r's sigma is then 0).

    Returns
    -------
    TwinFit
        The fitted parameters and residuals.

    Raises
    ------
    CalibrationError
        No data, or a trajectory that does not determine the parameters.
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

    free = slice(0, 3) if fit_radius else slice(1, 3)  # the parameters fitted

    def full(q: FloatArray) -> FloatArray:
        return q if fit_radius else np.concatenate(([1.0], q))

    def fun(q: FloatArray) -> FloatArray:
        p = full(q)
        return _residuals(segments, p[0] * r0, p[1] * b0, p[2], heading, yaw_weight_m_per_rad)[0]

    lo, hi = np.array([0.5, 0.5, 0.1]), np.array([2.0, 2.0, 10.0])
    p0 = np.array([1.0, 1.0, yaw_scale])
    sol = least_squares(
        fun, p0[free], bounds=(lo[free], hi[free]), x_scale=np.ones(3)[free], method="trf"
    )
    p = full(sol.x)
    res, rms_p, rms_w, rms_g = _residuals(
        segments, p[0] * r0, p[1] * b0, p[2], heading, yaw_weight_m_per_rad
    )
    _, rms_p0, _, _ = _residuals(segments, r0, b0, yaw_scale, heading, yaw_weight_m_per_rad)
    jac = np.asarray(sol.jac, dtype=np.float64)
    dof = max(1, len(res) - jac.shape[1])
    sd = np.zeros(3)
    try:
        cov = np.linalg.inv(jac.T @ jac) * float(res @ res) / dof
        sd[free] = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        sd[free] = np.nan
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
