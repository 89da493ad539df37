"""The navigator's global planning: when to plan, A* on the global costmap, which path to keep,
and why there is none (:class:`GlobalPlanning`).

* The path is recomputed every ``replan_period_s`` (1 Hz, Nav2 bringup's tree) and at once
  when the remaining path crosses a cell A* would refuse (inscribed or lethal) in either
  costmap (at most every ``blocked_replan_interval_s``); a plan that falls due on a tick that
  brought a scan waits for the next tick (50 ms), so that no tick both re-inflates the
  costmaps and plans: the worst tick is the larger of the two, not their sum.
* A periodic replan keeps the current path unless the new one is more than
  ``replan_hysteresis`` (10 %) cheaper. With the cylinder in the middle of the corridor the two
  routes around it cost nearly the same and the plan flipped sides on replans. Over 20 runs
  of the course with LiDAR noise, without it the slowest run took 58 s with 4 recoveries among
  all runs; with it 22 s and 1 recovery. (Nav2 always takes the new path.)
* "No path" is a state, not a loop. Obstacles the LiDAR has seen stay in the global costmap
  until a scan's ray clears them (Nav2's obstacle layer), and a failed plan does not clear
  them (Nav2's tree clears the global costmap and retries: with the obstacle still there, the
  retry plans through the erased obstacle, the next scan blocks it again, and the robot loops
  until its recoveries run out). Instead the robot stops, and the place that blocks the goal
  is found: the first point of the path planned on the map alone that the costmap now
  refuses. If that point is within the LiDAR's clearing range, scans keep checking it while
  the robot waits; still blocked after ``unreachable_confirm_s`` of them, the goal fails with
  ``goal (x, y) unreachable: blocked at (x, y)``. If it is farther, what the scans saw beyond
  their clearing range is forgotten (it may have moved; nothing in view is) and the robot
  drives on to look, at most ``max_reverifications`` times per goal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.host.control.navigator_config import NavigatorConfig
from jackson.host.nav import native, native_grid
from jackson.host.nav.astar import CostGrid, NoPathError, astar, path_cost
from jackson.host.nav.costmap import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, Costmap
from jackson.host.nav.dwb import prune_path
from jackson.host.nav.planner_server import InlinePlanner, Planner, PlanRequest
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class PlanOutcome:
    """What one tick's global planning did, for the navigator's state.

    Attributes
    ----------
    ready : bool
        There is a path to follow this tick (new, kept or the current one).
    planned : bool
        A plan was searched this tick.
    blocked : str or None
        The goal is cut off (``no path: blocked at (x, y)``): the navigator waits, planning.
    failure : str or None
        The goal fails with this reason.
    """

    ready: bool
    planned: bool = False
    blocked: str | None = None
    failure: str | None = None


class GlobalPlanning:
    """The global path of one goal (module docstring).

    Parameters
    ----------
    config : NavigatorConfig
        The planner, replanning and unreachable-goal settings.
    global_costmap : Costmap
        Static map + scans + inflation: A* plans on it.
    static_costmap : Costmap
        The map alone (no scans): where a path would run if nothing had been seen.
    local_costmap : Costmap
        The rolling window; a path crossing a refused cell of it is blocked too.

    Attributes
    ----------
    path : ndarray, shape (N, 2), or None
        The path followed [m], map frame.
    replans : int
        Global plans computed for the current goal.
    kept_plans : int
        Replans whose result was dropped for the current path (``replan_hysteresis``).
    blocked_at : tuple of float or None
        Where the goal was last found cut off [m], map frame.
    """

    def __init__(
        self,
        config: NavigatorConfig,
        global_costmap: Costmap,
        static_costmap: Costmap,
        local_costmap: Costmap,
        planner: Planner | None = None,
    ) -> None:
        self.config = config
        self.planner: Planner = planner if planner is not None else InlinePlanner()
        self._pending: PlanRequest | None = None  # the plan asked for, not yet taken
        self._pending_ticks = 0  # ticks since it was asked for
        self._pending_t_s = 0.0  # when
        self._requests = 0
        self._drop_path = False  # the path was found blocked: the plan asked for replaces it
        self.global_costmap = global_costmap
        self.static_costmap = static_costmap
        self.local_costmap = local_costmap
        self.path: FloatArray | None = None
        self.replans = 0
        self.kept_plans = 0
        self.blocked_at: tuple[float, float] | None = None
        self._t_plan_s = -math.inf
        self._t_blocked_plan_s = -math.inf
        self._no_path_since_s: float | None = None
        self._reverifications = 0
        self._plan_deferred = False
        self._scan_since_plan = False

    def reset(self) -> None:
        """A new goal: no path, nothing counted, nothing pending."""
        self._pending = None
        self._drop_path = False
        self.path = None
        self._t_plan_s = -math.inf
        self._t_blocked_plan_s = -math.inf
        self._no_path_since_s = None
        self._reverifications = 0
        self._plan_deferred = False
        self._scan_since_plan = False
        self.blocked_at = None
        self.replans = 0
        self.kept_plans = 0

    def update(self, t_s: float, pose: Pose2D, goal: Pose2D, scanned: bool) -> PlanOutcome:
        """Plan when due (module docstring).

        Parameters
        ----------
        t_s : float
            MCU time [s].
        pose : Pose2D
            Robot pose (map frame).
        goal : Pose2D
            The goal.
        scanned : bool
            This tick brought a scan (the costmaps were updated).

        Returns
        -------
        PlanOutcome
            Whether there is a path to follow, and what the search found.
        """
        self._scan_since_plan = self._scan_since_plan or scanned
        if self.config.plan_delay_ticks > 0:
            return self._update_ahead(t_s, pose, goal)
        if self._no_path_since_s is not None and not self._scan_since_plan:
            return PlanOutcome(False)  # cut off: only a new scan can change that
        due = self._needs_plan(t_s, pose) or self._plan_deferred
        if due and scanned and not self._plan_deferred:
            # this tick updated both costmaps: plan on the next one, so that no tick does both
            self._plan_deferred = True
        elif due:
            self._plan_deferred = False
            self._scan_since_plan = False
            return self._make_plan(t_s, pose, goal)
        return PlanOutcome(self.path is not None)

    def forget_path(self) -> None:
        """Drop the path and any plan asked for (a recovery ended: plan afresh from here)."""
        self.path = None
        self._pending = None
        self._drop_path = False

    def _update_ahead(self, t_s: float, pose: Pose2D, goal: Pose2D) -> PlanOutcome:
        """``plan_delay_ticks`` > 0: a plan is asked for when due and taken that many ticks
        later (the path followed meanwhile is the current one); the searches run in the
        planner (:mod:`jackson.host.nav.planner_server`). No tick waits for a scan's: the
        search runs elsewhere, on the costs as the tick that asks for it left them."""
        if self._pending is not None:
            self._pending_ticks += 1
            if self._pending_ticks < self.config.plan_delay_ticks:
                return PlanOutcome(self.path is not None)
            request, self._pending = self._pending, None
            answer = self.planner.answer(request)
            if self._drop_path:  # it was blocked: the new path replaces it, or none does
                self.path, self._drop_path = None, False
            if answer.path is None:  # why there is none is found here, as without the delay
                return self._no_path_found(t_s, pose, goal)
            costs = None
            if answer.cost is not None and answer.kept_cost is not None:
                costs = (answer.kept_cost, answer.cost)
            return self._accept(self._pending_t_s, pose, answer.path, None, costs)
        if self._no_path_since_s is not None and not self._scan_since_plan:
            return PlanOutcome(False)  # cut off: only a new scan can change that
        if self._needs_plan(t_s, pose):
            self._scan_since_plan = False
            self._requests += 1
            kept = None  # priced with the new path by the planner, on the same costs
            if not self._drop_path and self.path is not None and self.config.replan_hysteresis > 0:
                kept = np.vstack(((pose.x, pose.y), prune_path(self.path, pose.x, pose.y)))
            request = PlanRequest(
                self._requests,
                CostGrid.of(self.global_costmap),
                (pose.x, pose.y),
                (goal.x, goal.y),
                self.config.planner,
                kept,
            )
            self.planner.submit(request)
            self._pending, self._pending_ticks, self._pending_t_s = request, 0, t_s
        return PlanOutcome(self.path is not None)

    def _needs_plan(self, t_s: float, pose: Pose2D) -> bool:
        """No path yet, the replanning period is over, or the remaining path is blocked."""
        if self.path is None or t_s - self._t_plan_s >= self.config.replan_period_s:
            return True
        if t_s - self._t_blocked_plan_s < self.config.blocked_replan_interval_s:
            return False
        if self.path_blocked(pose):
            self._t_blocked_plan_s = t_s
            if self.config.plan_delay_ticks > 0:
                self._drop_path = True  # followed until the new one comes, never kept over it
            else:
                self.path = None  # the old path may not be kept
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
        if self.path is None:
            return False
        near = self.config.costmap.robot_radius_m + self.global_costmap.resolution_m
        if native.LIB is not None:  # the same answer, compiled (None: a NaN, numpy's answer)
            maps = (self.global_costmap, self.local_costmap)
            found = native_grid.path_blocked(
                self.path, (pose.x, pose.y), near,
                (maps[0].geometry.as_tuple(), maps[1].geometry.as_tuple()),
                (maps[0].costs_padded, maps[1].costs_padded),
                (INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE),
            )  # fmt: skip
            if found is not None:
                return found
        ahead = prune_path(self.path, pose.x, pose.y)
        ahead = ahead[np.hypot(ahead[:, 0] - pose.x, ahead[:, 1] - pose.y) > near]
        if len(ahead) == 0:
            return False
        for costmap in (self.global_costmap, self.local_costmap):
            cost = costmap.cost_at(ahead[:, 0], ahead[:, 1])
            if np.any((cost == INSCRIBED_INFLATED_OBSTACLE) | (cost == LETHAL_OBSTACLE)):
                return True
        return False

    def _make_plan(self, t_s: float, pose: Pose2D, goal: Pose2D) -> PlanOutcome:
        """Plan on the global costmap; without a path, stop and find out why."""
        start, target = (pose.x, pose.y), (goal.x, goal.y)
        try:
            path = astar(self.global_costmap, start, target, self.config.planner)
        except NoPathError:
            return self._no_path_found(t_s, pose, goal)
        return self._accept(t_s, pose, path, None)

    def _no_path_found(self, t_s: float, pose: Pose2D, goal: Pose2D) -> PlanOutcome:
        """The search found no path: wait, look again or fail (:meth:`_no_path`); a block
        forgotten is searched again at once, on this tick."""
        start, target = (pose.x, pose.y), (goal.x, goal.y)
        self.path = None
        again, blocked, failure = self._no_path(t_s, pose, goal)
        if not again:
            return PlanOutcome(False, True, blocked, failure)
        try:  # what blocked it was forgotten: plan again at once
            path = astar(self.global_costmap, start, target, self.config.planner)
        except NoPathError:
            _, blocked_again, failure = self._no_path(t_s, pose, goal)
            return PlanOutcome(False, True, blocked_again or blocked, failure)
        return self._accept(t_s, pose, path, blocked)

    def _accept(
        self,
        t_s: float,
        pose: Pose2D,
        path: FloatArray,
        blocked: str | None,
        costs: tuple[float, float] | None = None,
    ) -> PlanOutcome:
        """A path found (asked for at ``t_s``): follow it, unless the current one is kept.
        ``costs``: the current path's and the new one's, priced by the planner where it
        searched (else priced here, on the global costmap)."""
        self._no_path_since_s = None
        self.blocked_at = None
        self.replans += 1
        self._t_plan_s = t_s
        if self.path is not None and self.config.replan_hysteresis > 0.0:
            if costs is not None:
                old_cost, new_cost = costs
            else:
                ahead = np.vstack(((pose.x, pose.y), prune_path(self.path, pose.x, pose.y)))
                old_cost = path_cost(ahead, self.global_costmap, self.config.planner)
                new_cost = path_cost(path, self.global_costmap, self.config.planner)
            if old_cost <= (1.0 + self.config.replan_hysteresis) * new_cost:
                self.kept_plans += 1
                return PlanOutcome(True, True, blocked)
        self.path = path
        return PlanOutcome(True, True, blocked)

    def _no_path(
        self, t_s: float, pose: Pose2D, goal: Pose2D
    ) -> tuple[bool, str | None, str | None]:
        """The goal is cut off: wait for scans to confirm it, look again, or fail.

        Returns
        -------
        tuple
            (what blocked it lay out of view and was forgotten: plan again; the blocked
            state's reason, None when the map itself cuts the goal off; the failure, if the
            goal fails).
        """
        cfg = self.config
        start, target = (pose.x, pose.y), (goal.x, goal.y)
        try:
            witness = astar(self.static_costmap, start, target, cfg.planner)
        except NoPathError as on_map:
            failure = f"goal ({goal.x:.2f}, {goal.y:.2f}) unreachable on the map: {on_map}"
            return False, None, failure
        blocked = self._first_blocked(witness, pose)
        self.blocked_at = blocked
        where = f"({blocked[0]:.2f}, {blocked[1]:.2f})"
        reason = f"no path: blocked at {where}"
        clearing_m = cfg.costmap.raytrace_max_range_m
        out_of_view = math.hypot(blocked[0] - pose.x, blocked[1] - pose.y) > clearing_m - 0.25
        if out_of_view and self._reverifications < cfg.max_reverifications:
            # seen from afar and out of view now: forget it, drive on and look again
            self._reverifications += 1
            self.global_costmap.clear_obstacles(clearing_m, (pose.x, pose.y))
            self._no_path_since_s = None
            return True, reason, None
        if self._no_path_since_s is None:
            self._no_path_since_s = t_s
        elif t_s - self._no_path_since_s >= cfg.unreachable_confirm_s:
            failure = f"goal ({goal.x:.2f}, {goal.y:.2f}) unreachable: blocked at {where}"
            return False, reason, failure
        return False, reason, None

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
