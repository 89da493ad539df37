"""GoalAlign: point the robot's nose at the goal.

Raw score: the goal-align map at the point ``goal_align_forward_point_distance`` (0.1 m) ahead
of the roll-out's end pose, the Manhattan distance [cells] from its cell to the last cell of
the global path in the window, that cell pushed on by the same distance towards the goal when
it is the path's end (DWB shifts only the path's end, not a point where the path leaves the
window), through the cells below inscribed (:mod:`jackson.host.nav.dwb.core.distance`). Rejects a
roll-out whose forward point lies off the grid. Scale 24.0; 0 (and nothing rejected) while
RotateToGoal turns the stopped robot to the goal's yaw.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic
from jackson.host.nav.dwb.critics.rotate_to_goal import RotateToGoalCritic

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class GoalAlignCritic(Critic):
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
        self.config = config
        self.rotate_to_goal = rotate_to_goal
        self._scale = config.goal_align_scale
        self._map: FloatArray | None = None

    @property
    def scale(self) -> float:
        """``goal_align_scale``, 0 while RotateToGoal rotates."""
        return self._scale

    def prepare(self, context: Context) -> bool:
        """Fix the scale and take the map from the (pushed) target cell; False without a path
        in the window."""
        c = self.config
        rotating = self.rotate_to_goal is not None and self.rotate_to_goal.rotating
        self._scale = 0.0 if rotating else c.goal_align_scale
        plan = context.plan
        if plan is None:
            self._map = None
            return False
        costmap, pose, goal = context.costmap, context.pose, context.goal
        ar, ac = int(plan.rows[-1]), int(plan.cols[-1])
        if plan.reaches_end:
            heading = math.atan2(goal.y - pose.y, goal.x - pose.x)
            fpd = c.goal_align_forward_point_distance_m
            tx, ty = costmap.cell_to_world(ar, ac)
            sr, sc = costmap.world_to_cell(
                float(tx) + fpd * math.cos(heading), float(ty) + fpd * math.sin(heading)
            )
            rows, cols = costmap.shape
            if 0 <= sr < rows and 0 <= sc < cols:
                ar, ac = int(sr), int(sc)
        self._map = context.maps.to_cells(costmap, [ar], [ac])
        return True

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores (goal-align map at the forward point) and legality (forward point on the
        grid, while the scale is not 0)."""
        if self._map is None:
            raise RuntimeError("GoalAlign: scored without a map (prepare returned False)")
        cell, on_grid = batch.forward_cells(self.config.goal_align_forward_point_distance_m)
        legal = on_grid if self._scale > 0.0 else np.ones(batch.size, bool)
        return self._map.take(cell), legal
