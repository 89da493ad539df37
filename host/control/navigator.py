"""The navigator: Nav2's navigate-to-pose behaviour tree as a small state machine.

One :meth:`Navigator.step` per control tick, on MCU time, does what Nav2's bringup tree
(replanning at 1 Hz, with recovery) does:

* both costmaps take the latest scan: the global one (the static map + obstacle layer +
  inflation, unknown space tracked) and the local rolling window (3 m x 3 m at 0.05 m, scans
  only, as in Nav2's bringup);
* the global A* path is recomputed every ``replan_period_s`` (1 Hz) and at once when the
  remaining path crosses a cell A* would refuse (inscribed or lethal) in either costmap; a
  plan that falls due on a tick that brought a scan waits for the next tick (50 ms), so that
  no tick both re-inflates the costmaps and plans: the worst tick is the larger of the two,
  not their sum;
* "no path" is a state, not a loop. Obstacles the LiDAR has seen stay in the global costmap
  until a scan's ray clears them (Nav2's obstacle layer), and a failed plan does not clear
  them (Nav2's tree clears the global costmap and retries: with the obstacle still there, the
  retry plans through the erased obstacle, the next scan blocks it again, and the robot
  loops until its recoveries run out). Instead the robot stops, and the place that blocks
  the goal is found: the first point of the path planned on the map alone that the costmap
  now refuses. If that point is within the LiDAR's clearing range, scans keep checking it
  while the robot waits; still blocked after ``unreachable_confirm_s`` of them, the goal
  fails with ``goal (x, y) unreachable: blocked at (x, y)``. If it is farther, what the scans
  saw beyond their clearing range is forgotten (it may have moved; nothing in view is) and
  the robot drives on to look, at most ``max_reverifications`` times per goal;
* the DWB planner turns the path into (v, w) on the local costmap; when no trajectory is legal
  the robot is stopped, and after ``controller_failure_tolerance_s`` the local costmap is
  cleared once, then it counts as a failure;
* the progress checker counts a failure when the robot has not left a circle of
  ``progress_radius_m`` within ``progress_time_s``;
* each failure starts the next recovery of the round robin: clear the local costmap and what
  the global one holds beyond the clearing range, spin 1.57 rad, wait 5 s, back up; after
  ``max_retries`` (6) recoveries the goal fails with the last reason;
* the goal checker succeeds once the robot has been within the xy tolerance (latched, as
  Nav2's stateful goal checker) and, if a yaw tolerance is set, faces the goal's yaw.

Choices for this robot (0.27 m across, at most 0.30 m/s):

* progress: 0.25 m within 10 s instead of Nav2's 0.5 m. A turn in place of pi rad at the
  0.30 rad/s floor takes 10.5 s without any translation, and half a metre is almost two body
  lengths; a quarter metre in 10 s still catches a stalled or oscillating robot well before a
  person would.
* back up 0.15 m at 0.05 m/s: about half a body length, enough to leave the 0.16 m inscribed
  band the robot can get caught in, in 3 s; Nav2's tree backs up 0.30 m.
* spin at sqrt(2 alpha remaining) clamped to [0.30, 1.0] rad/s, 0.30 rad/s being the paper's
  minimum angular velocity (Nav2's behaviour server: 0.4) and alpha the limiter's bound.
* the yaw is not checked by default: the paper's Stage 3 success is the 0.25 m xy tolerance,
  and with the 0.30 rad/s floor DWB's RotateToGoal stops turning anywhere within about
  0.25 rad of the goal's yaw (half of what one 1.7 s roll-out at 0.30 rad/s turns), so a
  0.25 rad check could wait forever just outside it. Set ``yaw_goal_tolerance_rad`` to check.
* periodic replans keep the current path unless the new one is more than 10 % cheaper
  (``replan_hysteresis``; Nav2 always takes the new one). With the cylinder in the middle of
  the corridor the two routes around it cost nearly the same and the plan flipped sides on
  replans. Over 20 runs of the course with LiDAR noise, without it the slowest run took
  58 s with 4 recoveries among all runs; with it 22 s and 1 recovery.

Spin and back-up test the robot's disc and envelope against the local costmap over what is
left of the motion (up to 2 s ahead, Nav2's simulate_ahead_time), with the local planner's
escape rule, and end early instead of touching an obstacle. The scan's rays are cleared from
the robot's position (the RPLIDAR sits on the base's centre). Both costmaps live in the map
frame (Nav2's local costmap is in odom; with the pose given in the map frame it makes no
difference here).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from jackson.common.errors import JacksonError
from jackson.common.geometry import wrap_angle
from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.nav.astar import (
    AStarConfig,
    NoPathError,
    astar,
    cell_costs,
    path_cost,
    prepare,
)
from jackson.host.nav.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    Costmap,
    CostmapConfig,
)
from jackson.host.nav.dwb import Command, DwbConfig, DwbPlanner, own_granularity, prune_path
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]


class RouteError(JacksonError, ValueError):
    """A start or goal the map rules out (one line: which pose, where, what is wrong)."""


RECOVERIES = ("clear_costmaps", "spin", "wait", "backup")
"""The round robin of recovery behaviours, in Nav2 bringup's order."""


class NavState(str, Enum):
    """Where the navigator is."""

    IDLE = "idle"
    PLANNING = "planning"
    FOLLOWING = "following"
    RECOVERING = "recovering"
    SUCCEEDED = "succeeded"
    FAILED = "failed"


@dataclass(frozen=True)
class NavigatorConfig:
    """Costmaps, planners, checkers and recoveries.

    Attributes
    ----------
    costmap : CostmapConfig
        Robot shape, inflation and scan ranges, shared by both costmaps.
    global_track_unknown_space : bool
        Keep the map's unknown cells unknown in the global costmap (Nav2 bringup: true).
    local_size_m, local_resolution_m : float
        The local rolling window [m] (Nav2 bringup: 3 m, 0.05 m).
    planner : AStarConfig
        Global planner.
    dwb : DwbConfig
        Local planner.
    replan_period_s : float
        Global replanning period [s] (Nav2 bringup tree: 1 Hz).
    replan_hysteresis : float
        A periodic replan keeps the current path while it is unblocked and costs at most
        (1 + this) times the new one (0: always take the new path, as Nav2 does).
    blocked_replan_interval_s : float
        Shortest time between replans caused by a blocked path [s].
    controller_failure_tolerance_s : float
        How long the local planner may find nothing before it counts as failing [s]
        (Nav2 bringup: 0.3 s).
    progress_radius_m, progress_time_s : float
        The progress checker: leave a circle of this radius within this time [m], [s].
    xy_goal_tolerance_m : float
        Goal checker distance [m] (REFERENCE: 0.25 m).
    goal_margin_m : float
        The robot aims this much inside ``xy_goal_tolerance_m`` [m]: the goal checker and
        DWB's goal window use the tolerance less the margin, so that the error of the pose
        estimate does not leave the true end just outside the tolerance (stopping at its edge
        by the estimate, a run ends outside it on the ground truth about every other time).
    yaw_goal_tolerance_rad : float or None
        Goal checker yaw [rad]; None ignores the yaw.
    max_retries : int
        Recoveries before the goal fails (Nav2 bringup tree: 6).
    spin_angle_rad, spin_min_rad_s, spin_max_rad_s, spin_time_allowance_s
        Spin recovery: angle [rad] (1.57), speed bounds [rad/s] (REFERENCE 0.30, 1.0),
        time limit [s] (10).
    backup_distance_m, backup_speed_m_s, backup_time_allowance_s
        Back-up recovery [m] (0.15), [m/s] (0.05), [s] (10).
    wait_s : float
        Wait recovery [s] (Nav2 bringup tree: 5).
    unreachable_confirm_s : float
        How long scans must keep a goal cut off before it fails as unreachable [s].
    max_reverifications : int
        How often per goal a block beyond the clearing range may be forgotten and looked at
        again.
    simulate_ahead_time_s : float
        How far ahead spin and back-up check for collisions [s] (Nav2: 2.0).
    """

    costmap: CostmapConfig = field(default_factory=CostmapConfig)
    global_track_unknown_space: bool = True
    local_size_m: float = 3.0
    local_resolution_m: float = 0.05
    planner: AStarConfig = field(default_factory=AStarConfig)
    dwb: DwbConfig = field(default_factory=DwbConfig)
    replan_period_s: float = 1.0
    replan_hysteresis: float = 0.1
    blocked_replan_interval_s: float = 0.25
    controller_failure_tolerance_s: float = 0.3
    progress_radius_m: float = 0.25
    progress_time_s: float = 10.0
    xy_goal_tolerance_m: float = 0.25
    goal_margin_m: float = 0.10
    yaw_goal_tolerance_rad: float | None = None
    max_retries: int = 6
    spin_angle_rad: float = 1.57
    spin_min_rad_s: float = 0.30
    spin_max_rad_s: float = 1.0
    spin_time_allowance_s: float = 10.0
    backup_distance_m: float = 0.15
    backup_speed_m_s: float = 0.05
    backup_time_allowance_s: float = 10.0
    wait_s: float = 5.0
    simulate_ahead_time_s: float = 2.0
    unreachable_confirm_s: float = 2.0
    max_reverifications: int = 3

    def __post_init__(self) -> None:
        for name in (
            "local_size_m", "local_resolution_m", "replan_period_s", "progress_radius_m",
            "progress_time_s", "xy_goal_tolerance_m", "spin_angle_rad", "spin_min_rad_s",
            "spin_max_rad_s", "spin_time_allowance_s", "backup_distance_m", "backup_speed_m_s",
            "backup_time_allowance_s", "simulate_ahead_time_s",
        ):  # fmt: skip
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"NavigatorConfig.{name} must be finite and > 0, got {value}")
        for name in (
            "replan_hysteresis",
            "blocked_replan_interval_s",
            "controller_failure_tolerance_s",
            "wait_s",
            "unreachable_confirm_s",
            "goal_margin_m",
        ):
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"NavigatorConfig.{name} must be finite and >= 0, got {value}")
        if self.yaw_goal_tolerance_rad is not None and not self.yaw_goal_tolerance_rad > 0.0:
            raise ValueError(
                "NavigatorConfig.yaw_goal_tolerance_rad must be > 0 or None, "
                f"got {self.yaw_goal_tolerance_rad}"
            )
        if self.max_retries < 0:
            raise ValueError(f"NavigatorConfig.max_retries must be >= 0, got {self.max_retries}")
        if self.goal_margin_m >= self.xy_goal_tolerance_m:
            raise ValueError(
                "NavigatorConfig.goal_margin_m must be below xy_goal_tolerance_m, "
                f"got {self.goal_margin_m} >= {self.xy_goal_tolerance_m}"
            )
        if self.max_reverifications < 0:
            raise ValueError(
                f"NavigatorConfig.max_reverifications must be >= 0, got {self.max_reverifications}"
            )
        if self.spin_min_rad_s > self.spin_max_rad_s:
            raise ValueError(
                f"NavigatorConfig.spin_min_rad_s must not exceed spin_max_rad_s, "
                f"got {self.spin_min_rad_s} > {self.spin_max_rad_s}"
            )


@dataclass(frozen=True)
class NavCommand:
    """The navigator's output for one tick.

    Attributes
    ----------
    v_m_s, w_rad_s : float
        Velocity command [m/s], [rad/s] (for the velocity limiter).
    state : NavState
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
    state: NavState
    reason: str = ""
    behaviour: str | None = None
    distance_to_goal_m: float = math.nan


@dataclass
class _Recovery:
    """A recovery in progress."""

    name: str
    t_start_s: float
    start: Pose2D
    last_yaw_rad: float
    turned_rad: float = 0.0


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

    Attributes
    ----------
    config : NavigatorConfig
        As given.
    limits : LimiterConfig
        As given.
    global_costmap : Costmap
        Static map + scans + inflation.
    local_costmap : Costmap
        The rolling window around the robot.
    dwb : DwbPlanner
        The local planner.
    recoveries : dict of str to int
        Recoveries run for the current goal, by behaviour.
    retries : int
        Recovery rounds used for the current goal.
    replans : int
        Global plans computed for the current goal.
    kept_plans : int
        Replans whose result was dropped for the current path (``replan_hysteresis``).
    last_command : Command or None
        The local planner's last output, with its critic scores.
    """

    def __init__(
        self, config: NavigatorConfig, static_map: OccupancyGrid, limits: LimiterConfig
    ) -> None:
        self.config = config
        self.limits = limits
        global_cfg = dataclasses.replace(
            config.costmap, track_unknown_space=config.global_track_unknown_space
        )
        local_cfg = dataclasses.replace(config.costmap, track_unknown_space=False)
        self.global_costmap = Costmap.from_map(static_map, global_cfg, collision_checks=False)
        prepare(self.global_costmap)  # the search objects: not in the first control step
        # the map alone (no scans): where a path would run if nothing had been seen
        self.static_costmap = Costmap.from_map(static_map, global_cfg, collision_checks=False)
        cx = static_map.origin_x_m + 0.5 * static_map.width * static_map.resolution_m
        cy = static_map.origin_y_m + 0.5 * static_map.height * static_map.resolution_m
        self.local_costmap = Costmap.rolling_window(
            local_cfg, cx, cy, config.local_size_m, config.local_resolution_m
        )
        self.dwb = DwbPlanner(
            dataclasses.replace(config.dwb, xy_goal_tolerance_m=self.goal_window_m), limits
        )
        self.recoveries: dict[str, int] = dict.fromkeys(RECOVERIES, 0)
        self.retries = 0
        self.replans = 0
        self.kept_plans = 0
        self._state = NavState.IDLE
        self._reason = ""
        self._goal: Pose2D | None = None
        self._path: FloatArray | None = None
        self._local_plan: FloatArray = np.empty((0, 3))
        self._t_plan_s = -math.inf
        self._t_blocked_plan_s = -math.inf
        self._fail_since_s: float | None = None
        self._local_cleared = False
        self._progress_anchor: tuple[Pose2D, float] | None = None
        self._xy_reached = False
        self._next_recovery = 0
        self._recovery: _Recovery | None = None
        self._no_path_since_s: float | None = None
        self._reverifications = 0
        self._plan_deferred = False
        self._scan_since_plan = False
        self.blocked_at: tuple[float, float] | None = None
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
        self._state = NavState.PLANNING
        self._reason = ""
        self._path = None
        self._local_plan = np.empty((0, 3))
        self._t_plan_s = -math.inf
        self._t_blocked_plan_s = -math.inf
        self._fail_since_s = None
        self._local_cleared = False
        self._progress_anchor = None
        self._xy_reached = False
        self._next_recovery = 0
        self._recovery = None
        self._no_path_since_s = None
        self._reverifications = 0
        self._plan_deferred = False
        self._scan_since_plan = False
        self.blocked_at = None
        self.recoveries = dict.fromkeys(RECOVERIES, 0)
        self.retries = 0
        self.replans = 0
        self.kept_plans = 0
        self.dwb.reset()

    def cancel(self) -> None:
        """Drop the goal; the navigator idles and commands (0, 0)."""
        self._goal = None
        self._state = NavState.IDLE
        self._recovery = None

    @property
    def goal_window_m(self) -> float:
        """Where the goal checker succeeds: the xy tolerance less the margin [m]."""
        return self.config.xy_goal_tolerance_m - self.config.goal_margin_m

    @property
    def state(self) -> NavState:
        """The current state."""
        return self._state

    @property
    def goal(self) -> Pose2D | None:
        """The current goal, if any."""
        return self._goal

    @property
    def plan(self) -> FloatArray:
        """The current global path (/plan), shape (N, 2) [m]; empty without one."""
        return np.empty((0, 2)) if self._path is None else self._path.copy()

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
        self.local_costmap.recentre(pose_map.x, pose_map.y)
        if scan_points_map is not None:
            points = np.asarray(scan_points_map, np.float64).reshape(-1, 2)
            origin = (pose_map.x, pose_map.y)
            self.local_costmap.update(points, origin)
            self.global_costmap.update(points, origin)
        goal = self._goal
        if goal is None or self._state in (NavState.IDLE, NavState.SUCCEEDED, NavState.FAILED):
            return self._stop(goal, pose_map)
        if self._goal_reached(pose_map, goal):
            self._state = NavState.SUCCEEDED
            self._reason = "goal reached"
            self._recovery = None
            self._local_plan = np.empty((0, 3))
            return self._stop(goal, pose_map)
        if self._state == NavState.RECOVERING:
            out = self._recover(t_s, pose_map, goal)
            if out is not None:
                return out
        if self._progress_anchor is None:
            self._progress_anchor = (pose_map, t_s)

        scanned = scan_points_map is not None
        self._scan_since_plan = self._scan_since_plan or scanned
        if self._no_path_since_s is not None and not self._scan_since_plan:
            return self._stop(goal, pose_map)  # cut off: only a new scan can change that
        due = self._needs_plan(t_s, pose_map) or self._plan_deferred
        if due and scanned and not self._plan_deferred:
            # this tick updated both costmaps: plan on the next one, so that no tick does both
            self._plan_deferred = True
        elif due:
            self._plan_deferred = False
            self._scan_since_plan = False
            if not self._make_plan(t_s, pose_map, goal):
                return self._stop(goal, pose_map)
        path = self._path
        if path is None:  # not reached: a successful plan sets it
            return self._stop(goal, pose_map)
        if self._state == NavState.PLANNING:
            self._state = NavState.FOLLOWING

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
        behaviour = self._recovery.name if self._recovery is not None else None
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

    # ------------------------------------------------------------------ global planning

    def _needs_plan(self, t_s: float, pose: Pose2D) -> bool:
        """No path yet, the replanning period is over, or the remaining path is blocked."""
        if self._path is None or t_s - self._t_plan_s >= self.config.replan_period_s:
            return True
        if t_s - self._t_blocked_plan_s < self.config.blocked_replan_interval_s:
            return False
        if self.path_blocked(pose):
            self._t_blocked_plan_s = t_s
            self._path = None  # the old path may not be kept
            return True
        return False

    def path_blocked(self, pose: Pose2D) -> bool:
        """Whether the path ahead crosses an inscribed or lethal cell of either costmap.

        Points within the robot radius (plus a cell) of the robot are skipped: the robot
        may stand in an inscribed band it is leaving.

        Parameters
        ----------
        pose : Pose2D
            Robot pose.

        Returns
        -------
        bool
            True when the remaining path is blocked (False without a path).
        """
        if self._path is None:
            return False
        ahead = prune_path(self._path, pose.x, pose.y)
        near = self.config.costmap.robot_radius_m + self.global_costmap.resolution_m
        ahead = ahead[np.hypot(ahead[:, 0] - pose.x, ahead[:, 1] - pose.y) > near]
        if len(ahead) == 0:
            return False
        for costmap in (self.global_costmap, self.local_costmap):
            cost = costmap.cost_at(ahead[:, 0], ahead[:, 1])
            if np.any((cost == INSCRIBED_INFLATED_OBSTACLE) | (cost == LETHAL_OBSTACLE)):
                return True
        return False

    def _make_plan(self, t_s: float, pose: Pose2D, goal: Pose2D) -> bool:
        """Plan on the global costmap; without a path, stop and find out why."""
        start, target = (pose.x, pose.y), (goal.x, goal.y)
        try:
            path = astar(self.global_costmap, start, target, self.config.planner)
        except NoPathError:
            self._path = None
            if not self._no_path(t_s, pose, goal):
                return False
            try:  # what blocked it was forgotten: plan again at once
                path = astar(self.global_costmap, start, target, self.config.planner)
            except NoPathError:
                self._no_path(t_s, pose, goal)
                return False
        self._no_path_since_s = None
        self.blocked_at = None
        if self._state == NavState.PLANNING and self._reason.startswith("no path"):
            self._reason = ""
        self.replans += 1
        self._t_plan_s = t_s
        if self._path is not None and self.config.replan_hysteresis > 0.0:
            ahead = np.vstack(((pose.x, pose.y), prune_path(self._path, pose.x, pose.y)))
            old_cost = path_cost(ahead, self.global_costmap, self.config.planner)
            new_cost = path_cost(path, self.global_costmap, self.config.planner)
            if old_cost <= (1.0 + self.config.replan_hysteresis) * new_cost:
                self.kept_plans += 1
                return True
        self._path = path
        return True

    def _no_path(self, t_s: float, pose: Pose2D, goal: Pose2D) -> bool:
        """The goal is cut off: wait for scans to confirm it, look again, or fail.

        Returns True when what blocked it lay out of view and was forgotten (plan again).
        """
        cfg = self.config
        start, target = (pose.x, pose.y), (goal.x, goal.y)
        try:
            witness = astar(self.static_costmap, start, target, cfg.planner)
        except NoPathError as on_map:
            self._fail(f"goal ({goal.x:.2f}, {goal.y:.2f}) unreachable on the map: {on_map}")
            return False
        blocked = self._first_blocked(witness, pose)
        self.blocked_at = blocked
        where = f"({blocked[0]:.2f}, {blocked[1]:.2f})"
        self._state = NavState.PLANNING
        self._reason = f"no path: blocked at {where}"
        self._local_plan = np.empty((0, 3))
        clearing_m = cfg.costmap.raytrace_max_range_m
        out_of_view = math.hypot(blocked[0] - pose.x, blocked[1] - pose.y) > clearing_m - 0.25
        if out_of_view and self._reverifications < cfg.max_reverifications:
            # seen from afar and out of view now: forget it, drive on and look again
            self._reverifications += 1
            self.global_costmap.clear_obstacles(clearing_m, (pose.x, pose.y))
            self._no_path_since_s = None
            return True
        if self._no_path_since_s is None:
            self._no_path_since_s = t_s
        elif t_s - self._no_path_since_s >= cfg.unreachable_confirm_s:
            self._fail(f"goal ({goal.x:.2f}, {goal.y:.2f}) unreachable: blocked at {where}")
        return False

    def _first_blocked(self, path: FloatArray, pose: Pose2D) -> tuple[float, float]:
        """The first point along ``path`` (beyond the robot's own disc) on a cell the global
        costmap refuses, sampled every half cell; the robot's position when there is none."""
        res = self.global_costmap.resolution_m
        seg = np.diff(path, axis=0)
        length = np.hypot(seg[:, 0], seg[:, 1])
        pts = [path[:1]]
        for p0, d, n in zip(path[:-1], seg, np.ceil(length / (0.5 * res)).astype(int), strict=True):
            if n > 0:
                pts.append(p0 + d * (np.arange(1, n + 1)[:, None] / n))
        samples = np.vstack(pts)
        near = self.config.costmap.robot_radius_m + res
        ahead = np.hypot(samples[:, 0] - pose.x, samples[:, 1] - pose.y) > near
        cost = self.global_costmap.cost_at(samples[:, 0], samples[:, 1])
        bad = np.flatnonzero(ahead & (cost >= INSCRIBED_INFLATED_OBSTACLE))
        if bad.size == 0:
            return (pose.x, pose.y)
        return (float(samples[bad[0], 0]), float(samples[bad[0], 1]))

    def _fail(self, reason: str) -> None:
        """The goal fails at once (no recovery can help)."""
        self._state = NavState.FAILED
        self._reason = reason
        self._recovery = None
        self._local_plan = np.empty((0, 3))

    # ------------------------------------------------------------------ recoveries

    def _begin_recovery(self, t_s: float, pose: Pose2D, reason: str) -> None:
        """Count a failure and start the next behaviour of the round robin, or fail."""
        self._local_plan = np.empty((0, 3))
        self._fail_since_s = None
        if self.retries >= self.config.max_retries:
            self._state = NavState.FAILED
            self._reason = f"failed after {self.retries} recoveries: {reason}"
            self._recovery = None
            return
        self.retries += 1
        name = RECOVERIES[self._next_recovery % len(RECOVERIES)]
        self._next_recovery += 1
        self.recoveries[name] += 1
        self._state = NavState.RECOVERING
        self._reason = reason
        self._recovery = _Recovery(name, t_s, pose, pose.yaw)

    def _end_recovery(self, t_s: float) -> None:
        """Back to planning with a fresh path, progress window and oscillation memory."""
        self._recovery = None
        self._state = NavState.PLANNING
        self._path = None
        self._progress_anchor = None
        self._local_cleared = False
        self.dwb.critic("Oscillation").reset()

    def _motion_collides(self, x: FloatArray, y: FloatArray, yaw: FloatArray) -> bool:
        """Whether a recovery's motion from the current pose would hit or get nearer an
        obstacle (the local planner's test with its escape rule)."""
        hit = self.local_costmap.trajectories_collide(x[None, :], y[None, :], yaw[None, :])
        return bool(hit[0])

    def _recover(self, t_s: float, pose: Pose2D, goal: Pose2D) -> NavCommand | None:
        """One tick of the running recovery; None once it is over (planning resumes)."""
        rec = self._recovery
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
                speed = math.sqrt(2.0 * self.limits.max_alpha_rad_s2 * remaining)
                speed = min(max(speed, cfg.spin_min_rad_s), cfg.spin_max_rad_s)
                speed = min(speed, self.limits.max_w_rad_s)
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
                speed = min(cfg.backup_speed_m_s, self.limits.max_v_m_s)
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
            self._end_recovery(t_s)
            return None
        return NavCommand(v, w, self._state, self._reason, rec.name, pose.distance(goal))


class RouteChecker:
    """Refuses a start or goal the map rules out; the map's passable regions are labelled once,
    so a long-running service checks each new goal in constant time.

    Each pose must lie on the map, on a known cell (when the global costmap tracks unknown
    space), outside every obstacle and its inscribed band (the robot's radius), and every goal
    must be connected to the start through cells A* may cross.

    Parameters
    ----------
    grid : OccupancyGrid
        The map the robot localises and plans on.
    config : NavigatorConfig
        The costmap and planner settings the navigation will use.
    costmap : Costmap or None
        The map's costmap under those settings, if one is at hand (a navigator's
        ``static_costmap``); else it is built here.
    """

    def __init__(
        self, grid: OccupancyGrid, config: NavigatorConfig, costmap: Costmap | None = None
    ) -> None:
        self.grid = grid
        self.costmap_config = dataclasses.replace(
            config.costmap, track_unknown_space=config.global_track_unknown_space
        )
        if costmap is None:
            costmap = Costmap.from_map(grid, self.costmap_config, collision_checks=False)
        self.costmap = costmap
        passable = cell_costs(costmap, config.planner)[1]
        self.labels = ndimage.label(passable, structure=np.ones((3, 3), bool))[0]

    def region(self, pose: Pose2D, name: str) -> int:
        """The passable region ``pose`` lies in (0: none), after checking the pose itself.

        Raises
        ------
        RouteError
            Naming ``name``, its position and why it is refused.
        """
        grid, costmap, cfg = self.grid, self.costmap, self.costmap_config
        where = f"{name} ({pose.x:.2f}, {pose.y:.2f}) is"
        (r,), (c,) = (np.atleast_1d(a) for a in costmap.world_to_cell(pose.x, pose.y))
        if not costmap.inside(r, c):
            x0, y0 = grid.origin_x_m, grid.origin_y_m
            x1 = x0 + grid.width * grid.resolution_m
            y1 = y0 + grid.height * grid.resolution_m
            raise RouteError(
                f"{where} outside the map (x {x0:.2f} to {x1:.2f} m, y {y0:.2f} to {y1:.2f} m)"
            )
        value = int(grid.data[r, c])
        cost = int(costmap.costs[r, c])
        if value >= cfg.lethal_threshold_percent:
            raise RouteError(f"{where} in an obstacle of the map: pick a free point")
        if value < 0 and cfg.track_unknown_space:
            raise RouteError(
                f"{where} in unknown space of the map: map it first (jackson map --waypoint)"
            )
        if cost >= INSCRIBED_INFLATED_OBSTACLE and cost != 255:
            raise RouteError(
                f"{where} within the robot's radius ({cfg.robot_radius_m:g} m) of an "
                "obstacle of the map: pick a point farther from it"
            )
        return int(self.labels[r, c])

    def region_near(self, pose: Pose2D, radius_m: float = 0.3) -> int:
        """The passable region at ``pose`` or, where the robot stands too close to a wall for
        its own cell to be passable, the region most cells within ``radius_m`` belong to
        (0: none). Never raises: for where the robot is, not where it is asked to go."""
        costmap = self.costmap
        (r,), (c,) = (np.atleast_1d(a) for a in costmap.world_to_cell(pose.x, pose.y))
        if not costmap.inside(r, c):
            return 0
        if self.labels[r, c]:
            return int(self.labels[r, c])
        k = max(1, math.ceil(radius_m / self.grid.resolution_m))
        rows, cols = self.labels.shape
        window = self.labels[
            max(0, r - k) : min(rows, r + k + 1), max(0, c - k) : min(cols, c + k + 1)
        ]
        found = window[window > 0]
        return int(np.bincount(found).argmax()) if found.size else 0

    def check_goal(self, goal: Pose2D, region: int, name: str = "goal") -> None:
        """Refuse ``goal`` unless it is a valid pose in the passable region ``region``.

        Raises
        ------
        RouteError
            As :meth:`region`, or the goal cannot be reached from there.
        """
        if self.region(goal, name) != region or region == 0:
            raise RouteError(
                f"{name} ({goal.x:.2f}, {goal.y:.2f}) cannot be reached from the robot's "
                "position on the map"
            )


def check_route(
    grid: OccupancyGrid,
    start: Pose2D,
    goals: tuple[Pose2D, ...],
    config: NavigatorConfig,
    costmap: Costmap | None = None,
) -> None:
    """Refuse a start or goal the map rules out, before anything moves (:class:`RouteChecker`).

    Parameters
    ----------
    grid : OccupancyGrid
        The map the robot localises and plans on.
    start : Pose2D
        Where the robot stands (map frame).
    goals : tuple of Pose2D
        The goals, in order.
    config : NavigatorConfig
        The costmap and planner settings the navigation will use.
    costmap : Costmap or None
        The map's costmap under those settings, if one is at hand (a navigator's
        ``static_costmap``); else it is built here.

    Raises
    ------
    RouteError
        Naming the first pose at fault (``start`` or ``goal k``), its position and why.
    """
    checker = RouteChecker(grid, config, costmap)
    start_label = checker.region(start, "start")
    for k, pose in enumerate(goals, 1):
        label = checker.region(pose, f"goal {k}")
        if start_label == 0 or label != start_label:
            raise RouteError(
                f"goal {k} ({pose.x:.2f}, {pose.y:.2f}) cannot be reached from the start on the map"
            )
