"""GoalDist: get nearer the goal.

Raw score: the goal map at the roll-out's end pose, the Manhattan distance [cells] from its
cell to the last cell of the global path in the window (the goal's, or where the path leaves
the window), through the cells below inscribed (:mod:`jackson.host.nav.dwb.core.distance`). Rejects
a roll-out that ends off the grid. Scale 24.0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.path import PlanCells
from jackson.host.nav.dwb.critics.base import Context
from jackson.host.nav.dwb.critics.map_grid import MapGridCritic

IntArray = npt.NDArray[np.intp]


class GoalDistCritic(MapGridCritic):
    """Score the distance of the end pose to the path's last cell in the window.

    Parameters
    ----------
    config : DwbConfig
        Scale.
    """

    name = "GoalDist"

    @property
    def scale(self) -> float:
        """``goal_dist_scale``."""
        return self.config.goal_dist_scale

    def target_cells(self, context: Context, plan: PlanCells) -> tuple[IntArray, IntArray]:
        """The path's last cell in the window (DWB's last pose on the costmap)."""
        return plan.rows[-1:], plan.cols[-1:]
