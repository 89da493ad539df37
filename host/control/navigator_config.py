"""The navigator's parameters: costmaps, planners, checkers and recoveries in one place, as
Nav2 documents a navigator's parameters (:class:`NavigatorConfig`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from jackson.host.nav.astar import AStarConfig
from jackson.host.nav.costmap import CostmapConfig
from jackson.host.nav.dwb import DwbConfig

PLAN_DELAY_TICKS = 3
"""Control ticks from asking for a global plan to taking it, in the daemon and the twin's trials
(150 ms at 20 Hz): time for the planner server's worker to search a 20 m map on a Jetson-class
core (45-75 ms) while the frame loop goes on, and nothing beside Nav2's planner server, which
answers the controller asynchronously at 1 Hz. Chosen on the campaign's worlds: with 1 or 3
ticks every world's figures are those of the plans taken at once (d_min within 1 cm, t_nav
within 0.2 s), while 2 ticks put ``corridor_8m``'s d_min at 10 cm instead of 22 over 10 trials
(a detour planned at another phase of the 7.43 Hz scans, then kept by the hysteresis)."""
MAX_PLAN_DELAY_TICKS = 20


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
    plan_delay_ticks : int
        A global plan asked for at one control tick is taken this many ticks later (searched
        meanwhile by the planner server, :mod:`jackson.host.nav.planner_server`, off the
        control thread where the daemon runs one); 0 searches and takes it on the tick that
        asks for it, as runs recorded before the planner server did. :data:`PLAN_DELAY_TICKS`
        is what the daemon and the twin's trials use.
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
    plan_delay_ticks: int = 0

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
        if not 0 <= self.plan_delay_ticks <= MAX_PLAN_DELAY_TICKS:
            raise ValueError(
                f"NavigatorConfig.plan_delay_ticks must be in 0-{MAX_PLAN_DELAY_TICKS}, "
                f"got {self.plan_delay_ticks}"
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
