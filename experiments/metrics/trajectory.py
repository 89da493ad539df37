"""Baseline-referenced trajectory deviation of Stage 3 runs (Eq. 19-20)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
import numpy.typing as npt

from jackson.experiments.metrics.inputs import FloatArray, MetricInputError, as_points
from jackson.experiments.metrics.paths import point_to_polyline_distance

BASELINE_SAMPLES = 200  # points of a resampled trajectory in the median baseline
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
    xy = as_points("xy_m", xy_m)
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
    xy = as_points("xy_m", xy_m)
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
