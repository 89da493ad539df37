"""The occupancy grid, its map_server file pair, and the shared pose and scan types."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from jackson.host.nav.grid import MapFileError, OccupancyGrid
from jackson.host.nav.types import Pose2D, Scan


def test_map_pair_round_trips_and_reads_as_map_server_does(tmp_path: Path) -> None:
    g = OccupancyGrid.empty(1.0, 0.5, 0.05, origin_x_m=-0.5, origin_y_m=-0.25)
    g.data[0, :] = 100  # the lowest row: the bottom of the image
    g.data[3:5, 3:8] = 0
    yaml_path, pgm_path = g.save(tmp_path / "m.yaml")
    assert pgm_path.read_bytes().startswith(b"P5\n20 10\n255\n")
    pixels = pgm_path.read_bytes()[len(b"P5\n20 10\n255\n") :]
    assert pixels[-20:] == bytes([0] * 20)  # image rows run top (high y) to bottom
    h = OccupancyGrid.load(yaml_path)
    assert np.array_equal(h.data, g.data)
    assert (h.origin_x_m, h.origin_y_m, h.resolution_m) == (-0.5, -0.25, 0.05)


def test_cells_and_world_agree() -> None:
    g = OccupancyGrid.empty(2.0, 1.0, 0.05, origin_x_m=-1.0, origin_y_m=0.5)
    row, col = g.world_to_cell([-1.0, 0.99, -1.01], [0.5, 1.49, 0.5])
    assert row.tolist() == [0, 19, 0] and col.tolist() == [0, 39, -1]
    assert g.inside(row, col).tolist() == [True, True, False]
    x, y = g.cell_to_world(19, 39)
    assert (x, y) == pytest.approx((0.975, 1.475))


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("image: m.pgm\nresolution: 0.05\n", "origin: missing"),
        ("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\n", "resolution"),
        ("image: nope.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "nope.pgm"),
        ("[1, 2", "not YAML"),
    ],
)
def test_a_bad_map_file_is_one_line(tmp_path: Path, text: str, says: str) -> None:
    path = tmp_path / "m.yaml"
    path.write_text(text)
    with pytest.raises(MapFileError, match=says) as info:
        OccupancyGrid.load(path)
    assert "\n" not in str(info.value)


def test_pose_composition_and_scan_points() -> None:
    a = Pose2D(1.0, 2.0, math.pi / 2)
    b = Pose2D(0.5, 0.0, 0.0)
    assert a.compose(b).x == pytest.approx(1.0) and a.compose(b).y == pytest.approx(2.5)
    ident = a.compose(a.inverse())
    assert (ident.x, ident.y, ident.yaw) == pytest.approx((0.0, 0.0, 0.0))
    scan = Scan(0.0, np.array([0.0, math.pi / 2, 0.1]), np.array([1.0, 2.0, math.inf]))
    pts = scan.points(Pose2D(0.0, 0.0, math.pi / 2))
    assert pts == pytest.approx(np.array([[0.0, 1.0], [-2.0, 0.0]]))
