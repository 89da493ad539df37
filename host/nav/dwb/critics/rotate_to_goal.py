"""RotateToGoal: slow down and turn to the goal's yaw once inside the xy goal tolerance.

Raw score, inside the goal window only (latched: once the robot came within
``xy_goal_tolerance`` of the goal it stays inside until :meth:`RotateToGoalCritic.reset`):

- while still moving, v^2 x ``rotate_to_goal_slowing_factor`` (5.0) + |yaw error|, rejecting a
  target not slower than the current speed;
- once slower than ``trans_stopped_velocity`` (0.25 m/s; latched too: the robot is then
  rotating), |yaw error|, rejecting any target but the window's slowest (hardest braking), so
  the robot turns in place;

the yaw error being the roll-out's heading at the lookahead time (-1: its end) less the goal's.
Outside the window the raw score is 0 and every roll-out is legal. Scale 32.0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angles
from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class RotateToGoalCritic(Critic):
    """Slow down and turn to the goal's yaw once inside the xy goal tolerance (stateful).

    Parameters
    ----------
    config : DwbConfig
        Scale, tolerance, stop speed, slowing factor and lookahead.

    Attributes
    ----------
    in_window : bool
        Whether the robot came within the tolerance of the goal (latched).
    rotating : bool
        Whether it then slowed below the stop speed (latched): it turns in place to the goal's
        yaw, and GoalAlign and PathAlign stand aside.
    """

    name = "RotateToGoal"

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self.in_window = False
        self.rotating = False
        self._speed_sq = 0.0
        self._goal_yaw = 0.0

    @property
    def scale(self) -> float:
        """``rotate_to_goal_scale``."""
        return self.config.rotate_to_goal_scale

    def reset(self) -> None:
        """Forget the latched goal-window and rotating states (a new goal)."""
        self.in_window = False
        self.rotating = False

    def prepare(self, context: Context) -> bool:
        """Latch the goal window and the stopped state (:meth:`latch`)."""
        self.latch(context.pose, context.velocity[0], context.goal)
        return True

    def latch(self, pose: Pose2D, v_m_s: float, goal: Pose2D) -> None:
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

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores and legality of every roll-out (see the module's docstring)."""
        v = batch.v_m_s
        m = v.shape[0]
        if not self.in_window:
            return np.zeros(m), np.ones(m, bool)
        c = self.config
        ro = batch.rollouts
        k = self.pose_index(ro.t_s)
        yaw = batch.yaw_end_rad if k == ro.steps else ro.yaw_rad[ro.iw, k]
        err = np.abs(wrap_angles(yaw - self._goal_yaw))
        if not self.rotating:
            speed_sq = v * v
            return speed_sq * c.rotate_to_goal_slowing_factor + err, speed_sq < self._speed_sq
        return err, np.abs(v - batch.v_brake_m_s) <= 1e-12
