"""The vectorised critic interface: a cycle's :class:`Context`, its :class:`Batch` of roll-outs,
and the :class:`Critic` protocol.

Each cycle the planner calls, on every critic in its list (Nav2 bringup's order):

1. :meth:`Critic.prepare` with the cycle's :class:`Context` (pose, velocity, goal, costmap, the
   path's cells in the window and the distance maps), once; the critic keeps what it needs
   and fixes its :attr:`Critic.scale` for the cycle;
2. :meth:`Critic.score` with the :class:`Batch`: every roll-out at once, as arrays computed
   once per cycle and shared by all critics (targets, end poses, every 16th pose, cells);
   it returns the raw score and the legality of each roll-out;
3. :meth:`Critic.debrief` with the command chosen, when one was.

The total of a roll-out is the sum of scale x raw over the critics whose scale is not 0, in
list order (Eq. 11 of the paper); a roll-out any critic finds illegal is never chosen.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from jackson.host.nav.costmap import Costmap
from jackson.host.nav.dwb.core.config import Command
from jackson.host.nav.dwb.core.distance import DistanceMaps, cell_index
from jackson.host.nav.dwb.core.path import PlanCells
from jackson.host.nav.dwb.core.rollouts import Rollouts
from jackson.host.nav.types import Pose2D

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]

_CULL_STEPS = 16  # roll-out steps per block when sorting out the roll-outs far from obstacles


@dataclass(frozen=True)
class Context:
    """What a critic may read about the cycle before any roll-out is scored.

    Attributes
    ----------
    pose : Pose2D
        Robot pose in the costmap's (map) frame.
    velocity : tuple of float
        Current (v [m/s], w [rad/s]).
    goal : Pose2D
        The goal pose.
    costmap : Costmap
        The local costmap.
    plan : PlanCells or None
        The global path's cells in the window (Nav2's transformed plan); None when no point of
        it lies on a known cell.
    maps : DistanceMaps
        The distance maps of ``costmap`` (searched on demand, shared by the critics).
    """

    pose: Pose2D
    velocity: tuple[float, float]
    goal: Pose2D
    costmap: Costmap
    plan: PlanCells | None
    maps: DistanceMaps


@dataclass(frozen=True)
class Batch:
    """The M roll-outs of one cycle, as the arrays the critics score them by.

    Build it with :meth:`of`: the end poses and the coarse poses come from one
    :meth:`Rollouts.coarse` call, the end cells from one lookup, and the cells of points ahead
    of the end poses once per distance (:meth:`forward_cells`), whichever critics read them.
    Critics read the arrays and never write them.

    Attributes
    ----------
    v_m_s, w_rad_s : ndarray, shape (M,)
        The targets [m/s], [rad/s], in (v, w) order.
    v_brake_m_s : float
        The slowest linear target of the window (hardest braking) [m/s].
    rollouts : Rollouts
        The roll-outs, factored (the poses the critics do not read are never evaluated).
    coarse_x_m, coarse_y_m : ndarray, shape (B + 1, M)
        Position at the start, every ``_CULL_STEPS``-th pose and the end pose [m].
    coarse_length_m : ndarray, shape (B, M)
        Path length between those poses [m].
    x_end_m, y_end_m, yaw_end_rad : ndarray, shape (M,)
        The end pose of every roll-out [m], [m], [rad].
    cos_end, sin_end : ndarray, shape (M,)
        cos and sin of ``yaw_end_rad``.
    end_cell : ndarray of int, shape (M,)
        Flat index of the end pose's cell (clipped onto the grid) into the costmap's and the
        distance maps' cells.
    end_on_grid : ndarray of bool, shape (M,)
        Whether the end pose lies on the grid.
    costmap : Costmap
        The local costmap the cells index.
    """

    v_m_s: FloatArray
    w_rad_s: FloatArray
    v_brake_m_s: float
    rollouts: Rollouts
    coarse_x_m: FloatArray
    coarse_y_m: FloatArray
    coarse_length_m: FloatArray
    x_end_m: FloatArray
    y_end_m: FloatArray
    yaw_end_rad: FloatArray
    cos_end: FloatArray
    sin_end: FloatArray
    end_cell: IntArray
    end_on_grid: BoolArray
    costmap: Costmap
    _forward: dict[float, tuple[IntArray, BoolArray]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    @classmethod
    def of(
        cls,
        v_m_s: FloatArray,
        w_rad_s: FloatArray,
        v_brake_m_s: float,
        rollouts: Rollouts,
        costmap: Costmap,
    ) -> Batch:
        """The batch of the roll-outs of targets (v, w) on ``costmap``.

        Parameters
        ----------
        v_m_s, w_rad_s : ndarray, shape (M,)
            The targets [m/s], [rad/s].
        v_brake_m_s : float
            The window's slowest linear target [m/s].
        rollouts : Rollouts
            Their roll-outs.
        costmap : Costmap
            The local costmap.

        Returns
        -------
        Batch
            Its arrays evaluated.
        """
        x_c, y_c, length = rollouts.coarse(_CULL_STEPS)
        x_end, y_end = x_c[-1], y_c[-1]
        yaw_end = rollouts.yaw_rad[:, -1].take(rollouts.iw)
        end_cell, end_ok = cell_index(costmap, x_end, y_end)
        return cls(
            v_m_s, w_rad_s, v_brake_m_s, rollouts, x_c, y_c, length, x_end, y_end, yaw_end,
            np.cos(yaw_end), np.sin(yaw_end), end_cell, end_ok, costmap,
        )  # fmt: skip

    @property
    def size(self) -> int:
        """M, the roll-outs."""
        return int(self.v_m_s.shape[0])

    def forward_cells(self, distance_m: float) -> tuple[IntArray, BoolArray]:
        """The cells of the points ``distance_m`` ahead of the end poses, along their heading.

        Parameters
        ----------
        distance_m : float
            How far ahead [m] (a forward point distance).

        Returns
        -------
        tuple of ndarray, shape (M,)
            (flat cell index, clipped onto the grid; whether the point lies on the grid),
            evaluated once per distance and cycle.
        """
        found = self._forward.get(distance_m)
        if found is None:
            found = self._forward[distance_m] = cell_index(
                self.costmap,
                self.x_end_m + distance_m * self.cos_end,
                self.y_end_m + distance_m * self.sin_end,
            )
        return found


class Critic(Protocol):
    """A trajectory critic: scores all roll-outs of a cycle at once.

    A critic may hold state across cycles (:meth:`reset` forgets it) and may reject roll-outs.
    Classes that subclass it inherit the defaults: nothing to reset, always prepared, nothing
    to learn from the command.

    Attributes
    ----------
    name : str
        The critic's name in Nav2's parameters (``RotateToGoal``, ...), distinct in a planner.
    """

    name: str

    @property
    def scale(self) -> float:
        """The weight of the raw score in the total for this cycle (fixed by :meth:`prepare`;
        0 leaves the critic out of the total, not out of the legality)."""
        ...

    def reset(self) -> None:
        """Forget the state kept across cycles (a new goal)."""
        return None

    def prepare(self, context: Context) -> bool:
        """Take in the cycle before scoring.

        Parameters
        ----------
        context : Context
            The cycle.

        Returns
        -------
        bool
            False when the critic cannot score this cycle (the planner then sends no command).
        """
        return True

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores and legality of every roll-out.

        Parameters
        ----------
        batch : Batch
            The cycle's roll-outs.

        Returns
        -------
        tuple of ndarray, shape (M,)
            (raw score, float64; legal, bool). The planner only reads them.
        """
        ...

    def debrief(self, command: Command) -> None:
        """Learn from the command the planner chose this cycle (called only when it chose one).

        Parameters
        ----------
        command : Command
            The chosen command.
        """
        return None


@runtime_checkable
class DeferredLegality(Protocol):
    """A critic whose legality is costly to test (BaseObstacle's collision test): the planner
    may take its raw scores alone and ask its legality only of the roll-outs it would choose,
    in its order, until one is legal (``DwbConfig.short_circuit_trajectory_evaluation``). The
    answers must be :meth:`Critic.score`'s, so the choice is the same either way."""

    def raw_scores(self, batch: Batch) -> FloatArray:
        """:meth:`Critic.score`'s raw scores alone.

        Parameters
        ----------
        batch : Batch
            The cycle's roll-outs.

        Returns
        -------
        ndarray, shape (M,)
        """
        ...

    def first_legal(self, batch: Batch, order: IntArray) -> int:
        """Where in ``order`` the first roll-out :meth:`Critic.score` finds legal is.

        Parameters
        ----------
        batch : Batch
            The cycle's roll-outs.
        order : ndarray of int
            Roll-outs, in the order asked about.

        Returns
        -------
        int
            The position in ``order``; -1 when none is legal.
        """
        ...
