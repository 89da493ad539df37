"""A map judged against its world's true geometry: a perfect map scores perfectly, a missing
wall costs exactly that wall, a shifted wall costs precision, and only walls in sight count."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest

from jackson.experiments.metrics.inputs import MetricInputError
from jackson.experiments.metrics.map_quality import (
    MapQuality,
    judge_map,
    judge_run,
    plot_map_quality,
)
from jackson.experiments.run_csv import read_csv
from jackson.experiments.stage3 import mapping_spec, run_nav_trial
from jackson.host.nav.grid import OccupancyGrid
from jackson.sim.config import Cylinder, WorldSpec, load_world
from jackson.sim.raster import raster, reachable_free

RES = 0.05  # [m]
PARTITION = 4  # index of the room's free-standing partition
ROOM = WorldSpec(
    "room",
    walls=(
        (0.0, 0.0, 6.0, 0.0),
        (6.0, 0.0, 6.0, 4.0),
        (6.0, 4.0, 0.0, 4.0),
        (0.0, 4.0, 0.0, 0.0),
        (3.0, 1.0, 3.0, 3.0),  # the partition
    ),
    cylinders=(Cylinder(1.5, 3.2, 0.15),),
    start_pose=(1.0, 2.0, 0.0),
)
# a loop round the partition, clear of every obstacle
PATH = np.array(
    [(1.0, 2.0), (1.0, 0.6), (5.0, 0.6), (5.0, 3.4), (1.0, 3.4), (1.0, 2.0)], np.float64
)


def survey(path: np.ndarray = PATH, step_m: float = 0.05) -> np.ndarray:
    """Points every ``step_m`` along a polyline."""
    pts = [path[0]]
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(np.hypot(*(b - a)) / step_m))
        pts += [a + (b - a) * k / n for k in range(1, n + 1)]
    return np.asarray(pts)


def best_map(world: WorldSpec, judged: WorldSpec = ROOM) -> OccupancyGrid:
    """``world`` as a survey of ``judged`` would ideally map it: its obstacles occupied, the
    free space connected to the start free, the rest unknown (on ``judged``'s grid)."""
    occ_j, ox, oy = raster(judged, RES)
    h, w = occ_j.shape
    occ, _, _ = raster(world, RES, bounds=(ox, oy, ox + w * RES, oy + h * RES))
    free = reachable_free(occ, ox, oy, RES, world.start_pose[:2])
    data = np.full(occ.shape, -1, np.int8)
    data[free] = 0
    data[occ] = 100
    return OccupancyGrid(data, RES, ox, oy)


def coverage(q: MapQuality) -> list[float]:
    return [s.coverage for s in q.segments]


def test_the_world_s_own_raster_scores_perfectly() -> None:
    q = judge_map(best_map(ROOM), ROOM, survey(), max_range_m=8.0)
    assert len(q.judged) == len(ROOM.walls) + len(ROOM.cylinders)
    assert coverage(q) == [1.0] * len(q.segments)
    assert q.covered_fraction == 1.0 and q.sample_coverage == 1.0
    assert q.precision == 1.0 and q.misplacement_max_m == 0.0 and len(q.stray_xy) == 0
    assert q.ssim == pytest.approx(1.0)


def test_a_missing_wall_loses_exactly_that_wall_s_coverage() -> None:
    walls = tuple(w for k, w in enumerate(ROOM.walls) if k != PARTITION)
    q = judge_map(best_map(dataclasses.replace(ROOM, walls=walls)), ROOM, survey(), max_range_m=8.0)
    cov = coverage(q)
    assert cov[PARTITION] == 0.0
    assert cov[:PARTITION] + cov[PARTITION + 1 :] == [1.0] * (len(cov) - 1)
    assert q.worst is not None and q.worst.index == PARTITION
    assert q.covered_fraction == pytest.approx(5 / 6)
    assert q.precision == 1.0  # nothing wrong was added
    assert q.ssim < 0.99


def test_a_wall_shifted_by_30_cm_costs_precision_by_its_share_of_the_cells() -> None:
    walls = list(ROOM.walls)
    walls[PARTITION] = (3.32, 1.0, 3.32, 3.0)  # one column of cells, 0.30 m from the true ones
    shifted = best_map(dataclasses.replace(ROOM, walls=tuple(walls)))
    q = judge_map(shifted, ROOM, survey(), max_range_m=8.0)
    partition_cells = 2.0 / RES  # the 2 m partition's 40 cells
    assert q.precision == pytest.approx(1.0 - partition_cells / q.occupied_cells, abs=0.01)
    assert q.misplacement_max_m == pytest.approx(0.3, abs=RES)
    assert coverage(q)[PARTITION] == 0.0
    assert len(q.stray_xy) == pytest.approx(partition_cells, abs=2)
    assert np.allclose(q.stray_xy[:, 0], 3.325)


def test_walls_out_of_range_or_out_of_sight_are_not_judged() -> None:
    boxed = dataclasses.replace(
        ROOM,
        walls=(
            *ROOM.walls[:PARTITION],
            (2.5, 1.5, 3.5, 1.5),  # a closed box in place of the partition
            (3.5, 1.5, 3.5, 2.5),
            (3.5, 2.5, 2.5, 2.5),
            (2.5, 2.5, 2.5, 1.5),
        ),
        cylinders=(),
    )
    # a map without the box's east side and the room's east wall: neither is in view
    visible = dataclasses.replace(
        boxed, walls=tuple(w for k, w in enumerate(boxed.walls) if k not in (1, 5))
    )
    poses = survey(np.array([(0.5, 1.0), (0.5, 3.0)]))  # the room's west end
    q = judge_map(best_map(visible, boxed), boxed, poses, max_range_m=4.0)
    cov = coverage(q)
    assert math.isnan(cov[1])  # the east wall: 5.5 m away
    assert math.isnan(cov[5])  # the box's east side: behind the box
    assert cov[4] == 1.0 and cov[7] == 1.0  # its west side in view
    assert q.covered_fraction == 1.0 and len(q.judged) == len(boxed.walls) - 2


def test_judged_by_the_beams_a_face_no_beam_hits_does_not_count() -> None:
    # the partition (x = 3, y 1-3) seen only from its own line, below it: every sample of it
    # is in sight (nothing lies between), but a beam along the line ends on its near end
    # and none reaches the rest of it
    without = dataclasses.replace(ROOM, walls=ROOM.walls[:PARTITION])
    grid = best_map(without)
    poses = np.array([(3.0, 0.3 + 0.05 * k, math.pi / 2) for k in range(5)])
    angles = np.linspace(-math.pi, math.pi, 1080, endpoint=False)
    in_sight = judge_map(grid, ROOM, poses[:, :2], max_range_m=8.0)
    assert coverage(in_sight)[PARTITION] == 0.0  # judged, and missed
    beams = judge_map(grid, ROOM, poses, max_range_m=8.0, beam_angles_rad=angles)
    assert math.isnan(coverage(beams)[PARTITION])  # not judged
    assert beams.covered_fraction == 1.0
    # a face the beams do hit is judged as before: the room's walls, and the partition
    # seen from the side
    side = np.array([(2.0, 2.0, 0.0), (4.0, 2.0, math.pi)])
    q = judge_map(grid, ROOM, side, max_range_m=8.0, beam_angles_rad=angles)
    assert coverage(q)[PARTITION] == 0.0 and coverage(q)[0] == 1.0
    full = judge_map(best_map(ROOM), ROOM, side, max_range_m=8.0, beam_angles_rad=angles)
    assert coverage(full)[PARTITION] == 1.0
    with pytest.raises(MetricInputError, match="poses_xy"):  # beams need the headings
        judge_map(grid, ROOM, side[:, :2], max_range_m=8.0, beam_angles_rad=angles)


def test_a_survey_without_poses_is_refused() -> None:
    with pytest.raises(MetricInputError, match="poses_xy"):
        judge_map(best_map(ROOM), ROOM, np.zeros((0, 2)), max_range_m=8.0)


def test_a_mapping_run_of_the_twin_is_judged_consistently(tmp_path: Path) -> None:
    run = tmp_path / "map"
    m = run_nav_trial(mapping_spec("jackson_physical", "corridor_8m", 0, run))
    q = judge_run(run)
    assert q.worst is not None and q.worst.coverage == min(s.coverage for s in q.judged)
    figures = (q.covered_fraction, q.sample_coverage, q.precision, q.worst.coverage)
    assert all(0.0 <= f <= 1.0 for f in figures), figures
    assert q.ssim == pytest.approx(m["map_ssim"], abs=0.005)  # the figure jackson map reports
    assert len(q.stray_xy) == round((1.0 - q.precision) * q.occupied_cells)
    assert 0.0 <= q.misplacement_p99_m <= q.misplacement_max_m
    assert len(q.judged) >= 4  # the corridor's long walls were driven along
    gt = read_csv(run / "ground_truth.csv")
    grid = OccupancyGrid.load(run / "built_map.yaml")
    world = load_world(json.loads((run / "meta.json").read_text())["world"])
    path = np.column_stack((gt["x_m"], gt["y_m"]))
    png = plot_map_quality(tmp_path / "quality.png", grid, world, q, path)
    assert png.stat().st_size > 10_000 and png.with_suffix(".pdf").is_file()
