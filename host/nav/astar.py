"""Global path planning: cost-aware A* on a costmap, then a light smoothing pass.

The search runs on the costmap's cells, 8-connected. Entering cell n from a neighbour costs

    g(n) = g(m) + |n - m| (c_neutral + f c(n))

with |n - m| = 1 or sqrt(2) cells, c(n) the costmap value (0-252), c_neutral = 50 and f = 0.8
(the neutral cost and cost factor of Nav2's grid planners), so free space costs 50 per cell and
a cell next to an obstacle up to about 250. Lethal (254) and inscribed (253) cells are
impassable; unknown cells (255) are passable at the neutral cost when ``allow_unknown`` is set
(Nav2 bringup's planner), else impassable. The heuristic h(n) = c_neutral |n - goal| (Euclidean,
in cells) never exceeds the true remaining cost, since no step costs less than c_neutral per
cell, so the path found is the cheapest one.

Two escapes keep the planner useful where the robot really is: a start cell inside an
obstacle's inscribed band may leave through that band (its connected inscribed cells become
passable at the highest cost), and a blocked goal moves to the nearest passable cell within
``goal_tolerance_m`` (Nav2's planner tolerance).

Smoothing follows the fixed point of the usual gradient smoother, which pulls each interior
point y_i towards its original x_i (weight w_data) and towards its neighbours (w_smooth):

    w_data (x_i - y_i) + w_smooth (y_{i-1} - 2 y_i + y_{i+1}) = 0,  ends fixed,

solved directly as one tridiagonal system (``scipy.linalg.solve_banded``) instead of iterated.
A smoothed path that would put a point on a cell A* treats as blocked is rejected for a
weaker smoothing, down to none.

The open list is ``heapq`` over flat cell indices; per-cell costs, passability and the
neighbour offsets are precomputed with numpy on a grid padded by one blocked ring, so the loop
needs no bounds checks.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.linalg import solve_banded

from jackson.host.nav.costmap import (
    INSCRIBED_INFLATED_OBSTACLE,
    MAX_NON_OBSTACLE,
    NO_INFORMATION,
    Costmap,
)

FloatArray = npt.NDArray[np.float64]
SQRT2 = math.sqrt(2.0)


class NoPathError(RuntimeError):
    """No path exists between the start and the goal (the message says why, on one line)."""


@dataclass(frozen=True)
class AStarConfig:
    """A* and smoothing parameters.

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


def cell_costs(costmap: Costmap, config: AStarConfig) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
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
    c = costmap.costs
    unknown = c == NO_INFORMATION
    passable = (c < INSCRIBED_INFLATED_OBSTACLE) | (unknown & config.allow_unknown)
    value = np.where(unknown, 0.0, np.minimum(c, MAX_NON_OBSTACLE).astype(np.float64))
    return config.neutral_cost + config.cost_factor * value, passable


def astar(
    costmap: Costmap,
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
    step_cost, passable = cell_costs(costmap, cfg)
    if costmap.costs[sr, sc] == INSCRIBED_INFLATED_OBSTACLE:
        # leave through the inscribed band the robot already stands in
        band = costmap.costs == INSCRIBED_INFLATED_OBSTACLE
        labels, _ = ndimage.label(band, structure=np.ones((3, 3), bool))
        escape = labels == labels[sr, sc]
        passable = passable | escape
        step_cost = np.where(escape, cfg.neutral_cost + cfg.cost_factor * 253.0, step_cost)
    elif not passable[sr, sc]:
        raise NoPathError(
            f"start ({start_xy[0]:.3f}, {start_xy[1]:.3f}) is on an obstacle "
            f"(cost {int(costmap.costs[sr, sc])})"
        )
    goal_moved = False
    if not passable[gr, gc]:
        gr, gc = _nearest_passable(costmap, passable, int(gr), int(gc), cfg.goal_tolerance_m)
        goal_moved = True
    cells = _search(step_cost, passable, (int(sr), int(sc)), (int(gr), int(gc)), cfg.neutral_cost)
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


def path_cost(path: npt.ArrayLike, costmap: Costmap, config: AStarConfig | None = None) -> float:
    """A path's cost in A*'s terms on a costmap: sum of |segment| (c_neutral + f c(end)).

    Segment lengths are in cells, so the value is comparable with the search's g; ``inf``
    when a point lies on a cell A* treats as blocked or off the grid.

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
    step_cost, passable = cell_costs(costmap, cfg)
    r, c = costmap.world_to_cell(p[:, 0], p[:, 1])
    inside = costmap.inside(r, c)
    if not np.all(inside[1:]) or not np.all(passable[r[1:], c[1:]]):
        return math.inf
    seg = np.hypot(*np.diff(p, axis=0).T) / costmap.resolution_m
    return float(np.sum(seg * step_cost[r[1:], c[1:]]))


def _nearest_passable(
    costmap: Costmap, passable: npt.NDArray[np.bool_], gr: int, gc: int, tolerance_m: float
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


def _search(
    step_cost: FloatArray,
    passable: npt.NDArray[np.bool_],
    start: tuple[int, int],
    goal: tuple[int, int],
    neutral_cost: float,
) -> npt.NDArray[np.int_] | None:
    """A* over the cells; (N, 2) (row, col) from start to goal, or None."""
    rows, cols = passable.shape
    w = cols + 2  # padded width: a blocked ring around the grid
    pad_pass = np.zeros((rows + 2, w), bool)
    pad_pass[1:-1, 1:-1] = passable
    pad_cost = np.zeros((rows + 2, w))
    pad_cost[1:-1, 1:-1] = step_cost
    ok = pad_pass.ravel().tolist()
    cost = pad_cost.ravel().tolist()
    s = (start[0] + 1) * w + start[1] + 1
    g = (goal[0] + 1) * w + goal[1] + 1
    ok[s] = True
    gy, gx = divmod(g, w)
    moves = [
        (1, 1.0), (-1, 1.0), (w, 1.0), (-w, 1.0),
        (w + 1, SQRT2), (w - 1, SQRT2), (-w + 1, SQRT2), (-w - 1, SQRT2),
    ]  # fmt: skip
    best = [math.inf] * len(ok)
    parent = [-1] * len(ok)
    closed = [False] * len(ok)
    best[s] = 0.0
    hypot = math.hypot
    heap: list[tuple[float, float, int]] = [(0.0, 0.0, s)]
    push, pop = heapq.heappush, heapq.heappop
    while heap:
        _, gn, n = pop(heap)
        if closed[n]:
            continue
        if n == g:
            break
        closed[n] = True
        for off, length in moves:
            m = n + off
            if not ok[m] or closed[m]:
                continue
            gm = gn + length * cost[m]
            if gm < best[m]:
                best[m] = gm
                parent[m] = n
                my, mx = divmod(m, w)
                push(heap, (gm + neutral_cost * hypot(mx - gx, my - gy), gm, m))
    else:
        return None
    if best[g] == math.inf:
        return None
    chain = [g]
    while chain[-1] != s:
        chain.append(parent[chain[-1]])
    flat = np.array(chain[::-1])
    return np.column_stack((flat // w - 1, flat % w - 1))


def smooth_path(
    path: FloatArray,
    costmap: Costmap,
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
