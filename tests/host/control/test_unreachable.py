"""A goal the robot cannot reach is a state: the navigator stops, lets its scans confirm the
block, names it and fails, instead of clearing what it saw and planning through it again.
Goals and starts are checked against the map before anything moves."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.navigator import (
    Navigator,
    NavigatorConfig,
    NavigatorState,
    RouteError,
    check_route,
)
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.types import Pose2D
from jackson.sim.lidar import A1M8_ANGLE_INCREMENT_RAD, A1M8_BEAMS, Obstacles, cast

RES = 0.05
DT_S = 0.05  # [s] the control period
SCAN_PERIOD_S = 0.13465  # [s] RPLIDAR A1M8
# a corridor 10 m long and 1.6 m wide, open on the map from end to end
X0, X1, Y0, Y1 = 0.0, 10.0, -0.8, 0.8
WALLS = ((X0, Y0, X1, Y0), (X1, Y0, X1, Y1), (X1, Y1, X0, Y1), (X0, Y1, X0, Y0))
START = Pose2D(0.5, 0.0, 0.0)
GOAL = Pose2D(9.5, 0.0, 0.0)


def corridor_map() -> OccupancyGrid:
    """The corridor free, its walls occupied, outside unknown."""
    g = OccupancyGrid.empty(10.4, 2.0, RES, origin_x_m=-0.2, origin_y_m=-1.0, fill=-1)
    rows, cols = np.mgrid[0 : g.height, 0 : g.width]
    x, y = g.cell_to_world(rows, cols)
    g.data[(x > X0) & (x < X1) & (y > Y0) & (y < Y1)] = 0
    s = np.linspace(0.0, 1.0, 2000)
    for x1, y1, x2, y2 in WALLS:
        r, c = g.world_to_cell(x1 + s * (x2 - x1), y1 + s * (y2 - y1))
        g.data[r, c] = 100
    return g


def scan(pose: Pose2D, world: Obstacles) -> np.ndarray:
    """One noiseless A1M8 revolution from ``pose`` as map-frame points."""
    angles = -math.pi + A1M8_ANGLE_INCREMENT_RAD * np.arange(A1M8_BEAMS) + pose.yaw
    r = cast((pose.x, pose.y), angles, world, 8.0)
    ok = np.isfinite(r) & (r >= 0.15)
    return np.column_stack(
        (pose.x + r[ok] * np.cos(angles[ok]), pose.y + r[ok] * np.sin(angles[ok]))
    )


def test_a_goal_cut_off_by_an_obstacle_in_view_fails_as_unreachable_within_seconds() -> None:
    """A barrier across the corridor 1.5 m ahead: the robot never moves, no recovery runs,
    the scans confirm the block for 2 s and the goal fails naming where it is blocked."""
    world = Obstacles(segments=(*WALLS, (2.0, Y0, 2.0, Y1)))
    nav = Navigator(NavigatorConfig(), corridor_map(), LimiterConfig())
    nav.set_goal(GOAL)
    t, next_scan, commands = 0.0, 0.0, []
    while t < 30.0:
        points = None
        if t >= next_scan:
            points = scan(START, world)
            next_scan += SCAN_PERIOD_S
        cmd = nav.step(t, START, (0.0, 0.0), points)
        commands.append((cmd.v_m_s, cmd.w_rad_s))
        if cmd.state == NavigatorState.FAILED:
            break
        t += DT_S
    assert cmd.state == NavigatorState.FAILED
    assert cmd.reason.startswith("goal (9.50, 0.00) unreachable: blocked at (")
    assert nav.blocked_at is not None
    bx, by = nav.blocked_at
    assert 2.0 - 0.25 - 2 * RES <= bx <= 2.0 and abs(by) < 0.8
    assert 2.0 <= t <= 2.0 + 2 * SCAN_PERIOD_S  # the confirmation, not a loop of recoveries
    assert set(commands) == {(0.0, 0.0)}
    assert sum(nav.recoveries.values()) == 0 and nav.replans == 0


def test_an_obstacle_remembered_out_of_view_is_looked_at_again_not_trusted() -> None:
    """A barrier seen up close that has gone since: from 4 m away the scans cannot clear it,
    so the navigator forgets what lies beyond their clearing range and plans again."""
    barrier = Obstacles(segments=(*WALLS, (5.0, Y0, 5.0, Y1)))
    nav = Navigator(NavigatorConfig(), corridor_map(), LimiterConfig())
    near = Pose2D(4.0, 0.0, 0.0)
    nav.set_goal(GOAL)
    nav.step(0.0, near, (0.0, 0.0), scan(near, barrier))  # sees it 1 m ahead ...
    nav.step(0.05, near, (0.0, 0.0), None)  # ... and plans on the next tick: no path
    assert nav.state == NavigatorState.PLANNING and nav.blocked_at is not None
    back = Pose2D(0.8, 0.0, 0.0)  # the robot is carried back; the barrier is taken away
    open_world = Obstacles(segments=WALLS)
    nav.set_goal(GOAL)
    nav.step(0.1, back, (0.0, 0.0), scan(back, open_world))
    cmd = nav.step(0.15, back, (0.0, 0.0), None)
    assert cmd.state == NavigatorState.FOLLOWING, cmd.reason
    path = nav.plan
    assert path[-1, 0] == pytest.approx(GOAL.x) and nav.replans == 1


def test_the_clear_costmaps_recovery_keeps_the_obstacles_in_view() -> None:
    world = Obstacles(segments=(*WALLS, (2.0, Y0, 2.0, Y1)))
    nav = Navigator(NavigatorConfig(), corridor_map(), LimiterConfig())
    nav.set_goal(GOAL)
    nav.step(0.0, START, (0.0, 0.0), scan(START, world))
    assert nav.global_costmap.cost_at(2.0, 0.0) >= 253
    nav._begin_recovery(0.05, START, "test")
    nav.step(0.1, START, (0.0, 0.0), None)
    assert nav.recoveries["clear_costmaps"] == 1
    assert nav.global_costmap.cost_at(2.0, 0.0) >= 253  # 1.5 m away: still there


@pytest.mark.parametrize(
    ("goal", "problem"),
    [
        (Pose2D(5.0, 0.8), "in an obstacle of the map"),
        (Pose2D(5.0, 0.7), "within the robot's radius"),
        (Pose2D(5.0, 3.0), "outside the map"),
        (Pose2D(5.0, -0.95), "in unknown space of the map"),
    ],
)
def test_a_goal_on_a_wall_off_the_map_or_in_unknown_space_is_refused(
    goal: Pose2D, problem: str
) -> None:
    with pytest.raises(RouteError, match=problem) as info:
        check_route(corridor_map(), START, (Pose2D(9.0, 0.0), goal), NavigatorConfig())
    assert str(info.value).startswith(f"goal 2 ({goal.x:.2f}, {goal.y:.2f}) is ")
    assert "\n" not in str(info.value)


def test_a_goal_in_a_closed_room_is_refused_and_a_free_one_accepted() -> None:
    g = corridor_map()
    rows, cols = np.mgrid[0 : g.height, 0 : g.width]
    x, y = g.cell_to_world(rows, cols)
    box = (np.abs(x - 7.0) <= 0.3) & (np.abs(y) <= 0.3)
    inside = (np.abs(x - 7.0) < 0.25) & (np.abs(y) < 0.25)
    g.data[box & ~inside] = 100  # a closed box, its inside seen free
    with pytest.raises(RouteError, match="cannot be reached from the start on the map"):
        check_route(g, START, (Pose2D(7.0, 0.0),), NavigatorConfig())
    check_route(g, START, (GOAL,), NavigatorConfig())  # around the box: fine


def test_a_start_on_an_obstacle_is_refused() -> None:
    with pytest.raises(RouteError, match=r"^start \(0\.00, 0\.00\) is in an obstacle"):
        check_route(corridor_map(), Pose2D(0.0, 0.0), (GOAL,), NavigatorConfig())
