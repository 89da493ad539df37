"""Global path planning: the cheapest 8-connected path on a costmap, then a light smoothing pass.

Costs. A cell of costmap value c (0-252) costs C = c_neutral + f c per cell length, with
c_neutral = 50 and f = 0.8 (the neutral cost and cost factor of Nav2's grid planners), so free
space costs 50 per cell and a cell next to an obstacle up to about 250. Lethal (254) and
inscribed (253) cells are impassable; unknown cells (255) are passable at the neutral cost when
``allow_unknown`` is set (Nav2 bringup's planner), else impassable. A step between 8-connected
neighbours m and n costs

    |n - m| (C(m) + C(n)) / 2,    |n - m| = 1 or sqrt(2) cells,

and the path found is the cheapest under that sum (:func:`path_cost` prices any path so).

The search is scikit-image's compiled minimum-cost-path search, ``skimage.graph.MCP_Geometric``
(Dijkstra on the grid with a binary heap), run from the goal until the start's cost is final,
as Nav2's NavFn propagates from the goal; the sum is symmetric, so the direction changes no
cost. What differs from Nav2's A* and from this module's former pure-Python A*:

- **The step cost is the mean of the two cells' costs**, not the cost of the cell entered
  (|n - m| C(n)). ``MCP_Geometric`` prices a move half in each cell; the library's plain
  ``MCP`` ignores the step's length, and ``MCP_Flexible`` would call a Python method for every
  edge. Along a run of steps of one kind the two rules differ only at the ends (the mean rule
  counts half the start cell's cost and half the goal cell's, the entering rule all of the
  goal cell's), so the cheapest paths differ only where a change between axial and diagonal
  steps meets a change of cost. Priced by the entering rule, the path chosen was that rule's
  optimum on the benchmark's 20 m maps, within 2 % of it on inflated mazes of 0.6 m corridors
  with random start and goal cells, and within 8 % on random grids of unrelated costs; the
  worst case is a factor sqrt(2) (one diagonal step out of a costly start cell replaced by two
  axial steps through a free cell).
- **No heuristic** (the library has none): the search settles every cell cheaper to reach than
  the start, A* only those whose cost plus the straight-line estimate is. In a maze, and when
  the goal lies across the map from the start, that is most of the map either way.
- **An unreachable goal is found without a search**: the start and the goal lie in different
  8-connected components of the passable cells (``scipy.ndimage.label``), so the planner raises
  at once instead of exploring everything the start reaches.
- Ties between paths of equal cost are broken by the library's heap, not by A*'s order; the
  same costmap always gives the same path.

**Coarse to fine on large maps.** The search settles a cell in about 0.35 us, and the library
has no heuristic, so on a 20 m x 20 m map at 0.05 m (400 x 400 cells) a plan corner to corner
through 4 x 4 rooms (it settles nearly all 137 000 passable cells) took 50-56 ms of CPU on a
machine where ``sum(range(10000))`` took 175-280 us: a whole 50 ms control period. (The former
pure-Python A* took 280-350 ms; libtcod's compiled A*, ``tcod.path``, settles a cell in about
the same time, and its heuristic saves cells in the rooms, 16 ms, but not in a maze, 32 ms.)
A grid of more than 40 000 cells (a 10 m x 10 m map) is therefore searched twice, as Nav2's
Smac planner can plan on a downsampled costmap:

1. over blocks of 4 x 4 cells (0.2 m), a block costing the least of its passable cells and
   impassable when none is, so that every path of cells has a path of blocks (a gap narrower
   than a block is not lost);
2. over the cells within 2 blocks (0.4 m) of that block path only.

The path is the cheapest within that band, not always the cheapest overall: within 1 % of it
on 20 m mazes of 1 m cells (1.000 on the benchmark's maze, 0.9987 of the full search's smoothed
cost on its rooms, where smoothing differs). Should the band hold no path (the block path went
through a block whose passable cells do not connect), the whole grid is searched. Measured on
the benchmark's maps on a machine running at 2.5 times its idle time per reference loop: rooms
15 ms (65.8 ms searched whole), maze 17 ms (40.0 ms), unreachable 2 ms.

Two escapes keep the planner useful where the robot really is: a start cell inside an
obstacle's inscribed band may leave through that band (its connected inscribed cells become
passable at the inscribed cost c_neutral + 253 f), and a blocked goal moves to the nearest
passable cell within ``goal_tolerance_m`` (Nav2's planner tolerance).

Smoothing follows the fixed point of the usual gradient smoother, which pulls each interior
point y_i towards its original x_i (weight w_data) and towards its neighbours (w_smooth):

    w_data (x_i - y_i) + w_smooth (y_{i-1} - 2 y_i + y_{i+1}) = 0,  ends fixed,

solved directly as one tridiagonal system (``scipy.linalg.solve_banded``) instead of iterated.
A smoothed path that would put a point on a cell the search treats as blocked is rejected for a
weaker smoothing, down to none.

Two caches keep the per-plan work to the search: per costmap, the cell costs, passability and
components of its current costs (recomputed whenever the cost values differ from the ones they
were derived from, whatever the costmap's ``version`` says, so costs changed in place count);
per grid shape, one search object that reads a float64 cost array in place (checked once: a
library that copied it would get a new object per plan).
"""

from __future__ import annotations

import functools
import math
import threading
import weakref
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.linalg import solve_banded
from skimage.graph import MCP_Geometric

from jackson.common.errors import JacksonError
from jackson.common.geometry import GridCells
from jackson.host.nav.cost_values import (
    INSCRIBED_INFLATED_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int_]
EIGHT_CONNECTED = np.ones((3, 3), bool)
"""``scipy.ndimage.label``'s structure for the search's neighbourhood."""
_SEARCHERS_KEPT = 4
"""Search objects kept, one per grid shape, most recently used first."""
SEARCHES_PER_SEARCHER = 16
"""Searches a kept search object serves before it is built anew. scikit-image's heap (0.25)
empties its values on each search's reset but keeps its item count, so the entries an early-
stopping search leaves behind add up: one object kept for a whole run grew its heap by
doubling to megabytes (and every reset and every exhausted search walked all of it). A new
object every 16 searches bounds it; building one costs about a third of a search."""


@dataclass(eq=False)
class CostGrid(GridCells):
    """A costmap's cost values and where they lie, all the planner reads of a
    :class:`~jackson.host.nav.costmap.Costmap`: a copy to plan on elsewhere (the planner
    server's worker process, :mod:`jackson.host.nav.planner_server`).

    Attributes
    ----------
    costs : ndarray of uint8, shape (rows, cols)
        The master costs (row 0 at the lowest y).
    resolution_m, origin_x_m, origin_y_m : float
        Cell edge and the grid's lower-left corner [m].
    """

    costs: npt.NDArray[np.uint8]
    resolution_m: float
    origin_x_m: float
    origin_y_m: float

    @classmethod
    def of(cls, costmap: PlanGrid) -> CostGrid:
        """A copy of ``costmap``'s costs and geometry as they are now."""
        return cls(
            costmap.costs.copy(), costmap.resolution_m, costmap.origin_x_m, costmap.origin_y_m
        )

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return (int(self.costs.shape[0]), int(self.costs.shape[1]))


class PlanGrid(Protocol):
    """What the planner plans on: a :class:`~jackson.host.nav.costmap.Costmap`, or a copy of
    its costs (:class:`CostGrid`): the costs and the grid's
    :class:`~jackson.common.geometry.GridCells` arithmetic."""

    @property
    def costs(self) -> npt.NDArray[np.uint8]: ...

    origin_x_m: float
    origin_y_m: float
    resolution_m: float

    @property
    def shape(self) -> tuple[int, int]: ...

    def world_to_cell(
        self, x_m: npt.ArrayLike, y_m: npt.ArrayLike
    ) -> tuple[IntArray, IntArray]: ...

    def cell_to_world(
        self, row: npt.ArrayLike, col: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]: ...

    def inside(self, row: npt.ArrayLike, col: npt.ArrayLike) -> BoolArray: ...


class NoPathError(JacksonError, RuntimeError):
    """No path exists between the start and the goal (the message says why, on one line)."""


@dataclass(frozen=True)
class AStarConfig:
    """Planner and smoothing parameters.

    Attributes
    ----------
    neutral_cost : float
        Cost of one free cell (Nav2 grid planners: 50).
    cost_factor : float
        Weight of the costmap value in a cell's cost (Nav2 NavFn: 0.8).
    allow_unknown : bool
        Whether unknown cells may be crossed (Nav2 bringup: true).
    goal_tolerance_m : float
        How far a blocked goal may move to the nearest passable cell [m] (Nav2 bringup
        planner tolerance: 0.5 m).
    smooth : bool
        Apply the smoothing pass.
    w_data, w_smooth : float
        Smoother weights (Nav2's simple smoother: 0.2 and 0.3).
    """

    neutral_cost: float = 50.0
    cost_factor: float = 0.8
    allow_unknown: bool = True
    goal_tolerance_m: float = 0.5
    smooth: bool = True
    w_data: float = 0.2
    w_smooth: float = 0.3

    def __post_init__(self) -> None:
        if not 0.0 < self.neutral_cost < math.inf:
            raise ValueError(f"AStarConfig.neutral_cost must be > 0, got {self.neutral_cost}")
        if not 0.0 <= self.cost_factor < math.inf:
            raise ValueError(f"AStarConfig.cost_factor must be >= 0, got {self.cost_factor}")
        if not 0.0 <= self.goal_tolerance_m < math.inf:
            raise ValueError(
                f"AStarConfig.goal_tolerance_m must be >= 0, got {self.goal_tolerance_m}"
            )
        if not (0.0 < self.w_data < math.inf and 0.0 <= self.w_smooth < math.inf):
            raise ValueError(
                f"AStarConfig.w_data must be > 0 and w_smooth >= 0, got {self.w_data}, "
                f"{self.w_smooth}"
            )


def cell_costs(costmap: PlanGrid, config: AStarConfig) -> tuple[FloatArray, BoolArray]:
    """Per-cell traversal cost c_neutral + f c and passability of a costmap.

    Parameters
    ----------
    costmap : Costmap
        The costmap to plan on.
    config : AStarConfig
        Costs and the unknown-space rule.

    Returns
    -------
    tuple of ndarray
        (cost per cell length, shape of the costmap; passable mask, same shape).
    """
    # one table lookup per cell: the cost and the passability of each of the 256 values
    value = np.minimum(np.arange(256), MAX_NON_OBSTACLE).astype(np.float64)
    value[NO_INFORMATION] = 0.0
    step_lut = config.neutral_cost + config.cost_factor * value
    pass_lut = np.arange(256) < INSCRIBED_INFLATED_OBSTACLE
    pass_lut[NO_INFORMATION] = config.allow_unknown
    c = costmap.costs
    return step_lut[c], pass_lut[c]


def astar(
    costmap: PlanGrid,
    start_xy: tuple[float, float],
    goal_xy: tuple[float, float],
    config: AStarConfig | None = None,
) -> FloatArray:
    """The cheapest 8-connected path from start to goal on the costmap.

    Parameters
    ----------
    costmap : Costmap
        Global costmap (map frame).
    start_xy, goal_xy : tuple of float
        Map-frame positions [m].
    config : AStarConfig or None
        Planner parameters (defaults when None).

    Returns
    -------
    ndarray, shape (N, 2)
        Waypoints [m]: the start, the centres of the cells crossed (smoothed), the goal
        (or the passable cell it moved to). N >= 2.

    Raises
    ------
    NoPathError
        Start or goal off the map, start on a lethal cell, a goal with no passable cell
        within the tolerance, or no connection between them.
    """
    cfg = config if config is not None else AStarConfig()
    (sr,), (sc,) = (np.atleast_1d(a) for a in costmap.world_to_cell(start_xy[0], start_xy[1]))
    (gr,), (gc,) = (np.atleast_1d(a) for a in costmap.world_to_cell(goal_xy[0], goal_xy[1]))
    if not costmap.inside(sr, sc):
        raise NoPathError(f"start ({start_xy[0]:.3f}, {start_xy[1]:.3f}) is off the costmap")
    if not costmap.inside(gr, gc):
        raise NoPathError(f"goal ({goal_xy[0]:.3f}, {goal_xy[1]:.3f}) is off the costmap")
    start = (int(sr), int(sc))
    grid = _derived(costmap, cfg)
    passable, search_cost = grid.passable, grid.search_cost
    if costmap.costs[start] == INSCRIBED_INFLATED_OBSTACLE:
        # leave through the inscribed band the robot already stands in
        band = costmap.costs == INSCRIBED_INFLATED_OBSTACLE
        band_labels, _ = ndimage.label(band, structure=EIGHT_CONNECTED)
        escape = band_labels == band_labels[start]
        passable = passable | escape
        inscribed = cfg.neutral_cost + cfg.cost_factor * INSCRIBED_INFLATED_OBSTACLE
        search_cost = np.where(escape, inscribed, search_cost)
        labels: IntArray = ndimage.label(passable, structure=EIGHT_CONNECTED)[0]
    elif not passable[start]:
        raise NoPathError(
            f"start ({start_xy[0]:.3f}, {start_xy[1]:.3f}) is on an obstacle "
            f"(cost {int(costmap.costs[start])})"
        )
    else:
        labels = grid.labels()
    goal_moved = False
    if not passable[gr, gc]:
        gr, gc = _nearest_passable(costmap, passable, int(gr), int(gc), cfg.goal_tolerance_m)
        goal_moved = True
    goal = (int(gr), int(gc))
    # different components: nothing to search (the search would settle all the start reaches)
    cells = _search(search_cost, start, goal) if labels[start] == labels[goal] else None
    if cells is None:
        raise NoPathError(
            f"no path from ({start_xy[0]:.3f}, {start_xy[1]:.3f}) to "
            f"({goal_xy[0]:.3f}, {goal_xy[1]:.3f}): every route is blocked"
        )
    x, y = costmap.cell_to_world(cells[:, 0], cells[:, 1])
    path = np.column_stack((x, y))
    path[0] = start_xy
    if not goal_moved:
        path[-1] = goal_xy
    if len(path) == 1:
        path = np.vstack((path, path[-1:] if goal_moved else [goal_xy]))
    if cfg.smooth and len(path) > 2:
        path = smooth_path(path, costmap, cfg, passable)
    return path


def prepare(costmap: PlanGrid) -> None:
    """Build the search objects for this costmap's shape now (17 ms at 400 x 400 cells), so
    that the first plan, inside a control step, does not (call it where the costmap is made).

    Parameters
    ----------
    costmap : Costmap
        The costmap plans will run on.
    """
    rows, cols = costmap.shape
    shapes = [(rows, cols)]
    if rows * cols > COARSE_ABOVE_CELLS:
        f = COARSE_FACTOR
        shapes.append((-(-rows // f), -(-cols // f)))
    with _LOCK:
        for shape in shapes:
            _searcher(np.full(shape, np.inf))


def path_cost(path: npt.ArrayLike, costmap: PlanGrid, config: AStarConfig | None = None) -> float:
    """A path's cost in the planner's terms: sum of |segment| (C(from) + C(to)) / 2.

    C is a point's cell cost c_neutral + f c. Segment lengths are in cells, so for a path
    through cell centres the value is the search's cost. The first point (the robot) may
    stand on a blocked cell: it is priced at the inscribed cost c_neutral + 253 f there, and
    at c_neutral off the grid. ``inf`` when a later point lies on a blocked cell or off the
    grid.

    Parameters
    ----------
    path : array_like, shape (N, 2)
        Waypoints [m].
    costmap : Costmap
        The costmap to price the path on.
    config : AStarConfig or None
        Costs and the unknown-space rule (defaults when None).

    Returns
    -------
    float
        The cost (0 for fewer than two points).
    """
    cfg = config if config is not None else AStarConfig()
    p = np.asarray(path, np.float64).reshape(-1, 2)
    if len(p) < 2:
        return 0.0
    grid = _derived(costmap, cfg)
    r, c = costmap.world_to_cell(p[:, 0], p[:, 1])
    inside = costmap.inside(r, c)
    if not np.all(inside[1:]) or not np.all(grid.passable[r[1:], c[1:]]):
        return math.inf
    cost = np.empty(len(p))
    cost[1:] = grid.step_cost[r[1:], c[1:]]
    if not inside[0]:
        cost[0] = cfg.neutral_cost
    elif grid.passable[r[0], c[0]]:
        cost[0] = grid.step_cost[r[0], c[0]]
    else:
        cost[0] = cfg.neutral_cost + cfg.cost_factor * INSCRIBED_INFLATED_OBSTACLE
    seg = np.hypot(*np.diff(p, axis=0).T) / costmap.resolution_m
    return float(np.sum(seg * (0.5 * (cost[:-1] + cost[1:]))))


def _nearest_passable(
    costmap: PlanGrid, passable: BoolArray, gr: int, gc: int, tolerance_m: float
) -> tuple[int, int]:
    """The passable cell nearest a blocked goal cell, within the tolerance."""
    res = costmap.resolution_m
    k = math.floor(tolerance_m / res)
    rows, cols = passable.shape
    r0, r1 = max(0, gr - k), min(rows, gr + k + 1)
    c0, c1 = max(0, gc - k), min(cols, gc + k + 1)
    rr, cc = np.mgrid[r0:r1, c0:c1]
    d = np.hypot(rr - gr, cc - gc) * res
    ok = passable[r0:r1, c0:c1] & (d <= tolerance_m)
    if not np.any(ok):
        raise NoPathError(f"goal is blocked and no passable cell lies within {tolerance_m:g} m")
    i = int(np.argmin(np.where(ok, d, np.inf)))
    return int(rr.flat[i]), int(cc.flat[i])


# ---------------------------------------------------------------------------- caches


@dataclass
class _Derived:
    """What the planner derives from one costmap's cost values under one cost rule."""

    values: npt.NDArray[np.uint8]
    """A copy of the cost values they were derived from."""
    rule: tuple[float, float, bool]
    """(neutral_cost, cost_factor, allow_unknown)."""
    step_cost: FloatArray
    passable: BoolArray
    search_cost: FloatArray
    """``step_cost`` with ``inf`` on impassable cells: what the search reads."""
    _labels: IntArray | None = field(default=None, repr=False)

    def labels(self) -> IntArray:
        """The 8-connected components of the passable cells (0 on impassable ones)."""
        if self._labels is None:
            labels, _ = ndimage.label(self.passable, structure=EIGHT_CONNECTED)
            labels.setflags(write=False)
            self._labels = labels
        return self._labels


_LOCK = threading.RLock()
_DERIVED: weakref.WeakKeyDictionary[PlanGrid, _Derived] = weakref.WeakKeyDictionary()
_SEARCHERS: OrderedDict[tuple[int, int], _Kept] = OrderedDict()


@dataclass
class _Kept:
    """A kept search object, the cost buffer it reads, and the searches it has served."""

    buffer: FloatArray
    mcp: MCP_Geometric
    searches: int = 0


def _derived(costmap: PlanGrid, config: AStarConfig) -> _Derived:
    """The costmap's cell costs, passability and components, kept while its costs stay."""
    rule = (config.neutral_cost, config.cost_factor, config.allow_unknown)
    values = costmap.costs
    with _LOCK:
        held = _DERIVED.get(costmap)
        if held is not None and held.rule == rule and np.array_equal(held.values, values):
            return held
        step_cost, passable = cell_costs(costmap, config)
        search_cost = np.where(passable, step_cost, np.inf)
        for a in (step_cost, passable, search_cost):
            a.setflags(write=False)
        held = _Derived(values.copy(), rule, step_cost, passable, search_cost)
        _DERIVED[costmap] = held
        return held


@functools.cache
def _search_reads_costs_in_place() -> bool:
    """Whether ``MCP_Geometric`` searches a float64 Fortran-ordered cost array it was given
    without copying it (then one search object serves every plan on a grid shape)."""
    costs = np.ones((1, 3), order="F")
    probe = MCP_Geometric(costs)
    costs[0, 1] = np.inf
    cumulative, _ = probe.find_costs([(0, 0)], [(0, 2)], find_all_ends=False)
    return not bool(np.isfinite(cumulative[0, 2]))


def _searcher(search_cost: FloatArray) -> MCP_Geometric:
    """A search object over these costs: the shape's kept one, its costs overwritten.

    Call with ``_LOCK`` held, and search before releasing it.
    """
    if not _search_reads_costs_in_place():
        return MCP_Geometric(np.asfortranarray(search_cost))
    shape = (int(search_cost.shape[0]), int(search_cost.shape[1]))
    kept = _SEARCHERS.pop(shape, None)
    if kept is None or kept.searches >= SEARCHES_PER_SEARCHER:
        buffer: FloatArray = np.full(shape, np.inf, order="F")
        kept = _Kept(buffer, MCP_Geometric(buffer))
    kept.searches += 1
    _SEARCHERS[shape] = kept
    while len(_SEARCHERS) > _SEARCHERS_KEPT:
        _SEARCHERS.popitem(last=False)
    np.copyto(kept.buffer, search_cost)
    return kept.mcp


COARSE_FACTOR = 4
"""Cells per side of a block of the coarse search (0.2 m blocks at 0.05 m)."""
COARSE_ABOVE_CELLS = 40_000
"""Grids larger than this (a 10 m x 10 m map at 0.05 m) are searched coarse to fine."""
BAND_BLOCKS = 2
"""Half-width of the fine search's band around the coarse path, in blocks (0.4 m)."""


def _search(
    search_cost: FloatArray, start: tuple[int, int], goal: tuple[int, int]
) -> IntArray | None:
    """The path's cells, (N, 2) (row, col) from start to goal, or None.

    On a grid of more than :data:`COARSE_ABOVE_CELLS` cells, coarse to fine: first the
    cheapest path over blocks of ``COARSE_FACTOR`` x ``COARSE_FACTOR`` cells, a block costing
    the least of its passable cells (so that every fine path has a coarse one: the coarse
    search cannot miss a gap narrower than a block); then the cheapest fine path among the
    cells within :data:`BAND_BLOCKS` blocks of it. Should the band hold no fine path (the
    coarse one squeezed through blocks whose passable cells do not connect), the whole grid
    is searched.
    """
    rows, cols = search_cost.shape
    if rows * cols <= COARSE_ABOVE_CELLS:
        return _search_grid(search_cost, start, goal)
    f = COARSE_FACTOR
    pr, pc = -rows % f, -cols % f
    padded = np.pad(search_cost, ((0, pr), (0, pc)), constant_values=np.inf)
    blocks = padded.reshape((rows + pr) // f, f, (cols + pc) // f, f).min(axis=(1, 3))
    coarse = _search_grid(blocks, (start[0] // f, start[1] // f), (goal[0] // f, goal[1] // f))
    if coarse is None:  # cannot happen for a connected pair; the full search decides
        return _search_grid(search_cost, start, goal)
    near = np.zeros(blocks.shape, bool)
    near[coarse[:, 0], coarse[:, 1]] = True
    size = 2 * BAND_BLOCKS + 1
    near = ndimage.binary_dilation(near, structure=np.ones((size, size), bool))
    band = np.repeat(np.repeat(near, f, axis=0), f, axis=1)[:rows, :cols]
    cells = _search_grid(np.where(band, search_cost, np.inf), start, goal)
    return cells if cells is not None else _search_grid(search_cost, start, goal)


def _search_grid(
    search_cost: FloatArray, start: tuple[int, int], goal: tuple[int, int]
) -> IntArray | None:
    """The cheapest path's cells, (N, 2) (row, col) from start to goal, or None.

    ``search_cost`` is the cost per cell length, ``inf`` on impassable cells; the search runs
    from the goal and stops once the start's cost is final.
    """
    with _LOCK:
        mcp = _searcher(search_cost)
        cumulative, trace = mcp.find_costs([goal], [start], find_all_ends=False)
        if not np.isfinite(cumulative[start]):
            return None
        # follow the predecessors from the start to the goal (the library's own traceback
        # builds a tuple from a memoryview per cell: 3-30 us a cell against 0.5 us here)
        moves = np.asarray(mcp.offsets, np.int_).tolist()
        r, c = start
        cells = [start]
        k = int(trace[r, c])
        for _ in range(trace.size):
            if k < 0:
                break
            dr, dc = moves[k]
            r, c = r - dr, c - dc
            cells.append((r, c))
            k = int(trace[r, c])
        if (r, c) != goal:
            raise RuntimeError(f"the search's predecessors from {start} end at {(r, c)}")
    return np.array(cells, dtype=np.int_)


def smooth_path(
    path: FloatArray,
    costmap: PlanGrid,
    config: AStarConfig,
    passable: npt.NDArray[np.bool_] | None = None,
) -> FloatArray:
    """The smoother's fixed point, weakened until no point lands on a blocked cell.

    Parameters
    ----------
    path : ndarray, shape (N, 2)
        Waypoints [m]; the ends stay fixed.
    costmap : Costmap
        The costmap the path was planned on.
    config : AStarConfig
        ``w_data`` and ``w_smooth``.
    passable : ndarray of bool or None
        Cells a point may lie on (default: below inscribed, or unknown if allowed).

    Returns
    -------
    ndarray, shape (N, 2)
        The smoothed path (the input when every smoothing strength fails the check).
    """
    if passable is None:
        passable = cell_costs(costmap, config)[1]
    n = len(path)
    if n < 3 or config.w_smooth == 0.0:
        return path
    r0, c0 = costmap.world_to_cell(path[:, 0], path[:, 1])
    was_ok = costmap.inside(r0, c0)
    was_ok[was_ok] = passable[r0[was_ok], c0[was_ok]]
    w_smooth = config.w_smooth
    for _ in range(4):
        # rows of the banded matrix: super-diagonal, diagonal, sub-diagonal
        ab = np.zeros((3, n))
        ab[1, :] = 1.0
        ab[1, 1:-1] = config.w_data + 2.0 * w_smooth
        ab[0, 2:] = -w_smooth
        ab[2, :-2] = -w_smooth
        rhs = path.copy()
        rhs[1:-1] *= config.w_data
        smoothed = np.asarray(solve_banded((1, 1), ab, rhs), np.float64)
        r, c = costmap.world_to_cell(smoothed[:, 0], smoothed[:, 1])
        inside = costmap.inside(r, c)
        ok = inside.copy()
        ok[inside] = passable[r[inside], c[inside]]
        if np.all(ok | ~was_ok):
            return smoothed
        w_smooth *= 0.5
    return path
