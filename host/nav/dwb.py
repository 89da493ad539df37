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
   may have moved half a cell since the last pose checked;
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
breadth-first search each (``scipy.sparse.csgraph.dijkstra``, unit weights) and cached while
the costmap and the sources stay the same. Cells no source reaches score the number of cells.

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
from scipy.sparse.csgraph import dijkstra

from jackson.common.geometry import wrap_angle
from jackson.host.actuation.limiter import LimiterConfig, ramp
from jackson.host.nav.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    NO_INFORMATION,
    Costmap,
)
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

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

    def score(
        self, v: FloatArray, yaw: FloatArray, t_s: FloatArray, v_brake_m_s: float
    ) -> tuple[FloatArray, BoolArray]:
        """Raw scores and legality of every trajectory.

        Parameters
        ----------
        v : ndarray, shape (M,)
            Sampled linear velocities [m/s].
        yaw : ndarray, shape (M, K)
            Roll-out headings [rad].
        t_s : ndarray, shape (K,)
            Time of each roll-out pose [s].
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
        if c.rotate_to_goal_lookahead_time_s >= 0.0:
            k = int(np.searchsorted(t_s, c.rotate_to_goal_lookahead_time_s))
            end_yaw = yaw[:, min(k, yaw.shape[1] - 1)]
        else:
            end_yaw = yaw[:, -1]
        err = np.abs((end_yaw - self._goal_yaw + math.pi) % (2.0 * math.pi) - math.pi)
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
    direct = u0 + np.sign(gap) * np.minimum(np.abs(gap), rate * tt)
    t0 = abs(u0) / decel
    braking = u0 - math.copysign(decel, u0) * tt if u0 != 0.0 else np.zeros_like(tt)
    after = np.sign(r) * np.minimum(np.abs(r), accel * np.maximum(tt - t0, 0.0))
    through = np.where(tt < t0, braking, after)
    return np.asarray(np.where(same_side, direct, through), np.float64)


def grid_graph(free: BoolArray) -> csr_matrix:
    """The 4-connected graph of a grid's free cells (unit edges, flat row-major indices).

    Parameters
    ----------
    free : ndarray of bool, shape (rows, cols)
        Cells that may be crossed.

    Returns
    -------
    scipy.sparse.csr_matrix
        Upper-triangular adjacency (use undirected).
    """
    rows, cols = free.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    h = free[:, :-1] & free[:, 1:]
    v = free[:-1, :] & free[1:, :]
    i = np.concatenate((idx[:, :-1][h], idx[:-1, :][v]))
    j = np.concatenate((idx[:, 1:][h], idx[1:, :][v]))
    return csr_matrix((np.ones(len(i)), (i, j)), shape=(rows * cols, rows * cols))


def grid_distance(graph: csr_matrix, shape: tuple[int, int], sources: BoolArray) -> FloatArray:
    """Manhattan distance [cells] through the graph's cells to the nearest source.

    Cells no source reaches (obstacles, enclosed space) get DWB's obstacle score, the
    number of cells.

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
    d = dijkstra(
        graph, directed=False, indices=np.flatnonzero(sources), unweighted=True, min_only=True
    )
    d = np.where(np.isfinite(d), d, float(shape[0] * shape[1]))
    return np.asarray(d, np.float64).reshape(shape)


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
        vs = np.unique(np.linspace(v_lo, v_hi, c.vx_samples))
        ws = np.linspace(w_lo, w_hi, c.vtheta_samples)
        if w_lo <= 0.0 <= w_hi:
            ws = np.append(ws, 0.0)
        grid_v, grid_w = np.meshgrid(vs, np.unique(ws), indexing="ij")
        v, w = grid_v.ravel(), grid_w.ravel()
        w_min = min(c.min_speed_theta_rad_s, self.limits.max_w_rad_s)
        slow_turn = (np.abs(v) < 1e-9) & (w != 0.0) & (np.abs(w) < w_min)
        w_turn = np.where(slow_turn, np.copysign(w_min, w), w)
        pairs = np.asarray(np.unique(np.column_stack((v, w_turn)), axis=0), np.float64)
        return pairs[:, 0], pairs[:, 1], float(vs[0])

    def rollout(
        self, pose: Pose2D, velocity: tuple[float, float], v: FloatArray, w: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Roll every target out from ``pose``, ramping towards it at the limiter's bounds.

        The velocity follows :func:`velocity_profile` from the current one; the yaw
        integrates it with the trapezoidal rule, the position with the midpoint heading.

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
        c, lim = self.config, self.limits
        t_end = c.sim_time_s
        steps = np.maximum(
            np.abs(v) * t_end / c.linear_granularity_m,
            np.abs(w) * t_end / c.angular_granularity_rad,
        )
        k = max(1, math.ceil(float(steps.max()) - 1e-9))
        t = np.asarray(np.linspace(0.0, t_end, k + 1), np.float64)
        dt = t_end / k
        # the profiles depend on one axis each: compute them per distinct target, then gather
        uv, iv = np.unique(v, return_inverse=True)
        uw, iw = np.unique(w, return_inverse=True)
        vel_v = velocity_profile(velocity[0], uv, t, lim.max_accel_m_s2, lim.max_decel_m_s2)
        vel_w = velocity_profile(
            velocity[1], uw, t, lim.max_alpha_rad_s2, lim.max_alpha_decel_rad_s2
        )
        dyaw = 0.5 * (vel_w[:, 1:] + vel_w[:, :-1]) * dt
        yaw_u = np.empty_like(vel_w)
        yaw_u[:, 0] = 0.0
        np.cumsum(dyaw, axis=1, out=yaw_u[:, 1:])
        yaw_u += pose.yaw
        mid = yaw_u[:, :-1] + 0.5 * dyaw
        cos_u, sin_u = np.cos(mid), np.sin(mid)
        ds = (0.5 * (vel_v[:, 1:] + vel_v[:, :-1]) * dt)[iv]
        m = v.shape[0]
        x = np.empty((m, k + 1))
        y = np.empty((m, k + 1))
        x[:, 0], y[:, 0] = pose.x, pose.y
        np.cumsum(ds * cos_u[iw], axis=1, out=x[:, 1:])
        np.cumsum(ds * sin_u[iw], axis=1, out=y[:, 1:])
        x[:, 1:] += pose.x
        y[:, 1:] += pose.y
        yaw = yaw_u[iw]
        return x, y, yaw, t

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
        x, y, yaw, t = self.rollout(pose, (v0, w0), v, w)
        m = v.shape[0]
        legal: dict[str, BoolArray] = {}
        raw: dict[str, FloatArray] = {}
        scale: dict[str, float] = {}

        # RotateToGoal
        self.rotate_to_goal.prepare(pose, v0, goal)
        raw["RotateToGoal"], legal["RotateToGoal"] = self.rotate_to_goal.score(v, yaw, t, v_brake)
        scale["RotateToGoal"] = c.rotate_to_goal_scale

        # Oscillation
        raw["Oscillation"], legal["Oscillation"] = self.oscillation.score(w)
        scale["Oscillation"] = c.oscillation_scale

        # BaseObstacle: every pose on the grid and below inscribed, footprint clear
        legal["BaseObstacle"] = ~self._collisions(x, y, yaw, v, w, (v0, w0), costmap)
        raw["BaseObstacle"] = costmap.cost_at(x[:, -1], y[:, -1]).astype(np.float64)
        scale["BaseObstacle"] = c.base_obstacle_scale

        # the map-grid critics
        maps = self._distance_maps(pose, path, goal, costmap)
        if maps is None:
            return Command(
                0.0, 0.0, np.empty((0, 3)), valid=False, samples=m,
                reason="no point of the global path lies on the local costmap",
            )  # fmt: skip
        path_map, goal_map, goal_align_map = maps
        rows, cols = costmap.shape
        r_end, c_end = costmap.world_to_cell(x[:, -1], y[:, -1])
        end_ok = costmap.inside(r_end, c_end)
        r_end, c_end = np.clip(r_end, 0, rows - 1), np.clip(c_end, 0, cols - 1)
        raw["PathDist"] = path_map[r_end, c_end]
        raw["GoalDist"] = goal_map[r_end, c_end]
        legal["PathDist"] = end_ok
        legal["GoalDist"] = end_ok
        scale["PathDist"] = c.path_dist_scale
        scale["GoalDist"] = c.goal_dist_scale
        for name, grid, fpd, sc in (
            ("GoalAlign", goal_align_map, c.goal_align_forward_point_distance_m,
             c.goal_align_scale),
            ("PathAlign", path_map, c.path_align_forward_point_distance_m,
             c.path_align_scale * 0.5 * costmap.resolution_m),
        ):  # fmt: skip
            if (name == "PathAlign" and pose.distance(goal) <= fpd) or self.rotate_to_goal.rotating:
                sc = 0.0  # at the goal the nose follows RotateToGoal alone
            fx = x[:, -1] + fpd * np.cos(yaw[:, -1])
            fy = y[:, -1] + fpd * np.sin(yaw[:, -1])
            fr, fc = costmap.world_to_cell(fx, fy)
            f_ok = costmap.inside(fr, fc)
            raw[name] = grid[np.clip(fr, 0, rows - 1), np.clip(fc, 0, cols - 1)]
            legal[name] = f_ok if sc > 0.0 else np.ones(m, bool)
            scale[name] = sc

        all_ok = np.ones(m, bool)
        for name in CRITICS:
            all_ok &= legal[name]
        total = np.zeros(m)
        for name in CRITICS:
            if scale[name] != 0.0:
                total += scale[name] * raw[name]
        if not np.any(all_ok):
            shares = ", ".join(
                f"{name} {100.0 * np.mean(~legal[name]):.0f}%"
                for name in CRITICS
                if np.any(~legal[name])
            )
            return Command(
                0.0, 0.0, np.empty((0, 3)), valid=False, samples=m,
                reason=f"no legal trajectory of {m} ({shares})",
            )  # fmt: skip
        best = int(np.argmin(np.where(all_ok, total, np.inf)))
        scores = {name: float(scale[name] * raw[name][best]) for name in CRITICS}
        cmd_v, cmd_w = float(v[best]), float(w[best])
        self.oscillation.debrief(pose, cmd_v, cmd_w)
        return Command(
            cmd_v, cmd_w, np.column_stack((x[best], y[best], yaw[best])), scores,
            float(total[best]), True, "", m, int(np.count_nonzero(all_ok)),
        )  # fmt: skip

    def _collisions(
        self,
        x: FloatArray,
        y: FloatArray,
        yaw: FloatArray,
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
        missed. Strides are rounded down to powers of two and each group checked at once.
        """
        k = x.shape[1] - 1
        dt_s = self.config.sim_time_s / k
        r_m = costmap.config.circumscribed_radius_m
        speed = (
            np.maximum(np.abs(v), abs(velocity[0])) + np.maximum(np.abs(w), abs(velocity[1])) * r_m
        )
        per_step_m = speed * dt_s
        half_cell = 0.5 * costmap.resolution_m
        stride = np.minimum(k, np.floor(half_cell / np.maximum(per_step_m, 1e-12)))
        group = np.exp2(np.floor(np.log2(np.maximum(stride, 1.0)))).astype(int)
        hit = np.zeros(x.shape[0], bool)
        for g in np.unique(group):
            rows = np.flatnonzero(group == g)
            cols = np.arange(0, k + 1, g)
            if cols[-1] != k:
                cols = np.append(cols, k)
            sweep_m = min(g * float(per_step_m[rows].max()), half_cell)
            sub = np.ix_(rows, cols)
            hit[rows] = costmap.trajectories_collide(
                x[sub], y[sub], yaw[sub], margin_m=0.5 * sweep_m
            )
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
        c = self.config
        rows, cols = costmap.shape
        half_window_m = 0.5 * max(rows, cols) * costmap.resolution_m
        d = np.hypot(p[:, 0] - pose.x, p[:, 1] - pose.y)
        near = int(np.argmin(d))
        behind = np.flatnonzero(d[:near] >= min(half_window_m, c.prune_distance_m))
        begin = int(behind[-1]) + 1 if len(behind) else 0
        ahead = np.flatnonzero(d[near:] > min(half_window_m, c.forward_prune_distance_m))
        end = near + int(ahead[0]) if len(ahead) else len(p)
        return densify(p[begin : max(end, begin + 1)], costmap.resolution_m)

    def _distance_maps(
        self, pose: Pose2D, path: npt.ArrayLike, goal: Pose2D, costmap: Costmap
    ) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """Path, goal and goal-align distance maps [cells], or None without a path in view.

        The maps are cached while the costmap and the source cells stay the same.
        """
        full = np.asarray(path, np.float64).reshape(-1, 2)
        p = self._plan_in_window(pose, full, costmap)
        if len(p) == 0:
            return None
        r, c = costmap.world_to_cell(p[:, 0], p[:, 1])
        ok = costmap.inside(r, c)
        ok[ok] = costmap.costs[r[ok], c[ok]] != NO_INFORMATION
        if not np.any(ok):
            return None
        first = int(np.argmax(ok))
        off = np.flatnonzero(~ok[first:])
        last = first + (int(off[0]) - 1 if len(off) else len(ok) - first - 1)
        run_r, run_c = r[first : last + 1], c[first : last + 1]
        # GoalAlign's target: the path's end, pushed on towards the goal (DWB shifts only the
        # path's end, not a point where the path leaves the window)
        ar, ac = int(run_r[-1]), int(run_c[-1])
        reaches_end = last == len(p) - 1 and np.allclose(p[-1], full[-1])
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
        graph = grid_graph(costmap.costs < INSCRIBED_INFLATED_OBSTACLE)
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
