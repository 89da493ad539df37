"""The DWB-style local planner: roll-outs, critics and the choice of a command, against a
target-by-target reference."""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np
import pytest

from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
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
    velocity_profile,
)
from jackson.host.nav.dwb.core.distance import DistanceMaps
from jackson.host.nav.dwb.core.path import plan_cells, plan_span
from jackson.host.nav.types import Pose2D
from jackson.sim.lidar import Obstacles

from ...stage3_course import CYLINDER, DT_S, GOAL, RES, START, WALLS, scan_points, unicycle


def straight_path(x0: float, x1: float, y: float = 0.0) -> np.ndarray:
    n = round((x1 - x0) / RES) + 1
    return np.column_stack((np.linspace(x0, x1, n), np.full(n, y)))


def drive(
    planner: DwbPlanner, pose: Pose2D, path: np.ndarray, goal: Pose2D, cm: Costmap, steps: int
):
    """Run the planner in closed loop for ``steps`` periods; the poses and commands (the
    velocity limited as the default limits the planner was given)."""
    limiter = VelocityLimiter(LimiterConfig())
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
    w_min = min(c.min_speed_theta_rad_s, planner.kinematics.max_vel_theta_rad_s)
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
    kin = planner.kinematics
    t = np.linspace(0.0, planner.config.sim_time_s, k + 1)
    dt = planner.config.sim_time_s / k
    vel = velocity_profile(velocity[0], np.array([v]), t, kin.acc_lim_x_m_s2, kin.decel_lim_x_m_s2)
    rot = velocity_profile(
        velocity[1], np.array([w]), t, kin.acc_lim_theta_rad_s2, kin.decel_lim_theta_rad_s2
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
    # every roll-out's legality tested, as the reference does, to compare the counts too
    config = DwbConfig(short_circuit_trajectory_evaluation=False)
    planner = DwbPlanner(config, LimiterConfig())
    reference = ReferenceDwb(DwbPlanner(config, LimiterConfig()))
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


@pytest.mark.parametrize("seed", range(4))
def test_the_short_circuit_chooses_what_testing_every_roll_out_chooses(seed: int) -> None:
    """Drives past walls and the cylinder from random starts, near obstacles and away from
    them: asking BaseObstacle only as far as the choice needs gives every command of testing
    every roll-out (speeds, total, scores, trajectory, reason), compiled and with numpy; its
    count of legal roll-outs is never below the full one."""
    from jackson.host.nav import native

    world = Obstacles(segments=WALLS)
    world.add_circle(*CYLINDER)
    rng = np.random.default_rng(40 + seed)
    full = DwbConfig(short_circuit_trajectory_evaluation=False)
    compiled = native.LIB is not None
    shortened = 0
    for case in range(12):
        pose = Pose2D(
            float(rng.uniform(-0.4, 1.2)), float(rng.uniform(-0.3, 0.3)),
            float(rng.uniform(-math.pi, math.pi)),
        )  # fmt: skip
        velocity = (float(rng.uniform(0.0, 0.3)), float(rng.uniform(-1.5, 1.5)))
        cm = Costmap.rolling_window(CostmapConfig(), pose.x, pose.y)
        cm.update(scan_points(pose, world, rng, 0.01), (pose.x, pose.y))
        if case % 3 == 2:
            cm.checker._native = None  # numpy's collision test
        path = straight_path(pose.x, GOAL.x, pose.y)
        a = DwbPlanner(DwbConfig(), LimiterConfig()).compute(pose, velocity, path, GOAL, cm)
        b = DwbPlanner(full, LimiterConfig()).compute(pose, velocity, path, GOAL, cm)
        assert (a.v_m_s, a.w_rad_s, a.total, a.valid, a.reason, a.samples) == (
            b.v_m_s, b.w_rad_s, b.total, b.valid, b.reason, b.samples,
        )  # fmt: skip
        assert a.scores == b.scores and np.array_equal(a.trajectory, b.trajectory)
        assert a.legal >= b.legal
        shortened += a.legal > b.legal
    assert shortened > 0 or not compiled  # some cycles did stop before the last roll-out


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
