"""Beams end at walls, matches say how sure they are, and looks land later on larger graphs.

- A scan written at a pose that erred puts its returns behind a wall the earlier scans made:
  its beams cross the wall first, so they end there and write nothing behind it. Written again
  from scratch (after an optimisation, or when the map is saved) every scan is judged against
  all the walls, so a bad scan written before the wall was known is judged the same way.
- A match along a corridor with nothing to see along it fits the length of its window: its
  spread says so, and a loop closure that fits anywhere is refused.
- The look for a closure lands a share of the graph's size later on a large graph.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from jackson.host.nav.slam.graph import Edge, PoseGraph
from jackson.host.nav.slam.loops import LoopConfig, Node, close_loop
from jackson.host.nav.slam.mapper import Mapper, MappingConfig
from jackson.host.nav.slam.matcher import base_points, search
from jackson.host.nav.slam.occupancy import CountGrid
from jackson.host.nav.types import Pose2D, Scan
from jackson.sim.lidar import Obstacles

from .test_mapper import MOUNT, lidar, scan_at

WALL = Obstacles([[2.0, -3.0, 2.0, 3.0]])  # a wall 2 m ahead of the robot, 6 m long
ERRED = Pose2D(0.3, 0.0, 0.0)  # where a scan taken at the origin is written by mistake


def _cell(grid_data: np.ndarray, mapper_grid: object, x: float, y: float) -> int:
    row, col = mapper_grid.world_to_cell(x, y)  # type: ignore[attr-defined]
    return int(grid_data[row, col])


def _value(cells: CountGrid, x: float, y: float) -> int:
    grid = cells.grid()
    return _cell(grid.data, grid, x, y)


def test_returns_behind_a_wall_the_map_holds_are_not_written() -> None:
    sensor = lidar()
    for wall_hits, behind in ((3, -1), (0, 100)):
        cells = CountGrid(MappingConfig(wall_hits=wall_hits).insertion())
        for _ in range(5):
            cells.write(scan_at(sensor, Pose2D(), WALL), MOUNT)
        for _ in range(2):  # the same scan, written 0.3 m too far ahead: its wall at 2.3 m
            cells.write(scan_at(sensor, Pose2D(), WALL), ERRED.compose(MOUNT))
        assert _value(cells, 2.0, 0.0) == 100  # the wall stays
        assert _value(cells, 2.32, 0.0) == behind  # unknown: no beam passed the wall
        assert _value(cells, 2.17, 0.0) == (-1 if wall_hits else 0)


def test_written_again_a_scan_from_before_the_wall_is_judged_against_it() -> None:
    sensor = lidar()
    bad = [(scan_at(sensor, Pose2D(), WALL), ERRED.compose(MOUNT)) for _ in range(2)]
    good = [(scan_at(sensor, Pose2D(), WALL), MOUNT) for _ in range(5)]
    cells = CountGrid(MappingConfig().insertion())
    for scan, sensor_pose in bad + good:  # as they came: the bad ones before any wall
        cells.write(scan, sensor_pose)
    assert _value(cells, 2.32, 0.0) == 100
    cells.write_all(bad + good)
    assert _value(cells, 2.32, 0.0) == -1
    assert _value(cells, 2.0, 0.0) == 100


CORRIDOR = Obstacles([[-10.0, -0.6, 10.0, -0.6], [-10.0, 0.6, 10.0, 0.6]])
ROOM = Obstacles(
    [[-2.0, -1.5, 2.0, -1.5], [2.0, -1.5, 2.0, 1.5], [2.0, 1.5, -2.0, 1.5], [-2.0, 1.5, -2.0, -1.5]]
)


def _match_spread(world: Obstacles) -> tuple[float, float]:
    """The widest spread of a scan matched against the map of scans taken where it was, and
    the spread across the corridor (y)."""
    sensor = lidar()
    cells = CountGrid(MappingConfig().insertion())
    for _ in range(3):
        cells.write(scan_at(sensor, Pose2D(), world), MOUNT)
    bx, by = base_points(scan_at(sensor, Pose2D(), world), MOUNT, 8.0, 540)
    window = LoopConfig().window
    match = search(cells.match_field(None, 0.0), bx, by, Pose2D(0.02, -0.01, 0.01), window)
    assert match.pose.distance(Pose2D()) < 0.6
    return match.widest_m(), math.sqrt(match.spread[1, 1])


def test_a_match_along_a_featureless_corridor_spreads_along_it_and_a_room_does_not() -> None:
    along, across = _match_spread(CORRIDOR)
    assert along > 0.3 and across < 0.03  # the scan fits anywhere along the corridor
    widest, _ = _match_spread(ROOM)
    assert widest < 0.05  # the corners pin it: measured 0.038 (0.593 along the corridor)


def test_a_closure_that_fits_anywhere_along_a_corridor_is_refused() -> None:
    sensor = lidar()
    graph, nodes = PoseGraph(), []
    # out along the corridor and back: nodes 0.25 m apart, the way back 1 m off in x
    out = [Pose2D(0.25 * i - 3.0, 0.0, 0.0) for i in range(25)]
    back = [Pose2D(3.0 - 0.25 * i, 0.0, math.pi) for i in range(13)]
    travel = 0.0
    for i, truth in enumerate(out + back):
        believed = truth if i < len(out) else Pose2D(truth.x + 1.0, truth.y, truth.yaw)
        k = graph.add_node(believed)
        if k:
            travel += 0.25
            z = graph.pose(k - 1).inverse().compose(believed)
            graph.add_edge(Edge(k - 1, k, z, 0.01, 0.005))
        nodes.append(Node(scan_at(sensor, truth, CORRIDOR), MOUNT, believed, travel))
    k = len(nodes) - 1
    insertion = MappingConfig().insertion()
    assert close_loop(graph, nodes, k, LoopConfig(), insertion) is None
    anywhere = close_loop(graph, nodes, k, LoopConfig(max_spread_m=99.0), insertion)
    assert anywhere is not None  # it scores well: only its spread tells


@pytest.mark.parametrize(("nodes", "look_every"), [(100, 10), (1000, 50)])
def test_a_look_lands_a_share_of_the_graph_later(nodes: int, look_every: int) -> None:
    mapper = Mapper(MappingConfig(scan_matching=False, min_travel_m=0.0, min_heading_rad=0.0))
    angles = np.linspace(-math.pi, math.pi, 36, endpoint=False)
    gaps = []
    for i in range(nodes + 3 * look_every):
        before = mapper.next_look
        mapper.update(Scan(0.1 * i, angles, np.full(36, 2.0)), Pose2D(0.001 * i, 0.0, 0.0))
        if mapper.next_look != before:
            gaps.append((i, mapper.next_look - i))
    mapper.finish()
    later = [(k, gap) for k, gap in gaps if k >= nodes]
    assert later and all(gap == max(10, math.ceil(0.05 * k)) for k, gap in later)
    assert later[0][1] >= look_every
    assert gaps[0] == (10, 10)  # the first looks: every loop_every nodes


END = 2.0125  # a wall's east end, 1.25 cm into its cell
WALL_END = Obstacles([[0.0, 0.5, END, 0.5], [-1.0, -1.0, 4.0, -1.0]])


@pytest.mark.parametrize(("sigmas", "beside"), [(0.0, -1), (2.0, 0)])
def test_a_wall_cell_stops_only_the_beams_through_its_returns(sigmas: float, beside: int) -> None:
    # scans from above make the wall's end cell a wall, its returns only in its west quarter.
    # Beams from a sensor 3 cm east of the end pass the cell beside the wall: a wall cell that
    # stops every beam crossing it ends them there and nothing below is seen (unknown); one
    # that stops only the beams through its returns lets them by (free below, beside the end)
    sensor = lidar()
    above = [Pose2D(x, 1.5, -math.pi / 2) for x in np.linspace(0.3, 1.8, 16)]
    beside_end = [Pose2D(END + 0.03, 1.5, -math.pi / 2)] * 5  # its mount: 4 cm south
    cells = CountGrid(MappingConfig(wall_extent_sigmas=sigmas).insertion())
    cells.write_all([(scan_at(sensor, p, WALL_END), p.compose(MOUNT)) for p in above + beside_end])
    assert _value(cells, END - 0.005, 0.51) == 100  # the end cell is a wall either way
    assert [_value(cells, END + 0.02, y) for y in (0.2, -0.5)] == [beside, beside]
    assert _value(cells, 1.0, 0.0) == -1  # behind the wall itself: nothing passes


def test_with_wall_extents_returns_behind_a_wall_are_still_not_written() -> None:
    sensor = lidar()
    cells = CountGrid(MappingConfig(wall_extent_sigmas=2.0).insertion())
    for _ in range(5):
        cells.write(scan_at(sensor, Pose2D(), WALL), MOUNT)
    for _ in range(2):  # written 0.3 m too far ahead: these beams cross the wall's returns
        cells.write(scan_at(sensor, Pose2D(), WALL), ERRED.compose(MOUNT))
    assert _value(cells, 2.0, 0.0) == 100
    assert _value(cells, 2.32, 0.0) == -1
    assert _value(cells, 2.17, 0.0) == -1


@pytest.mark.parametrize(
    ("field", "value"), [("wall_extent_floor_m", 0.0), ("wall_extent_sigmas", -1.0)]
)
def test_a_wall_extent_setting_out_of_range_is_refused(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=f"MappingConfig.{field}: expected"):
        MappingConfig(**{field: value})
