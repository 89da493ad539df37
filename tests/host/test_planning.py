"""Planning: A* on the costmap, the DWB-style local planner, and the navigator in closed loop
on the paper's Stage 3 course (a cylinder appears in front of the robot)."""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from jackson.experiments.bench_stage3 import perfect_maze
from jackson.experiments.metrics import Cylinder, d_min
from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
from jackson.host.control.navigator import Navigator, NavigatorConfig, NavState
from jackson.host.nav import astar as astar_module
from jackson.host.nav.astar import AStarConfig, NoPathError, astar, cell_costs, path_cost
from jackson.host.nav.costmap import Costmap, CostmapConfig
from jackson.host.nav.dwb import (
    CRITICS,
    Batch,
    Command,
    Context,
    Critic,
    DwbConfig,
    DwbPlanner,
    bringup_critics,
    densify,
    own_granularity,
    velocity_profile,
)
from jackson.host.nav.dwb.core.distance import DistanceMaps
from jackson.host.nav.dwb.core.path import plan_cells, plan_span
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D
from jackson.sim.lidar import A1M8_ANGLE_INCREMENT_RAD, A1M8_BEAMS, Obstacles, cast

RES = 0.05
DT_S = 0.05  # [s] the 20 Hz control period
SCAN_PERIOD_S = 0.13465  # [s] RPLIDAR A1M8
START = Pose2D(-0.6909, -0.0364, 0.0)  # REFERENCE Stage 3
GOAL = Pose2D(1.2091, -0.0364, 0.0)
CYLINDER = Cylinder(0.6091, -0.0364, 0.125)
INSERT_AFTER_M = 0.1217
WALLS = (
    (-1.2, -0.9, 1.8, -0.9),
    (1.8, -0.9, 1.8, 0.8),
    (1.8, 0.8, -1.2, 0.8),
    (-1.2, 0.8, -1.2, -0.9),
)
"""The corridor of the twin's stage3_corridor world: 3.0 m x 1.7 m around the course."""


def corridor_map() -> OccupancyGrid:
    """The course's static map: the corridor free, its walls occupied, outside unknown."""
    g = OccupancyGrid.empty(3.4, 2.1, RES, origin_x_m=-1.4, origin_y_m=-1.1, fill=-1)
    rows, cols = np.mgrid[0 : g.height, 0 : g.width]
    x, y = g.cell_to_world(rows, cols)
    g.data[(x > -1.2) & (x < 1.8) & (y > -0.9) & (y < 0.8)] = 0
    s = np.linspace(0.0, 1.0, 400)
    for x1, y1, x2, y2 in WALLS:
        r, c = g.world_to_cell(x1 + s * (x2 - x1), y1 + s * (y2 - y1))
        g.data[r, c] = 100
    return g


def scan_points(pose: Pose2D, obstacles: Obstacles, rng: np.random.Generator, sigma_m: float):
    """One A1M8 scan from ``pose`` as map-frame points (exact ray casting plus noise)."""
    angles = -math.pi + A1M8_ANGLE_INCREMENT_RAD * np.arange(A1M8_BEAMS) + pose.yaw
    r = cast((pose.x, pose.y), angles, obstacles, 8.0)
    if sigma_m > 0.0:
        r = r + rng.normal(0.0, sigma_m, r.shape)
    ok = np.isfinite(r) & (r >= 0.15) & (r <= 8.0)
    return np.column_stack(
        (pose.x + r[ok] * np.cos(angles[ok]), pose.y + r[ok] * np.sin(angles[ok]))
    )


def unicycle(pose: Pose2D, v: float, w: float, dt: float) -> Pose2D:
    """Ideal differential drive: the exact arc (Eq. 1) over one step."""
    if abs(w) < 1e-9:
        return Pose2D(
            pose.x + v * dt * math.cos(pose.yaw), pose.y + v * dt * math.sin(pose.yaw), pose.yaw
        )
    yaw = pose.yaw + w * dt
    x = pose.x + v / w * (math.sin(yaw) - math.sin(pose.yaw))
    y = pose.y - v / w * (math.cos(yaw) - math.cos(pose.yaw))
    return Pose2D(x, y, math.atan2(math.sin(yaw), math.cos(yaw)))


# ---------------------------------------------------------------------------- A*


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


def maze_map(size_m: float, cell_m: float, seed: int) -> OccupancyGrid:
    """A perfect maze (depth-first carved, seeded) of ``cell_m`` cells with 0.1 m walls."""
    n, k = round(size_m / RES), round(cell_m / RES)
    return OccupancyGrid(perfect_maze(n, k, 2, np.random.default_rng(seed)), RES)


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


# ---------------------------------------------------------------------------- DWB


def straight_path(x0: float, x1: float, y: float = 0.0) -> np.ndarray:
    n = round((x1 - x0) / RES) + 1
    return np.column_stack((np.linspace(x0, x1, n), np.full(n, y)))


def drive(
    planner: DwbPlanner, pose: Pose2D, path: np.ndarray, goal: Pose2D, cm: Costmap, steps: int
):
    """Run the planner in closed loop for ``steps`` periods; the poses and commands."""
    limiter = VelocityLimiter(planner.limits)
    vel = (0.0, 0.0)
    poses, cmds = [pose], []
    for k in range(steps):
        cm.recentre(pose.x, pose.y)
        cmd = planner.compute(pose, vel, path, goal, cm)
        cmds.append(cmd)
        vel = limiter.limit(cmd.v_m_s, cmd.w_rad_s, k * DT_S)
        pose = unicycle(pose, *vel, DT_S)
        poses.append(pose)
    return poses, cmds


def test_dwb_drives_forward_along_a_straight_path() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    poses, cmds = drive(planner, Pose2D(), straight_path(0.0, 2.0), Pose2D(2.0, 0.0), cm, 30)
    assert cmds[0].valid and cmds[0].v_m_s > 0.2 and abs(cmds[0].w_rad_s) < 0.2
    assert poses[-1].x > 0.3 and abs(poses[-1].y) < 0.02 and abs(poses[-1].yaw) < 0.1
    assert all(0.0 <= c.v_m_s <= 0.30 for c in cmds)  # within LimiterConfig, no reversing


def test_dwb_turns_to_face_a_path_beside_it_first() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    start = Pose2D(0.0, 0.0, math.pi / 2)  # facing +y, the path runs along +x
    poses, cmds = drive(planner, start, straight_path(0.0, 3.0), Pose2D(3.0, 0.0), cm, 120)
    assert cmds[0].w_rad_s < 0.0  # clockwise, towards the path
    assert max(p.y for p in poses) < 0.25  # a turn of about a body length, not a loop
    assert abs(poses[-1].yaw) < 0.15 and abs(poses[-1].y) < 0.03 and poses[-1].x > 1.2


def test_dwb_in_place_turns_respect_the_minimum_angular_velocity() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    for v0, w0 in ((0.0, 0.0), (0.1, 0.2), (0.3, -1.0)):
        v, w, _ = planner.samples(v0, w0)
        turning_in_place = (v == 0.0) & (w != 0.0)
        assert np.all(np.abs(w[turning_in_place]) >= 0.30 - 1e-12)
        assert v.min() >= 0.0 and v.max() <= 0.30 and np.abs(w).max() <= 2.0


def test_dwb_stops_at_the_goal_and_turns_to_its_yaw() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    cm = Costmap.rolling_window(CostmapConfig(), 1.0, 0.0)
    goal = Pose2D(1.0, 0.0, 1.0)
    path = straight_path(0.0, 1.0)
    cmd = planner.compute(Pose2D(0.9, 0.0, 0.0), (0.0, 0.0), path, goal, cm)
    assert cmd.v_m_s == 0.0 and cmd.w_rad_s >= 0.30  # inside 0.25 m: turn in place, CCW
    _, cmds = drive(planner, Pose2D(0.9, 0.0, 0.0), path, goal, cm, 80)
    assert all(c.v_m_s == 0.0 for c in cmds)
    assert cmds[-1].w_rad_s == 0.0
    planner.reset()
    cmd = planner.compute(Pose2D(0.9, 0.0, 0.98), (0.0, 0.0), path, goal, cm)
    assert (cmd.v_m_s, cmd.w_rad_s) == (0.0, 0.0)  # already facing the goal's yaw


def test_dwb_never_picks_a_trajectory_through_an_obstacle() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    wall = np.column_stack((np.full(41, 0.45), np.linspace(-1.0, 1.0, 41)))
    cm.update(wall, (0.0, 0.0))
    path = straight_path(0.0, 1.2)  # straight through the wall
    poses, cmds = drive(planner, Pose2D(), path, Pose2D(1.2, 0.0), cm, 60)
    for cmd in cmds:
        if cmd.valid:
            tr = cmd.trajectory
            assert not np.any(cm.footprint_collides(tr[:, 0], tr[:, 1], tr[:, 2]))
    assert all(p.x < 0.45 - 0.135 for p in poses)


def test_dwb_says_why_when_no_trajectory_is_legal() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    cm.update(np.array([[0.01, 0.01]]), (0.3, 0.0))  # an obstacle under the robot's centre
    cmd = planner.compute(Pose2D(), (0.0, 0.0), straight_path(0.0, 1.0), Pose2D(1.0, 0.0), cm)
    assert not cmd.valid and (cmd.v_m_s, cmd.w_rad_s) == (0.0, 0.0)
    assert "BaseObstacle 100%" in cmd.reason and cmd.trajectory.shape == (0, 3)


def test_dwb_cycle_fits_the_control_period() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    cm.update(np.column_stack((np.full(30, 0.6), np.linspace(-0.3, 0.3, 30))), (0.0, 0.0))
    path = np.column_stack((np.linspace(0.0, 1.4, 29), 0.4 * np.sin(np.linspace(0, math.pi, 29))))
    times = []
    for k in range(40):
        t0 = time.perf_counter()
        planner.compute(Pose2D(0.0, 0.0, 0.0), (0.2, 0.1 * (k % 3)), path, Pose2D(1.4, 0.0), cm)
        times.append(time.perf_counter() - t0)
    ms = float(np.median(times)) * 1e3
    print(f"DWB cycle: {ms:.2f} ms median over 40 (control period 50 ms)")
    assert ms < 50.0


# DWB's cycle written out target by target, the way the docstring of jackson.host.nav.dwb
# states it: the planner evaluates everything at once and only what it reads, and must choose
# the same command.


def reference_targets(planner: DwbPlanner, v0: float, w0: float) -> list[tuple[float, float]]:
    """Steps 1-2: the window's (v, w) targets, each once, in (v, w) order."""
    c = planner.config
    v_lo, v_hi, w_lo, w_hi = planner.window(v0, w0)
    ws = list(np.linspace(w_lo, w_hi, c.vtheta_samples)) + ([0.0] if w_lo <= 0.0 <= w_hi else [])
    w_min = min(c.min_speed_theta_rad_s, planner.limits.max_w_rad_s)
    targets = set()
    for v in np.linspace(v_lo, v_hi, c.vx_samples):
        for w in ws:
            if abs(v) < 1e-9 and w != 0.0 and abs(w) < w_min:
                w = math.copysign(w_min, w)
            targets.add((float(v), float(w)))
    return sorted(targets)


def reference_rollout(
    planner: DwbPlanner, pose: Pose2D, velocity: tuple[float, float], v: float, w: float, k: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 3 for one target: ramp, trapezoidal yaw, positions at the mid-step heading."""
    lim = planner.limits
    t = np.linspace(0.0, planner.config.sim_time_s, k + 1)
    dt = planner.config.sim_time_s / k
    vel = velocity_profile(velocity[0], np.array([v]), t, lim.max_accel_m_s2, lim.max_decel_m_s2)
    rot = velocity_profile(
        velocity[1], np.array([w]), t, lim.max_alpha_rad_s2, lim.max_alpha_decel_rad_s2
    )
    dyaw = 0.5 * (rot[0, 1:] + rot[0, :-1]) * dt
    yaw = np.concatenate(([0.0], np.cumsum(dyaw))) + pose.yaw
    mid = yaw[:-1] + 0.5 * dyaw
    ds = 0.5 * (vel[0, 1:] + vel[0, :-1]) * dt
    x = np.concatenate(([0.0], np.cumsum(ds * np.cos(mid)))) + pose.x
    y = np.concatenate(([0.0], np.cumsum(ds * np.sin(mid)))) + pose.y
    return x, y, yaw


def reference_distance_map(cm: Costmap, sources: list[tuple[int, int]]) -> np.ndarray:
    """Manhattan distance through the cells below inscribed, breadth first, cell by cell."""
    rows, cols = cm.shape
    d = np.full((rows, cols), float(rows * cols))
    queue = deque()
    for cell in sources:
        d[cell] = 0.0
        queue.append(cell)
    while queue:
        r, c = queue.popleft()
        if cm.costs[r, c] >= 253:
            continue  # a source on an obstacle reaches nothing
        for nr, nc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            inside = 0 <= nr < rows and 0 <= nc < cols
            if inside and cm.costs[nr, nc] < 253 and d[nr, nc] > d[r, c] + 1.0:
                d[nr, nc] = d[r, c] + 1.0
                queue.append((nr, nc))
    return d


def reference_path_cells(
    planner: DwbPlanner, pose: Pose2D, path: np.ndarray, goal: Pose2D, cm: Costmap
) -> tuple[list[tuple[int, int]], tuple[int, int]] | None:
    """The path's cells in the window (Nav2's plan transform) and GoalAlign's target cell."""
    c = planner.config
    half_m = 0.5 * max(cm.shape) * cm.resolution_m
    d = [math.hypot(px - pose.x, py - pose.y) for px, py in path]
    near = int(np.argmin(d))
    begin = near
    while begin > 0 and d[begin - 1] < min(half_m, c.prune_distance_m):
        begin -= 1
    end = near
    while end < len(path) and d[end] <= min(half_m, c.forward_prune_distance_m):
        end += 1
    dense = densify(path[begin : max(end, begin + 1)], cm.resolution_m)
    cells, on_map = [], []
    for px, py in dense:
        r, col = (int(a) for a in cm.world_to_cell(px, py))
        known = 0 <= r < cm.shape[0] and 0 <= col < cm.shape[1] and cm.costs[r, col] != 255
        cells.append((r, col))
        on_map.append(known)
    if not any(on_map):
        return None
    first = on_map.index(True)
    last = first
    while last + 1 < len(on_map) and on_map[last + 1]:
        last += 1
    run = cells[first : last + 1]
    target = run[-1]
    if last == len(dense) - 1 and np.allclose(dense[-1], path[-1]):
        heading = math.atan2(goal.y - pose.y, goal.x - pose.x)
        tx, ty = cm.cell_to_world(*target)
        fpd = c.goal_align_forward_point_distance_m
        r, col = (
            int(a)
            for a in cm.world_to_cell(
                float(tx) + fpd * math.cos(heading), float(ty) + fpd * math.sin(heading)
            )
        )
        if 0 <= r < cm.shape[0] and 0 <= col < cm.shape[1]:
            target = (r, col)
    return run, target


@dataclass
class ReferenceDwb:
    """The reference planner: the same configuration, its own stateful critics."""

    planner: DwbPlanner

    def compute(
        self, pose: Pose2D, velocity: tuple[float, float], path: np.ndarray, goal: Pose2D,
        cm: Costmap,
    ) -> tuple[float, float, float, int, np.ndarray | None, str]:  # fmt: skip
        """(v, w, total, legal count, chosen trajectory, reason) of one cycle."""
        p, c = self.planner, self.planner.config
        v0, w0 = velocity
        targets = reference_targets(p, v0, w0)
        t_end = c.sim_time_s
        k = max(1, math.ceil(max(
            max(abs(v) * t_end / c.linear_granularity_m, abs(w) * t_end / c.angular_granularity_rad)
            for v, w in targets
        ) - 1e-9))  # fmt: skip
        rolls = [reference_rollout(p, pose, velocity, v, w, k) for v, w in targets]
        rotate_to_goal, oscillation = p.critic("RotateToGoal"), p.critic("Oscillation")
        rotate_to_goal.latch(pose, v0, goal)
        window = reference_path_cells(p, pose, path, goal, cm)
        if window is None:
            reason = "no point of the global path lies on the local costmap"
            return 0.0, 0.0, math.inf, 0, None, reason
        run, target = window
        path_map = reference_distance_map(cm, run)
        goal_map = reference_distance_map(cm, [run[-1]])
        align_map = reference_distance_map(cm, [target])
        # step 4: a pose per half cell of the fastest point's sweep, the robot grown by half of it
        r_m = cm.config.circumscribed_radius_m
        half_cell = 0.5 * cm.resolution_m
        per_step = [
            (max(abs(v), abs(v0)) + max(abs(w), abs(w0)) * r_m) * (t_end / k) for v, w in targets
        ]
        group = [
            2 ** math.floor(math.log2(max(min(k, math.floor(half_cell / max(s, 1e-12))), 1)))
            for s in per_step
        ]
        margin = {
            g: 0.5
            * min(g * max(s for s, gg in zip(per_step, group, strict=True) if gg == g), half_cell)
            for g in set(group)
        }
        # step 5: the critics, target by target
        rotating = rotate_to_goal.rotating
        at_goal_fpd = pose.distance(goal) <= c.path_align_forward_point_distance_m
        v_brake = targets[0][0]
        rows, cols = cm.shape
        totals, legal = [], []
        rejected = dict.fromkeys(CRITICS, 0)
        for (v, w), (x, y, yaw), g in zip(targets, rolls, group, strict=True):
            ok = dict.fromkeys(CRITICS, True)
            raw = dict.fromkeys(CRITICS, 0.0)
            scale = {
                "RotateToGoal": c.rotate_to_goal_scale, "Oscillation": c.oscillation_scale,
                "BaseObstacle": c.base_obstacle_scale, "GoalAlign": c.goal_align_scale,
                "PathAlign": c.path_align_scale * 0.5 * cm.resolution_m,
                "PathDist": c.path_dist_scale, "GoalDist": c.goal_dist_scale,
            }  # fmt: skip
            if rotate_to_goal.in_window:
                err = abs((yaw[-1] - goal.yaw + math.pi) % (2.0 * math.pi) - math.pi)
                if rotating:
                    raw["RotateToGoal"], ok["RotateToGoal"] = err, abs(v - v_brake) <= 1e-12
                else:
                    raw["RotateToGoal"] = v * v * c.rotate_to_goal_slowing_factor + err
                    ok["RotateToGoal"] = v * v < v0 * v0
            ok["Oscillation"] = bool(oscillation.allowed(np.array([w]))[0])
            checked = list(range(0, k + 1, g)) + ([k] if k % g else [])
            ok["BaseObstacle"] = not cm.trajectories_collide(
                x[None, checked], y[None, checked], yaw[None, checked], margin_m=margin[g]
            )[0]
            raw["BaseObstacle"] = float(cm.cost_at(x[-1], y[-1]))
            r, col = (int(a) for a in cm.world_to_cell(x[-1], y[-1]))
            ok["PathDist"] = ok["GoalDist"] = 0 <= r < rows and 0 <= col < cols
            r, col = min(max(r, 0), rows - 1), min(max(col, 0), cols - 1)
            raw["PathDist"], raw["GoalDist"] = path_map[r, col], goal_map[r, col]
            for name, grid in (("GoalAlign", align_map), ("PathAlign", path_map)):
                fpd = getattr(
                    c, f"{'goal' if name == 'GoalAlign' else 'path'}_align_forward_point_distance_m"
                )
                if rotating or (name == "PathAlign" and at_goal_fpd):
                    scale[name] = 0.0
                fr, fc = (
                    int(a)
                    for a in cm.world_to_cell(
                        x[-1] + fpd * math.cos(yaw[-1]), y[-1] + fpd * math.sin(yaw[-1])
                    )
                )
                ok[name] = scale[name] == 0.0 or (0 <= fr < rows and 0 <= fc < cols)
                raw[name] = grid[min(max(fr, 0), rows - 1), min(max(fc, 0), cols - 1)]
            for name in CRITICS:
                rejected[name] += not ok[name]
            legal.append(all(ok.values()))
            totals.append(sum(scale[n] * raw[n] for n in CRITICS if scale[n] != 0.0))
        if not any(legal):
            shares = ", ".join(
                f"{n} {100.0 * rejected[n] / len(targets):.0f}%" for n in CRITICS if rejected[n]
            )
            return 0.0, 0.0, math.inf, 0, None, f"no legal trajectory of {len(targets)} ({shares})"
        best = min((i for i in range(len(targets)) if legal[i]), key=lambda i: totals[i])
        (v, w), (x, y, yaw) = targets[best], rolls[best]
        oscillation.record(pose, v, w)
        return v, w, totals[best], sum(legal), np.column_stack((x, y, yaw)), ""


def test_dwb_chooses_what_the_target_by_target_reference_chooses() -> None:
    world = Obstacles(segments=WALLS)
    world.add_circle(*CYLINDER)
    rng = np.random.default_rng(4)
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    reference = ReferenceDwb(DwbPlanner(DwbConfig(), LimiterConfig()))
    cm = Costmap.rolling_window(CostmapConfig(), START.x, START.y)
    detour = np.column_stack(
        (np.linspace(START.x, GOAL.x, 39), START.y + 0.45 * np.sin(np.linspace(0, math.pi, 39)))
    )
    turn_at_goal = Pose2D(GOAL.x, GOAL.y, 1.0)
    cases = [  # pose, velocity, path, goal: driving up, beside the cylinder, at the goal
        (Pose2D(-0.3, -0.03, 0.05), (0.15, 0.0), detour, GOAL),
        (Pose2D(-0.1, 0.02, 0.3), (0.3, 0.6), detour, GOAL),
        (Pose2D(0.15, 0.1, 0.4), (0.05, -1.5), detour, GOAL),
        (Pose2D(0.3, -0.036, 0.0), (0.0, 0.0), straight_path(0.3, 1.2, -0.036), GOAL),
        (Pose2D(0.62, 0.24, -0.2), (0.2, -0.3), detour, GOAL),  # touching the cylinder
        (Pose2D(1.0, -0.036, 0.2), (0.3, 0.0), straight_path(0.3, 1.2, -0.036), turn_at_goal),
        (Pose2D(1.1, -0.036, 0.2), (0.0, 0.0), straight_path(0.3, 1.2, -0.036), turn_at_goal),
        (Pose2D(1.1, -0.036, 0.5), (0.0, 0.4), straight_path(0.3, 1.2, -0.036), turn_at_goal),
    ]
    chosen = set()
    for pose, velocity, path, goal in cases:
        cm.recentre(pose.x, pose.y)
        cm.update(scan_points(pose, world, rng, 0.01), (pose.x, pose.y))
        v, w, _ = planner.samples(*velocity)
        assert np.array_equal(np.column_stack((v, w)), reference_targets(planner, *velocity))
        cmd = planner.compute(pose, velocity, path, goal, cm)
        ref_v, ref_w, ref_total, ref_legal, ref_trajectory, reason = reference.compute(
            pose, velocity, path, goal, cm
        )
        assert (cmd.v_m_s, cmd.w_rad_s, cmd.legal, cmd.reason) == (ref_v, ref_w, ref_legal, reason)
        if cmd.valid:
            assert cmd.total == pytest.approx(ref_total, rel=1e-12, abs=1e-12)
            np.testing.assert_allclose(cmd.trajectory, ref_trajectory, rtol=0, atol=1e-12)
        chosen.add((cmd.v_m_s > 0.0, cmd.w_rad_s > 0.0, cmd.w_rad_s < 0.0, cmd.legal < cmd.samples))
    assert len(chosen) >= 3  # the cases cover straight, left and right turns, and rejections
    # no legal trajectory: the same shares of rejections
    cm.update(np.array([[1.11, -0.03]]), (1.5, -0.036))
    pose = Pose2D(1.1, -0.036, 0.0)
    cmd = planner.compute(pose, (0.0, 0.0), straight_path(0.3, 1.2, -0.036), GOAL, cm)
    *_, reason = reference.compute(pose, (0.0, 0.0), straight_path(0.3, 1.2, -0.036), GOAL, cm)
    assert not cmd.valid and cmd.reason == reason and "BaseObstacle 100%" in reason


def test_nothing_within_the_clear_reach_of_a_point_can_collide() -> None:
    # the DWB planner skips the collision test of roll-outs that stay within it
    world = Obstacles(segments=WALLS)
    world.add_circle(*CYLINDER)
    cm = Costmap.rolling_window(CostmapConfig(), 0.3, 0.0)
    cm.update(scan_points(Pose2D(0.3, 0.0, 0.0), world, np.random.default_rng(5), 0.01), (0.3, 0.0))
    rng = np.random.default_rng(6)
    x0, y0 = rng.uniform(-1.3, 1.9, 4000), rng.uniform(-1.6, 1.6, 4000)  # on and off the grid
    reach = cm.clear_reach_m(x0, y0)
    assert np.any(reach > 0.3) and np.any(reach < 0.0)
    far = np.flatnonzero(reach > 0.0)
    angle, s = rng.uniform(-math.pi, math.pi, len(far)), rng.uniform(0.0, 1.0, len(far))
    x = x0[far] + s * reach[far] * np.cos(angle)
    y = y0[far] + s * reach[far] * np.sin(angle)
    yaw = rng.uniform(-math.pi, math.pi, len(far))
    assert not np.any(cm.footprint_collides(x, y, yaw))
    hit = cm.trajectories_collide(
        x[:, None], y[:, None], yaw[:, None], escape=False, margin_m=cm.max_margin_m
    )
    assert not np.any(hit)


def test_dwb_rollout_equals_the_target_by_target_integration() -> None:
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    pose, velocity = Pose2D(0.2, -0.1, 2.5), (0.12, -0.7)
    v, w, _ = planner.samples(*velocity)
    x, y, yaw, t = planner.rollout(pose, velocity, v, w)
    k = len(t) - 1
    for i in range(0, len(v), 7):
        rx, ry, ryaw = reference_rollout(planner, pose, velocity, float(v[i]), float(w[i]), k)
        np.testing.assert_allclose(
            np.vstack((x[i], y[i], yaw[i])), np.vstack((rx, ry, ryaw)), rtol=0, atol=1e-12
        )


def test_dwb_critics_score_every_roll_out_of_a_cycle_at_once() -> None:
    # one interface: named as in Nav2's parameters, in bringup's order; prepared with the
    # cycle, then a raw score and a legality per roll-out, all roll-outs in one call
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    assert tuple(critic.name for critic in planner.critics) == CRITICS
    assert len(set(CRITICS)) == len(CRITICS) == 7
    world = Obstacles(segments=WALLS)
    world.add_circle(*CYLINDER)
    pose, velocity = Pose2D(0.15, 0.1, 0.4), (0.05, -1.5)  # beside the cylinder
    cm = Costmap.rolling_window(CostmapConfig(), pose.x, pose.y)
    cm.update(scan_points(pose, world, np.random.default_rng(7), 0.01), (pose.x, pose.y))
    path = straight_path(pose.x, GOAL.x, GOAL.y)
    c = planner.config
    span = plan_span(pose, path, cm, c.prune_distance_m, c.forward_prune_distance_m)
    context = Context(pose, velocity, GOAL, cm, plan_cells(path, span, cm), DistanceMaps())
    v, w, v_brake = planner.samples(*velocity)
    batch = Batch.of(v, w, v_brake, planner.rollouts(pose, velocity, v, w), cm)
    rejected = set()
    for critic in planner.critics:
        assert critic.prepare(context)
        raw, legal = critic.score(batch)
        assert raw.dtype == np.float64 and raw.shape == (len(v),)
        assert legal.dtype == bool and legal.shape == (len(v),)
        assert np.all(np.isfinite(raw)) and 0.0 <= critic.scale < math.inf
        if not legal.all():
            rejected.add(critic.name)
    assert "BaseObstacle" in rejected  # some roll-outs hit the cylinder
    # without the path in the window, the critics that follow it cannot score
    unprepared = [critic.name for critic in planner.critics if not critic.prepare(
        replace(context, plan=None)
    )]  # fmt: skip
    assert unprepared == ["GoalAlign", "PathAlign", "PathDist", "GoalDist"]


@dataclass
class SpyCritic(Critic):
    """A critic of one's own: scores nothing, rejects nothing, records its calls."""

    name: str = "Spy"
    calls: list[tuple[str, object]] = field(default_factory=list)

    @property
    def scale(self) -> float:
        return 0.0

    def prepare(self, context: Context) -> bool:
        self.calls.append(("prepare", context.pose))
        return True

    def score(self, batch: Batch) -> tuple[np.ndarray, np.ndarray]:
        self.calls.append(("score", batch.size))
        return np.zeros(batch.size), np.ones(batch.size, bool)

    def debrief(self, command: Command) -> None:
        self.calls.append(("debrief", command))


def test_dwb_takes_a_critic_list_of_ones_own() -> None:
    # without Oscillation, which rejects nothing on this drive, and with a critic that adds
    # nothing, every command is the same bit for bit
    config = DwbConfig()
    spy = SpyCritic()
    critics = [c for c in bringup_critics(config) if c.name != "Oscillation"] + [spy]
    planner = DwbPlanner(config, LimiterConfig(), critics)
    assert tuple(c.name for c in planner.critics) == (*CRITICS[:1], *CRITICS[2:], "Spy")
    path = np.column_stack((np.linspace(0.0, 1.4, 29), 0.4 * np.sin(np.linspace(0, math.pi, 29))))
    wall = np.column_stack((np.full(30, 0.6), np.linspace(-0.3, 0.3, 30)))
    drives = []
    for p in (DwbPlanner(config, LimiterConfig()), planner):
        cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
        cm.update(wall, (0.0, 0.0))
        drives.append(drive(p, Pose2D(), path, Pose2D(1.4, 0.0), cm, 40))
    (_, want), (poses, got) = drives
    for a, b in zip(want, got, strict=True):
        assert (a.v_m_s, a.w_rad_s, a.total, a.legal, a.samples) == (
            b.v_m_s, b.w_rad_s, b.total, b.legal, b.samples,
        )  # fmt: skip
        assert np.array_equal(a.trajectory, b.trajectory)
        assert {**a.scores, "Spy": 0.0} == {**b.scores, "Oscillation": 0.0}
    # prepared once a cycle, scored on every roll-out, debriefed with the command chosen
    assert [name for name, _ in spy.calls] == ["prepare", "score", "debrief"] * len(got)
    for k, cmd in enumerate(got):
        assert spy.calls[3 * k] == ("prepare", poses[k])
        assert spy.calls[3 * k + 1] == ("score", cmd.samples)
        assert spy.calls[3 * k + 2][1] is cmd
    with pytest.raises(ValueError, match="distinct"):
        DwbPlanner(config, LimiterConfig(), [*critics, SpyCritic()])


# ---------------------------------------------------------------------------- navigator


@dataclass
class Run:
    """The outcome of one closed-loop run of the course."""

    state: NavState
    t_s: float
    poses: np.ndarray
    t_insert_s: float | None
    recoveries: dict[str, int] = field(default_factory=dict)
    step_ms: list[float] = field(default_factory=list)


def run_course(
    cylinder: Cylinder | None = CYLINDER,
    sigma_m: float = 0.0,
    seed: int = 0,
    t_max_s: float = 60.0,
    config: NavigatorConfig | None = None,
    goal: Pose2D = GOAL,
) -> tuple[Run, Navigator]:
    """Navigate the Stage 3 course: ideal unicycle at 20 Hz, the A1M8 at 7.43 Hz."""
    rng = np.random.default_rng(seed)
    limits = LimiterConfig()
    nav = Navigator(config or NavigatorConfig(), corridor_map(), limits)
    nav.set_goal(goal)
    world = Obstacles(segments=WALLS)
    limiter = VelocityLimiter(limits)
    pose, vel, t, next_scan = START, (0.0, 0.0), 0.0, 0.0
    t_insert = None
    poses = [(pose.x, pose.y, pose.yaw)]
    step_ms = []
    state = nav.state
    while t < t_max_s:
        if cylinder is not None and t_insert is None and pose.distance(START) >= INSERT_AFTER_M:
            world.add_circle(*cylinder)
            t_insert = t
        points = None
        if t >= next_scan:
            points = scan_points(pose, world, rng, sigma_m)
            next_scan += SCAN_PERIOD_S
        t0 = time.perf_counter()
        cmd = nav.step(t, pose, vel, points)
        step_ms.append((time.perf_counter() - t0) * 1e3)
        state = cmd.state
        if state in (NavState.SUCCEEDED, NavState.FAILED):
            break
        vel = limiter.limit(cmd.v_m_s, cmd.w_rad_s, t)
        pose = unicycle(pose, *vel, DT_S)
        t += DT_S
        poses.append((pose.x, pose.y, pose.yaw))
    return Run(state, t, np.array(poses), t_insert, dict(nav.recoveries), step_ms), nav


@pytest.mark.parametrize(
    ("name", "cylinder", "sigma_m"),
    [
        ("C00", CYLINDER, 0.0),
        ("G01 obstacle y + 0.15 m", Cylinder(0.6091, 0.1136, 0.125), 0.0),
        ("G02 obstacle y - 0.15 m", Cylinder(0.6091, -0.1864, 0.125), 0.0),
        ("LiDAR sigma 0.010 m", CYLINDER, 0.010),
    ],
)
def test_the_robot_avoids_the_appearing_cylinder_and_reaches_the_goal(
    name: str, cylinder: Cylinder, sigma_m: float
) -> None:
    run, nav = run_course(cylinder, sigma_m=sigma_m, seed=1)
    assert run.state == NavState.SUCCEEDED, nav.state
    end = run.poses[-1]
    error = math.hypot(end[0] - GOAL.x, end[1] - GOAL.y)
    assert error <= 0.25
    assert run.t_insert_s is not None
    after = run.poses[round(run.t_insert_s / DT_S) :]
    clearance = d_min(after, cylinder)  # Eq. 21, oriented envelope to cylinder
    assert clearance > 0.0  # the envelope never overlapped the cylinder
    length = float(np.hypot(*np.diff(run.poses[:, :2], axis=0).T).sum())
    steps = np.array(run.step_ms)
    print(
        f"{name}: t_nav {run.t_s:.2f} s, d_min {clearance:.3f} m, path {length:.3f} m, "
        f"goal error {error:.3f} m, recoveries {sum(run.recoveries.values())}, replans "
        f"{nav.replans}, navigator step {np.median(steps):.1f} ms median, {steps.max():.1f} max"
    )


def test_without_an_obstacle_the_robot_drives_straight_to_the_goal() -> None:
    run, nav = run_course(cylinder=None)
    assert run.state == NavState.SUCCEEDED
    assert np.max(np.abs(run.poses[:, 1] - START.y)) < 0.02
    assert nav.plan.shape[1] == 2 and sum(run.recoveries.values()) == 0


@pytest.mark.parametrize("goal_yaw_rad", [math.pi / 2, -2.5])
def test_with_a_yaw_tolerance_the_robot_turns_to_the_goal_yaw_in_place(goal_yaw_rad: float) -> None:
    goal = Pose2D(GOAL.x, GOAL.y, goal_yaw_rad)
    config = NavigatorConfig(yaw_goal_tolerance_rad=0.25)
    run, nav = run_course(cylinder=None, config=config, goal=goal, t_max_s=30.0)
    assert run.state == NavState.SUCCEEDED
    x, y, yaw = run.poses[-1]
    assert math.hypot(x - goal.x, y - goal.y) <= nav.goal_window_m  # 0.15 m: aims inside 0.25
    assert abs(math.remainder(yaw - goal_yaw_rad, 2 * math.pi)) <= 0.25
    window = np.hypot(run.poses[:, 0] - goal.x, run.poses[:, 1] - goal.y) < nav.goal_window_m
    turning = run.poses[window]
    assert np.ptp(turning[:, 0]) < 0.05  # it stopped, then turned in place


def test_local_plan_is_published_at_its_own_granularity_as_nav2_does() -> None:
    """DWB rolls every target out with the step count of the most demanding one; the chosen
    trajectory goes out at its own: one step per 5 cm or per 0.025 rad."""
    t = np.linspace(0.0, 1.7, 137)
    straight = np.column_stack((0.26 * t, np.zeros_like(t), np.zeros_like(t)))
    thin = own_granularity(straight, 0.05, 0.025)
    assert len(thin) == 10  # 0.442 m / 0.05 m: 9 steps
    assert np.array_equal(thin[0], straight[0]) and np.array_equal(thin[-1], straight[-1])
    assert np.all(np.diff(thin[:, 0]) <= 0.05 + 0.26 * 1.7 / 136)
    # a turn in place: the angle sets the count (1.7 rad / 0.025 = 68 steps)
    spin = np.column_stack((np.zeros_like(t), np.zeros_like(t), 1.0 * t))
    assert len(own_granularity(spin, 0.05, 0.025)) == 69
    # never more poses than the roll-out, and a pose or two kept as they are
    assert len(own_granularity(np.column_stack((t, t, 30 * t)), 0.05, 0.025)) == len(t)
    assert own_granularity(straight[:1], 0.05, 0.025).shape == (1, 3)


def test_the_path_is_replanned_as_soon_as_an_obstacle_blocks_it() -> None:
    nav = Navigator(NavigatorConfig(), corridor_map(), LimiterConfig())
    nav.set_goal(GOAL)
    world = Obstacles(segments=WALLS)
    rng = np.random.default_rng(0)
    nav.step(0.0, START, (0.0, 0.0), scan_points(START, world, rng, 0.0))
    nav.step(0.05, START, (0.0, 0.0), None)  # the plan waits for the tick after the scan
    straight = nav.plan
    assert np.max(np.abs(straight[:, 1] - START.y)) < 0.02
    assert nav.local_plan.shape[1] == 3 and len(nav.local_plan) > 1
    world.add_circle(*CYLINDER)
    nav.step(0.10, START, (0.0, 0.0), scan_points(START, world, rng, 0.0))  # well before 1 s
    assert nav.replans == 1  # the scan's tick re-inflates; the next one plans
    nav.step(0.15, START, (0.0, 0.0), None)
    detour = nav.plan
    assert nav.replans == 2
    assert np.min(np.hypot(detour[:, 0] - CYLINDER.x_m, detour[:, 1] - CYLINDER.y_m)) > 0.125 + 0.16


def test_a_stuck_robot_recovers_in_turn_and_fails_after_six_rounds() -> None:
    cfg = NavigatorConfig(
        progress_time_s=2.0, wait_s=1.0, spin_time_allowance_s=1.0, backup_time_allowance_s=1.0
    )
    nav = Navigator(cfg, corridor_map(), LimiterConfig())
    nav.set_goal(GOAL)
    pose, t, seen = START, 0.0, []
    while t < 120.0:
        cmd = nav.step(t, pose, (0.0, 0.0), None)  # the wheels spin, the robot never moves
        if cmd.behaviour and (not seen or seen[-1] != cmd.behaviour):
            seen.append(cmd.behaviour)
        if cmd.state == NavState.FAILED:
            break
        t += DT_S
    assert cmd.state == NavState.FAILED
    assert "failed after 6 recoveries: no progress" in cmd.reason
    assert nav.recoveries == {"clear_costmaps": 2, "spin": 2, "wait": 1, "backup": 1}
    assert seen[:5] == ["clear_costmaps", "spin", "wait", "backup", "clear_costmaps"]
    assert nav.retries == 6


def test_a_goal_the_map_itself_cuts_off_fails_at_once() -> None:
    g = corridor_map()
    g.data[:, 50:53] = 100  # wall the corridor off at x = 1.1 m
    nav = Navigator(NavigatorConfig(), g, LimiterConfig())
    nav.set_goal(GOAL)
    cmd = nav.step(0.0, START, (0.0, 0.0), None)
    assert cmd.state == NavState.FAILED
    assert cmd.reason.startswith("goal (1.21, -0.04) unreachable on the map: no path")
    assert (cmd.v_m_s, cmd.w_rad_s) == (0.0, 0.0)
    assert nav.plan.shape == (0, 2) and sum(nav.recoveries.values()) == 0


def test_a_kept_search_object_is_built_anew_after_its_searches_and_finds_the_same_paths() -> None:
    """scikit-image's heap keeps its item count across a kept search object's searches, so
    one object kept for a whole run grows without bound (a navigating soak's resident set
    stepped up 2 MB at a time). Each kept object serves ``SEARCHES_PER_SEARCHER`` searches;
    a fresh one, and a reused one, give the same path."""
    g = maze_map(4.0, 0.5, 11)
    cm = Costmap.from_map(g, CostmapConfig())
    assert cm.shape[0] * cm.shape[1] <= astar_module.COARSE_ABOVE_CELLS  # one search a plan
    rng = np.random.default_rng(3)
    n = astar_module.SEARCHES_PER_SEARCHER
    astar_module._SEARCHERS.pop(cm.shape, None)  # the first plan builds the object
    seen: list[int] = []
    for _ in range(2 * n + 2):
        start = (float(rng.integers(0, 8)) * 0.5 + 0.25, float(rng.integers(0, 8)) * 0.5 + 0.25)
        goal = (float(rng.integers(0, 8)) * 0.5 + 0.25, float(rng.integers(0, 8)) * 0.5 + 0.25)
        reused = astar(cm, start, goal, AStarConfig(smooth=False))
        seen.append(id(astar_module._SEARCHERS[cm.shape].mcp))
        kept = astar_module._SEARCHERS.pop(cm.shape)
        fresh = astar(cm, start, goal, AStarConfig(smooth=False))
        astar_module._SEARCHERS[cm.shape] = kept
        np.testing.assert_array_equal(reused, fresh)
    changes = [i for i in range(1, len(seen)) if seen[i] != seen[i - 1]]
    assert changes == [n, 2 * n]
