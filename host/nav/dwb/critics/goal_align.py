"""GoalAlign: point the robot's nose at the goal.

A :class:`~jackson.host.nav.dwb.critics.goal_dist.GoalDistCritic` with its target pushed on
and scored at a point projected ahead, as DWB's GoalAlign derives from GoalDist. Raw score:
the goal-align map at the point ``goal_align_forward_point_distance`` (0.1 m) ahead of the
roll-out's end pose, the Manhattan distance [cells] from its cell to the last cell of the
global path in the window, that cell pushed on by the same distance towards the goal when it
is the path's end (DWB shifts only the path's end, not a point where the path leaves the
window), through the cells below inscribed (:mod:`jackson.host.nav.dwb.core.distance`). Rejects a
roll-out whose forward point lies off the grid. Scale 24.0; 0 (and nothing rejected) while
RotateToGoal turns the stopped robot to the goal's yaw.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.core.path import PlanCells
from jackson.host.nav.dwb.critics.base import Batch, Context
from jackson.host.nav.dwb.critics.goal_dist import GoalDistCritic
from jackson.host.nav.dwb.critics.map_grid import forward_cells
from jackson.host.nav.dwb.critics.rotate_to_goal import RotateToGoalCritic

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


class GoalAlignCritic(GoalDistCritic):
    """Score how far the point ahead of the end pose is from the goal.

    Parameters
    ----------
    config : DwbConfig
        Scale and forward point distance.
    rotate_to_goal : RotateToGoalCritic or None
        The planner's RotateToGoal, prepared before this critic: while it rotates, this
        critic's scale is 0.
    """

    name = "GoalAlign"

    def __init__(self, config: DwbConfig, rotate_to_goal: RotateToGoalCritic | None) -> None:
        super().__init__(config)
        self.rotate_to_goal = rotate_to_goal
        self._scale = config.goal_align_scale

    @property
    def scale(self) -> float:
        """``goal_align_scale``, 0 while RotateToGoal rotates."""
        return self._scale

    def prepare(self, context: Context) -> bool:
        """Fix the scale and take the map from the (pushed) target cell; False without a path
        in the window."""
        rotating = self.rotate_to_goal is not None and self.rotate_to_goal.rotating
        self._scale = 0.0 if rotating else self.config.goal_align_scale
        return super().prepare(context)

    def target_cells(self, context: Context, plan: PlanCells) -> tuple[IntArray, IntArray]:
        """GoalDist's cell, pushed on by the forward point distance along the heading from
        the robot to the goal when it is the path's end and the pushed cell is on the grid."""
        rows, cols = super().target_cells(context, plan)
        ar, ac = int(rows[-1]), int(cols[-1])
        if plan.reaches_end:
            costmap, pose, goal = context.costmap, context.pose, context.goal
            heading = math.atan2(goal.y - pose.y, goal.x - pose.x)
            fpd = self.config.goal_align_forward_point_distance_m
            tx, ty = costmap.cell_to_world(ar, ac)
            sr, sc = costmap.world_to_cell(
                float(tx) + fpd * math.cos(heading), float(ty) + fpd * math.sin(heading)
            )
            n_rows, n_cols = costmap.shape
            if 0 <= sr < n_rows and 0 <= sc < n_cols:
                ar, ac = int(sr), int(sc)
        return np.array([ar], np.intp), np.array([ac], np.intp)

    def scored_cells(self, batch: Batch) -> tuple[IntArray, BoolArray]:
        """The forward point's cell, legal on the grid while the scale is not 0."""
        return forward_cells(batch, self.config.goal_align_forward_point_distance_m, self._scale)
