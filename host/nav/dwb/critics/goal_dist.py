"""GoalDist: get nearer the goal.

Raw score: the goal map at the roll-out's end pose, the Manhattan distance [cells] from its
cell to the last cell of the global path in the window (the goal's, or where the path leaves
the window), through the cells below inscribed (:mod:`jackson.host.nav.dwb.core.distance`). Rejects
a roll-out that ends off the grid. Scale 24.0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class GoalDistCritic(Critic):
    """Score the distance of the end pose to the path's last cell in the window.

    Parameters
    ----------
    config : DwbConfig
        Scale.
    """

    name = "GoalDist"

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self._map: FloatArray | None = None

    @property
    def scale(self) -> float:
        """``goal_dist_scale``."""
        return self.config.goal_dist_scale

    def prepare(self, context: Context) -> bool:
        """Take the goal map; False without a path in the window."""
        plan = context.plan
        if plan is None:
            self._map = None
            return False
        self._map = context.maps.to_cells(context.costmap, plan.rows[-1:], plan.cols[-1:])
        return True

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores (goal map at the end pose) and legality (end pose on the grid)."""
        if self._map is None:
            raise RuntimeError("GoalDist: scored without a goal map (prepare returned False)")
        return self._map.take(batch.end_cell), batch.end_on_grid
