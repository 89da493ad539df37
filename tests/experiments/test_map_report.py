"""The report written beside a map: on a twin run its figures (the map judged against the world,
the largest loop's closure error), without a ground truth only the graph's own; a picture
either way."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest

from jackson.experiments.map_report import REPORT_JSON, REPORT_PNG, twin_world, write_map_report
from jackson.experiments.metrics.loop_closure import relative
from jackson.host.nav.grid import OccupancyGrid
from jackson.sim.config import WorldSpec
from jackson.sim.raster import raster, reachable_free

RES = 0.05  # [m]
ROOM = WorldSpec(
    "room",
    walls=((0.0, 0.0, 6.0, 0.0), (6.0, 0.0, 6.0, 4.0), (6.0, 4.0, 0.0, 4.0), (0.0, 4.0, 0.0, 0.0)),
    start_pose=(1.0, 1.0, 0.0),
)
# a lap of the room, 0.25 m a node and a second, back to the start
CORNERS = np.array([(1.0, 1.0), (5.0, 1.0), (5.0, 3.0), (1.0, 3.0), (1.0, 1.0)])
DRIFT = 0.001  # [rad] added to every chain step's turn: 48 steps, 0.048 rad round the lap


def lap() -> np.ndarray:
    """The nodes' true poses (x, y, heading along the lap)."""
    pts = [CORNERS[0]]
    for a, b in itertools.pairwise(CORNERS):
        n = round(np.hypot(*(b - a)) / 0.25)
        pts += [a + (b - a) * k / n for k in range(1, n + 1)]
    xy = np.asarray(pts)
    d = np.diff(xy, axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0])
    return np.column_stack((xy, np.append(yaw, yaw[-1])))


def mapping_run(folder: Path, truth: bool = True) -> Path:
    """A run folder as ``jackson map`` leaves it: the room's ideal map, the lap's pose graph
    (the chain turning :data:`DRIFT` too far a step, the nodes at their true poses, one loop
    closure from the last node to the first) and, if ``truth``, the ground truth and
    ``meta.json``."""
    folder.mkdir()
    occ, ox, oy = raster(ROOM, RES)
    data = np.full(occ.shape, -1, np.int8)
    data[reachable_free(occ, ox, oy, RES, ROOM.start_pose[:2])] = 0
    data[occ] = 100
    OccupancyGrid(data, RES, ox, oy).save(folder / "built_map.yaml")
    poses = lap()
    n = len(poses)
    chain = [relative(poses[k - 1], poses[k]) + np.array((0.0, 0.0, DRIFT)) for k in range(1, n)]
    np.savez_compressed(
        folder / "built_map.graph.npz",
        poses=poses,
        scan_t=np.arange(n, dtype=np.float64),
        travel=0.25 * np.arange(n, dtype=np.float64),
        edge_nodes=np.array([(k - 1, k) for k in range(1, n)] + [(0, n - 1)]),
        edge_z=np.array([*chain, relative(poses[0], poses[-1])]),
        edge_loop=np.array([False] * (n - 1) + [True]),
    )
    if truth:
        t = np.arange(0.0, n - 0.99, 0.5)
        x, y = (np.interp(t, np.arange(n), poses[:, c]) for c in (0, 1))
        yaw = np.interp(t, np.arange(n), np.unwrap(poses[:, 2]))
        rows = "".join(
            f"{a:.17g},{b:.17g},{c:.17g},{d:.17g},0,0,0\n"
            for a, b, c, d in zip(t, x, y, yaw, strict=True)
        )
        (folder / "ground_truth.csv").write_text(
            "t_s,x_m,y_m,yaw_rad,vx_m_s,vy_m_s,wz_rad_s\n" + rows
        )
        (folder / "meta.json").write_text(
            json.dumps({"robot": "jackson_physical", "world": "room"})
        )
    return folder


def is_png(path: Path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 20_000


def test_a_twin_run_s_report_has_the_map_s_figures_and_the_loop_s_drift(tmp_path: Path) -> None:
    run = mapping_run(tmp_path / "run")
    report = write_map_report(run, world=ROOM)
    assert report.png == run / REPORT_PNG and is_png(report.png)
    f = json.loads((run / REPORT_JSON).read_text())
    assert f.keys() == report.figures.keys()
    assert f["world"] == "room" and f["nodes"] == 49 and f["loop_closures"] == 1
    assert f["largest_loop_nodes"] == [0, 48] and f["largest_loop_travel_m"] == 12.0
    assert f["trajectory_m"] == pytest.approx(12.0)
    # the chain: step k (0.25 m along the lap) turned k * DRIFT too far; the nodes exact
    poses = lap()
    heading = np.arctan2(*np.diff(poses[:, :2], axis=0).T[::-1])
    k = np.arange(48)
    drift = 0.25 * (np.exp(1j * (heading + k * DRIFT)) - np.exp(1j * heading)).sum()
    assert f["loop_closure_before_m"] == pytest.approx(abs(drift), rel=1e-6)
    assert abs(drift) > 0.1
    assert f["loop_closure_before_rad"] == pytest.approx(48 * DRIFT)
    assert f["loop_closure_after_m"] == pytest.approx(0.0, abs=1e-6)
    assert f["loop_closure_after_rad"] == pytest.approx(0.0, abs=1e-6)
    assert f["precision"] == 1.0 and f["ssim"] == pytest.approx(1.0)
    assert f["segments_covered_fraction"] == 1.0 and f["misplacement_max_m"] == 0.0
    lines = "\n".join(report.lines())
    assert "loop closures      1" in lines and "SSIM               1.000" in lines


def test_a_recording_without_a_ground_truth_reports_the_graph_only(tmp_path: Path) -> None:
    run = mapping_run(tmp_path / "run", truth=False)
    report = write_map_report(run)
    assert is_png(report.png) and report.quality is None and report.loop is None
    f = json.loads(report.json.read_text())
    assert set(f) == {
        "world",
        "nodes",
        "trajectory_m",
        "loop_closures",
        "largest_loop_nodes",
        "largest_loop_travel_m",
    }
    assert f["world"] is None and f["nodes"] == 49 and f["loop_closures"] == 1
    assert not math.isnan(f["largest_loop_travel_m"])


def test_a_run_is_judged_only_with_a_ground_truth_and_a_world_that_loads(tmp_path: Path) -> None:
    (tmp_path / "meta.json").write_text(json.dumps({"world": "corridor_8m"}))
    assert twin_world(tmp_path) is None  # no ground truth: the real robot's run
    (tmp_path / "ground_truth.csv").write_text("t_s,x_m,y_m,yaw_rad\n0,0,0,0\n")
    world = twin_world(tmp_path)
    assert world is not None and world.name == "corridor_8m"
    (tmp_path / "meta.json").write_text(json.dumps({"world": "no_such_world"}))
    assert twin_world(tmp_path) is None
    (tmp_path / "meta.json").write_text(json.dumps({"mission": "teleop"}))
    assert twin_world(tmp_path) is None
