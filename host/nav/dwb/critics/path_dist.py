"""PathDist: stay near the global path.

Raw score: the path map at the roll-out's end pose, the Manhattan distance [cells] from its
cell to the nearest cell of the global path in the window (:class:`PlanCells`), through the
cells below inscribed (:mod:`jackson.host.nav.dwb.core.distance`). Rejects a roll-out that ends off
the grid. Scale 32.0.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.path import PlanCells
from jackson.host.nav.dwb.critics.base import Context
from jackson.host.nav.dwb.critics.map_grid import MapGridCritic

IntArray = npt.NDArray[np.intp]


class PathDistCritic(MapGridCritic):
    """Score the distance of the end pose to the global path.

    Parameters
    ----------
    config : DwbConfig
        Scale.
    """

    name = "PathDist"

    @property
    def scale(self) -> float:
        """``path_dist_scale``."""
        return self.config.path_dist_scale

    def target_cells(self, context: Context, plan: PlanCells) -> tuple[IntArray, IntArray]:
        """Every cell of the path in the window."""
        return plan.rows, plan.cols
