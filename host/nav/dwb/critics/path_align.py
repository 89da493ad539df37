"""PathAlign: keep the robot's nose on the global path.

A :class:`~jackson.host.nav.dwb.critics.path_dist.PathDistCritic` scored at a point projected
ahead, as DWB's PathAlign derives from PathDist. Raw score: the path map at the point
``path_align_forward_point_distance`` (0.1 m) ahead of the roll-out's end pose, the Manhattan
distance [cells] from its cell to the nearest cell of the global path in the window, through
the cells below inscribed (:mod:`jackson.host.nav.dwb.core.distance`). Rejects a roll-out whose
forward point lies off the grid. Scale 32.0 x resolution / 2, as DWB scales it; 0 (and
nothing rejected) within the forward point distance of the goal, where the nose follows
RotateToGoal alone, and, as GoalAlign, while RotateToGoal turns the stopped robot to the
goal's yaw.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context
from jackson.host.nav.dwb.critics.map_grid import forward_cells
from jackson.host.nav.dwb.critics.path_dist import PathDistCritic
from jackson.host.nav.dwb.critics.rotate_to_goal import RotateToGoalCritic

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


class PathAlignCritic(PathDistCritic):
    """Score how far the point ahead of the end pose is from the global path.

    Parameters
    ----------
    config : DwbConfig
        Scale and forward point distance.
    rotate_to_goal : RotateToGoalCritic or None
        The planner's RotateToGoal, prepared before this critic: while it rotates, this
        critic's scale is 0.
    """

    name = "PathAlign"

    def __init__(self, config: DwbConfig, rotate_to_goal: RotateToGoalCritic | None) -> None:
        super().__init__(config)
        self.rotate_to_goal = rotate_to_goal
        self._scale = 0.0

    @property
    def scale(self) -> float:
        """``path_align_scale`` x resolution / 2 (DWB's scaling); 0 at the goal or while
        RotateToGoal rotates."""
        return self._scale

    def prepare(self, context: Context) -> bool:
        """Fix the scale for the costmap's resolution and the distance to the goal, and take
        the path map; False without a path in the window."""
        c = self.config
        rotating = self.rotate_to_goal is not None and self.rotate_to_goal.rotating
        at_goal = context.pose.distance(context.goal) <= c.path_align_forward_point_distance_m
        if at_goal or rotating:
            self._scale = 0.0
        else:
            self._scale = c.path_align_scale * 0.5 * context.costmap.resolution_m
        return super().prepare(context)

    def scored_cells(self, batch: Batch) -> tuple[IntArray, BoolArray]:
        """The forward point's cell, legal on the grid while the scale is not 0."""
        return forward_cells(batch, self.config.path_align_forward_point_distance_m, self._scale)
