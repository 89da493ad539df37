"""Costmaps: Nav2's cost values and inflation, marking and clearing from scans, the rolling
window, and the collision test against the robot's disc and envelope."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from jackson.host.nav.costmap import (
    ENVELOPE_X_M,
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap,
    CostmapConfig,
    inflation_cost,
    occupancy_from_costs,
)
from jackson.host.nav.grid import OccupancyGrid

RES = 0.05


def ring(radius_m: float, centre: tuple[float, float] = (0.0, 0.0), n: int = 1080) -> np.ndarray:
    """Scan returns on a circle around the sensor."""
    a = np.linspace(-math.pi, math.pi, n, endpoint=False)
    return np.column_stack((centre[0] + radius_m * np.cos(a), centre[1] + radius_m * np.sin(a)))


def test_inflation_follows_the_nav2_formula_at_chosen_distances() -> None:
    d = np.array([0.0, 0.05, 0.16, 0.17, 0.20, 0.2236, 0.25, 0.2501, 1.0])
    expected = [254, 253, 253]
    expected += [math.floor(252.0 * math.exp(-10.0 * (x - 0.16))) for x in d[3:7]]
    expected += [0, 0]
    got = inflation_cost(
        d, inscribed_radius_m=0.16, inflation_radius_m=0.25, cost_scaling_factor=10
    )
    assert got.tolist() == expected
    assert expected[3:7] == [228, 168, 133, 102]  # the band between 0.16 m and 0.25 m


def test_a_lethal_cell_inflates_by_the_distance_between_cell_centres() -> None:
    grid = OccupancyGrid.empty(2.0, 2.0, RES, fill=0)
    grid.data[20, 20] = 100
    cm = Costmap.from_map(grid, CostmapConfig())
    assert cm.costs[20, 20] == LETHAL_OBSTACLE
    for cells in range(1, 8):  # along a row, so the distance is cells x RES
        d = cells * RES
        want = inflation_cost([d], 0.16, 0.25, 10.0)[0]
        assert cm.costs[20, 20 + cells] == want, cells
    assert cm.costs[20, 23] == INSCRIBED_INFLATED_OBSTACLE  # 0.15 m: inside the robot radius
    assert cm.costs[20, 24] == 168  # 0.20 m
    assert cm.costs[20, 26] == FREE_SPACE  # 0.30 m: beyond the inflation radius
    diag = math.hypot(3, 3) * RES  # 0.212 m
    assert cm.costs[23, 23] == math.floor(252.0 * math.exp(-10.0 * (diag - 0.16)))


def test_unknown_space_is_kept_or_freed_by_the_flag() -> None:
    grid = OccupancyGrid.empty(2.0, 1.0, RES, fill=-1)
    grid.data[:, :20] = 0
    grid.data[10, 19] = 100
    tracked = Costmap.from_map(grid, CostmapConfig(track_unknown_space=True))
    freed = Costmap.from_map(grid, CostmapConfig(track_unknown_space=False))
    assert tracked.costs[5, 35] == NO_INFORMATION
    assert freed.costs[5, 35] == FREE_SPACE
    # unknown next to the wall is raised only to inscribed, never to an inflated cost
    assert tracked.costs[10, 20] == INSCRIBED_INFLATED_OBSTACLE
    assert tracked.costs[10, 23] == NO_INFORMATION
    assert freed.costs[10, 23] == 168  # 0.20 m


def test_a_scan_marks_its_returns_and_clears_the_rays_to_them() -> None:
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)  # 3 m x 3 m at 0.05 m
    cm.update(ring(1.0), (0.0, 0.0))
    assert np.all(cm.cost_at(*ring(1.0).T) == LETHAL_OBSTACLE)
    assert np.all(cm.obstacle_layer[cm.world_to_cell(*ring(0.6).T)] == FREE_SPACE)
    # the obstacle moves away: the next scan's rays clear the old ring, mark the new one
    cm.update(ring(1.3), (0.0, 0.0))
    assert np.all(cm.cost_at(*ring(1.3).T) == LETHAL_OBSTACLE)
    assert np.all(cm.obstacle_layer[cm.world_to_cell(*ring(1.0).T)] == FREE_SPACE)
    assert np.all(cm.cost_at(*ring(1.0).T) < INSCRIBED_INFLATED_OBSTACLE)


def test_returns_beyond_the_obstacle_range_clear_but_do_not_mark() -> None:
    cfg = CostmapConfig(obstacle_max_range_m=1.0, raytrace_max_range_m=3.0)
    cm = Costmap.rolling_window(cfg, 0.0, 0.0, size_m=4.0)
    cm.update(np.array([[0.8, 0.0]]), (0.0, 0.0))
    assert cm.cost_at(0.8, 0.0) == LETHAL_OBSTACLE
    cm.update(np.array([[1.5, 0.0]]), (0.0, 0.0))  # beyond 1 m: the ray clears 0.8 m
    assert cm.cost_at(1.5, 0.0) != LETHAL_OBSTACLE
    assert cm.cost_at(0.8, 0.0) == FREE_SPACE


def test_scans_never_clear_the_static_map() -> None:
    grid = OccupancyGrid.empty(3.0, 1.0, RES, origin_x_m=-1.5, origin_y_m=-0.5, fill=0)
    grid.data[:, 40] = 100  # a wall at x = 0.5 m
    cm = Costmap.from_map(grid, CostmapConfig())
    cm.update(np.array([[1.2, 0.0]]), (0.0, 0.0))  # a return seen through the wall
    assert cm.cost_at(0.52, 0.0) == LETHAL_OBSTACLE
    assert cm.cost_at(1.2, 0.0) == LETHAL_OBSTACLE


def test_a_new_static_map_holds_a_wall_the_scans_cleared() -> None:
    """Mapping as it goes: the planner's costmap starts blank and only scans mark it, so a
    beam that passes through a partition's cell clears it again; the mapper's map taken into
    the static layer holds the partition, and the scans' marks stay."""
    blank = OccupancyGrid.empty(3.0, 1.0, RES, origin_x_m=-1.5, origin_y_m=-0.5, fill=-1)
    cm = Costmap.from_map(blank, CostmapConfig(track_unknown_space=False))
    cm.update(np.array([[0.5, 0.0], [-1.0, 0.2]]), (0.0, 0.0))
    assert cm.cost_at(0.5, 0.0) == LETHAL_OBSTACLE
    cm.update(np.array([[1.2, 0.0]]), (0.0, 0.0))  # a beam beside the partition's end
    assert cm.cost_at(0.5, 0.0) == FREE_SPACE
    mapped = OccupancyGrid.empty(2.0, 1.0, RES, origin_x_m=-0.55, origin_y_m=-0.5, fill=0)
    mapped.data[:, 21] = 100  # the partition at x = 0.5 m, on the mapper's own grid
    version = cm.version
    cm.set_static_map(mapped)
    assert cm.version > version
    assert cm.cost_at(0.52, 0.0) == LETHAL_OBSTACLE
    assert cm.cost_at(-1.0, 0.2) == LETHAL_OBSTACLE  # the scan's mark, off the new map, stays
    cm.update(np.array([[1.2, 0.0]]), (0.0, 0.0))
    assert cm.cost_at(0.52, 0.0) == LETHAL_OBSTACLE  # scans no longer clear it
    cm.set_static_map(None)
    assert cm.cost_at(0.52, 0.0) == FREE_SPACE  # the ray cleared it in the obstacle layer


def test_the_rolling_window_keeps_what_it_saw_while_it_moves() -> None:
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    cm.update(np.array([[0.7, 0.3]]), (0.0, 0.0))
    cm.recentre(0.5, -0.2)
    assert cm.origin_x_m == pytest.approx(0.5 - 1.5) and cm.origin_y_m == pytest.approx(-1.7)
    assert cm.cost_at(0.7, 0.3) == LETHAL_OBSTACLE
    cm.recentre(3.0, 0.0)  # the point leaves the window
    assert cm.cost_at(0.7, 0.3) == NO_INFORMATION  # off the grid
    cm.recentre(0.0, 0.0)
    assert cm.cost_at(0.7, 0.3) == FREE_SPACE  # forgotten, unknown counts as free here


@pytest.mark.parametrize(
    "jump", [(3.0, 0.0), (0.0, -3.0), (-7.3, 12.4), (25.0, -25.0), (1.5, 2.95)]
)
def test_the_rolling_window_follows_a_jump_of_any_size(jump: tuple[float, float]) -> None:
    """A window made at the map's centre follows a robot standing anywhere (a far start)."""
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    cm.update(np.array([[0.7, 0.3]]), (0.0, 0.0))
    x, y = jump
    cm.recentre(x, y)
    assert cm.origin_x_m == pytest.approx(math.floor((x - 1.5) / RES) * RES)
    assert cm.origin_y_m == pytest.approx(math.floor((y - 1.5) / RES) * RES)
    assert cm.cost_at(x, y) == FREE_SPACE
    cm.update(np.array([[x + 0.6, y]]), (x, y))
    assert cm.cost_at(x + 0.6, y) == LETHAL_OBSTACLE
    assert cm.cost_at(x + 0.3, y) == FREE_SPACE


def test_a_window_recentred_for_a_scan_combines_once_to_the_same_costs() -> None:
    """recentre(..., scan_follows=True) then update: the costs, distances and collision
    answers of recentre then update, combined once instead of twice."""
    rng = np.random.default_rng(4)
    windows = [Costmap.rolling_window(CostmapConfig(), 0.0, 0.0) for _ in range(2)]
    x = y = 0.0
    for _ in range(40):
        x, y = x + rng.uniform(-0.12, 0.12), y + rng.uniform(-0.12, 0.12)
        a = rng.uniform(0.0, 2.0 * math.pi, 60)
        r = rng.uniform(0.2, 1.4, 60)
        scan = np.column_stack((x + r * np.cos(a), y + r * np.sin(a)))
        versions = []
        for cm, deferred in zip(windows, (False, True), strict=True):
            cm.recentre(x, y, scan_follows=deferred)
            cm.update(scan, (x, y))
            versions.append(cm.version)
        old, new = windows
        assert np.array_equal(old.costs, new.costs)
        assert np.array_equal(old.lethal_distance_m, new.lethal_distance_m)
        assert (old.origin_x_m, old.origin_y_m) == (new.origin_x_m, new.origin_y_m)
        px, py = x + rng.uniform(-1.0, 1.0, 200), y + rng.uniform(-1.0, 1.0, 200)
        yaw = rng.uniform(-math.pi, math.pi, 200)
        assert np.array_equal(
            old.footprint_collides(px, py, yaw), new.footprint_collides(px, py, yaw)
        )
    assert versions[1] < versions[0]  # combined fewer times


def test_clearing_forgets_the_scans_but_keeps_the_map() -> None:
    grid = OccupancyGrid.empty(2.0, 2.0, RES, origin_x_m=-1.0, origin_y_m=-1.0, fill=0)
    grid.data[0, :] = 100
    cm = Costmap.from_map(grid, CostmapConfig())
    cm.update(np.array([[0.5, 0.5]]), (0.0, 0.0))
    cm.clear_obstacles()
    assert cm.cost_at(0.5, 0.5) == FREE_SPACE
    assert cm.cost_at(0.0, -0.98) == LETHAL_OBSTACLE


def test_collisions_use_the_oriented_envelope_and_the_robot_disc() -> None:
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    cm.update(np.array([[0.13, 0.13]]), (0.0, 0.0))  # 0.184 m away, at 45 degrees
    # square to the axes the point lies inside the envelope (corners reach 0.191 m) ...
    assert cm.footprint_collides(0.0, 0.0, 0.0)
    # ... turned 45 degrees it lies 0.184 m straight ahead: beyond the 0.135 m front and
    # beyond the 0.16 m disc
    assert not cm.footprint_collides(0.0, 0.0, math.pi / 4)
    # any heading collides once the disc of 0.16 m reaches it
    far = ENVELOPE_X_M[1] + 0.02
    cm2 = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    cm2.update(np.array([[far, 0.0]]), (0.0, 0.0))
    assert np.all(cm2.footprint_collides(0.0, 0.0, np.linspace(-math.pi, math.pi, 16)))


def test_a_robot_touching_an_obstacle_may_move_away_but_not_closer() -> None:
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    cm.update(np.array([[0.15, 0.0]]), (0.0, 0.0))  # inside the 0.16 m disc already
    s = np.linspace(0.0, 0.2, 9)
    away = (-s[None, :], np.zeros((1, 9)), np.zeros((1, 9)))
    closer = (0.5 * s[None, :] * 0.1, np.zeros((1, 9)), np.zeros((1, 9)))
    assert not cm.trajectories_collide(*away)[0]
    assert cm.trajectories_collide(*closer)[0]
    assert cm.trajectories_collide(*away, escape=False)[0]


def test_costs_publish_as_nav2_occupancy_values() -> None:
    costs = np.array([0, 1, 128, 252, 253, 254, 255], np.uint8)
    assert occupancy_from_costs(costs).tolist() == [0, 1, 50, 98, 99, 100, -1]


def test_bad_configs_are_refused_with_the_field_named() -> None:
    with pytest.raises(ValueError, match="inflation_radius_m"):
        CostmapConfig(robot_radius_m=0.3, inflation_radius_m=0.25)
    with pytest.raises(ValueError, match="footprint_x_m"):
        CostmapConfig(footprint_x_m=(0.1, 0.2))
    with pytest.raises(ValueError, match="obstacle_max_range_m"):
        CostmapConfig(obstacle_max_range_m=0.0)


def test_a_scan_updates_a_costmap_well_within_a_scan_period() -> None:
    grid = OccupancyGrid.empty(4.0, 3.0, RES, origin_x_m=-2.0, origin_y_m=-1.5, fill=0)
    grid.data[[0, -1], :] = 100
    grid.data[:, [0, -1]] = 100
    global_cm = Costmap.from_map(grid, CostmapConfig(track_unknown_space=True))
    local_cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
    scan = np.vstack((ring(1.4)[::2], ring(0.4, (0.8, 0.0))[::4]))  # 540 + 270 returns
    timings = {}
    for name, cm in (("global 4 m x 3 m", global_cm), ("local 3 m x 3 m", local_cm)):
        t0 = time.perf_counter()
        for _ in range(10):
            cm.update(scan, (0.0, 0.0))
        timings[name] = (time.perf_counter() - t0) / 10 * 1e3
    print("costmap update per scan: " + ", ".join(f"{k} {v:.2f} ms" for k, v in timings.items()))
    assert max(timings.values()) < 134.65  # the A1M8's scan period


def test_a_planning_costmap_reinflates_only_around_the_scan_and_gets_the_same_costs() -> None:
    """Without collision tables a scan re-inflates the part of the grid it can change; on a
    20 m map every cost equals that of a full re-inflation, scan after scan."""
    g = OccupancyGrid.empty(20.0, 16.0, RES, origin_x_m=-1.0, origin_y_m=-2.0, fill=-1)
    g.data[: g.height // 2, :] = 0
    g.data[::40, :] = 100
    cfg = CostmapConfig(track_unknown_space=True)
    full = Costmap.from_map(g, cfg)
    windowed = Costmap.from_map(g, cfg, collision_checks=False)
    rng = np.random.default_rng(1)
    for _ in range(12):
        centre = (float(rng.uniform(-1.0, 19.0)), float(rng.uniform(-2.0, 14.0)))
        a = np.linspace(-math.pi, math.pi, 1080, endpoint=False)
        r = rng.uniform(0.2, 4.0, a.size)
        points = np.column_stack((centre[0] + r * np.cos(a), centre[1] + r * np.sin(a)))
        full.update(points, centre)
        version = windowed.version
        windowed.update(points, centre)
        assert windowed.version == version + 1
        assert np.array_equal(windowed.costs, full.costs)
        near = full.lethal_distance_m <= cfg.inflation_radius_m
        assert np.array_equal(windowed.lethal_distance_m[near], full.lethal_distance_m[near])
        assert np.all(np.isinf(windowed.lethal_distance_m[~near]))


@pytest.mark.parametrize("shape", ["corridor", "sector", "far", "off_grid", "one_return"])
def test_a_scan_reinflates_only_the_box_of_its_rays_and_gets_the_same_costs(shape: str) -> None:
    """The part re-inflated is the box of the scan's rays (a strip in a corridor, a corner for
    a sector, the ranges' square for returns beyond them): every cost still equals that of a
    full re-inflation."""
    g = OccupancyGrid.empty(20.0, 16.0, RES, origin_x_m=-1.0, origin_y_m=-2.0, fill=-1)
    g.data[: g.height // 2, :] = 0
    g.data[::40, :] = 100
    g.data[:, ::60] = 100
    cfg = CostmapConfig(track_unknown_space=True)
    full = Costmap.from_map(g, cfg)
    windowed = Costmap.from_map(g, cfg, collision_checks=False)
    rng = np.random.default_rng(len(shape))
    for _ in range(10):
        centre = (float(rng.uniform(1.0, 17.0)), float(rng.uniform(0.0, 12.0)))
        a = np.linspace(-math.pi, math.pi, 720, endpoint=False)
        r = rng.uniform(0.2, 4.0, a.size)
        if shape == "corridor":  # walls 0.8 m either side, open ends 6-9 m away
            r = np.minimum(0.8 / np.maximum(np.abs(np.sin(a)), 1e-3), rng.uniform(6.0, 9.0))
        elif shape == "sector":
            a, r = a[(a > 0.3) & (a < 1.2)], r[(a > 0.3) & (a < 1.2)]
        elif shape == "far":
            r = rng.uniform(3.5, 12.0, a.size)
        elif shape == "off_grid":
            centre = (float(rng.choice([-2.5, 21.0])), float(rng.uniform(-3.0, 15.0)))
        else:
            a, r = a[:1], r[:1]
        points = np.column_stack((centre[0] + r * np.cos(a), centre[1] + r * np.sin(a)))
        full.update(points, centre)
        windowed.update(points, centre)
        assert np.array_equal(windowed.costs, full.costs)
        near = full.lethal_distance_m <= cfg.inflation_radius_m
        assert np.array_equal(windowed.lethal_distance_m[near], full.lethal_distance_m[near])
        assert np.all(np.isinf(windowed.lethal_distance_m[~near]))


def test_clearing_beyond_a_range_keeps_the_obstacles_near_the_robot() -> None:
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0, size_m=10.0)
    cm.update(np.array([[1.0, 0.0], [2.4, 0.0]]), (0.0, 0.0))
    cm.recentre(-2.0, 0.0)
    cm.clear_obstacles(3.5, (-2.0, 0.0))
    assert cm.cost_at(1.0, 0.0) == LETHAL_OBSTACLE  # 3.0 m from the robot: kept
    assert cm.cost_at(2.4, 0.0) == FREE_SPACE  # 4.4 m: forgotten


def test_a_pickled_costmap_updates_as_the_original_does() -> None:
    """``costs`` is a view of the padded grid that a small update writes in place; a pickle (a
    run folder's snapshot of the core) copied it apart, so a restored global costmap's costs
    went stale and its replay differed from the run."""
    import pickle

    grid = OccupancyGrid.empty(20.0, 20.0, RES, -10.0, -10.0, FREE_SPACE)
    live = Costmap.from_map(grid, CostmapConfig(), collision_checks=False)
    live.update(ring(1.0), (0.0, 0.0))
    restored = pickle.loads(pickle.dumps(live))
    post = np.array([[2.0, 0.0], [2.02, 0.05], [2.0, 0.1]])  # a small change: updated in place
    for cm in (live, restored):
        cm.update(post, (0.0, 0.0))
    assert np.shares_memory(restored.costs, restored._costs_2d)
    assert np.array_equal(restored.costs, live.costs)
    assert np.array_equal(restored.cost_at(*post.T), live.cost_at(*post.T))


@pytest.mark.xfail(
    strict=True,
    reason="known: the escape rule counts obstacles, so a corner turned into a wall whose "
    "obstacles the disc already overlaps is not caught (docs/stage3.md, DWB)",
)
def test_a_robot_whose_disc_overlaps_a_wall_cannot_turn_a_corner_into_it() -> None:
    """16.8 cm from a wall, turned 9 degrees towards it: the disc (0.16 m) overlaps the wall's
    obstacles, so the escape rule applies. Turning 30 degrees further towards the wall puts
    the front corner 2 cm into it and should collide."""
    from jackson.host.nav.types import Pose2D
    from jackson.sim.lidar import Obstacles

    from ..stage3_course import scan_points

    wall_x = 1.813
    pose = (wall_x - 0.168, 4.0, math.pi / 2 - math.radians(9.0))
    cm = Costmap.rolling_window(CostmapConfig(), pose[0], pose[1])
    world = Obstacles(segments=((wall_x, 0.0, wall_x, 8.0),))
    rng = np.random.default_rng(0)
    for _ in range(5):
        cm.update(scan_points(Pose2D(*pose), world, rng, 0.01), pose[:2])
    assert cm.checker.footprint_hits(*(np.array([v]) for v in pose), True)[0][0] > 0  # escaping
    turn = np.linspace(0.0, math.radians(30.0), 13)
    x, y = np.full((1, 13), pose[0]), np.full((1, 13), pose[1])
    assert cm.trajectories_collide(x, y, (pose[2] - turn)[None])[0]
