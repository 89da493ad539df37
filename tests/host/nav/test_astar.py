"""A* on the costmap: cheapest paths against Dijkstra, closed walls, blocked goals, coarse-to-fine
search on large maps, determinism."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from jackson.host.nav import astar as astar_module
from jackson.host.nav.astar import AStarConfig, NoPathError, astar, cell_costs, path_cost
from jackson.host.nav.costmap import Costmap, CostmapConfig
from jackson.host.nav.grid import OccupancyGrid

from ..stage3_course import RES, maze_map


def open_costmap(blocks: list[tuple[slice, slice]]) -> Costmap:
    """A 4 m x 3 m map at 0.05 m, free but for the given occupied blocks (row, col slices)."""
    g = OccupancyGrid.empty(4.0, 3.0, RES, origin_x_m=-2.0, origin_y_m=-1.5, fill=0)
    for rows, cols in blocks:
        g.data[rows, cols] = 100
    return Costmap.from_map(g, CostmapConfig())


def grid_graph(step: np.ndarray, passable: np.ndarray, entering: bool = False):
    """The 8-connected grid as a sparse graph over the passable cells; a step m -> n weighs
    |n - m| (C(m) + C(n)) / 2 (the planner's rule), or |n - m| C(n) with ``entering``."""
    rows, cols = passable.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    src, dst, w = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r0, r1 = max(0, -dr), rows - max(0, dr)
        c0, c1 = max(0, -dc), cols - max(0, dc)
        a = idx[r0:r1, c0:c1].ravel()
        b = idx[r0 + dr : r1 + dr, c0 + dc : c1 + dc].ravel()
        ok = passable.ravel()[a] & passable.ravel()[b]
        a, b = a[ok], b[ok]
        length = math.hypot(dr, dc)
        ca, cb = step.ravel()[a], step.ravel()[b]
        src += [a, b]
        dst += [b, a]
        w += [length * cb, length * ca] if entering else [length * 0.5 * (ca + cb)] * 2
    graph = coo_matrix(
        (np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(idx.size,) * 2
    )
    return graph.tocsr(), idx


def dijkstra_cells(
    step: np.ndarray,
    passable: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    entering: bool = False,
) -> float:
    """The cheapest path cost between two cells by plain Dijkstra (``inf`` when cut off)."""
    graph, idx = grid_graph(step, passable, entering)
    return float(dijkstra(graph, indices=int(idx[start]))[idx[goal]])


def dijkstra_cost(cm: Costmap, start: tuple[float, float], goal: tuple[float, float]) -> float:
    """The cheapest 8-connected path cost by plain Dijkstra, for comparison with the planner."""
    step, passable = cell_costs(cm, AStarConfig())
    (sr,), (sc,) = (np.atleast_1d(v) for v in cm.world_to_cell(*start))
    (gr,), (gc,) = (np.atleast_1d(v) for v in cm.world_to_cell(*goal))
    return dijkstra_cells(step, passable, (int(sr), int(sc)), (int(gr), int(gc)))


def raw_cells(cm: Costmap, path: np.ndarray) -> np.ndarray:
    """The (row, col) of an unsmoothed path's points."""
    return np.column_stack(cm.world_to_cell(path[:, 0], path[:, 1]))


def centre_path(cm: Costmap, cells: np.ndarray) -> np.ndarray:
    """Cell centres [m] of (row, col) cells."""
    return np.column_stack(cm.cell_to_world(cells[:, 0], cells[:, 1]))


def assert_valid_path(cells: np.ndarray, passable: np.ndarray) -> None:
    """Every cell passable, every step to one of the 8 neighbours."""
    assert np.all(passable[cells[:, 0], cells[:, 1]])
    steps = np.abs(np.diff(cells, axis=0))
    assert np.all(steps.max(axis=1) == 1)


def grid_costmap(values: np.ndarray) -> Costmap:
    """A costmap at 0.05 m whose master costs are the given values."""
    cm = Costmap(CostmapConfig(), values.shape[0], values.shape[1], RES)
    cm.costs[...] = values
    return cm


def test_astar_finds_the_cheapest_path_around_an_obstacle() -> None:
    cm = open_costmap([(slice(10, 50), slice(38, 42))])  # a 2 m x 0.2 m wall mid-map
    start, goal = (-1.0, 0.0), (1.0, 0.0)
    raw = astar(cm, start, goal, AStarConfig(smooth=False))
    cells = np.column_stack(cm.world_to_cell(raw[1:-1, 0], raw[1:-1, 1]))
    assert np.all(cm.costs[cells[:, 0], cells[:, 1]] < 253)  # never inscribed or lethal
    # optimal: the cost A* reached equals a plain Dijkstra's over the same graph
    ends = [np.array(cm.cell_to_world(*cm.world_to_cell(*p))) for p in (start, goal)]
    cells_path = np.vstack((ends[0], raw[1:-1], ends[1]))  # cell centres, as A* priced them
    cost = path_cost(cells_path, cm)
    assert cost == pytest.approx(dijkstra_cost(cm, start, goal), rel=1e-9)
    # around the wall's end, not through it: the path leaves the row of start and goal
    assert np.max(np.abs(raw[:, 1])) > 1.0
    smooth = astar(cm, start, goal)
    length = np.hypot(*np.diff(smooth, axis=0).T).sum()
    assert length <= np.hypot(*np.diff(raw, axis=0).T).sum()
    assert path_cost(smooth, cm) < math.inf  # smoothing kept it off blocked cells


def test_astar_reports_why_there_is_no_path_through_a_closed_wall() -> None:
    cm = open_costmap([(slice(0, 60), slice(38, 42))])
    with pytest.raises(NoPathError, match=r"no path .* every route is blocked"):
        astar(cm, (-1.0, 0.0), (1.0, 0.0))
    with pytest.raises(NoPathError, match=r"start .* is on an obstacle"):
        astar(cm, (0.0, 0.0), (1.0, 0.0))
    with pytest.raises(NoPathError, match="off the costmap"):
        astar(cm, (-1.0, 0.0), (5.0, 0.0))


def test_a_blocked_goal_moves_to_the_nearest_free_cell_within_the_tolerance() -> None:
    cm = open_costmap([(slice(28, 32), slice(58, 62))])  # a box around (1.0, 0.0)
    path = astar(cm, (-1.0, 0.0), (1.0, 0.0), AStarConfig(goal_tolerance_m=0.5))
    end = path[-1]
    assert 0.15 < math.hypot(end[0] - 1.0, end[1]) <= 0.5
    with pytest.raises(NoPathError, match=r"within 0\.1 m"):
        astar(cm, (-1.0, 0.0), (1.0, 0.0), AStarConfig(goal_tolerance_m=0.1))


def test_astar_plans_across_a_4_by_3_m_map_in_milliseconds() -> None:
    cm = open_costmap([(slice(5, 50), slice(20, 22)), (slice(10, 60), slice(45, 47))])
    t0 = time.perf_counter()
    for _ in range(5):
        path = astar(cm, (-1.7, -1.2), (1.7, 1.2))
    ms = (time.perf_counter() - t0) / 5 * 1e3
    print(f"A* on a 4 m x 3 m map at 0.05 m (80 x 60 cells): {ms:.1f} ms, {len(path)} points")
    assert ms < 1000.0  # a 1 Hz replanner's whole budget


CELL_VALUES = st.sampled_from([0, 0, 0, 0, 40, 128, 200, 252, 253, 254, 255])


@settings(max_examples=80, deadline=None)
@given(
    rows=st.integers(2, 12),
    cols=st.integers(2, 12),
    data=st.data(),
    allow_unknown=st.booleans(),
)
def test_the_planner_finds_the_cheapest_path_of_random_grids(
    rows: int, cols: int, data: st.DataObject, allow_unknown: bool
) -> None:
    values = np.array(
        data.draw(st.lists(CELL_VALUES, min_size=rows * cols, max_size=rows * cols)), np.uint8
    ).reshape(rows, cols)
    start = (data.draw(st.integers(0, rows - 1)), data.draw(st.integers(0, cols - 1)))
    goal = (data.draw(st.integers(0, rows - 1)), data.draw(st.integers(0, cols - 1)))
    values[start] = min(values[start], 252)  # a passable start (the escape has its own test)
    values[goal] = min(values[goal], 252)  # a passable goal: no tolerance move
    cm = grid_costmap(values)
    cfg = AStarConfig(allow_unknown=allow_unknown, smooth=False)
    step, passable = cell_costs(cm, cfg)
    best = dijkstra_cells(step, passable, start, goal)
    xy = [tuple(float(v) for v in cm.cell_to_world(*cell)) for cell in (start, goal)]
    if best == math.inf:
        with pytest.raises(NoPathError, match=r"no path .* every route is blocked"):
            astar(cm, xy[0], xy[1], cfg)
        return
    path = astar(cm, xy[0], xy[1], cfg)
    cells = raw_cells(cm, path)
    assert tuple(cells[0]) == start and tuple(cells[-1]) == goal
    if start != goal:
        assert_valid_path(cells, passable)
    # exact: the planner's cost is Dijkstra's over the same graph and step rule
    assert path_cost(path, cm, cfg) == pytest.approx(best, rel=1e-9, abs=1e-9)
    # the smoothed path keeps off blocked cells too
    assert path_cost(astar(cm, xy[0], xy[1], AStarConfig(allow_unknown=allow_unknown)), cm, cfg) < (
        math.inf
    )


def test_paths_priced_by_the_entering_cell_stay_near_that_rule_optimum() -> None:
    # the planner averages the two cells' costs per step (the library's rule); on inflated
    # costmaps with 0.5 m doors and 0.6 m maze corridors the path it picks, priced by the
    # entering cell's cost alone (Nav2's rule), is within 2 % of that rule's optimum
    rng = np.random.default_rng(5)
    worst = 0.0
    for k in range(4):
        g = maze_map(6.0, 0.6, k) if k % 2 else maze_map(6.0, 1.5, k)
        cm = Costmap.from_map(g, CostmapConfig())
        step, passable = cell_costs(cm, AStarConfig())
        free = np.argwhere(passable)
        for _ in range(4):
            a, b = free[rng.integers(len(free), size=2)]
            (sx, sy), (gx, gy) = centre_path(cm, np.vstack((a, b)))
            path = astar(cm, (sx, sy), (gx, gy), AStarConfig(smooth=False))
            cells = raw_cells(cm, path)
            lengths = np.hypot(*np.diff(cells, axis=0).T)
            entering = float(np.sum(lengths * step[cells[1:, 0], cells[1:, 1]]))
            best = dijkstra_cells(step, passable, tuple(a), tuple(b), entering=True)
            assert entering >= best - 1e-9
            worst = max(worst, entering / best - 1.0) if best > 0 else worst
    assert worst <= 0.02


def test_a_400_by_400_maze_gets_its_cheapest_path() -> None:
    g = maze_map(20.0, 1.0, 7)  # 20 m x 20 m at 0.05 m, 1 m maze cells
    cm = Costmap.from_map(g, CostmapConfig())
    assert cm.shape == (400, 400)
    start, goal = (0.5, 0.5), (19.5, 19.5)
    path = astar(cm, start, goal, AStarConfig(smooth=False))
    passable = cell_costs(cm, AStarConfig())[1]
    cells = raw_cells(cm, path)
    assert_valid_path(cells, passable)
    length_m = float(np.hypot(*np.diff(path, axis=0).T).sum())
    assert length_m > 2.0 * math.hypot(19.0, 19.0)  # it winds through the maze
    ends = centre_path(cm, cells[[0, -1]])
    centres = np.vstack((ends[0], path[1:-1], ends[1]))
    assert path_cost(centres, cm) == pytest.approx(dijkstra_cost(cm, start, goal), rel=1e-9)
    smooth = astar(cm, start, goal)
    assert path_cost(smooth, cm) < math.inf


def test_a_large_map_is_searched_coarse_to_fine_near_the_cheapest_cost() -> None:
    """On a 20 m map the search runs over 0.2 m blocks first, then in a band around that
    path: the path it finds costs at most 1 % more than the cheapest one."""
    g = maze_map(20.0, 1.0, 3)
    cm = Costmap.from_map(g, CostmapConfig())
    assert cm.shape[0] * cm.shape[1] > astar_module.COARSE_ABOVE_CELLS
    rng = np.random.default_rng(5)
    for _ in range(4):
        start = (float(rng.integers(0, 20)) + 0.5, float(rng.integers(0, 20)) + 0.5)
        goal = (float(rng.integers(0, 20)) + 0.5, float(rng.integers(0, 20)) + 0.5)
        path = astar(cm, start, goal, AStarConfig(smooth=False))
        cells = raw_cells(cm, path)
        assert_valid_path(cells, cell_costs(cm, AStarConfig())[1])
        ends = centre_path(cm, cells[[0, -1]])
        centres = np.vstack((ends[0], path[1:-1], ends[1]))
        assert path_cost(centres, cm) <= 1.01 * dijkstra_cost(cm, start, goal)


def test_a_coarse_path_through_a_gap_that_is_not_one_falls_back_to_the_whole_grid() -> None:
    """A wall one block thick whose block at x = 5 m holds two passable cells that do not
    touch: the blocks see a gap there, the cells do not. The real way round, at x = 19 m,
    lies outside the band around the coarse path; the planner finds it anyway."""
    g = OccupancyGrid.empty(20.0, 20.0, RES, fill=0)
    cm = Costmap.from_map(g, CostmapConfig())
    cm.costs[200:204, :] = 254  # a wall across y = 10 m (rows 200-203: block row 50)
    cm.costs[200, 100] = cm.costs[203, 101] = 0  # passable, but not connected to each other
    cm.costs[200:204, 380:384] = 0  # the real gap
    start, goal = (5.0, 5.0), (5.0, 15.0)
    path = astar(cm, start, goal, AStarConfig(smooth=False))
    cells = raw_cells(cm, path)
    assert_valid_path(cells, cell_costs(cm, AStarConfig())[1])
    crossing = cells[(cells[:, 0] >= 200) & (cells[:, 0] <= 203)]
    assert np.all(crossing[:, 1] >= 380)


def test_an_unreachable_goal_raises_without_a_search(monkeypatch: pytest.MonkeyPatch) -> None:
    g = maze_map(20.0, 1.0, 7)
    g.data[340:, 340:] = 100  # wall in the goal's corner
    g.data[360:380, 360:380] = 0
    cm = Costmap.from_map(g, CostmapConfig())

    def no_search(*args: object) -> None:
        raise AssertionError("searched although start and goal are not connected")

    monkeypatch.setattr(astar_module, "_search", no_search)
    with pytest.raises(NoPathError, match=r"no path from \(0\.500, 0\.500\) .* every route"):
        astar(cm, (0.5, 0.5), (18.5, 18.5))


def test_a_start_in_the_inscribed_band_leaves_through_it() -> None:
    cm = open_costmap([(slice(28, 32), slice(38, 42))])  # a 0.2 m box around (0.0, 0.0)
    start = (-0.2, 0.0)  # 0.1 m from the box: inside its inscribed band
    (sr,), (sc,) = (np.atleast_1d(v) for v in cm.world_to_cell(*start))
    assert cm.costs[sr, sc] == 253
    path = astar(cm, start, (-1.5, 0.0), AStarConfig(smooth=False))
    cells = raw_cells(cm, path)
    band = cm.costs[cells[:, 0], cells[:, 1]] == 253
    assert band[0] and not band[-1]
    first_out = int(np.argmin(band))
    assert not np.any(band[first_out:])  # once out, it never re-enters the band
    assert np.all(cm.costs[cells[:, 0], cells[:, 1]] <= 253)  # never through the box
    with pytest.raises(NoPathError, match=r"start \(0\.000, 0\.000\) is on an obstacle"):
        astar(cm, (0.0, 0.0), (-1.5, 0.0))


def test_the_same_costs_always_give_the_same_path() -> None:
    blocks = [(slice(5, 50), slice(20, 22)), (slice(10, 60), slice(45, 47))]
    first = astar(open_costmap(blocks), (-1.7, -1.2), (1.7, 1.2))
    other = Costmap.from_map(maze_map(6.0, 1.0, 1), CostmapConfig())
    astar(other, (0.5, 0.5), (5.5, 5.5))  # a plan on another grid shape in between
    cm = open_costmap(blocks)
    for _ in range(3):
        assert np.array_equal(astar(cm, (-1.7, -1.2), (1.7, 1.2)), first)


def test_costs_changed_in_place_are_planned_on() -> None:
    cm = open_costmap([])
    straight = astar(cm, (-1.0, 0.0), (1.0, 0.0), AStarConfig(smooth=False))
    assert np.max(np.abs(straight[:, 1])) < 0.05
    cm.costs[20:40, 38:42] = 254  # no update(): the version stays, the values change
    detour = astar(cm, (-1.0, 0.0), (1.0, 0.0), AStarConfig(smooth=False))
    assert np.max(np.abs(detour[:, 1])) > 0.4
    cells = raw_cells(cm, detour)
    assert np.all(cm.costs[cells[:, 0], cells[:, 1]] < 253)
