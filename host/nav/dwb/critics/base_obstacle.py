"""BaseObstacle: reject a colliding roll-out, score the cost under its end.

Raw score: the cost of the end pose's cell (0-254, off the grid: unknown). A roll-out is
illegal when the robot's disc and envelope rectangle collide with an obstacle at any of its
poses (:meth:`Costmap.trajectories_collide`: against the obstacles' returns rather than cells,
with an escape rule for a robot already touching one; see :mod:`jackson.host.nav.costmap`).
Scale 0.02.

The poses tested are those where the centre or a footprint corner may have moved half a cell
since the last pose tested (:func:`collisions`), except on the roll-outs that never come
within reach of an obstacle (:meth:`Costmap.clear_reach_m` at every 16th pose), which cannot
collide.

The collision test is the costly part of a cycle, so the critic also answers it only as far as
the planner's choice needs (:meth:`BaseObstacleCritic.first_legal`, DWB's
``short_circuit_trajectory_evaluation``): the roll-outs in the planner's order of total, up to
the first that does not collide.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from jackson.host.nav import native
from jackson.host.nav.costmap import Costmap
from jackson.host.nav.dwb.core.config import DwbConfig
from jackson.host.nav.dwb.core.rollouts import Rollouts
from jackson.host.nav.dwb.critics.base import Batch, Context, Critic

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]


class BaseObstacleCritic(Critic):
    """Reject colliding roll-outs; score the cost of the end pose's cell.

    Parameters
    ----------
    config : DwbConfig
        Scale and ``sim_time_s``.
    """

    name = "BaseObstacle"

    def __init__(self, config: DwbConfig) -> None:
        self.config = config
        self._velocity = (0.0, 0.0)

    @property
    def scale(self) -> float:
        """``base_obstacle_scale``."""
        return self.config.base_obstacle_scale

    def prepare(self, context: Context) -> bool:
        """Keep the current velocity (it bounds the sweep between poses)."""
        self._velocity = context.velocity
        return True

    def score(self, batch: Batch) -> tuple[FloatArray, BoolArray]:
        """Raw scores (cost at the end) and legality (no collision) of every roll-out."""
        return self.raw_scores(batch), ~collisions(self._sweep(batch))

    def raw_scores(self, batch: Batch) -> FloatArray:
        """The raw scores alone: the cost of each end pose's cell."""
        return batch.costmap.cost_at(batch.x_end_m, batch.y_end_m).astype(np.float64)

    def first_legal(self, batch: Batch, order: IntArray) -> int:
        """Where in ``order`` the first roll-out that does not collide is (-1: none), each
        tested only until that one is found: the first index of ``order`` that
        :meth:`score`'s legality holds at.

        Parameters
        ----------
        batch : Batch
            The cycle's roll-outs.
        order : ndarray of int
            Roll-outs, in the order they are asked about.

        Returns
        -------
        int
            The position in ``order``, or -1.
        """
        return first_clear(self._sweep(batch), order)

    def _sweep(self, batch: Batch) -> Sweep:
        coarse = (batch.coarse_x_m, batch.coarse_y_m, batch.coarse_length_m)
        return Sweep(
            batch.rollouts, coarse, batch.v_m_s, batch.w_rad_s, self._velocity, batch.costmap,
            self.config.sim_time_s,
        )  # fmt: skip


class Sweep(NamedTuple):
    """A cycle's roll-outs as the collision test reads them.

    Attributes
    ----------
    rollouts : Rollouts
        The roll-outs.
    coarse : tuple of ndarray
        ``rollouts.coarse(_CULL_STEPS)``: (x, y) at every ``_CULL_STEPS``-th pose, (B + 1, M)
        [m], and the path length between, (B, M) [m].
    v_m_s, w_rad_s : ndarray, shape (M,)
        The targets [m/s], [rad/s].
    velocity : tuple of float
        Current (v [m/s], w [rad/s]).
    costmap : Costmap
        The local costmap.
    sim_time_s : float
        The roll-outs' length [s].
    """

    rollouts: Rollouts
    coarse: tuple[FloatArray, FloatArray, FloatArray]
    v_m_s: FloatArray
    w_rad_s: FloatArray
    velocity: tuple[float, float]
    costmap: Costmap
    sim_time_s: float


def collisions(sweep: Sweep) -> BoolArray:
    """Which roll-outs collide, each checked at the poses it needs.

    A roll-out is checked at its first and last pose and every ``stride``-th between,
    the stride as long as no point of the robot moves more than half a cell (speed
    |v| + |w| r_circumscribed, whichever of the current and target velocity is faster);
    the robot is grown by half that sweep so that nothing between two checked poses is
    missed. Strides are rounded down to powers of two, and all roll-outs are checked in
    one call (:meth:`Rollouts.at_strides` folds them into rows of equal length, or the
    compiled :meth:`Costmap.rollouts_collide` makes each pose where it is tested).

    Parameters
    ----------
    sweep : Sweep
        The roll-outs, their coarse poses, targets and costmap.

    Returns
    -------
    ndarray of bool, shape (M,)
        True for a roll-out that collides.
    """
    if sweep.costmap.compiled:  # the same plan, then each pose made where it is tested
        return _collisions_compiled(sweep)
    ro, coarse, v, w, velocity, costmap, sim_time_s = sweep
    k = ro.steps
    dt_s = sim_time_s / k
    r_m = costmap.config.circumscribed_radius_m
    speed = np.maximum(np.abs(v), abs(velocity[0])) + np.maximum(np.abs(w), abs(velocity[1])) * r_m
    per_step_m = speed * dt_s
    half_cell = 0.5 * costmap.resolution_m
    stride = np.minimum(k, np.floor(half_cell / np.maximum(per_step_m, 1e-12)))
    group = np.exp2(np.floor(np.log2(np.maximum(stride, 1.0)))).astype(np.intp)
    margin_m = np.empty(v.shape[0])
    for g in np.bincount(group).nonzero()[0]:
        rows = group == g
        margin_m[rows] = 0.5 * min(g * float(per_step_m[rows].max()), half_cell)
    hit = np.zeros(v.shape[0], bool)
    # only the roll-outs that come within reach of an obstacle (or of the grid's edge)
    # need the test: from each pose every _CULL_STEPS steps, the centre moves at most
    # the path length of the next block
    x_c, y_c, length_m = coarse
    reach_m = costmap.clear_reach_m(x_c[:-1], y_c[:-1])
    near = np.flatnonzero(np.any(reach_m <= length_m + 1e-9, axis=0))
    if near.size == 0:
        return hit
    x, y, yaw, owner = ro.at_strides(near, group[near])
    hit_rows = costmap.trajectories_collide(x, y, yaw, margin_m=margin_m[owner])
    hit[owner[hit_rows]] = True
    return hit


def _collisions_compiled(sweep: Sweep) -> BoolArray:
    """:func:`collisions` by the compiled loops (:mod:`jackson.host.nav.native`): the strides,
    margins and the roll-outs near an obstacle in one call, then the near ones tested at the
    poses made where they are read; the same answer bit for bit."""
    ro, costmap = sweep.rollouts, sweep.costmap
    group, margin_m, near_mask = _plan(sweep)
    hit = np.zeros(sweep.v_m_s.shape[0], bool)
    near = np.flatnonzero(near_mask)
    if near.size == 0:
        return hit
    hit[near], _ = costmap.rollouts_collide(
        _start(ro), ro.ds_m, ro.cos_sin, ro.yaw_rad, ro.iv[near], ro.iw[near], group[near],
        margin_m[near],
    )  # fmt: skip
    return hit


def _plan(sweep: Sweep) -> tuple[npt.NDArray[np.int64], FloatArray, BoolArray]:
    """The compiled plan of the test (:func:`jackson.host.nav.native.dwb_collision_plan`):
    each roll-out's stride group, margin, and whether it comes near an obstacle."""
    ro, coarse, v, w, velocity, costmap, sim_time_s = sweep
    half_cell = 0.5 * costmap.resolution_m
    dt_s = sim_time_s / ro.steps
    return native.dwb_collision_plan(
        (v, w), velocity, (costmap.config.circumscribed_radius_m, dt_s, half_cell, ro.steps),
        (coarse[0], coarse[1], coarse[2]), costmap.clear_reach_table(),
        costmap.geometry.as_tuple(),
    )  # fmt: skip


def _start(ro: Rollouts) -> tuple[float, float, float]:
    """The roll-outs' start pose as the collision test takes it (numpy's 0 + x)."""
    return (0.0 + ro.pose.x, 0.0 + ro.pose.y, float(ro.yaw_rad[0, 0]))


def first_clear(sweep: Sweep, order: IntArray) -> int:
    """Where in ``order`` the first roll-out that does not collide is, -1 if none: the first
    index of ``order`` where :func:`collisions` says False, testing only as far as that.

    Compiled: a roll-out that never comes near an obstacle is clear without a test, so only
    the near ones before the first such roll-out of ``order`` are tested, in order, until one
    is clear. With numpy, :func:`collisions` of every roll-out.

    Parameters
    ----------
    sweep : Sweep
        As :func:`collisions`.
    order : ndarray of int
        Roll-outs, in the order asked about.

    Returns
    -------
    int
        The position in ``order``, or -1.
    """
    ro, costmap = sweep.rollouts, sweep.costmap
    if not costmap.compiled:
        clear = np.flatnonzero(~collisions(sweep)[order])
        return int(clear[0]) if clear.size else -1
    group, margin_m, near = _plan(sweep)
    far = np.flatnonzero(~near[order])
    stop = int(far[0]) if far.size else len(order)  # order[:stop] all come near an obstacle
    if stop == 0:
        return 0
    tested = order[:stop]
    _, first = costmap.rollouts_collide(
        _start(ro), ro.ds_m, ro.cos_sin, ro.yaw_rad, ro.iv[tested], ro.iw[tested],
        group[tested], margin_m[tested], stop_at_clear=True,
    )  # fmt: skip
    if first < stop:
        return first
    return stop if stop < len(order) else -1
