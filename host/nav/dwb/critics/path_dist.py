"""PathDist: stay near the global path.

Raw score: the path map at the roll-out's end pose, the Manhattan distance [cells] from its
cell to the nearest cell of the global path in the window (:class:`PlanCells`), through the
cells below inscribed (:mod:`jackson.host.nav.dwb.core.distance`). Rejects a roll-out that ends off
the grid. Scale 32.0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class PathDistCritic(Critic):
    """Score the distance of the end pose to the global path.

    Parameters
    ----------
    config : DwbConfig
        Scale.
    """

    name = "PathDist"

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self._map: FloatArray | None = None

    @property
    def scale(self) -> float:
        """``path_dist_scale``."""
        return self.config.path_dist_scale

    def prepare(self, context: Context) -> bool:
        """Take the path map; False without a path in the window."""
        plan = context.plan
        if plan is None:
            self._map = None
            return False
        self._map = context.maps.to_cells(context.costmap, plan.rows, plan.cols)
        return True

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores (path map at the end pose) and legality (end pose on the grid)."""
        if self._map is None:
            raise RuntimeError("PathDist: scored without a path map (prepare returned False)")
        return self._map.take(batch.end_cell), batch.end_on_grid
