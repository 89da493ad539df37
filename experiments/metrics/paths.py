"""Stage 1-2 metrics: closure, cross-track, heading, figure-eight geometry (Sec. 2.5.2, 4.2)."""

from __future__ import annotations

import math
from typing import cast

import numpy as np
import numpy.typing as npt

from jackson.experiments.metrics.inputs import (
    FloatArray,
    MetricInputError,
    as_points,
    as_series,
    check_same_length,
    wrap_angle,
)

_CHUNK_ELEMENTS = 1 << 20  # points x segments evaluated at once by the nearest-point search


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
    xy = as_points("xy_m", xy_m)
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
    p = as_points("points_m", points_m)
    poly = as_points("polyline_m", polyline_m)
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


def angle_rms(a_rad: npt.ArrayLike, b_rad: npt.ArrayLike, name_a: str, name_b: str) -> float:
    a = as_series(name_a, a_rad)
    b = as_series(name_b, b_rad)
    check_same_length(name_a, a, name_b, b)
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
    return angle_rms(yaw_est_rad, yaw_ref_rad, "yaw_est_rad", "yaw_ref_rad")


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
    xy = as_points("xy_m", xy_m, min_rows=3)
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
    yaw = as_series("yaw_unwrapped_rad", yaw_unwrapped_rad)
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
    xy = as_points("xy_m", xy_m)
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
