"""Where a robot may start and go on a map: a start or goal the map rules out is refused with
one line, before anything moves (:class:`RouteChecker`, :func:`check_route`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import ndimage

from jackson.common.errors import JacksonError
from jackson.host.control.navigator_config import NavigatorConfig
from jackson.host.nav.astar import cell_costs
from jackson.host.nav.costmap import INSCRIBED_INFLATED_OBSTACLE, Costmap
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D


class RouteError(JacksonError, ValueError):
    """A start or goal the map rules out (one line: which pose, where, what is wrong)."""


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
