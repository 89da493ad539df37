"""Planning: A* on the costmap, the DWB-style local planner, and the navigator in closed loop
on the paper's Stage 3 course (a cylinder appears in front of the robot)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from jackson.calibration.metrics import Cylinder, d_min
from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
from jackson.host.nav.astar import AStarConfig, NoPathError, astar, cell_costs, path_cost
from jackson.host.nav.costmap import Costmap, CostmapConfig
from jackson.host.nav.dwb import DwbConfig, DwbPlanner
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.navigator import Navigator, NavigatorConfig, NavState
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


def dijkstra_cost(cm: Costmap, start: tuple[float, float], goal: tuple[float, float]) -> float:
    """The cheapest 8-connected path cost by plain Dijkstra, for comparison with A*."""
    step, passable = cell_costs(cm, AStarConfig())
    rows, cols = cm.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    src, dst, w = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r0, r1 = max(0, -dr), rows - max(0, dr)
        c0, c1 = max(0, -dc), cols - max(0, dc)
        a = idx[r0:r1, c0:c1]
        b = idx[r0 + dr : r1 + dr, c0 + dc : c1 + dc]
        ok = passable.ravel()[a] & passable.ravel()[b]
        length = math.hypot(dr, dc)
        src += [a[ok], b[ok]]
        dst += [b[ok], a[ok]]
        w += [length * step.ravel()[b[ok]], length * step.ravel()[a[ok]]]
    graph = coo_matrix(
        (np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(idx.size,) * 2
    )
    (sr,), (sc,) = (np.atleast_1d(v) for v in cm.world_to_cell(*start))
    (gr,), (gc,) = (np.atleast_1d(v) for v in cm.world_to_cell(*goal))
    return float(dijkstra(graph.tocsr(), indices=int(idx[sr, sc]))[idx[gr, gc]])


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
    run, _ = run_course(cylinder=None, config=config, goal=goal, t_max_s=30.0)
    assert run.state == NavState.SUCCEEDED
    x, y, yaw = run.poses[-1]
    assert math.hypot(x - goal.x, y - goal.y) <= 0.25
    assert abs(math.remainder(yaw - goal_yaw_rad, 2 * math.pi)) <= 0.25
    turning = run.poses[np.hypot(run.poses[:, 0] - goal.x, run.poses[:, 1] - goal.y) < 0.25]
    assert np.ptp(turning[:, 0]) < 0.05  # it stopped, then turned in place


def test_the_path_is_replanned_as_soon_as_an_obstacle_blocks_it() -> None:
    nav = Navigator(NavigatorConfig(), corridor_map(), LimiterConfig())
    nav.set_goal(GOAL)
    world = Obstacles(segments=WALLS)
    rng = np.random.default_rng(0)
    nav.step(0.0, START, (0.0, 0.0), scan_points(START, world, rng, 0.0))
    straight = nav.plan
    assert np.max(np.abs(straight[:, 1] - START.y)) < 0.02
    assert nav.local_plan.shape[1] == 3 and len(nav.local_plan) > 1
    world.add_circle(*CYLINDER)
    nav.step(0.05, START, (0.0, 0.0), scan_points(START, world, rng, 0.0))  # well before 1 s
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


def test_an_unreachable_goal_fails_with_the_planner_reason() -> None:
    g = corridor_map()
    g.data[:, 50:53] = 100  # wall the corridor off at x = 1.1 m
    cfg = NavigatorConfig(wait_s=0.5, spin_time_allowance_s=1.0, backup_time_allowance_s=1.0)
    nav = Navigator(cfg, g, LimiterConfig())
    nav.set_goal(GOAL)
    t = 0.0
    while t < 60.0:
        cmd = nav.step(t, START, (0.0, 0.0), None)
        if cmd.state == NavState.FAILED:
            break
        t += DT_S
    assert cmd.state == NavState.FAILED
    assert "planner: no path" in cmd.reason
    assert nav.plan.shape == (0, 2)
