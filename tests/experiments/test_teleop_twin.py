"""The scripted teleop drive's pieces (experiments/teleop_route.py, teleop_twin.py): the route
it plans on a world, the driver that follows it, the truth file read while it grows. The drive
itself, with the twin, the daemon and ROS, is tests/ros/test_teleop_map.py."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from jackson.experiments.teleop_route import (
    PurePursuit,
    RouteError,
    cusps,
    resample,
    survey_via,
    teleop_route,
)
from jackson.experiments.teleop_twin import TruthTail, truth_header
from jackson.sim.config import load_world
from jackson.sim.raster import raster

DT_S = 0.1  # [s] one /cmd_vel period


def drive_unicycle(
    pursuit: PurePursuit, pose: tuple[float, float, float], steps: int
) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """The path of an ideal differential drive given the driver's commands every 0.1 s."""
    x, y, yaw = pose
    path, commands = [(x, y)], []
    for _ in range(steps):
        v, w = pursuit.command(x, y, yaw)
        commands.append((v, w))
        if pursuit.arrived(x, y):
            break
        x, y, yaw = x + v * DT_S * math.cos(yaw), y + v * DT_S * math.sin(yaw), yaw + w * DT_S
        path.append((x, y))
    return np.array(path), commands


def distance_to_route(points: np.ndarray, route: np.ndarray) -> np.ndarray:
    d = np.hypot(points[:, None, 0] - route[None, :, 0], points[:, None, 1] - route[None, :, 1])
    return d.min(axis=1)


def test_resample_spaces_points_evenly_and_keeps_both_ends() -> None:
    p = resample([[0.0, 0.0], [1.0, 0.0], [1.0, 0.52]], 0.05)
    assert np.allclose(p[0], [0.0, 0.0]) and np.allclose(p[-1], [1.0, 0.52])
    gaps = np.hypot(*np.diff(p, axis=0).T)
    assert np.all(gaps <= 0.05 + 1e-9) and np.all(gaps[:-1] > 0.049)


def test_the_driver_follows_an_out_and_back_route_with_a_corner_and_stops_at_its_end() -> None:
    route = resample([[0.0, 0.0], [2.0, 0.0], [2.0, 1.5], [2.0, 0.0], [0.5, 0.0]], 0.05)
    pursuit = PurePursuit(route, speed_m_s=0.2)
    path, commands = drive_unicycle(pursuit, (0.0, 0.0, 0.0), 2000)
    assert pursuit.arrived(*path[-1]) and commands[-1] == (0.0, 0.0)
    assert pursuit.progress_m == pytest.approx(pursuit.length_m, abs=0.1)
    assert distance_to_route(path, route).max() < 0.10  # cutting corners by under 10 cm
    v = np.array([c[0] for c in commands])
    w = np.array([c[1] for c in commands])
    assert v.max() == pytest.approx(0.2) and v.min() >= 0.0 and np.abs(w).max() <= 0.8
    assert np.sum(v == 0.0) > 10  # it turned on the spot at the far end (and the corners)
    # up to the corridor's end before turning back, not a look-ahead short of it
    assert np.hypot(path[:, 0] - 2.0, path[:, 1] - 1.5).min() < 0.08
    travelled = np.hypot(*np.diff(path, axis=0).T).sum()
    assert travelled > 0.9 * pursuit.length_m  # corners cut by the look-ahead


def test_cusps_are_where_a_route_doubles_back_not_its_corners() -> None:
    route = resample([[0.0, 0.0], [2.0, 0.0], [2.0, 1.5], [2.0, 0.5], [3.0, 0.5]], 0.05)
    (cusp,) = cusps(route)
    assert np.allclose(route[cusp], [2.0, 1.5])


def test_a_route_passing_a_place_twice_is_followed_in_order() -> None:
    # a loop back through its own start: the nearest point is never taken from the end
    route = resample([[0.0, 0.0], [1.5, 0.0], [1.5, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 0.0]], 0.05)
    pursuit = PurePursuit(route, speed_m_s=0.25)
    path, _ = drive_unicycle(pursuit, (0.0, 0.0, 0.0), 3000)
    travelled = np.hypot(*np.diff(path, axis=0).T).sum()
    assert pursuit.arrived(*path[-1]) and travelled > 0.9 * pursuit.length_m


def test_the_survey_route_of_partition_lshape_keeps_clear_of_walls_and_passes_the_door() -> None:
    world = load_world("partition_lshape")
    via = survey_via("partition_lshape")
    assert via[-1] == pytest.approx(world.start_pose[:2])  # back to the start, as jackson map
    route = teleop_route(world, via)
    occupied, ox, oy = raster(world, 0.01)
    clearance = ndimage.distance_transform_edt(~occupied) * 0.01
    col = ((route[:, 0] - ox) / 0.01).astype(int)
    row = ((route[:, 1] - oy) / 0.01).astype(int)
    # the 0.80 m door leaves 0.40 m on either side of its middle; elsewhere it keeps farther
    assert clearance[row, col].min() > 0.3
    for x, y in via:  # every waypoint on the way
        assert np.hypot(route[:, 0] - x, route[:, 1] - y).min() < 0.05
    # through the door to the packing aisle (y < 1.8) and back
    below = route[:, 1] < 1.8
    assert below.any() and np.all(np.abs(route[below & (route[:, 1] > 1.6), 0] - 11.4) < 0.2)


def test_a_waypoint_inside_a_wall_is_one_line() -> None:
    world = load_world("partition_lshape")
    with pytest.raises(RouteError, match=r"^the route: goal 2 \(8\.00, 1\.79\) is in an ") as info:
        teleop_route(world, [(8.0, 1.0), (8.0, 1.788)])  # on the partition
    assert "\n" not in str(info.value)


def test_the_truth_tail_reads_rows_as_they_are_written_and_waits_for_a_partial_row(
    tmp_path: Path,
) -> None:
    path = tmp_path / "truth.csv"
    tail = TruthTail(path)
    assert not tail.poll()  # not written yet
    path.write_text(
        "# jackson twin ground truth: boot_id 0x5e1f03a7, robot jackson_physical, world maze\n"
        "t_us,t_s,x_m,y_m,yaw_rad\n0,0.000000,1.0,2.0,0.0\n"
    )
    assert tail.poll() and tail.t_s == 0.0 and tail.pose == (1.0, 2.0, 0.0)
    with path.open("a") as f:
        f.write("50000,0.050000,1.1,2.0,0.1\n100000,0.1000")
    assert tail.poll() and tail.t_s == 0.05 and tail.pose == (1.1, 2.0, 0.1)
    with path.open("a") as f:
        f.write("00,1.2,2.0,0.2\n")
    assert tail.poll() and tail.t_s == 0.1 and tail.pose == (1.2, 2.0, 0.2)
    assert not tail.poll()
    tail.close()
    assert truth_header(path) == {
        "boot_id": "0x5e1f03a7",
        "robot": "jackson_physical",
        "world": "maze",
    }
