"""The navigator in closed loop on the paper's Stage 3 course (a cylinder appears in front of the
robot): avoidance, replanning, recoveries, goal yaw."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pytest

from jackson.experiments.metrics import Cylinder, d_min
from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
from jackson.host.control.navigator import Navigator, NavigatorConfig, NavigatorState
from jackson.host.nav import astar as astar_module
from jackson.host.nav.astar import AStarConfig, astar
from jackson.host.nav.costmap import Costmap, CostmapConfig
from jackson.host.nav.dwb import (
    own_granularity,
)
from jackson.host.nav.types import Pose2D
from jackson.sim.lidar import Obstacles

from ..stage3_course import (
    CYLINDER,
    DT_S,
    GOAL,
    INSERT_AFTER_M,
    SCAN_PERIOD_S,
    START,
    WALLS,
    corridor_map,
    maze_map,
    scan_points,
    unicycle,
)


@dataclass
class Run:
    """The outcome of one closed-loop run of the course."""

    state: NavigatorState
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
        if state in (NavigatorState.SUCCEEDED, NavigatorState.FAILED):
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
    assert run.state == NavigatorState.SUCCEEDED, nav.state
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
    assert run.state == NavigatorState.SUCCEEDED
    assert np.max(np.abs(run.poses[:, 1] - START.y)) < 0.02
    assert nav.plan.shape[1] == 2 and sum(run.recoveries.values()) == 0


@pytest.mark.parametrize("goal_yaw_rad", [math.pi / 2, -2.5])
def test_with_a_yaw_tolerance_the_robot_turns_to_the_goal_yaw_in_place(goal_yaw_rad: float) -> None:
    goal = Pose2D(GOAL.x, GOAL.y, goal_yaw_rad)
    config = NavigatorConfig(yaw_goal_tolerance_rad=0.25)
    run, nav = run_course(cylinder=None, config=config, goal=goal, t_max_s=30.0)
    assert run.state == NavigatorState.SUCCEEDED
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


def test_with_the_planner_server_a_blocked_path_is_followed_until_its_detour_comes() -> None:
    # plan_delay_ticks 2: the blocked path stays the one followed (no stop) for the two ticks
    # the detour takes, and the detour replaces it however it is priced
    nav = Navigator(NavigatorConfig(plan_delay_ticks=2), corridor_map(), LimiterConfig())
    nav.set_goal(GOAL)
    world = Obstacles(segments=WALLS)
    rng = np.random.default_rng(0)
    states = [nav.step(0.0, START, (0.0, 0.0), scan_points(START, world, rng, 0.0)).state]
    states += [nav.step(t, START, (0.0, 0.0), None).state for t in (0.05, 0.10)]
    assert states == [NavigatorState.PLANNING, NavigatorState.PLANNING, NavigatorState.FOLLOWING]
    straight = nav.plan
    assert nav.replans == 1 and np.max(np.abs(straight[:, 1] - START.y)) < 0.02
    world.add_circle(*CYLINDER)
    for k, t in enumerate((0.15, 0.20)):  # asked for at 0.15 s, taken at 0.25 s
        scan = scan_points(START, world, rng, 0.0) if k == 0 else None
        cmd = nav.step(t, START, (0.0, 0.0), scan)
        assert cmd.state == NavigatorState.FOLLOWING and np.array_equal(nav.plan, straight)
    nav.step(0.25, START, (0.0, 0.0), None)
    detour = nav.plan
    assert nav.replans == 2 and not np.array_equal(detour, straight)
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
        if cmd.state == NavigatorState.FAILED:
            break
        t += DT_S
    assert cmd.state == NavigatorState.FAILED
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
    assert cmd.state == NavigatorState.FAILED
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
