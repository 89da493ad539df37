"""The dynamic window and its velocity samples (steps 1-2 of the cycle).

Each cycle samples the velocities reachable from the current one within ``sim_time`` under the
planner's acceleration and deceleration bounds (:class:`~.kinematics.Kinematics`, ramped as the
velocity limiter ramps, :func:`jackson.common.ramp.ramp`), inside v in [min_vel_x, max_v]
(min_vel_x = 0: no
reversing outside the back-up recovery) and |w| <= max_w, with ``vx_samples`` x
``vtheta_samples`` targets (plus w = 0 when it lies inside). A target with v = 0 and
0 < |w| < min_speed_theta (DWB's minimum in-place rotation speed; REFERENCE: 0.30 rad/s)
becomes |w| = min_speed_theta.

A roll-out ramps from the current velocity towards its target as the limiter will
(:func:`velocity_profile`), so the first period of every roll-out is what the limiter lets
through.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.common.ramp import ramp
from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.core.kinematics import Kinematics

FloatArray = npt.NDArray[np.float64]


def dynamic_window(
    config: DwbConfig, kinematics: Kinematics, v_m_s: float, w_rad_s: float
) -> tuple[float, float, float, float]:
    """The dynamic window: (v_lo, v_hi, w_lo, w_hi) reachable within ``sim_time``.

    Parameters
    ----------
    config : DwbConfig
        ``sim_time_s`` and ``min_vel_x_m_s``.
    kinematics : Kinematics
        Speed and acceleration bounds; the window never leaves them.
    v_m_s, w_rad_s : float
        Current velocity [m/s], [rad/s].

    Returns
    -------
    tuple of float
        Bounds [m/s], [m/s], [rad/s], [rad/s], inside the speed limits.
    """
    c, k = config, kinematics
    t_s = c.sim_time_s
    v0 = min(max(v_m_s, -k.max_vel_x_m_s), k.max_vel_x_m_s)
    w0 = min(max(w_rad_s, -k.max_vel_theta_rad_s), k.max_vel_theta_rad_s)
    v_min = min(c.min_vel_x_m_s, k.max_vel_x_m_s)
    v_lo = ramp(v0, v_min, t_s, k.acc_lim_x_m_s2, k.decel_lim_x_m_s2)
    v_hi = ramp(v0, k.max_vel_x_m_s, t_s, k.acc_lim_x_m_s2, k.decel_lim_x_m_s2)
    v_lo, v_hi = max(v_lo, v_min), max(v_hi, v_min)
    w_lo = ramp(w0, -k.max_vel_theta_rad_s, t_s, k.acc_lim_theta_rad_s2, k.decel_lim_theta_rad_s2)
    w_hi = ramp(w0, k.max_vel_theta_rad_s, t_s, k.acc_lim_theta_rad_s2, k.decel_lim_theta_rad_s2)
    return v_lo, v_hi, w_lo, w_hi


def sample_targets(
    config: DwbConfig, kinematics: Kinematics, v_m_s: float, w_rad_s: float
) -> tuple[FloatArray, FloatArray, float]:
    """The (v, w) targets of the window, with the minimum rotation speed applied.

    Parameters
    ----------
    config : DwbConfig
        Samples per axis, ``min_speed_theta_rad_s`` and the window's parameters.
    kinematics : Kinematics
        Speed and acceleration bounds.
    v_m_s, w_rad_s : float
        Current velocity [m/s], [rad/s].

    Returns
    -------
    tuple
        (v (M,) [m/s], w (M,) [rad/s], slowest v of the window [m/s]): the M distinct pairs in
        lexicographic (v, w) order.
    """
    c = config
    v_lo, v_hi, w_lo, w_hi = dynamic_window(config, kinematics, v_m_s, w_rad_s)
    vs = _sorted_distinct(np.linspace(v_lo, v_hi, c.vx_samples, dtype=np.float64))
    ws = _sorted_distinct(np.linspace(w_lo, w_hi, c.vtheta_samples, dtype=np.float64))
    if w_lo <= 0.0 <= w_hi:
        ws = _with_zero(ws)
    w_min = min(c.min_speed_theta_rad_s, kinematics.max_vel_theta_rad_s)
    slow_turn = (ws != 0.0) & (np.abs(ws) < w_min)
    # still sorted (the slow turns move to +-w_min, beyond their neighbours towards 0)
    ws_in_place = _sorted_distinct(np.where(slow_turn, np.copysign(w_min, ws), ws))
    # (v, w) pairs in lexicographic order, each once: only a row with v = 0 changes
    rows = [ws_in_place if abs(vi) < 1e-9 else ws for vi in vs]
    v = np.repeat(vs, [len(r) for r in rows])
    return v, np.concatenate(rows), float(vs[0])


def velocity_profile(
    u0: float, target: FloatArray, t_s: FloatArray, accel: float, decel: float
) -> FloatArray:
    """The velocity over time when ramping from ``u0`` towards each target.

    The continuous form of :func:`jackson.common.ramp.ramp` with a fixed target
    r: speeding up on one side of zero, u(t) = u0 + sign(r - u0) min(|r - u0|, a t); slowing
    down on one side, the same with d; through zero (r = 0 or of the other sign), brake at d
    until t0 = |u0| / d, then u(t) = sign(r) min(|r|, a (t - t0)).

    Parameters
    ----------
    u0 : float
        Current velocity (m/s or rad/s).
    target : ndarray, shape (M,)
        Targets r, same unit.
    t_s : ndarray, shape (K,)
        Times [s], >= 0.
    accel, decel : float
        Bounds on the growth and the fall of |u| (unit/s).

    Returns
    -------
    ndarray, shape (M, K)
        u(t) for every target and time.
    """
    r = target[:, None]
    tt = t_s[None, :]
    same_side = (u0 == 0.0) | ((r != 0.0) & ((r > 0.0) == (u0 > 0.0)))
    rate = np.where(np.abs(r) >= abs(u0), accel, decel)
    gap = r - u0
    u = np.asarray(u0 + np.sign(gap) * np.minimum(np.abs(gap), rate * tt), np.float64)
    through = np.flatnonzero(~same_side[:, 0])
    if through.size:  # targets through zero, or zero: brake first
        t0 = abs(u0) / decel
        braking = u0 - math.copysign(decel, u0) * tt if u0 != 0.0 else np.zeros_like(tt)
        rt = r[through]
        after = np.sign(rt) * np.minimum(np.abs(rt), accel * np.maximum(tt - t0, 0.0))
        u[through] = np.where(tt < t0, braking, after)
    return u


def _sorted_distinct(a: FloatArray) -> FloatArray:
    """np.unique(a) for a nondecreasing ``a``: its first value of each run of equal ones."""
    if not (a[1:] >= a[:-1]).all():
        return np.asarray(np.unique(a), np.float64)
    keep = np.empty(a.size, bool)
    keep[:1] = True
    np.not_equal(a[1:], a[:-1], out=keep[1:])
    return np.asarray(a[keep], np.float64)


def _with_zero(ws: FloatArray) -> FloatArray:
    """np.unique(np.append(ws, 0.0)) for sorted, distinct ``ws``."""
    if (ws == 0.0).any():  # keep whichever zero the sort puts first
        return np.asarray(np.unique(np.append(ws, 0.0)), np.float64)
    i = int(ws.searchsorted(0.0))
    return np.concatenate((ws[:i], (0.0,), ws[i:]))
