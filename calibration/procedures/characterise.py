"""Step characterisation: top speed, time to 90 % and stopping distance."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from jackson.calibration.procedures.base import (
    CalibrationError,
    FloatArray,
    RunData,
    wheel_angle_rad,
)
from jackson.calibration.procedures.imu import rotation_matrix
from jackson.host.config import IDENTITY
from jackson.host.estimation.odometry import RobotGeometry

MAX_BRAKE_LAG_S = 0.15  # [s] from the brake's frame to the first interval below 90 % of the top
# speed: a motor and its driver take tens of ms (the paper's transport latency about 50 ms); a
# brake that acts later was written late on the MCU's clock (a twin that went on without a host)


@dataclass(frozen=True)
class Characterisation:
    """The response to a duty step on both wheels, then a short brake.

    Attributes
    ----------
    duty : float
        The step's duty (signed).
    top_wheel_speed_left_rad_s : float
        Mean left wheel speed once settled [rad/s].
    top_wheel_speed_right_rad_s : float
        The same for the right wheel.
    top_speed_m_s : float
        Mean robot speed once settled, (r_L w_L + r_R w_R) / 2 [m/s] (Eq. 2).
    time_to_90_s : float
        From the step to the chassis reaching 90 % of the top speed, by the
        accelerometer [s] (NaN without IMU samples).
    stopping_distance_m : float
        Travel of the chassis from the brake to standstill, by the
        accelerometer [m] (NaN without IMU samples).
    stopping_time_s : float
        From the brake to standstill by the accelerometer [s] (NaN without).
    wheel_time_to_90_s : float
        The same as ``time_to_90_s`` by the encoders [s]; shorter when
        the wheels spin up faster than the chassis, as at a full-duty launch.
    wheel_stopping_distance_m : float
        The same by the encoders [m]; shorter when the braked
        wheels skid, as a short brake from full speed does.
    wheel_stopping_time_s : float
        From the brake to the last count change [s].
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

    Parameters
    ----------
    v0_m_s : float
        Speed at the brake [m/s] (either sign).
    accel_m_s2 : numpy.ndarray
        Interval-mean acceleration along the direction of travel's axis [m/s^2].
    dt_s : numpy.ndarray
        Interval lengths [s].

    Returns
    -------
    tuple of float
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

    Parameters
    ----------
    run : RunData
        A run with raw duties (commands.csv).
    geometry : RobotGeometry
        Radii and resolutions per wheel.
    rotation : sequence of float
        The IMU's sensor-to-base rotation, row-major.
    settled_fraction : float
        The part of the step taken as settled.

    Returns
    -------
    Characterisation
        The characterisation.

    Raises
    ------
    CalibrationError
        No step, no brake after it, or a robot that did not move.
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
    _check_brake_lag(run.name, t[b:], s[b:], v_top)
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


def _check_brake_lag(name: str, t: FloatArray, s: FloatArray, v_top: float) -> None:
    """Refuse a run whose brake acted more than :data:`MAX_BRAKE_LAG_S` after its frame.

    The stopping time and distance are measured from the frame the brake was written after; a
    brake that reached the motors later (on the twin: one that went on in real time while the
    host was busy) would lengthen both, so such a run is not measured.

    Parameters
    ----------
    name : str
        The run, for the message.
    t : numpy.ndarray
        Frame times from the brake's frame on [s].
    s : numpy.ndarray
        Travel at those frames [m].
    v_top : float
        The settled speed before the brake [m/s].

    Raises
    ------
    CalibrationError
        The speed stayed at 90 % of the top speed or more for longer than the limit.
    """
    v = np.abs(np.diff(s) / np.diff(t))
    slower = np.flatnonzero(v < 0.9 * abs(v_top))
    lag = float(t[int(slower[0])] - t[0]) if len(slower) else float(t[-1] - t[0])
    if lag > MAX_BRAKE_LAG_S:
        raise CalibrationError(
            f"run {name}: the brake acted {lag:.2f} s after the frame it was written after (at "
            f"most {MAX_BRAKE_LAG_S:g} s): a late motor command or a twin that went on without "
            "its host; nothing was written, run it again"
        )
