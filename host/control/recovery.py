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

Spin and back-up test the robot's disc and envelope against the local costmap over what is
left of the motion (up to ``simulate_ahead_time_s``, 2 s, Nav2's simulate_ahead_time), with
the local planner's escape rule, and end early instead of touching an obstacle; each ends at
its time allowance too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle
from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.navigator_config import NavigatorConfig
from jackson.host.nav.costmap import Costmap
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]

RECOVERIES = ("clear_costmaps", "spin", "wait", "backup")
"""The round robin of recovery behaviours, in Nav2 bringup's order."""


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
    """

    name: str
    t_start_s: float
    start: Pose2D
    last_yaw_rad: float
    turned_rad: float = 0.0


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
                if self._motion_collides(np.full(n, pose.x), np.full(n, pose.y), yaws):
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
                ahead = min(remaining, speed * cfg.simulate_ahead_time_s)
                n = max(2, math.ceil(ahead / 0.025) + 1)
                s = -np.linspace(0.0, ahead, n, dtype=np.float64)
                xs = pose.x + s * math.cos(pose.yaw)
                ys = pose.y + s * math.sin(pose.yaw)
                if self._motion_collides(xs, ys, np.full(n, pose.yaw)):
                    done = True
                else:
                    v = -speed
        if done:
            self.current = None
            return None
        return v, w

    def _motion_collides(self, x: FloatArray, y: FloatArray, yaw: FloatArray) -> bool:
        """Whether a recovery's motion from the current pose would hit or get nearer an
        obstacle (the local planner's test with its escape rule)."""
        hit = self.local_costmap.trajectories_collide(x[None, :], y[None, :], yaw[None, :])
        return bool(hit[0])
