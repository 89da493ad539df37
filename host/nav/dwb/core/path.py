"""The global path as the local planner uses it: pruned, cut to the window, densified to cells.

The critics that follow the path read it through the cells it crosses on the local costmap
(:class:`PlanCells`), taken as Nav2's DWB transforms the plan: from the path point nearest the
robot, back over the points within ``prune_distance`` of it and forward up to the first point
farther than ``forward_prune_distance``, both capped at half the window (:func:`plan_span`);
that slice densified to the costmap's resolution (:func:`densify`), from its first point on a
known cell to the last before it leaves the known window (:func:`plan_cells`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.host.nav.costmap import NO_INFORMATION, Costmap
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True)
class PlanCells:
    """The cells of the global path in the local window, in path order.

    Attributes
    ----------
    rows, cols : ndarray of int, shape (N,)
        Row and column of each cell of the densified path, from the first on a known cell to
        the last before the path leaves the known window (repeats kept).
    reaches_end : bool
        Whether the last of them is the path's end (else the path leaves the window there).
    """

    rows: IntArray
    cols: IntArray
    reaches_end: bool


def densify(path: FloatArray, spacing_m: float) -> FloatArray:
    """The path with points inserted so that neighbours are at most ``spacing_m`` apart.

    Parameters
    ----------
    path : ndarray, shape (N, 2)
        Waypoints [m].
    spacing_m : float
        Largest gap [m].

    Returns
    -------
    ndarray, shape (N', 2)
        The denser path, original points kept.
    """
    if len(path) < 2:
        return path
    seg = np.diff(path, axis=0)
    n = np.maximum(1, np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / spacing_m).astype(int))
    idx = np.repeat(np.arange(len(seg)), n)
    frac = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
    return np.vstack((path[idx] + frac[:, None] * seg[idx], path[-1:]))


def own_granularity(trajectory: FloatArray, linear_m: float, angular_rad: float) -> FloatArray:
    """The poses of a roll-out at its own granularity, as Nav2's DWB publishes its chosen
    trajectory: ``K = ceil(max(length / linear_m, |turn| / angular_rad))`` steps (at least
    one), evenly through the roll-out's poses, first and last kept. The roll-outs share the
    step count of the most demanding one (136 poses for a 2 rad/s target over 1.7 s); a nearly
    straight trajectory at 0.26 m/s needs 9.

    Parameters
    ----------
    trajectory : ndarray, shape (K, 3)
        x, y [m], yaw [rad] at equal time steps.
    linear_m, angular_rad : float
        :class:`~jackson.host.nav.dwb.core.config.DwbConfig`'s ``linear_granularity_m`` and
        ``angular_granularity_rad``.

    Returns
    -------
    ndarray, shape (J, 3)
        J <= K poses of ``trajectory``.
    """
    k = len(trajectory)
    if k <= 2:
        return trajectory.copy()
    length = float(np.hypot(*np.diff(trajectory[:, :2], axis=0).T).sum())
    turn = float(np.abs(np.diff(np.unwrap(trajectory[:, 2]))).sum())
    steps = max(1, math.ceil(max(length / linear_m, turn / angular_rad) - 1e-9))
    if steps >= k - 1:
        return trajectory.copy()
    idx = np.unique(np.rint(np.linspace(0, k - 1, steps + 1)).astype(np.intp))
    return np.asarray(trajectory[idx], np.float64)


def prune_path(path: FloatArray, x_m: float, y_m: float) -> FloatArray:
    """The path from its point nearest (x, y) onwards.

    Parameters
    ----------
    path : ndarray, shape (N, 2)
        Waypoints [m].
    x_m, y_m : float
        Robot position [m].

    Returns
    -------
    ndarray, shape (N', 2)
        The remaining path.
    """
    if len(path) == 0:
        return path
    i = int(np.argmin(np.hypot(path[:, 0] - x_m, path[:, 1] - y_m)))
    return path[i:]


def plan_span(
    pose: Pose2D,
    path: FloatArray,
    costmap: Costmap,
    prune_distance_m: float,
    forward_prune_distance_m: float,
) -> tuple[int, int]:
    """The slice [begin, end) of the global path the planner works with (Nav2's transform).

    Parameters
    ----------
    pose : Pose2D
        Robot pose, map frame.
    path : ndarray, shape (N, 2), N >= 1
        The global path [m].
    costmap : Costmap
        The local costmap (its window caps both distances at half its size).
    prune_distance_m, forward_prune_distance_m : float
        How far behind and ahead of the path point nearest the robot the slice reaches [m].

    Returns
    -------
    tuple of int
        (begin, end), never empty: from the first point behind the nearest one that lies
        within the back distance, to the first point ahead beyond the forward distance.
    """
    rows, cols = costmap.shape
    half_window_m = 0.5 * max(rows, cols) * costmap.resolution_m
    d = np.hypot(path[:, 0] - pose.x, path[:, 1] - pose.y)
    near = int(np.argmin(d))
    behind = np.flatnonzero(d[:near] >= min(half_window_m, prune_distance_m))
    begin = int(behind[-1]) + 1 if len(behind) else 0
    ahead = np.flatnonzero(d[near:] > min(half_window_m, forward_prune_distance_m))
    end = near + int(ahead[0]) if len(ahead) else len(path)
    return begin, max(end, begin + 1)


def plan_cells(path: FloatArray, span: tuple[int, int], costmap: Costmap) -> PlanCells | None:
    """The cells of the path's slice, densified to the costmap's resolution.

    Parameters
    ----------
    path : ndarray, shape (N, 2)
        The global path [m].
    span : tuple of int
        Its slice, from :func:`plan_span`.
    costmap : Costmap
        The local costmap.

    Returns
    -------
    PlanCells or None
        From the first cell of the slice on a known cell of the costmap to the last before it
        leaves; None when no cell of it is known.
    """
    p = densify(path[span[0] : span[1]], costmap.resolution_m)
    r, c = costmap.world_to_cell(p[:, 0], p[:, 1])
    ok = costmap.inside(r, c)
    ok[ok] = costmap.costs[r[ok], c[ok]] != NO_INFORMATION
    if not np.any(ok):
        return None
    first = int(np.argmax(ok))
    off = np.flatnonzero(~ok[first:])
    last = first + (int(off[0]) - 1 if len(off) else len(ok) - first - 1)
    reaches_end = last == len(p) - 1 and bool(np.allclose(p[-1], path[-1]))
    return PlanCells(r[first : last + 1], c[first : last + 1], reaches_end)
