"""MapGrid: the critics that read a distance map at one point of each roll-out, as DWB's
``MapGridCritic`` is the base of its path and goal critics.

A map-grid critic takes, once per cycle, the distance map [cells] to a set of target cells of
the local costmap (:meth:`MapGridCritic.target_cells`, searched through the cells below
inscribed, :mod:`jackson.host.nav.dwb.core.distance`), and scores each roll-out by the map at
the cell of one point of it (:meth:`MapGridCritic.scored_cells`): the end pose, or, for the
align critics, a point projected ahead of it. Nav2's family, reproduced here:

=================  ===============  =================================================
critic             derives from     target cells, scored point
=================  ===============  =================================================
PathDist           MapGrid          the path's cells in the window; the end pose
PathAlign          PathDist         the same; the forward point of the end pose
GoalDist           MapGrid          the path's last cell in the window; the end pose
GoalAlign          GoalDist         that cell pushed towards the goal; the forward point
=================  ===============  =================================================
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.core.path import PlanCells
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


class MapGridCritic(Critic):
    """Score the distance map at one point of each roll-out (module docstring).

    Subclasses name the map's target cells (:meth:`target_cells`) and may score another point
    than the end pose (:meth:`scored_cells`).

    Parameters
    ----------
    config : DwbConfig
        The planner's parameters (the subclass reads its scale and distances there).
    """

    name = "MapGrid"

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self._map: FloatArray | None = None

    def target_cells(self, context: Context, plan: PlanCells) -> tuple[IntArray, IntArray]:
        """The cells the map measures the distance to.

        Parameters
        ----------
        context : Context
            The cycle.
        plan : PlanCells
            The global path's cells in the window.

        Returns
        -------
        tuple of ndarray of int, shape (N,)
            (rows, cols) of the target cells.
        """
        raise NotImplementedError

    def scored_cells(self, batch: Batch) -> tuple[IntArray, BoolArray]:
        """The cell each roll-out is scored at and whether the roll-out is legal: the end
        pose's cell, legal on the grid.

        Parameters
        ----------
        batch : Batch
            The cycle's roll-outs.

        Returns
        -------
        tuple of ndarray, shape (M,)
            (flat cell index, legal).
        """
        return batch.end_cell, batch.end_on_grid

    def prepare(self, context: Context) -> bool:
        """Take the distance map to the target cells; False without a path in the window."""
        plan = context.plan
        if plan is None:
            self._map = None
            return False
        self._map = context.maps.to_cells(context.costmap, *self.target_cells(context, plan))
        return True

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores (the map at the scored cells) and legality."""
        if self._map is None:
            raise RuntimeError(f"{self.name}: scored without a map (prepare returned False)")
        cell, legal = self.scored_cells(batch)
        return self._map.take(cell), legal


def forward_cells(batch: Batch, distance_m: float, scale: float) -> tuple[IntArray, BoolArray]:
    """The align critics' scored cells: the point ``distance_m`` ahead of each end pose (DWB's
    ``getForwardPose``), legal on the grid while ``scale`` is not 0 (a critic left out of the
    total rejects nothing).

    Parameters
    ----------
    batch : Batch
        The cycle's roll-outs.
    distance_m : float
        The forward point distance [m].
    scale : float
        The critic's scale this cycle.

    Returns
    -------
    tuple of ndarray, shape (M,)
        (flat cell index, legal).
    """
    cell, on_grid = batch.forward_cells(distance_m)
    legal = on_grid if scale > 0.0 else np.ones(batch.size, bool)
    return cell, legal
