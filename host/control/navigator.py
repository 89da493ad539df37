"""The navigator: Nav2's navigate-to-pose behaviour tree as a small state machine.

One :meth:`Navigator.step` per control tick, on MCU time, does what Nav2's bringup tree
(replanning at 1 Hz, with recovery) does:

* both costmaps take the latest scan: the global one (the static map + obstacle layer +
  inflation, unknown space tracked) and the local rolling window (3 m x 3 m at 0.05 m, scans
  only, as in Nav2's bringup);
* the global A* path is kept, replanned, or found cut off
  (:class:`~jackson.host.control.replanning.GlobalPlanning`: every ``replan_period_s``, at
  once when the path ahead is blocked; a goal cut off waits for scans to confirm it, then
  fails as unreachable);
* the DWB planner turns the path into (v, w) on the local costmap; when no trajectory is legal
  the robot is stopped, and after ``controller_failure_tolerance_s`` the local costmap is
  cleared once, then it counts as a failure;
* the progress checker counts a failure when the robot has not left a circle of
  ``progress_radius_m`` within ``progress_time_s``;
* each failure starts the next recovery of the round robin
  (:class:`~jackson.host.control.recovery.RecoveryBehaviours`: clear the local costmap and
  what the global one holds beyond the clearing range, spin 1.57 rad, wait 5 s, back up); after
  ``max_retries`` (6) recoveries the goal fails with the last reason;
* the goal checker succeeds once the robot has been within the xy tolerance (latched, as
  Nav2's stateful goal checker) and, if a yaw tolerance is set, faces the goal's yaw.

Its settings are :class:`~jackson.host.control.navigator_config.NavigatorConfig`; the speed
and acceleration bounds it plans within can change between ticks (:meth:`Navigator.set_limits`,
the daemon's live settings). Choices for this robot (0.27 m across, at most 0.30 m/s):

* progress: 0.25 m within 10 s instead of Nav2's 0.5 m. A turn in place of pi rad at the
  0.30 rad/s floor takes 10.5 s without any translation, and half a metre is almost two body
  lengths; a quarter metre in 10 s still catches a stalled or oscillating robot well before a
  person would.
* the yaw is not checked by default: the paper's Stage 3 success is the 0.25 m xy tolerance,
  and with the 0.30 rad/s floor DWB's RotateToGoal stops turning anywhere within about
  0.25 rad of the goal's yaw (half of what one 1.7 s roll-out at 0.30 rad/s turns), so a
  0.25 rad check could wait forever just outside it. Set ``yaw_goal_tolerance_rad`` to check.
* periodic replans keep the current path unless the new one is more than 10 % cheaper
  (``replan_hysteresis``; Nav2 always takes the new one).

The scan's rays are cleared from the robot's position (the RPLIDAR sits on the base's centre).
Both costmaps live in the map frame (Nav2's local costmap is in odom; with the pose given in
the map frame it makes no difference here). Where a start or goal is refused before anything
moves: :mod:`jackson.host.control.route`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import wrap_angle
from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.navigator_config import NavigatorConfig as NavigatorConfig
from jackson.host.control.recovery import RECOVERIES as RECOVERIES
from jackson.host.control.recovery import RecoveryBehaviours
from jackson.host.control.replanning import GlobalPlanning, PlanOutcome
from jackson.host.control.route import RouteChecker as RouteChecker
from jackson.host.control.route import RouteError as RouteError
from jackson.host.control.route import check_route as check_route
from jackson.host.nav.astar import prepare
from jackson.host.nav.costmap import Costmap
from jackson.host.nav.dwb import Command, DwbPlanner, own_granularity
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.planner_server import Planner
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]


class NavigatorState(str, Enum):
    """Where the navigator is."""

    IDLE = "idle"
    PLANNING = "planning"
    FOLLOWING = "following"
    RECOVERING = "recovering"
    SUCCEEDED = "succeeded"
    FAILED = "failed"


@dataclass(frozen=True)
class NavCommand:
    """The navigator's output for one tick.

    Attributes
    ----------
    v_m_s, w_rad_s : float
        Velocity command [m/s], [rad/s] (for the velocity limiter).
    state : NavigatorState
        State after this tick.
    reason : str
        Why the state is what it is (a failure, a recovery's cause), else "".
    behaviour : str or None
        The recovery running, if any.
    distance_to_goal_m : float
        Straight-line distance to the goal [m] (nan without a goal).
    """

    v_m_s: float
    w_rad_s: float
    state: NavigatorState
    reason: str = ""
    behaviour: str | None = None
    distance_to_goal_m: float = math.nan


class Navigator:
    """Plans, follows and recovers towards one goal at a time.

    Parameters
    ----------
    config : NavigatorConfig
        Everything tunable.
    static_map : OccupancyGrid
        The map (map frame) of the global costmap's static layer.
    limits : LimiterConfig
        Speed and acceleration bounds (the local planner samples inside them).
    planner : Planner or None
        Where global plans are searched when ``config.plan_delay_ticks`` > 0
        (:mod:`jackson.host.nav.planner_server`; default: on the caller's thread).

    Attributes
    ----------
    config : NavigatorConfig
        As given.
    limits : LimiterConfig
        As given, or as last set (:meth:`set_limits`).
    local_costmap : Costmap
        The rolling window around the robot.
    planning : GlobalPlanning
        The global path, on the global costmap (static map + scans + inflation).
    behaviours : RecoveryBehaviours
        The recoveries of the current goal.
    dwb : DwbPlanner
        The local planner.
    last_command : Command or None
        The local planner's last output, with its critic scores.
    """

    def __init__(
        self,
        config: NavigatorConfig,
        static_map: OccupancyGrid,
        limits: LimiterConfig,
        planner: Planner | None = None,
    ) -> None:
        self.config = config
        self.limits = limits
        global_cfg = dataclasses.replace(
            config.costmap, track_unknown_space=config.global_track_unknown_space
        )
        local_cfg = dataclasses.replace(config.costmap, track_unknown_space=False)
        global_costmap = Costmap.from_map(static_map, global_cfg, collision_checks=False)
        prepare(global_costmap)  # the search objects: not in the first control step
        # the map alone (no scans): where a path would run if nothing had been seen
        static_costmap = Costmap.from_map(static_map, global_cfg, collision_checks=False)
        cx = static_map.origin_x_m + 0.5 * static_map.width * static_map.resolution_m
        cy = static_map.origin_y_m + 0.5 * static_map.height * static_map.resolution_m
        self.local_costmap = Costmap.rolling_window(
            local_cfg, cx, cy, config.local_size_m, config.local_resolution_m
        )
        self.planning = GlobalPlanning(
            config, global_costmap, static_costmap, self.local_costmap, planner
        )
        self.behaviours = RecoveryBehaviours(config, self.local_costmap, global_costmap)
        self.dwb = DwbPlanner(
            dataclasses.replace(config.dwb, xy_goal_tolerance_m=self.goal_window_m), limits
        )
        self._state = NavigatorState.IDLE
        self._reason = ""
        self._goal: Pose2D | None = None
        self._local_plan: FloatArray = np.empty((0, 3))
        self._fail_since_s: float | None = None
        self._local_cleared = False
        self._progress_anchor: tuple[Pose2D, float] | None = None
        self._xy_reached = False
        self.last_command: Command | None = None

    # ------------------------------------------------------------------ goal and outputs

    def set_goal(self, goal: Pose2D) -> None:
        """Start navigating to ``goal`` (map frame), forgetting any previous goal.

        Parameters
        ----------
        goal : Pose2D
            The goal pose.
        """
        self._goal = goal
        self._state = NavigatorState.PLANNING
        self._reason = ""
        self._local_plan = np.empty((0, 3))
        self._fail_since_s = None
        self._local_cleared = False
        self._progress_anchor = None
        self._xy_reached = False
        self.planning.reset()
        self.behaviours.reset()
        self.dwb.reset()

    def cancel(self) -> None:
        """Drop the goal; the navigator idles and commands (0, 0)."""
        self._goal = None
        self._state = NavigatorState.IDLE
        self.behaviours.current = None

    def set_limits(self, limits: LimiterConfig) -> None:
        """New speed and acceleration bounds, from the next tick on: the local planner's window
        and roll-outs and the recoveries' speeds follow them (the daemon's live settings,
        :mod:`jackson.host.core.settings`).

        Parameters
        ----------
        limits : LimiterConfig
            The navigation's bounds.
        """
        self.limits = limits
        self.dwb.set_limits(limits)

    @property
    def goal_window_m(self) -> float:
        """Where the goal checker succeeds: the xy tolerance less the margin [m]."""
        return self.config.xy_goal_tolerance_m - self.config.goal_margin_m

    @property
    def state(self) -> NavigatorState:
        """The current state."""
        return self._state

    @property
    def goal(self) -> Pose2D | None:
        """The current goal, if any."""
        return self._goal

    @property
    def global_costmap(self) -> Costmap:
        """Static map + scans + inflation (the global planner's)."""
        return self.planning.global_costmap

    @property
    def static_costmap(self) -> Costmap:
        """The map alone, under the global costmap's settings."""
        return self.planning.static_costmap

    @property
    def recoveries(self) -> dict[str, int]:
        """Recoveries run for the current goal, by behaviour."""
        return self.behaviours.counts

    @property
    def retries(self) -> int:
        """Recovery rounds used for the current goal."""
        return self.behaviours.retries

    @property
    def replans(self) -> int:
        """Global plans computed for the current goal."""
        return self.planning.replans

    @property
    def kept_plans(self) -> int:
        """Replans whose result was dropped for the current path (``replan_hysteresis``)."""
        return self.planning.kept_plans

    @property
    def blocked_at(self) -> tuple[float, float] | None:
        """Where the goal was last found cut off [m] (None since a plan was found)."""
        return self.planning.blocked_at

    @property
    def plan(self) -> FloatArray:
        """The current global path (/plan), shape (N, 2) [m]; empty without one."""
        path = self.planning.path
        return np.empty((0, 2)) if path is None else path.copy()

    @property
    def local_plan(self) -> FloatArray:
        """The trajectory DWB chose last, shape (K, 3): x, y [m], yaw [rad]."""
        return self._local_plan.copy()

    @property
    def published_local_plan(self) -> FloatArray:
        """/local_plan: :attr:`local_plan` at its own granularity, as Nav2 publishes it
        (:func:`~jackson.host.nav.dwb.core.path.own_granularity`)."""
        c = self.config.dwb
        return own_granularity(self._local_plan, c.linear_granularity_m, c.angular_granularity_rad)

    def path_blocked(self, pose: Pose2D) -> bool:
        """Whether the path ahead crosses an inscribed or lethal cell of either costmap
        (:meth:`~jackson.host.control.replanning.GlobalPlanning.path_blocked`)."""
        return self.planning.path_blocked(pose)

    # ------------------------------------------------------------------ the tick

    def step(
        self,
        t_s: float,
        pose_map: Pose2D,
        velocity: tuple[float, float],
        scan_points_map: npt.ArrayLike | None = None,
    ) -> NavCommand:
        """Advance by one control tick.

        Parameters
        ----------
        t_s : float
            MCU time [s].
        pose_map : Pose2D
            Robot pose in the map frame.
        velocity : tuple of float
            Current (v [m/s], w [rad/s]), e.g. the EKF's.
        scan_points_map : array_like, shape (N, 2), or None
            A new scan's valid returns in the map frame, or None when no scan arrived.

        Returns
        -------
        NavCommand
            The velocity command and the state.
        """
        self.local_costmap.recentre(pose_map.x, pose_map.y, scan_points_map is not None)
        if scan_points_map is not None:
            points = np.asarray(scan_points_map, np.float64).reshape(-1, 2)
            origin = (pose_map.x, pose_map.y)
            self.local_costmap.update(points, origin)
            self.global_costmap.update(points, origin)
        goal = self._goal
        idle = (NavigatorState.IDLE, NavigatorState.SUCCEEDED, NavigatorState.FAILED)
        if goal is None or self._state in idle:
            return self._stop(goal, pose_map)
        if self._goal_reached(pose_map, goal):
            self._state = NavigatorState.SUCCEEDED
            self._reason = "goal reached"
            self.behaviours.current = None
            self._local_plan = np.empty((0, 3))
            return self._stop(goal, pose_map)
        if self._state == NavigatorState.RECOVERING:
            out = self._recover(t_s, pose_map, goal)
            if out is not None:
                return out
        if self._progress_anchor is None:
            self._progress_anchor = (pose_map, t_s)

        planned = self.planning.update(t_s, pose_map, goal, scan_points_map is not None)
        self._take_plan(planned)
        path = self.planning.path
        if not planned.ready or path is None:
            return self._stop(goal, pose_map)
        if self._state == NavigatorState.PLANNING:
            self._state = NavigatorState.FOLLOWING

        cmd = self.dwb.compute(pose_map, velocity, path, goal, self.local_costmap)
        self.last_command = cmd
        if not cmd.valid:
            self._local_plan = np.empty((0, 3))
            if self._fail_since_s is None:
                self._fail_since_s = t_s
            elif t_s - self._fail_since_s > self.config.controller_failure_tolerance_s:
                if not self._local_cleared:
                    self.local_costmap.clear_obstacles()
                    self._local_cleared = True
                    self._fail_since_s = t_s
                else:
                    self._begin_recovery(t_s, pose_map, f"controller: {cmd.reason}")
            return self._stop(goal, pose_map)
        self._fail_since_s = None
        self._local_cleared = False
        self._local_plan = cmd.trajectory

        anchor, t_anchor = self._progress_anchor
        if pose_map.distance(anchor) >= self.config.progress_radius_m:
            self._progress_anchor = (pose_map, t_s)
        elif t_s - t_anchor > self.config.progress_time_s:
            self._begin_recovery(
                t_s, pose_map,
                f"no progress: moved less than {self.config.progress_radius_m:g} m "
                f"in {self.config.progress_time_s:g} s",
            )  # fmt: skip
            return self._stop(goal, pose_map)
        return NavCommand(
            cmd.v_m_s, cmd.w_rad_s, self._state, self._reason, None, pose_map.distance(goal)
        )

    def _stop(self, goal: Pose2D | None, pose: Pose2D) -> NavCommand:
        """(0, 0) in the current state."""
        rec = self.behaviours.current
        behaviour = rec.name if rec is not None else None
        dist = pose.distance(goal) if goal is not None else math.nan
        return NavCommand(0.0, 0.0, self._state, self._reason, behaviour, dist)

    def _goal_reached(self, pose: Pose2D, goal: Pose2D) -> bool:
        """The stateful goal checker."""
        cfg = self.config
        self._xy_reached = self._xy_reached or pose.distance(goal) <= self.goal_window_m
        if not self._xy_reached:
            return False
        tol = cfg.yaw_goal_tolerance_rad
        return tol is None or abs(wrap_angle(pose.yaw - goal.yaw)) <= tol

    def _take_plan(self, out: PlanOutcome) -> None:
        """The global planning's outcome in the navigator's state: cut off, the goal waits in
        PLANNING with the reason; a failure fails the goal; a path found clears the reason."""
        if out.blocked is not None:
            self._state = NavigatorState.PLANNING
            self._reason = out.blocked
            self._local_plan = np.empty((0, 3))
        if out.failure is not None:
            self._fail(out.failure)
        elif (
            out.ready
            and out.planned
            and self._state == NavigatorState.PLANNING
            and self._reason.startswith("no path")
        ):
            self._reason = ""

    def _fail(self, reason: str) -> None:
        """The goal fails at once (no recovery can help)."""
        self._state = NavigatorState.FAILED
        self._reason = reason
        self.behaviours.current = None
        self._local_plan = np.empty((0, 3))

    # ------------------------------------------------------------------ recoveries

    def _begin_recovery(self, t_s: float, pose: Pose2D, reason: str) -> None:
        """Count a failure and start the next behaviour of the round robin, or fail."""
        self._local_plan = np.empty((0, 3))
        self._fail_since_s = None
        if not self.behaviours.begin(t_s, pose):
            self._state = NavigatorState.FAILED
            self._reason = f"failed after {self.behaviours.retries} recoveries: {reason}"
            return
        self._state = NavigatorState.RECOVERING
        self._reason = reason

    def _end_recovery(self) -> None:
        """Back to planning with a fresh path, progress window and oscillation memory."""
        self._state = NavigatorState.PLANNING
        self.planning.forget_path()
        self._progress_anchor = None
        self._local_cleared = False
        self.dwb.critic("Oscillation").reset()

    def _recover(self, t_s: float, pose: Pose2D, goal: Pose2D) -> NavCommand | None:
        """One tick of the running recovery; None once it is over (planning resumes)."""
        rec = self.behaviours.current
        if rec is None:
            return None
        out = self.behaviours.tick(t_s, pose, self.limits)
        if out is None:
            self._end_recovery()
            return None
        return NavCommand(out[0], out[1], self._state, self._reason, rec.name, pose.distance(goal))
