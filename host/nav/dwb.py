"""A DWB-style local planner: sample (v, w), roll each out, score it with weighted critics.

Each control period (1 / controller_frequency; Nav2 bringup: 20 Hz) the planner

1. samples the dynamic window: the velocities reachable from the current one within
   ``sim_time`` under the limiter's acceleration and deceleration bounds (``LimiterConfig``,
   the ramp of :func:`jackson.host.actuation.limiter.ramp`), inside v in [min_vel_x, max_v]
   (min_vel_x = 0: no reversing outside the back-up recovery) and |w| <= max_w, with
   ``vx_samples`` x ``vtheta_samples`` targets (plus w = 0 when it lies inside);
2. applies the minimum in-place rotation speed (DWB's min_speed_theta; REFERENCE: 0.30 rad/s):
   a target with v = 0 and 0 < |w| < 0.30 becomes |w| = 0.30;
3. rolls every target out for ``sim_time`` (1.7 s): the velocity ramps from the current one
   towards the target at the limiter's bounds (:func:`velocity_profile`, the limiter's ramp in
   continuous time), so the first period of every roll-out is exactly what the limiter will
   let through; poses are integrated with the midpoint rule, ceil(max(|v| T / 0.05 m,
   |w| T / 0.025 rad)) steps for the most demanding target (DWB's granularity rule);
4. checks each roll-out for collisions with the robot's disc and envelope rectangle
   (:meth:`Costmap.trajectories_collide`) at every pose where the centre or a footprint corner
   may have moved half a cell since the last pose checked, except the roll-outs that never
   come within reach of an obstacle (:meth:`Costmap.clear_reach_m`, every 16 steps), which
   cannot collide;
5. scores all roll-outs at once, J = sum_i scale_i raw_i (Eq. 11 of the paper, with Nav2
   bringup's critics and scales); a critic may also reject a roll-out:

   ============  =====  =========================================================
   critic        scale  raw score
   ============  =====  =========================================================
   RotateToGoal  32.0   inside the xy goal tolerance (latched) only: while still
                        moving, v^2 * 5.0 + |yaw error at the end|, rejecting a
                        target not slower than now; once slower than 0.25 m/s,
                        |yaw error at the end|, rejecting any translation
   Oscillation   1.0    0; rejects an in-place rotation against the sign of the
                        previous one until the robot moved 0.05 m or 0.2 rad
   BaseObstacle  0.02   cost of the last pose's cell; rejects a colliding roll-out
   GoalAlign     24.0   goal map at the point 0.1 m ahead of the last pose
   PathAlign     32.0   path map at the point 0.1 m ahead of the last pose, scaled
                        by resolution / 2 as DWB does; off within 0.1 m of the goal
                        and, as GoalAlign, while RotateToGoal turns in place
   PathDist      32.0   path map at the last pose
   GoalDist      24.0   goal map at the last pose
   ============  =====  =========================================================

6. returns the lowest total's target (as DWB does; the limiter ramps towards it), or no
   command when every roll-out is rejected (DWB's "no legal trajectories"), with the share
   each critic rejected.

The path and goal maps are Manhattan distances in cells over the local costmap, from the cells
of the global path (Nav2's plan transform: from the path point nearest the robot, back within
``prune_distance`` and forward until a point lies beyond ``forward_prune_distance``, both
capped at half the window) or from its last cell (for GoalAlign pushed 0.1 m on towards the
goal when that cell is the path's end). They are propagated through the cells below inscribed
only, as ROS 1's dwb_critics did (Nav2's version propagates through obstacles), by one
breadth-first search each (:func:`grid_distance`) and cached while the costmap and the sources
stay the same. Cells no source reaches score the number of cells.

The cycle is vectorised over all targets, and evaluates only what it reads: the velocity and
heading profiles are computed once per distinct linear and angular target (a 20 x 21 window
has about 20 of each), every 16th and the end pose of all roll-outs by small matrix products
of path lengths and headings, the poses of the collision test only for the roll-outs that
come near an obstacle, and the whole trajectory only for the one chosen (:class:`Rollouts`).

Where this differs from Nav2's DWB, measured on the paper's Stage 3 course in closed loop:

* the window spans ``sim_time``, not one period (Nav2's LimitedAccelGenerator): from rest the
  one-period window only holds 4 cm roll-outs, which leave the cell-quantised distance maps
  unchanged, and the robot never started;
* distances stop at obstacles: through them, GoalDist and GoalAlign (48 per cell together,
  Manhattan) pull the robot straight at the cylinder whenever the goal lies within the window;
  in 6 of 8 runs of the course the robot was still trapped in front of it after 60 s;
* collisions are tested against the obstacles' returns, not cells, with an escape rule for a
  robot already touching one (see :mod:`jackson.host.nav.costmap`);
* GoalAlign and PathAlign are off while RotateToGoal turns the stopped robot to the goal's
  yaw: a turn of d rad moves their 0.1 m forward point by 2 d cells (48 d) while RotateToGoal
  gains only 32 d, so the robot never turned.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order

from jackson.common.geometry import wrap_angle, wrap_angles
from jackson.host.actuation.limiter import LimiterConfig, ramp
from jackson.host.nav.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    NO_INFORMATION,
    Costmap,
)
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]
ComplexArray = npt.NDArray[np.complex128]

_CULL_STEPS = 16  # roll-out steps per block when sorting out the roll-outs far from obstacles

CRITICS = (
    "RotateToGoal",
    "Oscillation",
    "BaseObstacle",
    "GoalAlign",
    "PathAlign",
    "PathDist",
    "GoalDist",
)
"""Critic names, in Nav2 bringup's order."""


@dataclass(frozen=True)
class DwbConfig:
    """Sampling, simulation and critic parameters (Nav2 bringup's DWB values by default).

    Attributes
    ----------
    controller_frequency_hz : float
        Control rate [Hz] (20).
    vx_samples, vtheta_samples : int
        Samples across the window per axis (20, 20).
    sim_time_s : float
        Roll-out length [s] (1.7).
    linear_granularity_m, angular_granularity_rad : float
        Largest step between roll-out poses [m], [rad] (0.05, 0.025).
    min_vel_x_m_s : float
        Lowest linear velocity sampled [m/s] (0: no reversing).
    min_speed_theta_rad_s : float
        Lowest |w| of an in-place rotation [rad/s] (REFERENCE: 0.30).
    xy_goal_tolerance_m : float
        Distance at which RotateToGoal takes over [m] (REFERENCE: 0.25).
    trans_stopped_velocity_m_s : float
        Speed below which the robot counts as stopped at the goal [m/s] (0.25).
    rotate_to_goal_scale, rotate_to_goal_slowing_factor, rotate_to_goal_lookahead_time_s
        RotateToGoal (32.0, 5.0, -1.0: the trajectory's end).
    oscillation_scale, oscillation_reset_dist_m, oscillation_reset_angle_rad
        Oscillation (1.0, 0.05 m, 0.2 rad).
    oscillation_x_only_threshold_m_s : float
        The rotation trend is tracked only at |v| at or below this [m/s] (0: DWB's value
        when min_speed_xy is 0, as in bringup).
    base_obstacle_scale : float
        BaseObstacle (0.02).
    goal_align_scale, goal_align_forward_point_distance_m
        GoalAlign (24.0, 0.1 m).
    path_align_scale, path_align_forward_point_distance_m
        PathAlign (32.0, 0.1 m).
    path_dist_scale, goal_dist_scale : float
        PathDist (32.0), GoalDist (24.0).
    prune_distance_m, forward_prune_distance_m : float
        How much of the global path behind and ahead of the robot the critics use [m]
        (2.0, 2.0; both capped at half the local window).
    """

    controller_frequency_hz: float = 20.0
    vx_samples: int = 20
    vtheta_samples: int = 20
    sim_time_s: float = 1.7
    linear_granularity_m: float = 0.05
    angular_granularity_rad: float = 0.025
    min_vel_x_m_s: float = 0.0
    min_speed_theta_rad_s: float = 0.30
    xy_goal_tolerance_m: float = 0.25
    trans_stopped_velocity_m_s: float = 0.25
    rotate_to_goal_scale: float = 32.0
    rotate_to_goal_slowing_factor: float = 5.0
    rotate_to_goal_lookahead_time_s: float = -1.0
    oscillation_scale: float = 1.0
    oscillation_reset_dist_m: float = 0.05
    oscillation_reset_angle_rad: float = 0.2
    oscillation_x_only_threshold_m_s: float = 0.0
    base_obstacle_scale: float = 0.02
    goal_align_scale: float = 24.0
    goal_align_forward_point_distance_m: float = 0.1
    path_align_scale: float = 32.0
    path_align_forward_point_distance_m: float = 0.1
    path_dist_scale: float = 32.0
    goal_dist_scale: float = 24.0
    prune_distance_m: float = 2.0
    forward_prune_distance_m: float = 2.0

    def __post_init__(self) -> None:
        for name in (
            "controller_frequency_hz", "sim_time_s", "linear_granularity_m",
            "angular_granularity_rad", "xy_goal_tolerance_m", "prune_distance_m",
            "forward_prune_distance_m",
        ):  # fmt: skip
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"DwbConfig.{name} must be finite and > 0, got {value}")
        for name in ("vx_samples", "vtheta_samples"):
            if getattr(self, name) < 1:
                raise ValueError(f"DwbConfig.{name} must be >= 1, got {getattr(self, name)}")
        for name in (
            "min_vel_x_m_s", "min_speed_theta_rad_s", "trans_stopped_velocity_m_s",
            "rotate_to_goal_scale", "rotate_to_goal_slowing_factor", "oscillation_scale",
            "oscillation_x_only_threshold_m_s", "base_obstacle_scale", "goal_align_scale",
            "goal_align_forward_point_distance_m", "path_align_scale",
            "path_align_forward_point_distance_m", "path_dist_scale", "goal_dist_scale",
        ):  # fmt: skip
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"DwbConfig.{name} must be finite and >= 0, got {value}")

    @property
    def sim_period_s(self) -> float:
        """One control period [s]."""
        return 1.0 / self.controller_frequency_hz


@dataclass(frozen=True)
class Command:
    """The local planner's choice for one control period.

    Attributes
    ----------
    v_m_s, w_rad_s : float
        Velocity command [m/s], [rad/s]; (0, 0) when ``valid`` is False.
    trajectory : ndarray, shape (K, 3)
        The chosen roll-out (x [m], y [m], yaw [rad], map frame): /local_plan; empty when
        no trajectory was legal.
    scores : Mapping of str to float
        Weighted score (scale x raw) of each critic for the chosen trajectory.
    total : float
        Sum of ``scores``.
    valid : bool
        Whether any trajectory was legal.
    reason : str
        Why no trajectory was legal (share of samples each critic rejected), else "".
    samples, legal : int
        Trajectories evaluated and accepted.
    """

    v_m_s: float
    w_rad_s: float
    trajectory: FloatArray
    scores: Mapping[str, float] = field(default_factory=dict)
    total: float = math.inf
    valid: bool = True
    reason: str = ""
    samples: int = 0
    legal: int = 0


class RotateToGoalCritic:
    """Slow down and turn to the goal's yaw once inside the xy goal tolerance (stateful).

    Parameters
    ----------
    config : DwbConfig
        Tolerance, stop speed, slowing factor and lookahead.
    """

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self.in_window = False
        self.rotating = False
        self._speed_sq = 0.0
        self._goal_yaw = 0.0

    def reset(self) -> None:
        """Forget the latched goal-window and rotating states (a new goal)."""
        self.in_window = False
        self.rotating = False

    def prepare(self, pose: Pose2D, v_m_s: float, goal: Pose2D) -> None:
        """Latch the goal window and the stopped state from the current pose and speed.

        Parameters
        ----------
        pose : Pose2D
            Robot pose.
        v_m_s : float
            Current linear velocity [m/s].
        goal : Pose2D
            The goal.
        """
        c = self.config
        self.in_window = self.in_window or pose.distance(goal) <= c.xy_goal_tolerance_m
        self._speed_sq = v_m_s * v_m_s
        stopped = self._speed_sq <= c.trans_stopped_velocity_m_s**2
        self.rotating = self.rotating or (self.in_window and stopped)
        self._goal_yaw = goal.yaw

    def pose_index(self, t_s: FloatArray) -> int:
        """Which roll-out pose's heading :meth:`score` reads: at the lookahead time, or the last.

        Parameters
        ----------
        t_s : ndarray, shape (K,)
            Time of each roll-out pose [s].

        Returns
        -------
        int
            Index into the K poses.
        """
        lookahead_s = self.config.rotate_to_goal_lookahead_time_s
        if lookahead_s >= 0.0:
            return min(int(np.searchsorted(t_s, lookahead_s)), len(t_s) - 1)
        return len(t_s) - 1

    def score(
        self, v: FloatArray, yaw: FloatArray, v_brake_m_s: float
    ) -> tuple[FloatArray, BoolArray]:
        """Raw scores and legality of every trajectory.

        Parameters
        ----------
        v : ndarray, shape (M,)
            Sampled linear velocities [m/s].
        yaw : ndarray, shape (M,)
            Roll-out headings at pose :meth:`pose_index` [rad].
        v_brake_m_s : float
            The slowest linear velocity in the window (hardest braking) [m/s].

        Returns
        -------
        tuple of ndarray
            (raw scores (M,), legal mask (M,)).
        """
        m = v.shape[0]
        if not self.in_window:
            return np.zeros(m), np.ones(m, bool)
        c = self.config
        err = np.abs(wrap_angles(yaw - self._goal_yaw))
        if not self.rotating:
            speed_sq = v * v
            return speed_sq * c.rotate_to_goal_slowing_factor + err, speed_sq < self._speed_sq
        return err, np.abs(v - v_brake_m_s) <= 1e-12


class OscillationCritic:
    """Reject reversals of the in-place rotation until the robot has moved (stateful).

    Parameters
    ----------
    config : DwbConfig
        Reset distance and angle, x-only threshold.
    """

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self.reset()
        self._stationary = Pose2D()

    def reset(self) -> None:
        """Clear the rotation trend."""
        self._sign = 0
        self.positive_only = False
        self.negative_only = False

    def score(self, w: FloatArray) -> tuple[FloatArray, BoolArray]:
        """Raw scores (0) and legality of every sampled w.

        Parameters
        ----------
        w : ndarray, shape (M,)
            Sampled angular velocities [rad/s].

        Returns
        -------
        tuple of ndarray
            (zeros (M,), legal mask (M,)).
        """
        bad = (self.positive_only & (w < 0.0)) | (self.negative_only & (w > 0.0))
        return np.zeros(w.shape[0]), ~bad

    def debrief(self, pose: Pose2D, v_m_s: float, w_rad_s: float) -> None:
        """Update the trend with the command sent from ``pose``.

        Parameters
        ----------
        pose : Pose2D
            Robot pose when the command was chosen.
        v_m_s, w_rad_s : float
            The command [m/s], [rad/s].
        """
        c = self.config
        flipped = False
        if abs(v_m_s) <= c.oscillation_x_only_threshold_m_s and w_rad_s != 0.0:
            sign = 1 if w_rad_s > 0.0 else -1
            if self._sign == -sign:
                flipped = True
                self.positive_only = self.positive_only or sign > 0
                self.negative_only = self.negative_only or sign < 0
            self._sign = sign
        if flipped:
            self._stationary = pose
        if self.positive_only or self.negative_only:
            moved = pose.distance(self._stationary) > c.oscillation_reset_dist_m
            turned = abs(wrap_angle(pose.yaw - self._stationary.yaw)) > (
                c.oscillation_reset_angle_rad
            )
            if moved or turned:
                self.reset()


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
        :class:`DwbConfig`'s ``linear_granularity_m`` and ``angular_granularity_rad``.

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


def velocity_profile(
    u0: float, target: FloatArray, t_s: FloatArray, accel: float, decel: float
) -> FloatArray:
    """The velocity over time when ramping from ``u0`` towards each target.

    The continuous form of :func:`jackson.host.actuation.limiter.ramp` with a fixed target
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


def _distinct(a: FloatArray) -> tuple[FloatArray, IntArray]:
    """np.unique(a, return_inverse=True), without the sort when ``a`` is sorted already."""
    if a.size and np.all(a[1:] >= a[:-1]):
        new = np.empty(a.size, bool)
        new[0] = True
        np.not_equal(a[1:], a[:-1], out=new[1:])
        return a[new], np.cumsum(new) - 1
    values, inverse = np.unique(a, return_inverse=True)
    return values, inverse.ravel()


def _cell_index(costmap: Costmap, x_m: FloatArray, y_m: FloatArray) -> tuple[IntArray, BoolArray]:
    """Flat index of the cell of each point, clipped onto the grid, and whether it lies on it."""
    rows, cols = costmap.shape
    r, c = costmap.world_to_cell(x_m, y_m)
    ok = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    np.minimum(np.maximum(r, 0, out=r), rows - 1, out=r)
    np.minimum(np.maximum(c, 0, out=c), cols - 1, out=c)
    r *= cols
    r += c
    return r, ok


def grid_graph(free: BoolArray) -> csr_matrix:
    """The 4-connected graph of a grid's free cells (unit edges, flat row-major indices).

    Parameters
    ----------
    free : ndarray of bool, shape (rows, cols)
        Cells that may be crossed.

    Returns
    -------
    scipy.sparse.csr_matrix
        Symmetric adjacency (every edge both ways), built row by row: cell i's neighbours
        are i - cols, i - 1, i + 1, i + cols, those free with i free.
    """
    rows, cols = free.shape
    n = rows * cols
    f = free.ravel()
    edge = np.zeros((4, n), bool)  # towards i - cols, i - 1, i + 1, i + cols
    np.logical_and(f[cols:], f[:-cols], out=edge[0, cols:])
    np.logical_and(f[1:], f[:-1], out=edge[1, 1:])
    edge[1, ::cols] = False  # no left neighbour in the first column
    np.logical_and(f[:-1], f[1:], out=edge[2, :-1])
    edge[2, cols - 1 :: cols] = False  # no right neighbour in the last column
    np.logical_and(f[:-cols], f[cols:], out=edge[3, :-cols])
    indptr = np.zeros(n + 1, np.int32)
    np.cumsum(edge.sum(axis=0, dtype=np.int32), out=indptr[1:])
    neighbour = np.arange(n, dtype=np.int32) + np.array([-cols, -1, 1, cols], np.int32)[:, None]
    indices = neighbour.T[edge.T]
    return csr_matrix((np.ones(len(indices)), indices, indptr), shape=(n, n))


def grid_distance(graph: csr_matrix, shape: tuple[int, int], sources: BoolArray) -> FloatArray:
    """Manhattan distance [cells] through the graph's cells to the nearest source.

    One breadth-first search (``scipy.sparse.csgraph.breadth_first_order``) from an extra
    node joined to every source; a cell's depth in the search tree is its distance + 1,
    found for all cells at once by pointer jumping (each cell adds its ancestor's depth
    and skips to the ancestor's ancestor, log2(depth) rounds). Cells no source reaches
    (obstacles, enclosed space) get DWB's obstacle score, the number of cells.

    Parameters
    ----------
    graph : scipy.sparse.csr_matrix
        From :func:`grid_graph`.
    shape : tuple of int
        (rows, cols).
    sources : ndarray of bool, shape (rows, cols)
        Source cells.

    Returns
    -------
    ndarray, shape (rows, cols)
        Distances.
    """
    n = shape[0] * shape[1]
    src = np.flatnonzero(sources).astype(graph.indices.dtype)
    indptr = np.append(graph.indptr, graph.indptr[-1] + len(src)).astype(graph.indptr.dtype)
    indices = np.concatenate((graph.indices, src))
    with_root = csr_matrix((np.ones(len(indices)), indices, indptr), shape=(n + 1, n + 1))
    order, pred = breadth_first_order(with_root, n, directed=True, return_predecessors=True)
    # in search order: each node's parent's position (the root its own) and depth
    pos = np.empty(n + 1, np.intp)
    pos[order] = np.arange(len(order))
    up = pred[order]
    up[0] = n
    parent = pos[up]
    depth = np.ones(len(order), np.intp)
    depth[0] = 0
    while parent.any():
        depth += depth[parent]
        parent = parent[parent]
    d = np.full(n + 1, float(n))
    d[order] = depth - 1.0
    return d[:n].reshape(shape)


class Rollouts:
    """The roll-outs of one cycle, kept factored: M targets from V linear and W angular ramps.

    The linear velocity of target m follows linear ramp ``iv[m]``, its angular velocity
    angular ramp ``iw[m]``, so step i (of K) of roll-out m advances

        ds_i = ds[iv, i],   (dx_i, dy_i) = ds_i (cos, sin)(yaw_mid[iw, i])

    and its pose j is yaw_j = yaw[iw, j], (x_j, y_j) = (x_0, y_0) + sum_{i < j} (dx_i, dy_i).
    A cycle reads only part of the M x (K + 1) poses: every 16th pose and the end pose of every
    roll-out, per pair of ramps by small matrix products (:meth:`coarse`: the end poses for
    the critics, the others to sort out the roll-outs far from obstacles), the poses at a
    stride of the others for the collision test (:meth:`at_strides`) and the whole of the
    chosen one (:meth:`trajectory`); nothing else is evaluated.

    Parameters
    ----------
    pose : Pose2D
        Start pose, map frame.
    t_s : ndarray, shape (K + 1,)
        Time of each pose [s].
    ds_m : ndarray, shape (V, K)
        Path length of each step of each linear ramp [m].
    yaw_rad : ndarray, shape (W, K + 1)
        Heading of each pose of each angular ramp [rad].
    yaw_mid_rad : ndarray, shape (W, K)
        Heading at the middle of each step [rad].
    iv, iw : ndarray of int, shape (M,)
        The ramps of each target.

    Attributes
    ----------
    pose, t_s, ds_m, yaw_rad, iv, iw
        As given.
    cos_sin : ndarray, shape (2 W, K)
        cos (first W rows) and sin (last W rows) of ``yaw_mid_rad``.
    """

    def __init__(
        self,
        pose: Pose2D,
        t_s: FloatArray,
        ds_m: FloatArray,
        yaw_rad: FloatArray,
        yaw_mid_rad: FloatArray,
        iv: IntArray,
        iw: IntArray,
    ) -> None:
        self.pose = pose
        self.t_s = t_s
        self.ds_m = ds_m
        self.yaw_rad = yaw_rad
        self.iv = iv
        self.iw = iw
        w = yaw_mid_rad.shape[0]
        self.cos_sin = np.empty((2 * w, yaw_mid_rad.shape[1]))
        np.cos(yaw_mid_rad, out=self.cos_sin[:w])
        np.sin(yaw_mid_rad, out=self.cos_sin[w:])
        self._heading: ComplexArray | None = None

    @property
    def steps(self) -> int:
        """K, the steps of every roll-out."""
        return int(self.ds_m.shape[1])

    @property
    def heading(self) -> ComplexArray:
        """cos + i sin of the mid-step headings (W, K): a step is ds * heading, x and y at once."""
        if self._heading is None:
            w = self.cos_sin.shape[0] // 2
            self._heading = np.empty((w, self.steps), np.complex128)
            self._heading.real = self.cos_sin[:w]
            self._heading.imag = self.cos_sin[w:]
        return self._heading

    def coarse(self, stride: int) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Every roll-out at poses 0, stride, 2 stride, ... and K, and its path length between.

        Computed per pair of ramps (V x W) rather than per roll-out, then gathered: the steps
        of each block of ``stride`` summed by one small matrix product of path lengths and
        headings, ``ds[:, block] @ [cos; sin][:, block].T``, the blocks accumulated.

        Parameters
        ----------
        stride : int
            Steps per block.

        Returns
        -------
        tuple of ndarray
            (x [m], y [m]) of shape (B + 1, M) at the start pose and the ends of the B blocks
            (the last one may be shorter, it ends at pose K), and the path length of each
            block, shape (B, M) [m].
        """
        v, k = self.ds_m.shape
        w = self.cos_sin.shape[0] // 2
        starts = np.arange(0, k, stride)
        table = np.empty((len(starts) + 1, v, 2 * w))
        table[0] = 0.0
        for b, s0 in enumerate(starts):
            s1 = s0 + stride
            np.dot(self.ds_m[:, s0:s1], self.cos_sin[:, s0:s1].T, out=table[b + 1])
        np.cumsum(table, axis=0, out=table)
        flat = table.reshape(len(starts) + 1, v * 2 * w)
        pair = self.iv * (2 * w) + self.iw
        length = np.add.reduceat(np.abs(self.ds_m), starts, axis=1).T
        return (
            flat.take(pair, axis=1) + self.pose.x,
            flat.take(pair + w, axis=1) + self.pose.y,
            length.take(self.iv, axis=1),
        )

    def at_strides(
        self, rows: IntArray, stride: IntArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, IntArray]:
        """Some roll-outs, each at its own stride, folded into rows of equal length.

        Roll-out ``rows[i]`` is read at poses 0, s, 2 s, ... and K (s = ``stride[i]``). Its
        poses, padded with its last one, fill consecutive rows of as many poses as the
        coarsest stride gives, so that each roll-out's test is one row or a few (the padding
        repeats a pose already read).

        Parameters
        ----------
        rows : ndarray of int, shape (R,)
            The roll-outs.
        stride : ndarray of int, shape (R,)
            Steps between the poses read, 1 to K, per roll-out.

        Returns
        -------
        tuple of ndarray
            (x [m], y [m], yaw [rad]) of shape (P, C), the first row starting at the start
            pose, and the roll-out (of ``rows``) each row belongs to (P,).
        """
        k = self.steps
        # which of ``rows`` and which pose each element of the folded rows reads: the q-th
        # row of a roll-out reads poses (q width + j) s, j < width, the last one beyond K
        n_cols = k // stride + 1 + (k % stride > 0)
        width = int(n_cols.min())
        pieces = -(-n_cols // width)
        which = np.arange(len(rows)).repeat(pieces)
        q = np.arange(len(which)) - (pieces.cumsum() - pieces).repeat(pieces)
        col = (q[:, None] * width + np.arange(width)) * stride[which, None]
        np.minimum(col, k, out=col)
        # these roll-outs step by step, x + i y
        z = np.empty((len(rows), k + 1), np.complex128)
        z[:, 0] = 0.0
        np.cumsum(self.ds_m[self.iv[rows]] * self.heading[self.iw[rows]], axis=1, out=z[:, 1:])
        z += complex(self.pose.x, self.pose.y)
        owner = rows[which]
        at = z.take(which[:, None] * (k + 1) + col)
        yaw = self.yaw_rad.take(self.iw[owner, None] * (k + 1) + col)
        return at.real, at.imag, yaw, owner

    def trajectory(self, m: int) -> FloatArray:
        """Every pose of roll-out ``m``, step by step.

        Parameters
        ----------
        m : int
            The roll-out.

        Returns
        -------
        ndarray, shape (K + 1, 3)
            (x [m], y [m], yaw [rad]) per pose.
        """
        x, y, yaw = self.full(np.array([m]))
        return np.column_stack((x[0], y[0], yaw[0]))

    def full(self, rows: IntArray | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Every pose of some roll-outs (all by default), step by step.

        Parameters
        ----------
        rows : ndarray of int, shape (R,), or None
            The roll-outs; None for all M.

        Returns
        -------
        tuple of ndarray, shape (R, K + 1)
            (x [m], y [m], yaw [rad]), the start pose first.
        """
        iv = self.iv if rows is None else self.iv[rows]
        iw = self.iw if rows is None else self.iw[rows]
        ds = self.ds_m[iv]
        w = self.cos_sin.shape[0] // 2
        r, k = ds.shape
        x = np.empty((r, k + 1))
        y = np.empty((r, k + 1))
        x[:, 0], y[:, 0] = self.pose.x, self.pose.y
        np.cumsum(ds * self.cos_sin[iw], axis=1, out=x[:, 1:])
        np.cumsum(ds * self.cos_sin[w + iw], axis=1, out=y[:, 1:])
        x[:, 1:] += self.pose.x
        y[:, 1:] += self.pose.y
        return x, y, self.yaw_rad[iw]


class DwbPlanner:
    """The DWB-style local planner.

    Parameters
    ----------
    config : DwbConfig
        Sampling, simulation and critics.
    limits : LimiterConfig
        Speed and acceleration bounds; the window never leaves them.

    Attributes
    ----------
    config : DwbConfig
        As given.
    limits : LimiterConfig
        As given.
    rotate_to_goal : RotateToGoalCritic
        The stateful goal critic.
    oscillation : OscillationCritic
        The stateful oscillation critic.
    """

    def __init__(self, config: DwbConfig, limits: LimiterConfig) -> None:
        self.config = config
        self.limits = limits
        self.rotate_to_goal = RotateToGoalCritic(config)
        self.oscillation = OscillationCritic(config)
        self._maps_key: tuple[object, ...] | None = None
        self._times: dict[int, FloatArray] = {}
        self._graph_key: tuple[int, int] | None = None
        self._graph: csr_matrix | None = None
        self._window_key: tuple[object, ...] | None = None
        self._window: tuple[IntArray, IntArray, bool] | None = None
        self._maps: tuple[FloatArray, FloatArray, FloatArray] | None = None

    def reset(self) -> None:
        """Forget the stateful critics' state (a new goal)."""
        self.rotate_to_goal.reset()
        self.oscillation.reset()

    # ------------------------------------------------------------------ sampling

    def window(self, v_m_s: float, w_rad_s: float) -> tuple[float, float, float, float]:
        """The dynamic window: (v_lo, v_hi, w_lo, w_hi) reachable within ``sim_time``.

        Parameters
        ----------
        v_m_s, w_rad_s : float
            Current velocity [m/s], [rad/s].

        Returns
        -------
        tuple of float
            Bounds [m/s], [m/s], [rad/s], [rad/s], inside the speed limits.
        """
        c, lim = self.config, self.limits
        t_s = c.sim_time_s
        v0 = min(max(v_m_s, -lim.max_v_m_s), lim.max_v_m_s)
        w0 = min(max(w_rad_s, -lim.max_w_rad_s), lim.max_w_rad_s)
        v_min = min(c.min_vel_x_m_s, lim.max_v_m_s)
        v_lo = ramp(v0, v_min, t_s, lim.max_accel_m_s2, lim.max_decel_m_s2)
        v_hi = ramp(v0, lim.max_v_m_s, t_s, lim.max_accel_m_s2, lim.max_decel_m_s2)
        v_lo, v_hi = max(v_lo, v_min), max(v_hi, v_min)
        w_lo = ramp(w0, -lim.max_w_rad_s, t_s, lim.max_alpha_rad_s2, lim.max_alpha_decel_rad_s2)
        w_hi = ramp(w0, lim.max_w_rad_s, t_s, lim.max_alpha_rad_s2, lim.max_alpha_decel_rad_s2)
        return v_lo, v_hi, w_lo, w_hi

    def samples(self, v_m_s: float, w_rad_s: float) -> tuple[FloatArray, FloatArray, float]:
        """The (v, w) targets of the window, with the minimum rotation speed applied.

        Parameters
        ----------
        v_m_s, w_rad_s : float
            Current velocity [m/s], [rad/s].

        Returns
        -------
        tuple
            (v (M,), w (M,), slowest v of the window).
        """
        c = self.config
        v_lo, v_hi, w_lo, w_hi = self.window(v_m_s, w_rad_s)
        vs = _sorted_distinct(np.linspace(v_lo, v_hi, c.vx_samples, dtype=np.float64))
        ws = _sorted_distinct(np.linspace(w_lo, w_hi, c.vtheta_samples, dtype=np.float64))
        if w_lo <= 0.0 <= w_hi:
            ws = _with_zero(ws)
        w_min = min(c.min_speed_theta_rad_s, self.limits.max_w_rad_s)
        slow_turn = (ws != 0.0) & (np.abs(ws) < w_min)
        # still sorted (the slow turns move to +-w_min, beyond their neighbours towards 0)
        ws_in_place = _sorted_distinct(np.where(slow_turn, np.copysign(w_min, ws), ws))
        # (v, w) pairs in lexicographic order, each once: only a row with v = 0 changes
        rows = [ws_in_place if abs(vi) < 1e-9 else ws for vi in vs]
        v = np.repeat(vs, [len(r) for r in rows])
        return v, np.concatenate(rows), float(vs[0])

    def rollout(
        self, pose: Pose2D, velocity: tuple[float, float], v: FloatArray, w: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Roll every target out from ``pose``, ramping towards it at the limiter's bounds.

        The velocity follows :func:`velocity_profile` from the current one; the yaw
        integrates it with the trapezoidal rule, the position with the midpoint heading.
        (:meth:`compute` evaluates only the poses it reads, from :meth:`rollouts`.)

        Parameters
        ----------
        pose : Pose2D
            Start pose (map frame).
        velocity : tuple of float
            Current (v [m/s], w [rad/s]).
        v, w : ndarray, shape (M,)
            Targets [m/s], [rad/s].

        Returns
        -------
        tuple of ndarray
            (x (M, K+1), y (M, K+1), yaw (M, K+1), t (K+1,)), the start pose first.
        """
        ro = self.rollouts(pose, velocity, v, w)
        x, y, yaw = ro.full()
        return x, y, yaw, ro.t_s

    def rollouts(
        self, pose: Pose2D, velocity: tuple[float, float], v: FloatArray, w: FloatArray
    ) -> Rollouts:
        """The roll-outs of :meth:`rollout`, factored by axis and evaluated on demand.

        Parameters
        ----------
        pose : Pose2D
            Start pose (map frame).
        velocity : tuple of float
            Current (v [m/s], w [rad/s]).
        v, w : ndarray, shape (M,)
            Targets [m/s], [rad/s].

        Returns
        -------
        Rollouts
            K steps of sim_time / K, K = ceil(max(|v| T / 0.05 m, |w| T / 0.025 rad)).
        """
        c, lim = self.config, self.limits
        t_end = c.sim_time_s
        steps = max(
            float(np.abs(v).max()) * t_end / c.linear_granularity_m,
            float(np.abs(w).max()) * t_end / c.angular_granularity_rad,
        )
        k = max(1, math.ceil(steps - 1e-9))
        t = self._times.get(k)
        if t is None:
            t = self._times[k] = np.asarray(np.linspace(0.0, t_end, k + 1), np.float64)
        dt = t_end / k
        # the profiles depend on one axis each: computed per distinct target
        uv, iv = _distinct(v)
        uw, iw = _distinct(w)
        vel_v = velocity_profile(velocity[0], uv, t, lim.max_accel_m_s2, lim.max_decel_m_s2)
        vel_w = velocity_profile(
            velocity[1], uw, t, lim.max_alpha_rad_s2, lim.max_alpha_decel_rad_s2
        )
        dyaw = 0.5 * (vel_w[:, 1:] + vel_w[:, :-1]) * dt
        yaw = np.empty_like(vel_w)
        yaw[:, 0] = 0.0
        np.cumsum(dyaw, axis=1, out=yaw[:, 1:])
        yaw += pose.yaw
        mid = yaw[:, :-1] + 0.5 * dyaw
        ds = 0.5 * (vel_v[:, 1:] + vel_v[:, :-1]) * dt
        return Rollouts(pose, t, ds, yaw, mid, iv, iw)

    # ------------------------------------------------------------------ scoring

    def compute(
        self,
        pose: Pose2D,
        velocity: tuple[float, float],
        path: npt.ArrayLike,
        goal: Pose2D,
        costmap: Costmap,
    ) -> Command:
        """Choose the command for this control period.

        Parameters
        ----------
        pose : Pose2D
            Robot pose in the costmap's (map) frame.
        velocity : tuple of float
            Current (v [m/s], w [rad/s]).
        path : array_like, shape (N, 2)
            The global path [m], map frame.
        goal : Pose2D
            The goal pose.
        costmap : Costmap
            The local costmap.

        Returns
        -------
        Command
            The best legal command, or an invalid one with the reason.
        """
        c = self.config
        v0, w0 = float(velocity[0]), float(velocity[1])
        v, w, v_brake = self.samples(v0, w0)
        ro = self.rollouts(pose, (v0, w0), v, w)
        coarse = ro.coarse(_CULL_STEPS)
        x_end, y_end = coarse[0][-1], coarse[1][-1]
        yaw_end = ro.yaw_rad[:, -1].take(ro.iw)
        m = v.shape[0]
        legal: dict[str, BoolArray] = {}
        raw: dict[str, FloatArray] = {}
        scale: dict[str, float] = {}

        # RotateToGoal
        self.rotate_to_goal.prepare(pose, v0, goal)
        k_goal = self.rotate_to_goal.pose_index(ro.t_s)
        yaw_goal = yaw_end if k_goal == ro.steps else ro.yaw_rad[ro.iw, k_goal]
        raw["RotateToGoal"], legal["RotateToGoal"] = self.rotate_to_goal.score(v, yaw_goal, v_brake)
        scale["RotateToGoal"] = c.rotate_to_goal_scale

        # Oscillation
        raw["Oscillation"], legal["Oscillation"] = self.oscillation.score(w)
        scale["Oscillation"] = c.oscillation_scale

        maps = self._distance_maps(pose, path, goal, costmap)
        if maps is None:
            return Command(
                0.0, 0.0, np.empty((0, 3)), valid=False, samples=m,
                reason="no point of the global path lies on the local costmap",
            )  # fmt: skip

        # BaseObstacle: every pose on the grid and below inscribed, footprint clear
        legal["BaseObstacle"] = ~self._collisions(ro, coarse, v, w, (v0, w0), costmap)
        raw["BaseObstacle"] = costmap.cost_at(x_end, y_end).astype(np.float64)
        scale["BaseObstacle"] = c.base_obstacle_scale

        # the map-grid critics
        path_map, goal_map, goal_align_map = maps
        end_cell, end_ok = _cell_index(costmap, x_end, y_end)
        raw["PathDist"] = path_map.take(end_cell)
        raw["GoalDist"] = goal_map.take(end_cell)
        legal["PathDist"] = end_ok
        legal["GoalDist"] = end_ok
        scale["PathDist"] = c.path_dist_scale
        scale["GoalDist"] = c.goal_dist_scale
        cos_end, sin_end = np.cos(yaw_end), np.sin(yaw_end)
        for name, grid, fpd, sc in (
            ("GoalAlign", goal_align_map, c.goal_align_forward_point_distance_m,
             c.goal_align_scale),
            ("PathAlign", path_map, c.path_align_forward_point_distance_m,
             c.path_align_scale * 0.5 * costmap.resolution_m),
        ):  # fmt: skip
            if (name == "PathAlign" and pose.distance(goal) <= fpd) or self.rotate_to_goal.rotating:
                sc = 0.0  # at the goal the nose follows RotateToGoal alone
            f_cell, f_ok = _cell_index(costmap, x_end + fpd * cos_end, y_end + fpd * sin_end)
            raw[name] = grid.take(f_cell)
            legal[name] = f_ok if sc > 0.0 else np.ones(m, bool)
            scale[name] = sc

        all_ok = np.ones(m, bool)
        for name in CRITICS:
            all_ok &= legal[name]
        total = np.zeros(m)
        for name in CRITICS:
            if scale[name] != 0.0:
                total += scale[name] * raw[name]
        if not all_ok.any():
            shares = ", ".join(
                f"{name} {100.0 * np.mean(~legal[name]):.0f}%"
                for name in CRITICS
                if np.any(~legal[name])
            )
            return Command(
                0.0, 0.0, np.empty((0, 3)), valid=False, samples=m,
                reason=f"no legal trajectory of {m} ({shares})",
            )  # fmt: skip
        best = int(np.where(all_ok, total, np.inf).argmin())
        scores = {name: float(scale[name] * raw[name][best]) for name in CRITICS}
        cmd_v, cmd_w = float(v[best]), float(w[best])
        self.oscillation.debrief(pose, cmd_v, cmd_w)
        return Command(
            cmd_v, cmd_w, ro.trajectory(best), scores,
            float(total[best]), True, "", m, int(np.count_nonzero(all_ok)),
        )  # fmt: skip

    def _collisions(
        self,
        ro: Rollouts,
        coarse: tuple[FloatArray, FloatArray, FloatArray],
        v: FloatArray,
        w: FloatArray,
        velocity: tuple[float, float],
        costmap: Costmap,
    ) -> BoolArray:
        """Which roll-outs collide, each checked at the poses it needs.

        A roll-out is checked at its first and last pose and every ``stride``-th between,
        the stride as long as no point of the robot moves more than half a cell (speed
        |v| + |w| r_circumscribed, whichever of the current and target velocity is faster);
        the robot is grown by half that sweep so that nothing between two checked poses is
        missed. Strides are rounded down to powers of two, and all roll-outs are checked in
        one call (:meth:`Rollouts.at_strides` folds them into rows of equal length).
        """
        k = ro.steps
        dt_s = self.config.sim_time_s / k
        r_m = costmap.config.circumscribed_radius_m
        speed = (
            np.maximum(np.abs(v), abs(velocity[0])) + np.maximum(np.abs(w), abs(velocity[1])) * r_m
        )
        per_step_m = speed * dt_s
        half_cell = 0.5 * costmap.resolution_m
        stride = np.minimum(k, np.floor(half_cell / np.maximum(per_step_m, 1e-12)))
        group = np.exp2(np.floor(np.log2(np.maximum(stride, 1.0)))).astype(np.intp)
        margin_m = np.empty(v.shape[0])
        for g in np.bincount(group).nonzero()[0]:
            rows = group == g
            margin_m[rows] = 0.5 * min(g * float(per_step_m[rows].max()), half_cell)
        hit = np.zeros(v.shape[0], bool)
        # only the roll-outs that come within reach of an obstacle (or of the grid's edge)
        # need the test: from each pose every _CULL_STEPS steps, the centre moves at most
        # the path length of the next block
        x_c, y_c, length_m = coarse  # from ro.coarse(_CULL_STEPS)
        reach_m = costmap.clear_reach_m(x_c[:-1], y_c[:-1])
        near = np.flatnonzero(np.any(reach_m <= length_m + 1e-9, axis=0))
        if near.size == 0:
            return hit
        if costmap.compiled:  # the poses made where they are tested, the same bit for bit
            start = (0.0 + ro.pose.x, 0.0 + ro.pose.y, float(ro.yaw_rad[0, 0]))
            hit[near] = costmap.rollouts_collide(
                start, ro.ds_m, ro.cos_sin, ro.yaw_rad, ro.iv[near], ro.iw[near], group[near],
                margin_m[near],
            )  # fmt: skip
            return hit
        x, y, yaw, owner = ro.at_strides(near, group[near])
        hit_rows = costmap.trajectories_collide(x, y, yaw, margin_m=margin_m[owner])
        hit[owner[hit_rows]] = True
        return hit

    def _plan_in_window(self, pose: Pose2D, path: npt.ArrayLike, costmap: Costmap) -> FloatArray:
        """The part of the global path DWB works with, densified to the costmap's cells.

        As Nav2's DWB transforms the plan: from the path point nearest the robot, back over
        the points within ``min(window / 2, prune_distance)`` of it, and forward up to the
        first point farther than ``min(window / 2, forward_prune_distance)``.
        """
        p = np.asarray(path, np.float64).reshape(-1, 2)
        if len(p) == 0:
            return p
        begin, end = self._plan_span(pose, p, costmap)
        return densify(p[begin:end], costmap.resolution_m)

    def _plan_span(self, pose: Pose2D, p: FloatArray, costmap: Costmap) -> tuple[int, int]:
        """The slice [begin, end) of the (non-empty) path that :meth:`_plan_in_window` keeps."""
        c = self.config
        rows, cols = costmap.shape
        half_window_m = 0.5 * max(rows, cols) * costmap.resolution_m
        d = np.hypot(p[:, 0] - pose.x, p[:, 1] - pose.y)
        near = int(np.argmin(d))
        behind = np.flatnonzero(d[:near] >= min(half_window_m, c.prune_distance_m))
        begin = int(behind[-1]) + 1 if len(behind) else 0
        ahead = np.flatnonzero(d[near:] > min(half_window_m, c.forward_prune_distance_m))
        end = near + int(ahead[0]) if len(ahead) else len(p)
        return begin, max(end, begin + 1)

    def _distance_maps(
        self, pose: Pose2D, path: npt.ArrayLike, goal: Pose2D, costmap: Costmap
    ) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """Path, goal and goal-align distance maps [cells], or None without a path in view.

        The source cells are kept while the costmap and the slice of the path stay the same,
        the maps while the costmap and the source cells do.
        """
        full = np.asarray(path, np.float64).reshape(-1, 2)
        if len(full) == 0:
            return None
        span = self._plan_span(pose, full, costmap)
        window_key = (id(costmap), costmap.version, span, full.tobytes())
        if window_key != self._window_key:
            self._window_key = window_key
            self._window = self._path_cells(full, span, costmap)
        if self._window is None:
            return None
        run_r, run_c, reaches_end = self._window
        # GoalAlign's target: the path's end, pushed on towards the goal (DWB shifts only the
        # path's end, not a point where the path leaves the window)
        ar, ac = int(run_r[-1]), int(run_c[-1])
        if reaches_end:
            heading = math.atan2(goal.y - pose.y, goal.x - pose.x)
            fpd = self.config.goal_align_forward_point_distance_m
            tx, ty = costmap.cell_to_world(ar, ac)
            sr, sc = costmap.world_to_cell(
                float(tx) + fpd * math.cos(heading), float(ty) + fpd * math.sin(heading)
            )
            if costmap.inside(sr, sc):
                ar, ac = int(sr), int(sc)
        key = (id(costmap), costmap.version, run_r.tobytes(), run_c.tobytes(), ar, ac)
        if key == self._maps_key and self._maps is not None:
            return self._maps
        graph_key = (id(costmap), costmap.version)
        if graph_key != self._graph_key or self._graph is None:
            self._graph = grid_graph(costmap.costs < INSCRIBED_INFLATED_OBSTACLE)
            self._graph_key = graph_key
        graph = self._graph
        shape = costmap.shape
        sources = np.zeros(shape, bool)
        sources[run_r, run_c] = True
        path_map = grid_distance(graph, shape, sources)
        goal_src = np.zeros(shape, bool)
        goal_src[run_r[-1], run_c[-1]] = True
        goal_map = grid_distance(graph, shape, goal_src)
        if (ar, ac) == (int(run_r[-1]), int(run_c[-1])):
            align_map = goal_map
        else:
            align_src = np.zeros(shape, bool)
            align_src[ar, ac] = True
            align_map = grid_distance(graph, shape, align_src)
        self._maps_key = key
        self._maps = (path_map, goal_map, align_map)
        return self._maps

    @staticmethod
    def _path_cells(
        full: FloatArray, span: tuple[int, int], costmap: Costmap
    ) -> tuple[IntArray, IntArray, bool] | None:
        """The cells of the path's slice, densified, from the first on a known cell of the
        costmap to the last before it leaves (rows, cols, whether that is the path's end), or
        None when no cell of it is known."""
        p = densify(full[span[0] : span[1]], costmap.resolution_m)
        r, c = costmap.world_to_cell(p[:, 0], p[:, 1])
        ok = costmap.inside(r, c)
        ok[ok] = costmap.costs[r[ok], c[ok]] != NO_INFORMATION
        if not np.any(ok):
            return None
        first = int(np.argmax(ok))
        off = np.flatnonzero(~ok[first:])
        last = first + (int(off[0]) - 1 if len(off) else len(ok) - first - 1)
        reaches_end = last == len(p) - 1 and bool(np.allclose(p[-1], full[-1]))
        return r[first : last + 1], c[first : last + 1], reaches_end
