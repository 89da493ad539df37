"""Aligning two runs at time zero (Eq. 12) and their cross-domain deviation (Eq. 13-14)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.experiments.metrics.inputs import (
    FloatArray,
    MetricInputError,
    NoMotionError,
    as_points,
    as_series,
    check_same_length,
    wrap_angle,
)
from jackson.experiments.metrics.paths import angle_rms

TIME_ZERO_V_M_S = 0.01  # [m/s] time zero: first command with v above this (Sec. 2.5.3)
# ---- alignment (Sec. 2.5.3, Eq. 12) -----------------------------------------------------------


def time_zero_index(
    t_s: npt.ArrayLike, v_cmd_m_s: npt.ArrayLike, threshold_m_s: float = TIME_ZERO_V_M_S
) -> int:
    """Index of time zero: the first sample whose commanded v exceeds 0.01 m/s (Sec. 2.5.3).

    Both domains' timelines are shifted so that t = 0 there. The test is v > threshold on the
    signed command (a reversing start is not time zero), strictly greater as in the paper.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Time stamps of the commands [s], increasing.
    v_cmd_m_s : array_like, shape (N,)
        Commanded linear velocity [m/s].
    threshold_m_s : float
        Threshold [m/s], 0.01 in the paper.

    Returns
    -------
    int
        k with v_k > threshold and v_j <= threshold for every j < k.

    Raises
    ------
    NoMotionError
        No command exceeds the threshold.
    """
    t = as_series("t_s", t_s)
    v = as_series("v_cmd_m_s", v_cmd_m_s)
    check_same_length("t_s", t, "v_cmd_m_s", v)
    above = np.flatnonzero(v > threshold_m_s)
    if above.size == 0:
        raise NoMotionError(f"no commanded v exceeds {threshold_m_s} m/s: the run never started")
    return int(above[0])


def align_start(
    xy_or_pose: npt.ArrayLike, start_index: int = 0, yaw0_rad: float | None = None
) -> FloatArray:
    """Anchor a trajectory at (0, 0, 0) at one of its samples (Eq. 12).

    The pose at ``start_index`` (normally :func:`time_zero_index`) is moved to the origin and
    the trajectory rotated by minus its heading yaw0:

        [x', y']^T = R(-yaw0) [x - x0, y - y0]^T,   yaw' = yaw - yaw0

    The heading is shifted, not wrapped, so an unwrapped input stays continuous. Samples
    before ``start_index`` are transformed alike; slice them off if they are not wanted.

    Parameters
    ----------
    xy_or_pose : array_like, shape (N, 2) or (N, 3)
        Positions [m], or poses x [m], y [m], yaw [rad].
    start_index : int
        Sample that becomes (0, 0, 0).
    yaw0_rad : float, optional
        Heading to rotate away [rad]; defaults to the pose's own yaw at ``start_index``, and
        to 0 (translation only) for positions without a heading.

    Returns
    -------
    numpy.ndarray, same shape as the input
        The anchored trajectory.
    """
    arr = np.asarray(xy_or_pose, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] not in (2, 3) or arr.shape[0] == 0:
        raise MetricInputError(f"xy_or_pose must have shape (N, 2) or (N, 3), got {arr.shape}")
    if not -arr.shape[0] <= start_index < arr.shape[0]:
        raise MetricInputError(f"start_index {start_index} outside {arr.shape[0]} samples")
    if yaw0_rad is None:
        yaw0_rad = float(arr[start_index, 2]) if arr.shape[1] == 3 else 0.0
    c, s = math.cos(yaw0_rad), math.sin(yaw0_rad)
    d = arr[:, :2] - arr[start_index, :2]
    out = arr.copy()
    out[:, 0] = c * d[:, 0] + s * d[:, 1]
    out[:, 1] = -s * d[:, 0] + c * d[:, 1]
    if arr.shape[1] == 3:
        out[:, 2] = arr[:, 2] - yaw0_rad
    return out


def synchronise(
    t_a_s: npt.ArrayLike,
    a: npt.ArrayLike,
    t_b_s: npt.ArrayLike,
    b: npt.ArrayLike,
    t_common_s: npt.ArrayLike,
    angular: bool = False,
) -> tuple[FloatArray, FloatArray]:
    """Two signals linearly interpolated onto common time stamps, the K samples of Eq. 13-14.

    With ``angular`` the signals are headings: each is unwrapped before the interpolation
    (so 179 deg -> -179 deg passes through 180 deg, not 0) and wrapped to [-pi, pi) after.
    No extrapolation: every common time must lie within both signals' time spans.

    Parameters
    ----------
    t_a_s, t_b_s : array_like, shape (N_a,), (N_b,)
        Strictly increasing time stamps of the two signals [s], on the same clock (both from
        time zero, :func:`time_zero_index`).
    a, b : array_like, shape (N_a,) or (N_a, C), and (N_b,) or (N_b, C)
        Samples; columns of a 2-D signal are interpolated independently.
    t_common_s : array_like, shape (K,)
        Times to interpolate onto [s].
    angular : bool
        Treat every column as an angle [rad].

    Returns
    -------
    tuple of numpy.ndarray, shapes (K,) or (K, C)
        a and b at ``t_common_s``.
    """
    t_common = as_series("t_common_s", t_common_s)
    return (
        _interpolate("a", t_a_s, a, t_common, angular),
        _interpolate("b", t_b_s, b, t_common, angular),
    )


def _interpolate(
    name: str, t_s: npt.ArrayLike, values: npt.ArrayLike, t_new: FloatArray, angular: bool
) -> FloatArray:
    t = as_series(f"t_{name}_s", t_s, min_len=1)
    v = np.asarray(values, dtype=np.float64)
    if v.ndim not in (1, 2) or v.shape[0] != t.shape[0]:
        raise MetricInputError(
            f"{name} must have shape (N,) or (N, C) with N = len(t_{name}_s) = {t.shape[0]}, "
            f"got {v.shape}"
        )
    if np.any(np.diff(t) <= 0.0):
        raise MetricInputError(f"t_{name}_s must be strictly increasing")
    if t_new.size and (t_new.min() < t[0] or t_new.max() > t[-1]):
        raise MetricInputError(
            f"common times [{t_new.min()}, {t_new.max()}] s leave {name}'s span [{t[0]}, {t[-1]}] s"
        )
    cols: FloatArray = v.reshape(v.shape[0], -1)
    if angular:
        cols = np.unwrap(cols, axis=0).astype(np.float64)
    out = np.column_stack([np.interp(t_new, t, cols[:, j]) for j in range(cols.shape[1])])
    if angular:
        out = wrap_angle(out)
    return out.reshape((t_new.shape[0], *v.shape[1:]))


# ---- cross-domain deviation (Eq. 13-14) -------------------------------------------------------


def d_trans(p_sim_m: npt.ArrayLike, p_real_m: npt.ArrayLike) -> float:
    """Cross-domain translational deviation D_trans (Eq. 13).

        D_trans = sqrt(1/K sum_k ||p_sim,k - p_real,k||^2)

    Parameters
    ----------
    p_sim_m, p_real_m : array_like, shape (K, 2)
        Synchronised positions [m] (:func:`synchronise`), both anchored by :func:`align_start`.

    Returns
    -------
    float
        D_trans [m].
    """
    a = as_points("p_sim_m", p_sim_m)
    b = as_points("p_real_m", p_real_m)
    check_same_length("p_sim_m", a, "p_real_m", b)
    d = a - b
    return float(np.sqrt(np.mean(np.einsum("ij,ij->i", d, d))))


def d_rot(theta_sim_rad: npt.ArrayLike, theta_real_rad: npt.ArrayLike) -> float:
    """Cross-domain rotational discrepancy D_rot (Eq. 14), differences wrapped to [-pi, pi).

        D_rot = sqrt(1/K sum_k wrap(theta_sim,k - theta_real,k)^2)

    Parameters
    ----------
    theta_sim_rad, theta_real_rad : array_like, shape (K,)
        Synchronised headings [rad].

    Returns
    -------
    float
        D_rot [rad].
    """
    return angle_rms(theta_sim_rad, theta_real_rad, "theta_sim_rad", "theta_real_rad")
