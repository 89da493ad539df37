"""The paper's validation metrics (Sec. 2.5.3-2.5.6, Appendix D), one pure function each.

Stage 1 and 2 (square, figure-eight), per run:

    closure error          e_c = ||p_K - p_1||                            (Sec. 2.5.2)
    cross-track RMSE/max   nearest-point distance of p_k to the nominal path polyline
    heading RMSE           sqrt(mean wrap(theta_est,k - theta_ref,k)^2)
    loop diameters         2 R of an algebraic (Kasa) circle fit to each figure-eight loop
    optimism gap           e_c,GT - e_c,EKF                               (Sec. 4.2)

Estimator consistency, per EKF output k against ground truth (not in the paper):

    NEES                   eps_k = e_k^T P_k^-1 e_k,  e = pose error [x, y, yaw]
    95 % band              [chi2_n^-1(0.025), chi2_n^-1(0.975)], n = 3 (0.216, 9.348)
    band of an N-run mean  [chi2_Nn^-1(0.025), chi2_Nn^-1(0.975)] / N
    end-position 2-sigma   2 sqrt(lambda_max(P_xy)), the 2-sigma ellipse's semi-major axis

Cross-domain deviation over K synchronised samples, both runs anchored at (0, 0, 0) (Eq. 12)
from time zero, the first command with v > 0.01 m/s (Sec. 2.5.3):

    D_trans = sqrt(1/K sum_k ||p_sim,k - p_real,k||^2)                   (Eq. 13)
    D_rot   = sqrt(1/K sum_k wrap(theta_sim,k - theta_real,k)^2)         (Eq. 14)
    SSIM(M_sim, M_real) of 8-bit occupancy maps                         (Eq. 15 / A19)

Stage 3 (maze with the dynamic cylinder):

    S_vector = [P_success, C_count, d_min, E_recovery, t_nav]           (Eq. 16)
    D_traj,i = sqrt(sum_k w_ik d^2(p_ik, P_0) / sum_k w_ik)             (Eq. 19)
    d(p, P_0) = min_{q in P_0} ||p - q||                                (Eq. 20)
    d_min = min_{t >= t_ins} d_geom(B_robot(t), C_cyl)                  (Eq. 21)

and the paper's summaries: mean +- SD with a 95 % CI (Stages 1-2; t-based as the paper's, or
one that stays in the quantity's domain: log-normal, bootstrap, binomial), median [IQR]
(continuous Stage 3 outcomes). Angles are in radians, lengths in metres, times in seconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple, cast

import numpy as np
import numpy.typing as npt

from jackson.common.errors import JacksonError
from jackson.common.geometry import wrap_angles

wrap_angle = wrap_angles  # the metrics' name for the elementwise wrap (common/geometry.py)

FloatArray = npt.NDArray[np.float64]

TIME_ZERO_V_M_S = 0.01  # [m/s] time zero: first command with v above this (Sec. 2.5.3)
ENVELOPE_X_M = (-0.135000, 0.135177)  # [m] Stage 3 collision envelope, robot frame (Eq. A21)
ENVELOPE_Y_M = (-0.135439, 0.135000)  # [m]
CYLINDER_RADIUS_M = 0.125  # [m] Stage 3 dynamic cylinder r_c
SSIM_DATA_RANGE = 255  # L, 8-bit maps (Eq. A19)
SSIM_K1 = 0.01  # C1 = (K1 L)^2
SSIM_K2 = 0.03  # C2 = (K2 L)^2
SSIM_WIN_SIZE = 7  # [px] side of the local window
BASELINE_SAMPLES = 200  # points of a resampled trajectory in the median baseline
NEES_CONFIDENCE = 0.95  # two-sided probability inside the NEES band
BOOTSTRAP_RESAMPLES = 9999  # resamples of a percentile bootstrap interval
BOOTSTRAP_SEED = 0  # its random generator's seed: the same runs give the same interval
SINGULAR_RCOND = 1e-12  # a covariance whose eigenvalues span more than 1e12 is singular
_CHUNK_ELEMENTS = 1 << 20  # points x segments evaluated at once by the nearest-point search


def _stats() -> Any:  # (scipy has no type information)
    """``scipy.stats``, imported on first use: half a second that a single run (``jackson run``
    computes its metrics from this module) never needs."""
    from scipy import stats

    return stats


def _ssim(*args: object, **kwargs: object) -> float:
    """scikit-image's ``structural_similarity``, imported on first use (as :func:`_stats`)."""
    from skimage.metrics import structural_similarity

    return cast(Callable[..., float], structural_similarity)(*args, **kwargs)


class MetricInputError(JacksonError, ValueError):
    """An input a metric cannot be computed from (wrong shape, too few samples, ...)."""


class NoMotionError(MetricInputError):
    """No commanded speed exceeds the time-zero threshold: the run never started."""


class Cylinder(NamedTuple):
    """A vertical cylinder seen from above: centre (x_m, y_m) and radius_m [m]."""

    x_m: float
    y_m: float
    radius_m: float


STAGE3_CYLINDER = Cylinder(0.6091, -0.0364, CYLINDER_RADIUS_M)  # map frame (Sec. 4.3)


# ---- input checks ------------------------------------------------------------------------------


def _points(name: str, value: npt.ArrayLike, min_rows: int = 1) -> FloatArray:
    """value as a float (N, 2) array with N >= min_rows."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise MetricInputError(f"{name} must have shape (N, 2), got {arr.shape}")
    if arr.shape[0] < min_rows:
        raise MetricInputError(f"{name} needs at least {min_rows} points, got {arr.shape[0]}")
    return arr


def _series(name: str, value: npt.ArrayLike, min_len: int = 1) -> FloatArray:
    """value as a float (N,) array with N >= min_len."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != 1:
        raise MetricInputError(f"{name} must be one-dimensional, got shape {arr.shape}")
    if arr.shape[0] < min_len:
        raise MetricInputError(f"{name} needs at least {min_len} samples, got {arr.shape[0]}")
    return arr


def _same_length(name_a: str, a: FloatArray, name_b: str, b: FloatArray) -> None:
    if a.shape[0] != b.shape[0]:
        raise MetricInputError(
            f"{name_a} and {name_b} must be synchronised (same length), "
            f"got {a.shape[0]} and {b.shape[0]}"
        )


# ---- Stage 1-2: closure, cross-track, heading --------------------------------------------------


def closure_error(xy_m: npt.ArrayLike) -> float:
    """Closure error e_c = sqrt(dx^2 + dy^2) from the first to the last point (Sec. 2.5.2).

    The paper's terminal displacement of a closed manoeuvre (square, figure-eight) that starts
    and ends on the same marked pose.

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Positions [m], in time order.

    Returns
    -------
    float
        ||p_N - p_1|| [m].
    """
    xy = _points("xy_m", xy_m)
    return float(np.hypot(*(xy[-1] - xy[0])))


def point_to_polyline_distance(points_m: npt.ArrayLike, polyline_m: npt.ArrayLike) -> FloatArray:
    """Nearest-point distance d(p, P) = min_{q in P} ||p - q|| of each point (Eq. 20).

    P is the polyline itself, every point of every segment, not only its vertices: for a
    segment a -> b the nearest point is a + t (b - a) with t the projection clipped to [0, 1].

    Parameters
    ----------
    points_m : array_like, shape (N, 2)
        Query points [m].
    polyline_m : array_like, shape (M, 2)
        Vertices of the polyline [m], M >= 1 (a single vertex is a point).

    Returns
    -------
    numpy.ndarray, shape (N,)
        Distance of each query point to the polyline [m].
    """
    p = _points("points_m", points_m)
    poly = _points("polyline_m", polyline_m)
    if poly.shape[0] == 1:
        return cast(FloatArray, np.hypot(*(p - poly[0]).T))
    a = poly[:-1]  # (S, 2) segment starts
    ab = poly[1:] - a  # (S, 2) segment vectors
    ab_sq = np.einsum("ij,ij->i", ab, ab)  # (S,)
    inv_ab_sq = np.divide(1.0, ab_sq, out=np.zeros_like(ab_sq), where=ab_sq > 0.0)
    out = np.empty(p.shape[0])
    rows = max(1, _CHUNK_ELEMENTS // a.shape[0])
    for start in range(0, p.shape[0], rows):
        ap = p[start : start + rows, None, :] - a[None, :, :]  # (n, S, 2)
        t = np.clip(np.einsum("nsk,sk->ns", ap, ab) * inv_ab_sq, 0.0, 1.0)
        diff = ap - t[:, :, None] * ab[None, :, :]
        out[start : start + rows] = np.sqrt(np.min(np.einsum("nsk,nsk->ns", diff, diff), axis=1))
    return out


def cross_track_rmse(xy_m: npt.ArrayLike, path_m: npt.ArrayLike) -> float:
    """Cross-track RMSE: sqrt(mean_k d(p_k, path)^2) against the nominal path (Sec. 2.5.2).

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Trajectory [m], anchored at (0, 0, 0) like the path (Eq. 12).
    path_m : array_like, shape (M, 2)
        Nominal path polyline [m] (:func:`square_path`, :func:`figure_eight_path`).

    Returns
    -------
    float
        Root-mean-square nearest-point distance [m].
    """
    d = point_to_polyline_distance(xy_m, path_m)
    return float(np.sqrt(np.mean(d * d)))


def max_cross_track(xy_m: npt.ArrayLike, path_m: npt.ArrayLike) -> float:
    """Maximum cross-track deviation max_k d(p_k, path) [m] (Table 7).

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Trajectory [m].
    path_m : array_like, shape (M, 2)
        Nominal path polyline [m].

    Returns
    -------
    float
        Largest nearest-point distance [m].
    """
    return float(np.max(point_to_polyline_distance(xy_m, path_m)))


def square_path(side_m: float = 1.0) -> FloatArray:
    """Nominal Stage 1 square, counter-clockwise from the origin heading +x (Sec. 2.5.2).

    Parameters
    ----------
    side_m : float
        Side length [m]; the paper's square is 1.0 m (4.0 m perimeter).

    Returns
    -------
    numpy.ndarray, shape (5, 2)
        Closed polyline (0, 0), (s, 0), (s, s), (0, s), (0, 0) [m].
    """
    s = float(side_m)
    return np.array([[0.0, 0.0], [s, 0.0], [s, s], [0.0, s], [0.0, 0.0]])


def figure_eight_path(radius_m: float = 0.5, n: int = 720) -> FloatArray:
    """Nominal Stage 2 figure-eight: one CCW loop, then one CW loop (Sec. 2.5.2).

    Both loops pass through the origin heading +x: the first is the circle of radius R
    centred (0, R) driven counter-clockwise, (R sin phi, R - R cos phi); the second the circle
    centred (0, -R) driven clockwise, (R sin phi, -R + R cos phi), phi from 0 to 2 pi.

    Parameters
    ----------
    radius_m : float
        Loop radius R [m]; the paper's is 0.50 m (v = 0.08 m/s, |omega| = 0.16 rad/s).
    n : int
        Segments per loop (the chord of a 0.5 m loop at n = 720 lies within 5 um of the arc).

    Returns
    -------
    numpy.ndarray, shape (2 n + 1, 2)
        Closed polyline [m] from the origin back to the origin; vertex n is the crossing.
    """
    if n < 3:
        raise MetricInputError(f"figure_eight_path needs n >= 3 segments per loop, got {n}")
    r = float(radius_m)
    phi = np.linspace(0.0, 2.0 * math.pi, n + 1)
    ccw = np.column_stack((r * np.sin(phi), r - r * np.cos(phi)))
    cw = np.column_stack((r * np.sin(phi), -r + r * np.cos(phi)))
    ccw[-1] = cw[0] = 0.0  # the crossing and the end lie exactly on the origin
    cw[-1] = 0.0
    return np.vstack((ccw, cw[1:]))


def _angle_rms(a_rad: npt.ArrayLike, b_rad: npt.ArrayLike, name_a: str, name_b: str) -> float:
    a = _series(name_a, a_rad)
    b = _series(name_b, b_rad)
    _same_length(name_a, a, name_b, b)
    e = wrap_angle(a - b)
    return float(np.sqrt(np.mean(e * e)))


def heading_rmse(yaw_est_rad: npt.ArrayLike, yaw_ref_rad: npt.ArrayLike) -> float:
    """Heading-error RMSE sqrt(mean_k wrap(yaw_est,k - yaw_ref,k)^2) (Sec. 2.5.2, Table 8).

    The differences are wrapped to [-pi, pi) before squaring, so 179 deg against -179 deg is
    a 2 deg error, and wrapped and unwrapped inputs give the same value.

    Parameters
    ----------
    yaw_est_rad : array_like, shape (N,)
        Estimated heading (EKF or raw odometry) [rad].
    yaw_ref_rad : array_like, shape (N,)
        Reference heading on the same time stamps (ground truth or nominal) [rad].

    Returns
    -------
    float
        RMS of the wrapped heading error [rad].
    """
    return _angle_rms(yaw_est_rad, yaw_ref_rad, "yaw_est_rad", "yaw_ref_rad")


def final_heading_error(yaw_start_rad: float, yaw_end_rad: float) -> float:
    """Final heading residual wrap(yaw_end - yaw_start) of a closed manoeuvre (Sec. 2.5.2).

    Signed (CCW positive) so that a CW/CCW bias stays visible; the paper reports its absolute
    value (1.41 +- 1.02 deg on the physical square).

    Parameters
    ----------
    yaw_start_rad, yaw_end_rad : float
        Heading at the start and at the end of the run [rad].

    Returns
    -------
    float
        Heading change in [-pi, pi) [rad].
    """
    return float(wrap_angle(float(yaw_end_rad) - float(yaw_start_rad)))


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
    t = _series("t_s", t_s)
    v = _series("v_cmd_m_s", v_cmd_m_s)
    _same_length("t_s", t, "v_cmd_m_s", v)
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
    t_common = _series("t_common_s", t_common_s)
    return (
        _interpolate("a", t_a_s, a, t_common, angular),
        _interpolate("b", t_b_s, b, t_common, angular),
    )


def _interpolate(
    name: str, t_s: npt.ArrayLike, values: npt.ArrayLike, t_new: FloatArray, angular: bool
) -> FloatArray:
    t = _series(f"t_{name}_s", t_s, min_len=1)
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
    a = _points("p_sim_m", p_sim_m)
    b = _points("p_real_m", p_real_m)
    _same_length("p_sim_m", a, "p_real_m", b)
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
    return _angle_rms(theta_sim_rad, theta_real_rad, "theta_sim_rad", "theta_real_rad")


# ---- figure-eight geometry (Sec. 4.2) ---------------------------------------------------------


def fit_circle_kasa(xy_m: npt.ArrayLike) -> tuple[float, float, float]:
    """Algebraic (Kasa) least-squares circle through points.

    Minimises sum_k (x_k^2 + y_k^2 + D x_k + E y_k + F)^2, linear in (D, E, F); then the
    centre is (-D/2, -E/2) and R^2 = D^2/4 + E^2/4 - F. The points are centred on their mean
    first, which leaves the fit unchanged and keeps the system well conditioned.

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Points [m], N >= 3, not all on one line.

    Returns
    -------
    tuple of float
        Centre x, centre y and radius [m].
    """
    xy = _points("xy_m", xy_m, min_rows=3)
    mean = xy.mean(axis=0)
    u = xy - mean
    a = np.column_stack((u, np.ones(u.shape[0])))
    rhs = -np.einsum("ij,ij->i", u, u)
    (d, e, f), _, rank, _ = np.linalg.lstsq(a, rhs, rcond=None)
    r_sq = 0.25 * (d * d + e * e) - f
    if rank < 3 or not r_sq > 0.0:
        raise MetricInputError("points do not determine a circle (collinear or coincident)")
    return float(mean[0] - 0.5 * d), float(mean[1] - 0.5 * e), float(math.sqrt(r_sq))


def figure_eight_split(yaw_unwrapped_rad: npt.ArrayLike) -> int:
    """Sample where the figure-eight turns from its CCW loop into its CW loop (Sec. 4.2).

    The integrated heading rises by 2 pi over the CCW loop and falls back over the CW loop,
    so the split is where it peaks (the first maximum). The input is unwrapped again, which
    leaves an already continuous heading unchanged.

    Parameters
    ----------
    yaw_unwrapped_rad : array_like, shape (N,)
        Heading over the run [rad], CCW positive.

    Returns
    -------
    int
        Index of the maximum of the integrated heading.
    """
    yaw = _series("yaw_unwrapped_rad", yaw_unwrapped_rad)
    return int(np.argmax(np.unwrap(yaw)))


def loop_diameters(xy_m: npt.ArrayLike, split_index: int) -> tuple[float, float]:
    """Diameters 2 R of the two figure-eight loops, by a Kasa circle fit to each (Sec. 4.2).

    The paper measured 1.0795 m (CCW) and 1.1280 m (CW) on the physical robot against the
    nominal 1.00 m. The split sample, the crossing, belongs to both loops.

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Figure-eight trajectory [m], CCW loop first.
    split_index : int
        Crossing sample (:func:`figure_eight_split`); each loop needs at least 3 points.

    Returns
    -------
    tuple of float
        (CCW diameter, CW diameter) [m].
    """
    xy = _points("xy_m", xy_m)
    if not 2 <= split_index <= xy.shape[0] - 3:
        raise MetricInputError(
            f"split_index {split_index} leaves fewer than 3 points in a loop of {xy.shape[0]}"
        )
    _, _, r_ccw = fit_circle_kasa(xy[: split_index + 1])
    _, _, r_cw = fit_circle_kasa(xy[split_index:])
    return 2.0 * r_ccw, 2.0 * r_cw


def optimism_gap(ekf_closure_m: float, gt_closure_m: float) -> float:
    """Estimator optimism gap e_c,GT - e_c,EKF (Sec. 4.2): positive when the EKF under-reports.

    Sign convention: ground truth minus estimate. The paper's Stage 2 gaps follow it
    (physical 11.59 - 6.90 = 4.69 cm, i.e. |GT - EKF|; twin 7.08 - 1.92 = 5.16 cm); its
    Stage 1 "-2.43 cm optimism bias" of the twin is the opposite sign, EKF - GT
    (0.95 - 3.39 cm). Compute it per run and summarise the per-run gaps (the paper's 4.69 +-
    2.82 cm is the SD of per-run differences).

    Parameters
    ----------
    ekf_closure_m : float
        Closure error the EKF reports [m].
    gt_closure_m : float
        Closure error of the reference: ground truth or the floor measurement [m].

    Returns
    -------
    float
        gt_closure_m - ekf_closure_m [m].
    """
    return float(gt_closure_m) - float(ekf_closure_m)


# ---- estimator consistency (NEES) -------------------------------------------------------------


def nees(errors: npt.ArrayLike, covariances: npt.ArrayLike) -> FloatArray:
    """Normalised estimation error squared eps_k = e_k^T P_k^-1 e_k of each sample.

    The chi-square test of a filter's covariance (Bar-Shalom, Li and Kirubarajan, *Estimation
    with Applications to Tracking and Navigation*, Sec. 5.4.2): when the errors e_k are
    zero-mean Gaussian with the covariance P_k the filter states, eps_k is chi-square
    distributed with n = dim(e) degrees of freedom, mean n. Above the band
    (:func:`nees_band`) the filter claims more than it knows (optimistic), below it less
    (pessimistic).

    P_k is symmetrised, (P + P^T) / 2, and a sample is left out (NaN) when P_k is singular:
    not positive definite, or its smallest eigenvalue at most ``SINGULAR_RCOND`` times its
    largest; also when e_k or P_k is not finite.

    Parameters
    ----------
    errors : array_like, shape (N, n)
        Estimate minus truth, angles already wrapped (:func:`wrap_angle`).
    covariances : array_like, shape (N, n, n)
        The filter's covariance of the same components at the same samples.

    Returns
    -------
    numpy.ndarray, shape (N,)
        eps_k, NaN where it is undefined.
    """
    e = np.asarray(errors, dtype=np.float64)
    p = np.asarray(covariances, dtype=np.float64)
    if e.ndim != 2 or p.shape != (e.shape[0], e.shape[1], e.shape[1]):
        raise MetricInputError(
            f"errors (N, n) and covariances (N, n, n) expected, got {e.shape} and {p.shape}"
        )
    out = np.full(e.shape[0], math.nan)
    p = 0.5 * (p + np.swapaxes(p, 1, 2))
    finite = np.isfinite(e).all(axis=1) & np.isfinite(p).all(axis=(1, 2))
    eig = np.linalg.eigvalsh(p[finite])  # ascending
    regular = (eig[:, -1] > 0.0) & (eig[:, 0] > SINGULAR_RCOND * eig[:, -1])
    use = np.flatnonzero(finite)[regular]
    solved = np.linalg.solve(p[use], e[use][:, :, None])[:, :, 0]
    out[use] = np.einsum("ij,ij->i", e[use], solved)
    return out


def nees_band(dof: int, confidence: float = NEES_CONFIDENCE, runs: int = 1) -> tuple[float, float]:
    """Two-sided chi-square acceptance band of the NEES, or of its mean over N runs.

        single run:  [chi2_n^-1((1 - c) / 2), chi2_n^-1((1 + c) / 2)]
        N runs:      [chi2_Nn^-1((1 - c) / 2), chi2_Nn^-1((1 + c) / 2)] / N

    N eps_bar of N independent runs is chi-square with N n degrees of freedom (the average
    NEES, Bar-Shalom et al., Sec. 5.4.2), so the band of the mean narrows around n as N grows.
    For n = 3 and c = 0.95: [0.216, 9.348] for one run, [1.679, 4.698] for ten.

    Parameters
    ----------
    dof : int
        n, the dimension of the error (3 for [x, y, yaw]).
    confidence : float
        Two-sided probability inside the band.
    runs : int
        N, the runs averaged.

    Returns
    -------
    tuple of float
        (lower, upper) bound.
    """
    if dof < 1 or runs < 1 or not 0.0 < confidence < 1.0:
        raise MetricInputError(
            f"nees_band needs dof >= 1, runs >= 1 and 0 < confidence < 1, "
            f"got {dof}, {runs}, {confidence}"
        )
    k = dof * runs
    lo = float(_stats().chi2.ppf(0.5 * (1.0 - confidence), k)) / runs
    hi = float(_stats().chi2.ppf(0.5 * (1.0 + confidence), k)) / runs
    return lo, hi


def position_two_sigma(covariance_xy: npt.ArrayLike) -> float:
    """2-sigma radius of a position covariance: 2 sqrt(lambda_max(P_xy)) [m].

    The semi-major axis of the 2-sigma ellipse, the largest distance from the estimate at
    which the ellipse still reaches: an error inside the ellipse is within this radius (the
    converse does not hold across the minor axis).

    Parameters
    ----------
    covariance_xy : array_like, shape (2, 2)
        Covariance of (x, y) [m^2].

    Returns
    -------
    float
        2 sqrt of its largest eigenvalue [m]; NaN if it is not finite.
    """
    p = np.asarray(covariance_xy, dtype=np.float64)
    if p.shape != (2, 2):
        raise MetricInputError(f"covariance_xy must have shape (2, 2), got {p.shape}")
    if not np.isfinite(p).all():
        return math.nan
    lam = float(np.linalg.eigvalsh(0.5 * (p + p.T))[-1])
    return 2.0 * math.sqrt(max(lam, 0.0))


# ---- baseline-referenced trajectory deviation (Eq. 19-20) -------------------------------------


def arc_length_weights(xy_m: npt.ArrayLike) -> FloatArray:
    """Local arc-length weights w_k of Eq. 19: half of each segment to either end point.

        w_1 = |p_2 - p_1| / 2,  w_k = (|p_k - p_k-1| + |p_k+1 - p_k|) / 2,  w_N = |p_N - p_N-1| / 2

    They sum to the path length, so a weighted mean is the trapezoidal path integral divided
    by the length, independent of how densely a stretch was sampled (a robot standing still
    adds samples of zero weight).

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Trajectory [m].

    Returns
    -------
    numpy.ndarray, shape (N,)
        Weights [m]; all zero for a single point or a trajectory that never moves.
    """
    xy = _points("xy_m", xy_m)
    seg = np.hypot(*np.diff(xy, axis=0).T)
    w = np.zeros(xy.shape[0])
    w[:-1] += 0.5 * seg
    w[1:] += 0.5 * seg
    return w


def d_traj(xy_m: npt.ArrayLike, baseline_m: npt.ArrayLike) -> float:
    """Baseline-referenced trajectory deviation D_traj (Eq. 19 with Eq. 20).

        D_traj = sqrt(sum_k w_k d^2(p_k, P_0) / sum_k w_k)

    with w_k from :func:`arc_length_weights` and d the nearest-point distance to the baseline
    polyline P_0 (:func:`point_to_polyline_distance`). A trajectory that never moves has no
    arc length; its samples are then weighted equally.

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Trajectory [m], initial-pose aligned (:func:`align_start`).
    baseline_m : array_like, shape (M, 2)
        Baseline polyline [m] (:func:`median_baseline`).

    Returns
    -------
    float
        D_traj [m].
    """
    w = arc_length_weights(xy_m)
    if not w.sum() > 0.0:
        w = np.ones_like(w)
    d = point_to_polyline_distance(xy_m, baseline_m)
    return float(np.sqrt(np.sum(w * d * d) / np.sum(w)))


def resample_by_arc_length(xy_m: npt.ArrayLike, n: int = BASELINE_SAMPLES) -> FloatArray:
    """n points spaced evenly along a trajectory's arc length, first and last included.

    Parameters
    ----------
    xy_m : array_like, shape (N, 2)
        Trajectory [m].
    n : int
        Number of points, >= 2.

    Returns
    -------
    numpy.ndarray, shape (n, 2)
        Points at arc length s_j = j L / (n - 1) [m]; n copies of the start if L = 0.
    """
    if n < 2:
        raise MetricInputError(f"resampling needs n >= 2 points, got {n}")
    xy = _points("xy_m", xy_m)
    seg = np.hypot(*np.diff(xy, axis=0).T)
    keep = np.concatenate(([True], seg > 0.0))  # drop repeated points: s must increase
    xy = xy[keep]
    s = np.concatenate(([0.0], np.cumsum(seg[seg > 0.0])))
    if s[-1] == 0.0:
        return np.repeat(xy[:1], n, axis=0)
    s_new = np.linspace(0.0, s[-1], n)
    return np.column_stack((np.interp(s_new, s, xy[:, 0]), np.interp(s_new, s, xy[:, 1])))


def median_baseline(trajectories: Sequence[npt.ArrayLike], n: int = BASELINE_SAMPLES) -> FloatArray:
    """Median baseline polyline P_0 of Eq. 19: the pointwise median of resampled runs.

    Each run is resampled to n points evenly spaced in its own arc length
    (:func:`resample_by_arc_length`), and the median is taken per point and per coordinate.

    Parameters
    ----------
    trajectories : sequence of array_like, shapes (N_i, 2)
        The baseline (C00) runs [m], aligned at their initial pose.
    n : int
        Points of the baseline.

    Returns
    -------
    numpy.ndarray, shape (n, 2)
        The baseline polyline [m].
    """
    if len(trajectories) == 0:
        raise MetricInputError("median_baseline needs at least one trajectory")
    stack = np.stack([resample_by_arc_length(xy, n) for xy in trajectories])
    return cast(FloatArray, np.median(stack, axis=0))


def d_traj_leave_one_out(
    trajectories: Sequence[npt.ArrayLike], n: int = BASELINE_SAMPLES
) -> list[float]:
    """D_traj of each baseline run against the median of the others (Sec. 2.5.6).

    The paper's C00 repeatability: comparing a run with a baseline it is part of would bias
    the value towards zero, so run i is compared with :func:`median_baseline` of the runs
    j != i.

    Parameters
    ----------
    trajectories : sequence of array_like, shapes (N_i, 2)
        The baseline runs [m], at least two.
    n : int
        Points of each leave-one-out baseline.

    Returns
    -------
    list of float
        D_traj of each run [m], in input order.
    """
    if len(trajectories) < 2:
        raise MetricInputError(f"leave-one-out needs at least 2 runs, got {len(trajectories)}")
    runs = list(trajectories)
    return [d_traj(xy, median_baseline(runs[:i] + runs[i + 1 :], n)) for i, xy in enumerate(runs)]


# ---- map similarity (Eq. 15 / A19) -------------------------------------------------------------


def occupancy_ssim(
    map_a: npt.NDArray[np.uint8],
    map_b: npt.NDArray[np.uint8],
    gaussian_weights: bool = False,
    win_size: int = SSIM_WIN_SIZE,
) -> float:
    """Structural similarity of two 8-bit occupancy maps (Eq. 15 / A19).

        SSIM = (2 mu_a mu_b + C1)(2 sigma_ab + C2)
               / ((mu_a^2 + mu_b^2 + C1)(sigma_a^2 + sigma_b^2 + C2))

    with C1 = (0.01 L)^2, C2 = (0.03 L)^2 and L = 255, evaluated on local windows ("localized
    spatial mean and variance", App. D.1) and averaged over the map (scikit-image's
    structural_similarity, K1 and K2 passed explicitly). The paper names no weighting, so the
    default is a uniform win_size x win_size window with sample (co)variances, scikit-image's
    own default; ``gaussian_weights=True`` gives Wang et al.'s Gaussian window (sigma 1.5 px).

    Parameters
    ----------
    map_a, map_b : numpy.ndarray of uint8, shape (H, W)
        Rasterised maps of the same size (e.g. map_saver's 254 free / 0 occupied / 205
        unknown), H and W at least ``win_size``.
    gaussian_weights : bool
        Gaussian instead of uniform local window.
    win_size : int
        Side of the uniform window [px], odd; ignored with Gaussian weights.

    Returns
    -------
    float
        Mean SSIM, 1 for identical maps.
    """
    a = np.asarray(map_a)
    b = np.asarray(map_b)
    for name, arr in (("map_a", a), ("map_b", b)):
        if arr.dtype != np.uint8 or arr.ndim != 2:
            raise MetricInputError(f"{name} must be a 2-D uint8 map, got {arr.dtype} {arr.shape}")
    if a.shape != b.shape:
        raise MetricInputError(f"maps differ in size: {a.shape} and {b.shape}")
    side = 11 if gaussian_weights else win_size
    if min(a.shape) < side:
        raise MetricInputError(f"maps of {a.shape} px are smaller than the {side} px window")
    if gaussian_weights:
        value = _ssim(
            a,
            b,
            data_range=SSIM_DATA_RANGE,
            K1=SSIM_K1,
            K2=SSIM_K2,
            gaussian_weights=True,
            sigma=1.5,
            use_sample_covariance=False,
        )
    else:
        value = _ssim(a, b, data_range=SSIM_DATA_RANGE, K1=SSIM_K1, K2=SSIM_K2, win_size=win_size)
    return float(value)


# ---- Stage 3 clearance and safety (Eq. 16, 21) -------------------------------------------------


def envelope_to_circle_distance(
    pose: npt.ArrayLike,
    cylinder: Cylinder | tuple[float, float, float],
    envelope_x_m: tuple[float, float] = ENVELOPE_X_M,
    envelope_y_m: tuple[float, float] = ENVELOPE_Y_M,
) -> FloatArray:
    """d_geom(B_robot(t), C_cyl) of Eq. 21 at each pose: rectangle-to-circle distance.

    The circle centre c is taken into the robot frame, l = R(-yaw) (c - p), where the
    envelope is the axis-aligned box [x0, x1] x [y0, y1] (App. D.3). The signed distance of
    l to the box is

        outside:  sqrt(max(x0 - lx, 0, lx - x1)^2 + max(y0 - ly, 0, ly - y1)^2)
        inside:   -min(lx - x0, x1 - lx, ly - y0, y1 - ly)

    and the clearance is that minus the radius: > 0 a gap, 0 touching, < 0 overlapping.
    Exact, not sampled on the edges.

    Parameters
    ----------
    pose : array_like, shape (N, 3) or (3,)
        Robot poses x [m], y [m], yaw [rad].
    cylinder : Cylinder or tuple of float
        Centre x, centre y and radius [m].
    envelope_x_m, envelope_y_m : tuple of float
        Envelope bounds in the robot frame [m].

    Returns
    -------
    numpy.ndarray, shape (N,)
        Clearance at each pose [m].
    """
    poses = np.atleast_2d(np.asarray(pose, dtype=np.float64))
    if poses.ndim != 2 or poses.shape[1] != 3:
        raise MetricInputError(f"pose must have shape (N, 3), got {np.shape(pose)}")
    cx, cy, radius = (float(v) for v in cylinder)
    (x0, x1), (y0, y1) = envelope_x_m, envelope_y_m
    if not (x0 < x1 and y0 < y1 and radius >= 0.0):
        raise MetricInputError("envelope bounds must be increasing and the radius >= 0")
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    dx, dy = cx - poses[:, 0], cy - poses[:, 1]
    lx = c * dx + s * dy
    ly = -s * dx + c * dy
    ox = np.maximum(np.maximum(x0 - lx, lx - x1), 0.0)
    oy = np.maximum(np.maximum(y0 - ly, ly - y1), 0.0)
    inside_depth = np.minimum(np.minimum(lx - x0, x1 - lx), np.minimum(ly - y0, y1 - ly))
    signed = np.where(inside_depth > 0.0, -inside_depth, np.hypot(ox, oy))
    return signed - radius


def d_min(
    poses: npt.ArrayLike,
    cylinder: Cylinder | tuple[float, float, float] = STAGE3_CYLINDER,
    *,
    envelope_x_m: tuple[float, float] = ENVELOPE_X_M,
    envelope_y_m: tuple[float, float] = ENVELOPE_Y_M,
    t_s: npt.ArrayLike | None = None,
    t_ins_s: float | None = None,
) -> float:
    """Minimum obstacle clearance d_min = min_{t >= t_ins} d_geom(B_robot(t), C_cyl) (Eq. 21).

    B_robot is the conservative oriented collision envelope x in [-0.135, 0.135177] m,
    y in [-0.135439, 0.135] m (Eq. A21), C_cyl the cylinder (r_c = 0.125 m); the distance is
    exact (:func:`envelope_to_circle_distance`): 0 when touching and negative when the
    envelope and the cylinder overlap.

    Parameters
    ----------
    poses : array_like, shape (N, 3)
        Robot poses x [m], y [m], yaw [rad], in the cylinder's frame.
    cylinder : Cylinder or tuple of float
        Centre x, centre y and radius [m]; the paper's Stage 3 cylinder by default.
    envelope_x_m, envelope_y_m : tuple of float
        Envelope bounds in the robot frame [m].
    t_s : array_like, shape (N,), optional
        Time stamps of the poses [s]; needed with ``t_ins_s``.
    t_ins_s : float, optional
        Cylinder insertion time [s]; only poses at t >= t_ins count. All poses without it.

    Returns
    -------
    float
        d_min [m].
    """
    dist = envelope_to_circle_distance(poses, cylinder, envelope_x_m, envelope_y_m)
    if t_ins_s is not None:
        if t_s is None:
            raise MetricInputError("t_ins_s needs the pose time stamps t_s")
        t = _series("t_s", t_s)
        _same_length("t_s", t, "poses", dist)
        dist = dist[t >= t_ins_s]
        if dist.size == 0:
            raise MetricInputError(f"no pose at or after the insertion time {t_ins_s} s")
    return float(np.min(dist))


@dataclass(frozen=True)
class SafetyVector:
    """S_vector = [P_success, C_count, d_min, E_recovery, t_nav] (Eq. 16 / A20).

    Attributes
    ----------
    p_success : float
        Successful goal completions over all attempted runs, aborted ones included.
    c_count : int
        Physical contact or collision events.
    d_min : float
        Minimum clearance to the obstacle [m] (Eq. 21).
    e_recovery : int
        Recovery actions invoked by the navigation stack.
    t_nav : float
        Navigation time from NavigateToPose feedback [s].
    """

    p_success: float
    c_count: int
    d_min: float
    e_recovery: int
    t_nav: float

    def as_tuple(self) -> tuple[float, int, float, int, float]:
        """The vector in the paper's order."""
        return (self.p_success, self.c_count, self.d_min, self.e_recovery, self.t_nav)


def safety_vector(
    successes: int,
    attempts: int,
    collisions: int,
    d_min_m: float,
    recoveries: int,
    t_nav_s: float,
) -> SafetyVector:
    """The safety-performance vector of Eq. 16, P_success = successes / attempts.

    Parameters
    ----------
    successes : int
        Runs that reached the goal.
    attempts : int
        All attempted runs, including unsuccessful and aborted ones (Sec. 2.5.5), > 0.
    collisions : int
        Contact events C_count.
    d_min_m : float
        Minimum clearance [m] (:func:`d_min`, or its summary over runs).
    recoveries : int
        Recovery actions E_recovery.
    t_nav_s : float
        Navigation time [s].

    Returns
    -------
    SafetyVector
    """
    if attempts <= 0:
        raise MetricInputError(f"attempts must be > 0, got {attempts}")
    if not 0 <= successes <= attempts:
        raise MetricInputError(f"successes must be in [0, {attempts}], got {successes}")
    if collisions < 0 or recoveries < 0:
        raise MetricInputError("collisions and recoveries are counts, >= 0")
    return SafetyVector(
        p_success=successes / attempts,
        c_count=int(collisions),
        d_min=float(d_min_m),
        e_recovery=int(recoveries),
        t_nav=float(t_nav_s),
    )


# ---- summaries (Sec. 2.5.5) --------------------------------------------------------------------


Domain = Literal["real", "positive", "unit_interval", "binary"]
"""Where a per-run quantity lives, which picks its confidence interval (:func:`mean_sd_ci`)."""

CI_METHODS: dict[str, str] = {
    "t": "t-based interval of the mean, mean -+ t_{n-1} sd / sqrt(n)",
    "lognormal-cox": (
        "log-normal interval of the mean (modified Cox): "
        "exp(ybar + s^2/2 -+ t_{n-1} sqrt(s^2/n + s^4/(2(n-1)))), y = ln x"
    ),
    "bootstrap-percentile": (
        f"percentile bootstrap of the mean ({BOOTSTRAP_RESAMPLES} resamples, fixed seed)"
    ),
    "clopper-pearson": "exact (Clopper-Pearson) binomial interval of the share of runs",
}
"""Every confidence-interval method :func:`mean_sd_ci` uses, by name, with its formula."""


@dataclass(frozen=True)
class MeanSdCi:
    """Mean, sample SD (ddof = 1) and a confidence interval of the mean.

    Attributes
    ----------
    mean, sd : float
        Arithmetic mean and sample SD (ddof = 1; NaN for one value).
    ci_low, ci_high : float
        The interval of the mean (NaN where ``method`` cannot give one).
    n : int
        Number of values (0 when unknown: a summary built by hand).
    method : str
        A key of :data:`CI_METHODS`.
    """

    mean: float
    sd: float
    ci_low: float
    ci_high: float
    n: int = 0
    method: str = "t"

    @property
    def half_width(self) -> float:
        """Half-width of the confidence interval (t_0.975,n-1 sd / sqrt(n) for ``"t"``)."""
        return 0.5 * (self.ci_high - self.ci_low)


@dataclass(frozen=True)
class MedianIqr:
    """Median and the first and third quartiles (the paper's "median [IQR]")."""

    median: float
    q1: float
    q3: float


def mean_sd_ci(
    values: npt.ArrayLike, confidence: float = 0.95, domain: Domain = "real"
) -> MeanSdCi:
    """Mean +- SD with a confidence interval of the mean that stays in the quantity's domain.

    The Stage 1-2 summary (Sec. 2.5.5) is mean +- SD with a t-based CI,

        CI = mean -+ t_{(1 + confidence)/2, n-1} sd / sqrt(n),   sd with ddof = 1

    which, with few runs, reaches below zero for a closure or an RMSE. ``domain`` picks an
    interval that cannot leave the quantity's range (:data:`CI_METHODS`):

    - ``"real"``: the t-based interval above (a signed quantity: the optimism gap).
    - ``"positive"``: the modified Cox interval of a log-normal mean (Olsson 2005),
      exp(ybar + s^2/2 -+ t_{n-1} sqrt(s^2/n + s^4 / (2 (n - 1)))) with y = ln x, strictly
      positive; a value <= 0 falls back to the percentile bootstrap.
    - ``"unit_interval"``: a share in [0, 1] per run: the percentile bootstrap of the mean,
      inside [min, max] of the values (:func:`bootstrap_mean_ci`).
    - ``"binary"``: 0/1 per run: the exact Clopper-Pearson interval of the share of runs.

    The mean and the SD are the arithmetic ones whatever the domain, as the paper reports.

    Parameters
    ----------
    values : array_like, shape (n,)
        Per-run values, n >= 1; with n = 1 the SD is NaN, and so is the CI but for
        ``"binary"``.
    confidence : float
        Two-sided confidence level.
    domain : {"real", "positive", "unit_interval", "binary"}
        Where the quantity lives.

    Returns
    -------
    MeanSdCi

    Raises
    ------
    MetricInputError
        A value outside ``domain`` ("unit_interval", "binary") or an unknown domain.
    """
    x = _series("values", values, min_len=1)
    n = x.shape[0]
    mean = float(np.mean(x))
    if domain == "binary":
        if not np.all((x == 0.0) | (x == 1.0)):
            raise MetricInputError("binary values must be 0 or 1")
        k = int(np.count_nonzero(x))
        ci = _stats().binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
        sd = float(np.std(x, ddof=1)) if n > 1 else math.nan
        return MeanSdCi(mean, sd, float(ci.low), float(ci.high), n, "clopper-pearson")
    if domain == "unit_interval" and not np.all((x >= 0.0) & (x <= 1.0)):
        raise MetricInputError("unit_interval values must lie in [0, 1]")
    if domain not in ("real", "positive", "unit_interval"):
        raise MetricInputError(f"unknown domain {domain!r}")
    if n == 1:
        method = {"real": "t", "positive": "lognormal-cox"}.get(domain, "bootstrap-percentile")
        return MeanSdCi(mean, math.nan, math.nan, math.nan, 1, method)
    sd = float(np.std(x, ddof=1))
    t = float(_stats().t.ppf(0.5 + 0.5 * confidence, n - 1))
    if domain == "real":
        half = t * sd / math.sqrt(n)
        return MeanSdCi(mean, sd, mean - half, mean + half, n, "t")
    if domain == "positive" and np.all(x > 0.0):
        y = np.log(x)
        y_bar, s2 = float(np.mean(y)), float(np.var(y, ddof=1))
        centre = y_bar + 0.5 * s2
        half = t * math.sqrt(s2 / n + s2 * s2 / (2.0 * (n - 1)))
        return MeanSdCi(
            mean, sd, math.exp(centre - half), math.exp(centre + half), n, "lognormal-cox"
        )
    low, high = bootstrap_mean_ci(x, confidence)
    return MeanSdCi(mean, sd, low, high, n, "bootstrap-percentile")


def bootstrap_mean_ci(
    values: npt.ArrayLike, confidence: float = 0.95, seed: int = BOOTSTRAP_SEED
) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean (``scipy.stats.bootstrap``), reproducible.

    The interval's ends are means of resamples of the values, so they lie inside
    [min, max] of the values and keep a bounded quantity in its bounds. With few values it is
    too narrow (n = 2 gives about [min, max]); equal values give [value, value].

    Parameters
    ----------
    values : array_like, shape (n,)
        Per-run values, n >= 2.
    confidence : float
        Two-sided confidence level.
    seed : int
        Seed of the resampling (:data:`BOOTSTRAP_SEED`): a report is the same for the same
        runs.

    Returns
    -------
    tuple of float
        (low, high).
    """
    x = _series("values", values, min_len=2)
    if np.all(x == x[0]):
        return float(x[0]), float(x[0])
    res = _stats().bootstrap(
        (x,),
        np.mean,
        n_resamples=BOOTSTRAP_RESAMPLES,
        confidence_level=confidence,
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def median_iqr(values: npt.ArrayLike) -> MedianIqr:
    """Median [Q1, Q3], the continuous Stage 3 summary (Sec. 2.5.5).

    Quartiles by linear interpolation between order statistics (NumPy's default).

    Parameters
    ----------
    values : array_like, shape (n,)
        Per-run values, n >= 1.

    Returns
    -------
    MedianIqr
    """
    x = _series("values", values, min_len=1)
    q1, median, q3 = np.percentile(x, [25.0, 50.0, 75.0])
    return MedianIqr(float(median), float(q1), float(q3))


def format_mean_sd(
    x: MeanSdCi | npt.ArrayLike, scale: float = 100.0, unit: str = "cm", decimals: int = 2
) -> str:
    """Format a summary as "mean ± SD unit" in display units, e.g. "1.18 ± 0.96 cm".

    Parameters
    ----------
    x : MeanSdCi or array_like
        A summary, or the per-run values to summarise (:func:`mean_sd_ci`), in SI units.
    scale : float
        Factor to the display unit (100: m -> cm).
    unit : str
        Appended after a space; "" for the bare "1.18 ± 0.96" of a table with the unit in
        its header.
    decimals : int
        Digits after the point.

    Returns
    -------
    str
    """
    s = x if isinstance(x, MeanSdCi) else mean_sd_ci(x)
    text = f"{s.mean * scale:.{decimals}f} ± {s.sd * scale:.{decimals}f}"
    return f"{text} {unit}" if unit else text


def map_ssim(estimate: npt.ArrayLike, truth: npt.ArrayLike) -> float:
    """SSIM of an estimated occupancy map against a reference map (Eq. 15 / A19).

    Both maps become the 8-bit image map_saver writes and map_server reads (trinary mode):
    occupied 0 where p > 0.65, free 254 where p < 0.196, unknown 205 otherwise and where the
    value is -1; the images are compared by :func:`occupancy_ssim` with its defaults (L = 255,
    C1 = (0.01 L)^2, C2 = (0.03 L)^2, uniform 7 x 7 window), i.e. scikit-image's
    structural_similarity with data_range=255.

    The caller puts both maps on one grid: same resolution, same origin, same shape. The
    twin's truth lands on the estimate's grid with ``jackson.sim.raster.raster(world,
    grid.resolution_m, bounds=(x0, y0, x0 + width * res, y0 + height * res))`` when the
    estimate's origin is a multiple of the resolution (the mapper's always is); to score a
    fixed extent (e.g. the world plus a margin), slice both arrays to the same window, padding
    the estimate with -1 where it does not reach. A truth made of free space everywhere off the
    obstacles scores the unobservable outside of a room as free against the estimate's
    unknown; ``jackson.sim.raster.reachable_free`` gives the free space a map can hold, the
    rest of the truth is then -1.

    Parameters
    ----------
    estimate : array_like, shape (H, W)
        Occupancy in ``nav_msgs/OccupancyGrid`` values: -1 unknown, 0-100 [%]
        (``OccupancyGrid.data``).
    truth : array_like, shape (H, W)
        The reference on the same grid: the same values, or bool (True occupied, False free).

    Returns
    -------
    float
        Mean SSIM, 1 for maps of the same classes everywhere.
    """
    from jackson.host.nav.grid import (
        FREE_THRESH,
        OCCUPIED_THRESH,
        PGM_FREE,
        PGM_OCCUPIED,
        PGM_UNKNOWN,
    )

    def image(name: str, value: npt.ArrayLike) -> npt.NDArray[np.uint8]:
        arr = np.asarray(value)
        if arr.ndim != 2:
            raise MetricInputError(f"{name} must be a 2-D occupancy map, got shape {arr.shape}")
        if arr.dtype == np.bool_:
            arr = np.where(arr, 100, 0)
        p = arr.astype(np.float64) / 100.0
        known = arr >= 0
        out = np.full(arr.shape, PGM_UNKNOWN, np.uint8)
        out[known & (p > OCCUPIED_THRESH)] = PGM_OCCUPIED
        out[known & (p < FREE_THRESH)] = PGM_FREE
        return out

    return occupancy_ssim(image("estimate", estimate), image("truth", truth))
