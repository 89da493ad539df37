"""The patrol's navigation figures on inputs whose answer is known: the daemon's map-frame pose
composed from /tf and its error against the truth, the shortest collision-free path and the
path ratio, and the check that a map lies in the world's frame."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from jackson.common.geometry import world_to_cell
from jackson.experiments.patrol.floor import check_map_frame, goal_cells
from jackson.experiments.patrol.localisation import (
    PoseTrack,
    compose_map_poses,
    localisation_errors,
    read_truth,
)
from jackson.experiments.patrol.paths import ShortestPaths, path_length, ratio_figures
from jackson.experiments.patrol.records import PatrolError
from jackson.experiments.stage3 import world_grid
from jackson.host.nav.grid import OccupancyGrid
from jackson.sim.config import WorldSpec

RADIUS_M = 0.16  # [m] the host's robot radius
OUTLINE = ((0.0, 0.0, 6.0, 0.0), (6.0, 0.0, 6.0, 6.0), (6.0, 6.0, 0.0, 6.0), (0.0, 6.0, 0.0, 0.0))
ROOM = WorldSpec("room", walls=OUTLINE, start_pose=(1.0, 1.0, 0.0))
# a wall from the floor's south side up to y = 4, between x = 1 and x = 5
SPLIT = WorldSpec("split", walls=(*OUTLINE, (3.0, 0.0, 3.0, 4.0)), start_pose=(1.0, 1.0, 0.0))
CLOSED = WorldSpec("closed", walls=(*OUTLINE, (3.0, 0.0, 3.0, 6.0)), start_pose=(1.0, 1.0, 0.0))


def _track(t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray | float) -> PoseTrack:
    return PoseTrack.of(np.column_stack((t, x, y, np.broadcast_to(yaw, t.shape))))


# ---- the daemon's pose against the truth --------------------------------------------------------


def test_a_known_offset_of_the_estimate_is_the_error_everywhere() -> None:
    """Odometry along its x at 0.2 m/s (30 Hz), a correction turning it by 90 degrees and
    moving it to (1, 2) (20 Hz): the map pose runs up y from (1, 2); the truth 5 cm beside it."""
    t_odom = np.arange(0.0, 10.0, 1 / 30)
    odom = _track(t_odom, 0.2 * t_odom, 0 * t_odom, 0.0)
    t_corr = np.arange(0.0, 10.0, 0.05)
    corr = _track(t_corr, 1 + 0 * t_corr, 2 + 0 * t_corr, math.pi / 2)
    est = compose_map_poses(odom, corr)
    assert np.allclose(est.x_m, 1.0) and np.allclose(est.y_m, 2.0 + 0.2 * est.t_s)
    truth = _track(t_corr, 1.03 + 0 * t_corr, 2.04 + 0.2 * t_corr, math.pi / 2)
    errors = localisation_errors(est, truth)
    assert errors.error_m.size > 250
    assert np.allclose(errors.error_m, 0.05)
    figures = errors.figures()
    assert figures["median_m"] == pytest.approx(0.05)
    assert figures["p99_m"] == pytest.approx(0.05)
    assert figures["max_m"] == pytest.approx(0.05)


def test_the_last_correction_holds_until_the_next() -> None:
    """A correction of 0 until t = 5 s, then 0.1 m along x: the error is 0 before and 0.1 m
    from that sample on (the truth is the odometry)."""
    t = np.arange(0.0, 10.0, 0.05)
    odom = _track(t, 0.2 * t, 0 * t, 0.0)
    corr = PoseTrack.of([(0.0, 0.0, 0.0, 0.0), (5.0, 0.1, 0.0, 0.0)])
    errors = localisation_errors(compose_map_poses(odom, corr), odom)
    assert np.allclose(errors.error_m[errors.t_s < 5.0 - 1e-9], 0.0)
    assert np.allclose(errors.error_m[errors.t_s >= 5.0 - 1e-9], 0.1)


def test_samples_at_rest_are_left_out() -> None:
    """At rest for 5 s (with a 0.3 m error until 4.5 s), then driving 5 s with none: only the
    drive and the quarter second around it counts; a turn on the spot counts as driving."""
    t = np.arange(0.0, 15.0, 0.05)
    x = np.clip(t - 5.0, 0.0, 5.0) * 0.2
    yaw = np.where(t > 10.0, (t - 10.0) * 0.5, 0.0)
    truth = _track(t, x, 0 * t, yaw)
    est = _track(t, x + np.where(t < 4.5, 0.3, 0.0), 0 * t, yaw)
    errors = localisation_errors(est, truth)
    assert errors.figures()["max_m"] == pytest.approx(0.0, abs=1e-9)
    assert 4.7 <= errors.t_s.min() < 5.0 and errors.t_s.max() > 14.5


def test_the_truth_file_is_read_without_its_cut_last_line(tmp_path: Path) -> None:
    path = tmp_path / "truth.csv"
    path.write_text(
        "# jackson twin ground truth\nt_us,t_s,x_m,y_m,yaw_rad\n"
        "0,0.0,1.0,2.0,0.0\n50000,0.05,1.01,2.0,0.0\n100000,0.1,1.0"
    )
    truth = read_truth(path)
    assert truth.t_s.tolist() == [0.0, 0.05] and truth.x_m.tolist() == [1.0, 1.01]


# ---- the shortest path and the ratio ------------------------------------------------------------


def test_a_straight_trip_in_open_space_has_ratio_one() -> None:
    shortest = ShortestPaths.of_world(ROOM, RADIUS_M)
    length = shortest.length_m((1.0, 3.0), (5.0, 3.0))
    assert length == pytest.approx(4.0, abs=1e-9)
    driven = np.column_stack((np.linspace(1.0, 5.0, 81), np.full(81, 3.0)))
    assert path_length(driven) / length == pytest.approx(1.0)
    assert shortest.length_m((1.0, 1.0), (5.0, 5.0)) == pytest.approx(4.0 * math.sqrt(2))


def test_a_detour_round_a_wall_has_the_ratio_of_the_taut_string() -> None:
    """From (1, 2) to (5, 2) past a wall up to (3, 4): the shortest path is the taut string
    round the wall's end kept the robot's radius off (tangent, arc, tangent); a drive up to
    y = 5, across and down (10 m) is that much longer."""
    a, b, end = (1.0, 2.0), (5.0, 2.0), (3.0, 4.0)
    d = math.hypot(end[0] - a[0], end[1] - a[1])
    climb = math.atan2(end[1] - a[1], end[0] - a[0]) + math.asin(RADIUS_M / d)
    taut = 2 * math.sqrt(d * d - RADIUS_M**2) + 2 * RADIUS_M * climb
    length = ShortestPaths.of_world(SPLIT, RADIUS_M).length_m(a, b)
    # the wall's cells reach a cell beyond its line and its end: up to 0.1 m longer
    assert taut <= length <= taut + 0.1, (length, taut)
    driven = np.array([a, (1.0, 5.0), (5.0, 5.0), b])  # 10 m
    ratio = path_length(driven) / length
    assert ratio == pytest.approx(10.0 / taut, rel=0.02)
    assert ratio > 1.25


def test_no_way_through_gives_no_length() -> None:
    assert math.isnan(ShortestPaths.of_world(CLOSED, RADIUS_M).length_m((1.0, 3.0), (5.0, 3.0)))


def test_the_ratio_figures_count_the_detours() -> None:
    f = ratio_figures([1.0, 1.1, 1.3, math.nan])
    assert f["median"] == pytest.approx(1.1) and f["max"] == pytest.approx(1.3)
    assert f["above_1_25"] == 1 and f["goals"] == 3
    assert ratio_figures([])["median"] is None


# ---- the map the daemon gets --------------------------------------------------------------------


def test_a_map_of_the_world_in_its_frame_is_taken_and_a_shifted_one_refused() -> None:
    grid = world_grid(SPLIT)
    assert check_map_frame(grid, SPLIT, "m.yaml") == pytest.approx(1.0)
    shifted = OccupancyGrid(grid.data, grid.resolution_m, grid.origin_x_m + 1.0, grid.origin_y_m)
    with pytest.raises(PatrolError, match="not a map of this world in its frame"):
        check_map_frame(shifted, SPLIT, "m.yaml")


def test_goals_are_sent_only_where_the_map_knows_the_floor_free() -> None:
    """A map that knows only the floor's west half: no goal east of x = 3."""
    grid = world_grid(ROOM)
    _, cols = np.indices(grid.data.shape)
    x = grid.origin_x_m + (cols + 0.5) * grid.resolution_m
    grid.data[x > 3.0] = -1
    all_x, _ = goal_cells(ROOM)
    on_map_x, _ = goal_cells(ROOM, grid=grid)
    assert all_x.max() > 5.0 and 0 < len(on_map_x) < len(all_x)
    assert on_map_x.max() < 3.0


# ---- the summary and the plot -------------------------------------------------------------------


def test_the_summary_and_the_plot_carry_the_figures(tmp_path: Path) -> None:
    from jackson.experiments.patrol import (
        GoalOutcome,
        PatrolResult,
        PatrolSpec,
        plot_patrol,
        summarise,
    )
    from jackson.experiments.patrol.localisation import LocalisationErrors

    result = PatrolResult(contacts=0, daemon_exit=0)
    for k, ratio in enumerate((1.02, 1.1, 1.4)):
        o = GoalOutcome(k, "goal", k + 1, 5.0, 3.0, "succeeded", "", 0.0, 1.0, 0.1, True)
        o.path_ratio = ratio
        result.outcomes.append(o)
    t = np.arange(0.0, 100.0, 0.05)
    error = np.where(t < 99.0, 0.02, 0.15)
    result.localisation = LocalisationErrors(t, 1 + t / 25, 3 + 0 * t, error, 100.0, 100.0)
    summary = summarise(PatrolSpec("split", tmp_path), result, (90, 100))
    assert summary["localisation_error"]["median_m"] == pytest.approx(0.02)
    assert summary["localisation_error"]["max_m"] == pytest.approx(0.15)
    assert summary["path_ratio"]["above_1_25"] == 1
    assert summary["goal_points_on_map"] == "90/100"
    png = tmp_path / "patrol.png"
    plot_patrol(png, SPLIT, result, summary, world_grid(SPLIT))
    assert png.stat().st_size > 10_000


MAPPING_FLOORS = ("partition_lshape", "ring_block", "hall_400", "corridor_out_back")


@pytest.mark.parametrize("name", MAPPING_FLOORS)
def test_the_mapping_floors_drop_in_open_floor_and_list_shut_off_points(name: str) -> None:
    """Drop spots 1.25 m from every wall and cylinder, reached from the start; unreachable
    points free but shut off (the twin's raster)."""
    from jackson.sim.config import load_world
    from jackson.sim.raster import raster, reachable_free
    from jackson.sim.world import World

    spec = load_world(name)
    assert spec.patrol is not None
    occupied, x0, y0 = raster(spec, 0.05)
    reach = reachable_free(occupied, x0, y0, 0.05, spec.start_pose[:2])
    world = World(spec)
    for x, y in spec.patrol.drop_spots:
        r, c = world_to_cell(x, y, x0, y0, 0.05)
        assert world.clearance(x, y) >= 1.25 and reach[r, c], (x, y)
    for x, y in spec.patrol.unreachable:
        r, c = world_to_cell(x, y, x0, y0, 0.05)
        assert not occupied[r, c] and not reach[r, c], (x, y)


def test_a_processs_figures_may_count_the_children_it_started() -> None:
    # the daemon's memory and CPU with its planner worker's: a child that burns CPU and holds
    # memory shows in the parent's figures with its children, and not without
    import os
    import subprocess
    import sys

    from jackson.experiments.patrol.processes import children, cpu_s, rss_mb

    burn = 'b = b"x" * (64 << 20); import time; t = time.process_time() + 0.3\n'
    burn += "while time.process_time() < t: pass\nprint(flush=True); input()"
    child = subprocess.Popen(
        [sys.executable, "-c", burn], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout is not None
        child.stdout.readline()  # it has burnt its CPU and holds its memory
        me = os.getpid()
        assert child.pid in children(me)
        assert cpu_s(me, with_children=True) >= cpu_s(me) + 0.29
        assert rss_mb(me, with_children=True) >= rss_mb(me) + 60.0
    finally:
        child.kill()
        child.wait()
