"""PathAlign: keep the robot's nose on the global path.

Raw score: the path map at the point ``path_align_forward_point_distance`` (0.1 m) ahead of the
roll-out's end pose, the Manhattan distance [cells] from its cell to the nearest cell of the
global path in the window, through the cells below inscribed
(:mod:`jackson.host.nav.dwb.core.distance`). Rejects a roll-out whose forward point lies off the
grid. Scale 32.0 x resolution / 2, as DWB scales it; 0 (and nothing rejected) within the
forward point distance of the goal, where the nose follows RotateToGoal alone, and, as
GoalAlign, while RotateToGoal turns the stopped robot to the goal's yaw.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic
from jackson.host.nav.dwb.critics.rotate_to_goal import RotateToGoalCritic

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class PathAlignCritic(Critic):
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
        self.config = config
        self.rotate_to_goal = rotate_to_goal
        self._scale = 0.0
        self._map: FloatArray | None = None

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
        plan = context.plan
        if plan is None:
            self._map = None
            return False
        self._map = context.maps.to_cells(context.costmap, plan.rows, plan.cols)
        return True

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores (path map at the forward point) and legality (forward point on the grid,
        while the scale is not 0)."""
        if self._map is None:
            raise RuntimeError("PathAlign: scored without a path map (prepare returned False)")
        cell, on_grid = batch.forward_cells(self.config.path_align_forward_point_distance_m)
        legal = on_grid if self._scale > 0.0 else np.ones(batch.size, bool)
        return self._map.take(cell), legal
