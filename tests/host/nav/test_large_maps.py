"""A 50 m x 50 m floor at 0.05 m with the robot in a corner, far from the map's centre: the
navigator plans through it and steps on it, the particle filter localises on it, and mapping
without a map starts where the robot stands."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from jackson.host.actuation.limiter import LimiterConfig
from jackson.host.control.navigator import Navigator, NavigatorConfig, NavigatorState
from jackson.host.nav.amcl import AmclConfig, ParticleFilter
from jackson.host.nav.grid import BYTES_PER_CELL, MAX_CELLS, MapFileError, OccupancyGrid
from jackson.host.nav.slam.mapper import Mapper, MappingConfig
from jackson.host.nav.types import Pose2D, Scan
from jackson.sim.lidar import A1M8_ANGLE_INCREMENT_RAD, A1M8_BEAMS, Obstacles, cast

SIZE_M = 50.0
RES = 0.05


@pytest.fixture(scope="module")
def floor() -> tuple[OccupancyGrid, Obstacles]:
    """A serpentine: nine walls across the floor, each open at one end in turn."""
    walls = [(0.0, 0.0, SIZE_M, 0.0), (SIZE_M, 0.0, SIZE_M, SIZE_M)]
    walls += [(SIZE_M, SIZE_M, 0.0, SIZE_M), (0.0, SIZE_M, 0.0, 0.0)]
    for k in range(1, 10):
        walls.append(
            (5.0 * k, 0.0, 5.0 * k, SIZE_M - 3.0) if k % 2 else (5.0 * k, 3.0, 5.0 * k, SIZE_M)
        )
    g = OccupancyGrid.empty(SIZE_M, SIZE_M, RES, fill=0)
    s = np.linspace(0.0, 1.0, 4000)
    for x1, y1, x2, y2 in walls:
        r, c = g.world_to_cell(x1 + s * (x2 - x1), y1 + s * (y2 - y1))
        g.data[np.clip(r, 0, g.height - 1), np.clip(c, 0, g.width - 1)] = 100
    return g, Obstacles(segments=walls)


def scan_from(pose: Pose2D, world: Obstacles, t_s: float = 0.0) -> Scan:
    angles = -math.pi + A1M8_ANGLE_INCREMENT_RAD * np.arange(A1M8_BEAMS)
    r = cast((pose.x, pose.y), angles + pose.yaw, world, 8.0)
    return Scan(t_s, angles, np.where(np.isfinite(r), r, np.inf))


def test_the_navigator_plans_through_a_50_m_floor_from_its_corner(
    floor: tuple[OccupancyGrid, Obstacles],
) -> None:
    grid, world = floor
    nav = Navigator(NavigatorConfig(), grid, LimiterConfig())
    start = Pose2D(47.5, 2.0, math.pi / 2)  # 32 m from the map's centre
    nav.set_goal(Pose2D(2.5, 47.0))
    points = scan_from(start, world).points(start)
    for k in range(4):
        cmd = nav.step(0.05 * k, start, (0.0, 0.0), points if k == 0 else None)
    assert cmd.state == NavigatorState.FOLLOWING, cmd.reason
    path = nav.plan
    assert float(np.hypot(*np.diff(path, axis=0).T).sum()) > 9 * 45.0  # it winds through all
    lo, hi = nav.local_costmap.origin_x_m, nav.local_costmap.origin_x_m + 3.0
    assert lo < start.x < hi  # the local window came along to the corner
    assert cmd.v_m_s >= 0.0 and abs(cmd.w_rad_s) > 0.0  # turning onto the path


def test_the_particle_filter_localises_on_a_50_m_floor_as_on_a_piece_of_it(
    floor: tuple[OccupancyGrid, Obstacles],
) -> None:
    """The same drive up a lane, on the whole floor and on a crop of what its scans reach: the
    map's size changes nothing the filter does."""
    grid, world = floor
    r0, c0 = 680, 660  # the crop: x 33-50 m, y 34-50 m, all the scans reach
    crop = OccupancyGrid(grid.data[r0:, c0:].copy(), RES, c0 * RES, r0 * RES)
    estimates = []
    for g in (grid, crop):
        pf = ParticleFilter(g, AmclConfig(), np.random.default_rng(1))
        start = Pose2D(42.0, 43.0, math.pi / 2)  # driving up a lane towards its end wall
        pf.initialise(start)
        for k in range(20):
            pose = Pose2D(start.x, start.y + 0.06 * k, start.yaw)
            pf.update(pose, scan_from(pose, world, 0.2 * k))
        estimates.append(pf.estimate())
    whole, piece = estimates
    assert math.hypot(whole.x - pose.x, whole.y - pose.y) < 0.15
    assert math.hypot(whole.x - piece.x, whole.y - piece.y) < 1e-9


def test_mapping_without_a_map_starts_where_the_robot_stands() -> None:
    world = Obstacles(segments=[(40.0, -45.0, 40.0, -35.0), (35.0, -36.0, 45.0, -36.0)])
    mapper = Mapper(MappingConfig(scan_matching=False, min_travel_m=0.0))
    pose = Pose2D(38.0, -40.0, 0.0)
    for _ in range(2):  # a cell is known once two scans saw it
        mapper.update(scan_from(pose, world), pose)
    g = mapper.grid()
    assert g.width * g.height < 400 * 400  # around the robot, not from the origin
    r, c = g.world_to_cell(40.02, -40.0)
    assert g.data[r, c] > 50


@pytest.mark.parametrize("side", [5000, 10000])
def test_a_map_over_what_navigation_holds_in_memory_is_refused_from_its_header(
    tmp_path: Path, side: int
) -> None:
    """A 5000 x 5000 map took ``jackson run maze`` past 4 GiB: refused before it is decoded,
    the limit and the memory a cell needs in the line."""
    (tmp_path / "big.pgm").write_bytes(f"P5\n{side} {side}\n255\n".encode() + b"\0")
    (tmp_path / "big.yaml").write_text(
        "image: big.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
        "free_thresh: 0.196\nnegate: 0\n"
    )
    with pytest.raises(MapFileError) as info:
        OccupancyGrid.load(tmp_path / "big.yaml")
    line = str(info.value)
    assert f"{side} x {side} pixels" in line and f"{MAX_CELLS:,} in all" in line
    assert f"{BYTES_PER_CELL} bytes of memory a cell" in line and "\n" not in line


def test_the_cell_limit_keeps_the_navigation_stack_under_2_gib() -> None:
    side = math.isqrt(MAX_CELLS)
    assert side * side <= MAX_CELLS
    assert BYTES_PER_CELL * MAX_CELLS < 2 * 2**30  # the navigation stack's peak under 2 GiB
