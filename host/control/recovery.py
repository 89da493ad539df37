"""The navigator's recovery behaviours: Nav2 bringup's round robin of clear, spin, wait and
back up (:class:`RecoveryBehaviours`).

Each failure the navigator counts (the controller finds nothing, no progress) starts the next
behaviour of :data:`RECOVERIES`; after ``max_retries`` of them the goal fails:

* ``clear_costmaps``: the local costmap's obstacles, and what the global one holds beyond the
  LiDAR's clearing range (what is in view stays), one tick;
* ``spin``: turn ``spin_angle_rad`` (1.57) at sqrt(2 alpha remaining) clamped to
  [``spin_min_rad_s``, ``spin_max_rad_s``] (0.30, the paper's minimum angular velocity, and
  1.0 rad/s) and to the limiter's ``max_w``, alpha being the limiter's bound;
* ``wait``: ``wait_s`` (5 s) braked;
* ``backup``: ``backup_distance_m`` (0.15, about half a body length: enough to leave the
  0.16 m inscribed band the robot can get caught in) at ``backup_speed_m_s`` (0.05) in 3 s;
  Nav2's tree backs up 0.30 m.

Spin and back-up test the robot's body over what is left of the motion (up to
``simulate_ahead_time_s``, 2 s, Nav2's simulate_ahead_time) and end early instead of touching
an obstacle; each ends at its time allowance too. The test (:meth:`Costmap.body_contacts`) is
closer than the local planner's: the envelope rectangle alone (not Nav2's 0.16 m disc around
it) against the last scan's returns, each marked cell the capsule of its own and its
neighbours' returns with the range noise taken out, so that a wall reads within about a
centimetre of where it is, not 3 cm nearer. The body may reach no deeper into an obstacle than
at the start (nowhere, if it started clear), and the centre may come no nearer one than at the
start, or than 0.16 m if it started farther, less :data:`BACKUP_SLACK_M`.

Where they differ from Nav2's, so that a robot beside a wall can get away from it: the
back-up does not always go straight back. Of straight back and arcs of radius
:data:`BACKUP_RADII_M` to either side (:data:`BACKUP_CURVATURES`), it drives the free one that
ends with the centre farthest from the obstacles, straight back on a tie (clearances beyond
0.25 m count alike). A robot stopped beside a wall, facing along it, too near to turn in place
(its corners reach 19.1 cm from its centre), so backs away from the wall instead of along it,
turning a little like the first leg of a three-point turn, and can then turn; with nothing
near, it backs up straight, as Nav2's does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle
from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.navigator_config import NavigatorConfig
from jackson.host.estimation.odometry import integrate_arc
from jackson.host.nav.costmap import Costmap
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]

RECOVERIES = ("clear_costmaps", "spin", "wait", "backup")
"""The round robin of recovery behaviours, in Nav2 bringup's order."""

BACKUP_RADII_M = (0.6, 0.3)
"""Radii of the back-up's arcs [m]: over 0.15 m the tighter one moves the centre 3.7 cm sideways
and turns the robot 29 degrees; its front corner swings out by at most 2.1 cm on the way."""

BACKUP_SLACK_M = 0.01
"""How much nearer an obstacle than at its start [m] (the LiDAR's range noise) the back-up lets
the centre come while the robot's disc overlaps one (a robot caught in the disc's band): moving
along a wall, the nearest obstacle disc changes and their radii differ by that much."""

BACKUP_MARGIN_M = 0.005
"""How far clear of the obstacles [m] the body must stay along a back-up for it to be chosen (the
limiter's ramps bend the first centimetres of the arc)."""

BACKUP_STEP_M = 0.01
"""The back-up's poses are tested this far apart along its arc [m]."""

BACKUP_CURVATURES = (0.0, *(k for r in BACKUP_RADII_M for k in (1.0 / r, -1.0 / r)))
"""The back-up's candidate curvatures [1/m], straight back first (it wins a tie)."""


@dataclass
class Recovery:
    """A recovery in progress.

    Attributes
    ----------
    name : str
        One of :data:`RECOVERIES`.
    t_start_s : float
        MCU time it started [s].
    start : Pose2D
        Where it started (map frame).
    last_yaw_rad, turned_rad : float
        The yaw at the last tick and the angle turned so far [rad] (``spin``).
    curvature_per_m : float or None
        The back-up's curvature [1/m] (positive: a left turn's arc, driven backwards, so the
        heading falls as it backs), chosen at its first tick.
    floor_m : float
        The spin's or back-up's clearance floor [m]: its centre may come no nearer an
        obstacle.
    depth_m : float
        How deep into obstacles the body may reach [m] (:meth:`Costmap.body_contacts`): as
        deep as at the start, ``-inf`` when it started clear of them.
    """

    name: str
    t_start_s: float
    start: Pose2D
    last_yaw_rad: float
    turned_rad: float = 0.0
    curvature_per_m: float | None = None
    floor_m: float = -math.inf
    depth_m: float = -math.inf


class RecoveryBehaviours:
    """The round robin of recoveries of one goal (module docstring).

    Parameters
    ----------
    config : NavigatorConfig
        The behaviours' settings and ``max_retries``.
    local_costmap, global_costmap : Costmap
        The navigator's costmaps: cleared by ``clear_costmaps``; spin and back-up are tested
        against the local one.

    Attributes
    ----------
    counts : dict of str to int
        Recoveries run for the current goal, by behaviour.
    retries : int
        Recovery rounds used for the current goal.
    current : Recovery or None
        The recovery running, if any.
    """

    def __init__(
        self, config: NavigatorConfig, local_costmap: Costmap, global_costmap: Costmap
    ) -> None:
        self.config = config
        self.local_costmap = local_costmap
        self.global_costmap = global_costmap
        self.counts: dict[str, int] = dict.fromkeys(RECOVERIES, 0)
        self.retries = 0
        self.current: Recovery | None = None
        self._next = 0

    def reset(self) -> None:
        """A new goal: no recovery running, none counted, the round robin from its start."""
        self.counts = dict.fromkeys(RECOVERIES, 0)
        self.retries = 0
        self.current = None
        self._next = 0

    def begin(self, t_s: float, pose: Pose2D) -> bool:
        """Start the next behaviour of the round robin at ``pose``.

        Returns
        -------
        bool
            False when ``max_retries`` recoveries are used up (none starts: the goal fails).
        """
        if self.retries >= self.config.max_retries:
            self.current = None
            return False
        self.retries += 1
        name = RECOVERIES[self._next % len(RECOVERIES)]
        self._next += 1
        self.counts[name] += 1
        self.current = Recovery(name, t_s, pose, pose.yaw)
        return True

    def tick(self, t_s: float, pose: Pose2D, limits: LimiterConfig) -> tuple[float, float] | None:
        """One tick of the running recovery.

        Parameters
        ----------
        t_s : float
            MCU time [s].
        pose : Pose2D
            Robot pose (map frame).
        limits : LimiterConfig
            The speed and acceleration bounds in force.

        Returns
        -------
        tuple of float or None
            (v [m/s], w [rad/s]); None when no recovery runs or it is over (then none runs).
        """
        rec = self.current
        if rec is None:
            return None
        cfg = self.config
        elapsed = t_s - rec.t_start_s
        v, w = 0.0, 0.0
        done = False
        if rec.name == "clear_costmaps":
            self.local_costmap.clear_obstacles()
            self.global_costmap.clear_obstacles(cfg.costmap.raytrace_max_range_m, (pose.x, pose.y))
            done = True
        elif rec.name == "wait":
            done = elapsed >= cfg.wait_s
        elif rec.name == "spin":
            rec.turned_rad += wrap_angle(pose.yaw - rec.last_yaw_rad)
            rec.last_yaw_rad = pose.yaw
            remaining = cfg.spin_angle_rad - abs(rec.turned_rad)
            if remaining <= 0.0 or elapsed > cfg.spin_time_allowance_s:
                done = True
            else:
                speed = math.sqrt(2.0 * limits.max_alpha_rad_s2 * remaining)
                speed = min(max(speed, cfg.spin_min_rad_s), cfg.spin_max_rad_s)
                speed = min(speed, limits.max_w_rad_s)
                ahead = min(remaining, speed * cfg.simulate_ahead_time_s)
                n = max(2, math.ceil(ahead / 0.025) + 1)
                yaws = pose.yaw + np.linspace(0.0, ahead, n, dtype=np.float64)
                if rec.floor_m == -math.inf:  # the first tick
                    rec.floor_m, rec.depth_m = self._floor(pose)
                # a corner moves up to 0.025 rad x 0.191 m between two poses tested
                sweep = 0.5 * (ahead / (n - 1)) * cfg.costmap.circumscribed_radius_m
                px, py = np.full(n, pose.x), np.full(n, pose.y)
                if self._body_blocked(px, py, yaws, rec.floor_m, rec.depth_m, sweep):
                    done = True
                else:
                    w = speed
        elif rec.name == "backup":
            travelled = pose.distance(rec.start)
            remaining = cfg.backup_distance_m - travelled
            if remaining <= 0.0 or elapsed > cfg.backup_time_allowance_s:
                done = True
            else:
                speed = min(cfg.backup_speed_m_s, limits.max_v_m_s)
                if rec.curvature_per_m is None:  # the first tick: which way to back
                    rec.floor_m, rec.depth_m = self._floor(pose)
                    rec.curvature_per_m = self._backup_curvature(
                        pose, cfg.backup_distance_m, rec.floor_m, rec.depth_m
                    )
                k = rec.curvature_per_m
                ahead = min(remaining, speed * cfg.simulate_ahead_time_s)
                n = max(2, math.ceil(ahead / BACKUP_STEP_M) + 1)
                xs, ys, yaws = _arc(pose, -np.linspace(0.0, ahead, n, dtype=np.float64), k)
                margin = _turn_margin(ahead / (n - 1), k, cfg)
                if self._body_blocked(xs, ys, yaws, rec.floor_m, rec.depth_m, margin):
                    done = True
                else:
                    v = -speed
                    w = -speed * k
        if done:
            self.current = None
            return None
        return v, w

    def _backup_curvature(
        self, pose: Pose2D, distance_m: float, floor_m: float, depth_m: float
    ) -> float:
        """Of :data:`BACKUP_CURVATURES`, the one whose back-up of ``distance_m`` is free
        (:meth:`_body_blocked`, its body :data:`BACKUP_MARGIN_M` clear too) and ends with the
        centre farthest from the obstacles, clearances beyond the inflation radius (0.25 m:
        room to turn in place) counting alike; straight back on a tie or when none is free.
        """
        n = max(2, math.ceil(distance_m / BACKUP_STEP_M) + 1)
        s = -np.linspace(0.0, distance_m, n, dtype=np.float64)
        best, best_clear = 0.0, -math.inf
        cap = self.config.costmap.inflation_radius_m
        for k in BACKUP_CURVATURES:
            xs, ys, yaws = _arc(pose, s, k)
            margin = BACKUP_MARGIN_M + _turn_margin(distance_m / (n - 1), k, self.config)
            if self._body_blocked(xs, ys, yaws, floor_m, depth_m + BACKUP_MARGIN_M, margin):
                continue
            _, clear = self.local_costmap.body_contacts(xs[-1], ys[-1], yaws[-1])
            end = min(float(clear[0]), cap)
            if end > best_clear:
                best, best_clear = k, end
        return best

    def _floor(self, pose: Pose2D) -> tuple[float, float]:
        """How near an obstacle a spin or a back-up from ``pose`` lets the centre come [m] (as
        near as now, or the robot's radius if it is farther, less :data:`BACKUP_SLACK_M`),
        and how deep into obstacles its body may reach [m] (as deep as now)."""
        depth, clear = self.local_costmap.body_contacts(pose.x, pose.y, pose.yaw)
        floor_m = min(float(clear[0]), self.config.costmap.robot_radius_m) - BACKUP_SLACK_M
        return floor_m, float(depth[0]) + 1e-9

    def _body_blocked(
        self,
        x: FloatArray,
        y: FloatArray,
        yaw: FloatArray,
        floor_m: float,
        depth_m: float,
        margin_m: float = 0.0,
    ) -> bool:
        """Whether a recovery's poses put the robot's body (grown by ``margin_m``) deeper into
        an obstacle than ``depth_m`` or its centre nearer one than ``floor_m``
        (:meth:`Costmap.body_contacts`)."""
        depth, clear = self.local_costmap.body_contacts(x, y, yaw, margin_m)
        return bool((depth > depth_m).any() or (clear < floor_m).any())


def _arc(pose: Pose2D, s_m: FloatArray, curvature_per_m: float) -> tuple[FloatArray, ...]:
    """Poses ``s_m`` along the arc of the given curvature from ``pose`` (negative s: backwards):
    (x, y, yaw) arrays (the odometry's exact arc, :func:`integrate_arc`)."""
    poses = np.array(
        [integrate_arc(pose.x, pose.y, pose.yaw, s, curvature_per_m * s) for s in s_m.tolist()]
    ).reshape(-1, 3)
    return poses[:, 0], poses[:, 1], poses[:, 2]


def _turn_margin(step_m: float, curvature_per_m: float, config: NavigatorConfig) -> float:
    """How far a corner swings sideways between two poses ``step_m`` apart on an arc, halved:
    grown by this much, the body tested at the poses covers it in between [m]."""
    return 0.5 * step_m * abs(curvature_per_m) * config.costmap.circumscribed_radius_m
