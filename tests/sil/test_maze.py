"""Stage 3 end to end: the real host daemon against the twin over ptys (its MCU and its
emulated RPLIDAR), mapping the maze, then navigating it around the dropped cylinder."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from jackson.experiments.stage3 import (
    NavTrialSpec,
    mapping_spec,
    run_nav_trial,
)
from jackson.host.nav import native
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.replay import replay


@pytest.fixture(scope="module")
def mapped(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    out = tmp_path_factory.mktemp("maze") / "map"
    return out, run_nav_trial(mapping_spec("jackson_physical", "maze", 3, out))


def test_the_host_maps_the_maze_while_it_drives(mapped: tuple[Path, dict[str, Any]]) -> None:
    out, r = mapped
    assert r["completed"], r["failure"]
    assert r["collisions"] == 0
    assert 0.0 < r["cpu_s"] < 10.0 * r["wall_s"]  # the trial's own CPU time, twin thread included
    assert r["scans"] > 50  # 7.43 Hz of sim time
    assert r["map_ssim"] > 0.85  # the paper: 0.885 (robot), 0.942 (Isaac)
    assert r["localisation_error_max_cm"] < 5.0  # scan matching against the map so far
    grid = OccupancyGrid.load(out / "built_map.yaml")  # a map_server pair Nav2 can load
    assert (out / "built_map.pgm").read_bytes().startswith(b"P5\n")
    assert grid.resolution_m == 0.05


def test_the_host_navigates_around_the_dropped_cylinder_and_replays_bit_for_bit(
    mapped: tuple[Path, dict[str, Any]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    map_dir, m = mapped
    assert m["completed"]
    run = tmp_path / "nav"
    r = run_nav_trial(
        NavTrialSpec(0, 4, "jackson_physical", "maze", run, map_yaml=map_dir / "built_map.yaml")
    )
    assert r["completed"], r["failure"]
    assert r["collisions"] == 0
    assert r["t_insert_s"] > 0  # the cylinder was dropped in the robot's way ...
    assert r["d_min_m"] > 0.0  # ... and the envelope never touched it
    assert r["goal_error_m"] < 0.30  # xy goal tolerance 0.25 m, judged on the estimate
    assert 1.7 < r["path_length_m"] < 2.8
    assert r["localisation_error_max_cm"] < 8.0
    # the host read the densest mode of the twin's A1M8: Sensitivity's ultra capsules
    lidar = json.loads((run / "meta.json").read_text())["lidar"]
    assert lidar["mode"] == "Sensitivity" and lidar["answer_type"] == 0x84
    assert lidar["device"] == "A1M8 firmware 1.29 hardware 7"
    result = replay(run, tmp_path / "replay")  # the scans come back from the logged bytes
    assert result.complete and not result.differ, result.differ
    assert result.frames > 100
    # the costmap's collision tests in numpy instead of compiled: the same run, bit for bit
    if native.LIB is not None:
        monkeypatch.setattr(native, "LIB", None)
        again = replay(run, tmp_path / "replay-numpy")
        assert again.complete and not again.differ, again.differ
