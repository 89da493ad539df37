"""The costmap's compiled collision tests (host/nav/native/collide.cpp) against its numpy code:
the same answers bit for bit, on random scenes, margins, escapes and off-grid poses (a navigation
replayed with numpy's: tests/sil/test_maze.py)."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from jackson.host.nav import native
from jackson.host.nav.costmap import LETHAL_OBSTACLE, Costmap, CostmapConfig
from jackson.host.nav.grid import OccupancyGrid

pytestmark = pytest.mark.skipif(native.LIB is None, reason=f"no compiled build: {native.REASON}")


def _scene(rng: np.random.Generator) -> Costmap:
    """A rolling window with a static wall, scan returns in clumps and a random centre."""
    static = OccupancyGrid.empty(6.0, 6.0, 0.05, -3.0, -3.0, fill=0)
    static.data[rng.integers(0, 120), :] = 100
    cx, cy = rng.uniform(-1.0, 1.0, 2)
    cm = Costmap.rolling_window(CostmapConfig(), cx, cy, static_map=static)
    clumps = rng.uniform(-1.2, 1.2, (6, 2)) + np.array([cx, cy])
    pts = np.concatenate([c + rng.normal(0.0, 0.03, (20, 2)) for c in clumps])
    cm.update(pts, (cx, cy))
    return cm


def _both(cm: Costmap, method: str, *args: object, **kw: object) -> tuple[object, object]:
    checker = cm.checker
    got = getattr(checker, method)(*args, **kw)
    saved, checker._native = checker._native, None
    try:
        want = getattr(checker, method)(*args, **kw)
    finally:
        checker._native = saved
    return got, want


@pytest.mark.parametrize("seed", range(12))
def test_footprint_hits_and_clearances_are_numpys_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    cm = _scene(rng)
    n = 4000
    x = rng.uniform(cm.origin_x_m - 0.3, cm.origin_x_m + 3.3, n)  # off the grid too
    y = rng.uniform(cm.origin_y_m - 0.3, cm.origin_y_m + 3.3, n)
    yaw = rng.uniform(-math.pi, math.pi, n)
    margin = rng.uniform(0.0, cm.max_margin_m, n)
    for m in (0.0, margin):
        (count, clear), (count0, clear0) = _both(cm, "footprint_hits", x, y, yaw, True, m)
        assert np.array_equal(count, count0)
        assert clear.tobytes() == clear0.tobytes()
    assert np.count_nonzero(count) > 50  # the scene has obstacles the poses meet
    got, want = _both(cm, "footprint_collides", x, y, yaw)
    assert np.array_equal(got, want)


@pytest.mark.parametrize("seed", range(12))
def test_trajectories_collide_as_numpy_does_with_and_without_escape(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    cm = _scene(rng)
    m, k = 300, 40
    # arcs from one start pose off the obstacles' cells, often within the robot's reach of
    # one (the escape rule), sometimes anywhere
    obstacles = cm.checker._obstacle_xy
    while True:
        start = obstacles[rng.integers(len(obstacles))] + rng.normal(0.0, 0.15, 2)
        if seed % 3 == 0:
            start = rng.uniform(0.5, 2.5, 2) + np.array([cm.origin_x_m, cm.origin_y_m])
        near = (
            cm.checker._class_padded[cm.padded_index(*start)] == 1
        )  # within reach: tested exactly
        if cm.cost_at(*start) < LETHAL_OBSTACLE and (near or seed % 3 == 0):
            break
    v = rng.uniform(-0.3, 0.3, m)[:, None]
    w = rng.uniform(-2.0, 2.0, m)[:, None]
    t = np.linspace(0.0, 1.7, k)[None, :]
    yaw0 = rng.uniform(-math.pi, math.pi)
    yaw = yaw0 + w * t
    safe_w = np.where(np.abs(w) < 1e-9, 1e-9, w)
    x = start[0] + v / safe_w * (np.sin(yaw) - math.sin(yaw0))
    y = start[1] - v / safe_w * (np.cos(yaw) - math.cos(yaw0))
    margins = rng.uniform(0.0, cm.max_margin_m, m)
    mixed = False  # some trajectories collide and some do not: the test tells them apart
    for margin in (0.0, margins):
        for escape in (True, False):
            got, want = _both(cm, "trajectories_collide", x, y, yaw, escape, margin)
            assert np.array_equal(got, want), (margin, escape)
            mixed = mixed or 0 < np.count_nonzero(got) < m
    assert mixed or seed % 3 == 0  # a start anywhere may be far from every obstacle


@pytest.mark.parametrize("seed", range(10))
def test_dwb_rollouts_collide_where_they_are_as_numpys_folded_rows(seed: int) -> None:
    """DWB's roll-outs tested by the compiled loop that makes each pose where it is read give
    the numpy path's answer (poses folded into rows, then the row test), roll-out by roll-out,
    from starts near obstacles (the escape rule) until some roll-outs collide and some do not,
    and at every stride."""
    from jackson.host.actuation.limiter import LimiterConfig
    from jackson.host.nav.dwb import _CULL_STEPS, DwbConfig, DwbPlanner
    from jackson.host.nav.dwb.critics.base_obstacle import Sweep, collisions
    from jackson.host.nav.types import Pose2D

    rng = np.random.default_rng(300 + seed)
    cm = _scene(rng)
    obstacles = cm.checker._obstacle_xy
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    mixed = False
    for _ in range(200):
        start = obstacles[rng.integers(len(obstacles))] + rng.normal(0.0, 0.25, 2)
        if cm.cost_at(*start) >= LETHAL_OBSTACLE:
            continue
        pose = Pose2D(float(start[0]), float(start[1]), float(rng.uniform(-math.pi, math.pi)))
        velocity = (float(rng.uniform(-0.05, 0.3)), float(rng.uniform(-1.5, 1.5)))
        v, w, _ = planner.samples(*velocity)
        ro = planner.rollouts(pose, velocity, v, w)
        coarse = ro.coarse(_CULL_STEPS)
        sim_time_s = planner.config.sim_time_s
        got = collisions(Sweep(ro, coarse, v, w, velocity, cm, sim_time_s))
        saved, cm.checker._native = cm.checker._native, None
        try:
            want = collisions(Sweep(ro, coarse, v, w, velocity, cm, sim_time_s))
        finally:
            cm.checker._native = saved
        assert np.array_equal(got, want)
        mixed = 0 < np.count_nonzero(got) < len(v)
        if mixed:
            break
    assert mixed  # the test tells colliding roll-outs from the others
    # every stride, every roll-out, margins up to the largest
    rows = np.arange(len(v))
    stride = rng.integers(1, ro.steps + 1, len(v))
    margin = rng.uniform(0.0, cm.max_margin_m, len(v))
    got, _ = cm.rollouts_collide(
        (0.0 + pose.x, 0.0 + pose.y, float(ro.yaw_rad[0, 0])), ro.ds_m, ro.cos_sin, ro.yaw_rad,
        ro.iv, ro.iw, stride, margin,
    )  # fmt: skip
    x, y, yaw, owner = ro.at_strides(rows, stride)
    hit_rows = cm.trajectories_collide(x, y, yaw, margin_m=margin[owner])
    want = np.zeros(len(v), bool)
    want[owner[hit_rows]] = True
    assert np.array_equal(got, want)


@pytest.mark.parametrize("seed", range(8))
def test_dwb_tables_and_coarse_poses_are_numpys_bit_for_bit(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """DWB's roll-out tables (velocity profiles through zero, from rest, braking, turning
    either way) and their coarse poses at several strides, compiled and with numpy: the same
    bytes (signed zeros included); the coarse end pose is the last pose of the whole
    roll-out."""
    from jackson.host.actuation.limiter import LimiterConfig
    from jackson.host.nav.dwb import DwbConfig, DwbPlanner
    from jackson.host.nav.types import Pose2D

    rng = np.random.default_rng(700 + seed)
    planner = DwbPlanner(DwbConfig(), LimiterConfig())
    for case in range(12):
        pose = Pose2D(*rng.uniform(-3.0, 3.0, 2), float(rng.uniform(-math.pi, math.pi)))
        velocity = (
            (0.0, 0.0) if case == 0 else
            (0.0, float(rng.uniform(-1.5, 1.5))) if case == 1 else
            (float(rng.uniform(-0.1, 0.35)), float(rng.uniform(-2.0, 2.0)))
        )  # fmt: skip
        v, w, _ = planner.samples(*velocity)
        got = []
        for lib in (native.LIB, None):
            monkeypatch.setattr(native, "LIB", lib)
            ro = planner.rollouts(pose, velocity, v, w)
            tables = [ro.ds_m, ro.yaw_rad, ro.cos_sin]
            for stride in (1, 5, 16, ro.steps):
                tables += list(ro.coarse(stride))
            got.append(tables)
            x, y, _ = ro.full()
            x_c, y_c, _ = ro.coarse(16)
            assert np.array_equal(x_c[-1], x[:, -1]) and np.array_equal(y_c[-1], y[:, -1])
        for a, b in zip(*got, strict=True):
            assert a.shape == b.shape and a.tobytes() == b.tobytes()


def test_rollouts_collide_refuses_indices_off_the_tables() -> None:
    cm = _scene(np.random.default_rng(1))
    ds, cs, yaw = np.zeros((2, 4)), np.zeros((6, 4)), np.zeros((3, 5))
    one = np.zeros(1, np.int_)
    for iv, iw, stride in ((one + 2, one, one + 1), (one, one + 3, one + 1), (one, one, one)):
        with pytest.raises(ValueError, match="ramp index off its table, or a stride below 1"):
            cm.rollouts_collide((0.0, 0.0, 0.0), ds, cs, yaw, iv, iw, stride, np.zeros(1))


def test_the_library_reports_itself() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "jackson.host.nav.native"], capture_output=True, text=True
    )
    assert out.returncode == 0 and "compiled (" in out.stdout


@pytest.mark.parametrize("seed", range(6))
def test_rays_clear_the_cells_numpy_clears(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Scans from a moving sensor (returns near and far, some beyond the window, some closer
    than the minimum range): the same obstacle layer and costs compiled and with numpy."""
    maps = []
    for lib in (native.LIB, None):
        monkeypatch.setattr(native, "LIB", lib)
        cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0)
        scan_rng = np.random.default_rng(seed)
        for i in range(8):
            sensor = (0.1 * i, -0.05 * i)
            cm.recentre(*sensor)
            a = np.linspace(-math.pi, math.pi, 1060, endpoint=False)
            r = scan_rng.uniform(0.05, 4.0, a.size)
            cm.update(
                np.column_stack((sensor[0] + r * np.cos(a), sensor[1] + r * np.sin(a))), sensor
            )
        maps.append((cm.obstacle_layer.copy(), cm.costs.copy()))
    assert np.array_equal(maps[0][0], maps[1][0])
    assert np.array_equal(maps[0][1], maps[1][1])


@pytest.mark.parametrize("seed", range(8))
def test_rays_from_anywhere_clear_what_numpy_clears(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The compiled rays visit only the samples that can lie on the grid: from sensors inside,
    on the edge of and outside the grid (rays entering it, crossing it, missing it), along the
    axes and the grid lines too, every cell numpy's samples clear and no other."""
    from jackson.common.geometry import GridGeometry
    from jackson.host.nav.costmap import ObstacleLayer

    rng = np.random.default_rng(700 + seed)
    res = float(rng.choice([0.025, 0.05, 0.1]))
    g = GridGeometry(float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), res, 37, 52)
    config = CostmapConfig(raytrace_max_range_m=float(rng.uniform(1.0, 6.0)))
    centre = (g.origin_x_m + 26 * res, g.origin_y_m + 18.5 * res)
    sensors = [
        centre, (g.origin_x_m, g.origin_y_m), (g.origin_x_m - 1.3, centre[1]),
        (centre[0] + 3.0, g.origin_y_m - 0.7), (g.origin_x_m + 5 * res, centre[1]),
    ]  # fmt: skip
    angles = np.concatenate(
        (rng.uniform(-math.pi, math.pi, 40), np.arange(8) * (math.pi / 4))  # axes, diagonals
    )
    ranges = [rng.uniform(0.0, 7.0, angles.size) for _ in sensors]
    cleared = {}
    for lib in (native.LIB, None):
        monkeypatch.setattr(native, "LIB", lib)
        for i, (sensor, r) in enumerate(zip(sensors, ranges, strict=True)):
            layer = ObstacleLayer(config, g, discs=False)
            layer.costs[...] = LETHAL_OBSTACLE
            p = np.column_stack((sensor[0] + r * np.cos(angles), sensor[1] + r * np.sin(angles)))
            d = p - np.asarray(sensor)
            layer._clear_rays(p, d, np.hypot(d[:, 0], d[:, 1]), sensor, g)
            cleared.setdefault(i, []).append(layer.costs == 0)
    for i, (compiled, interpreted) in cleared.items():
        assert np.array_equal(compiled, interpreted), sensors[i]
    counts = [int(np.count_nonzero(c[0])) for c in cleared.values()]
    assert counts[0] > 0 and all(n < g.rows * g.cols for n in counts), counts


@pytest.mark.parametrize("seed", range(8))
def test_the_obstacle_layer_clears_and_marks_as_numpy_does(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One scan into the obstacle layer in one compiled call (rays, marks, the cells' discs of
    returns) and by numpy: the same costs, centroids, spreads and marked returns, byte for byte,
    from sensors inside and outside the grid, with returns off it, stacked in one cell, beyond
    the marking range or too near to clear, none at all, and without discs."""
    from jackson.common.geometry import GridGeometry
    from jackson.host.nav.costmap import ObstacleLayer

    rng = np.random.default_rng(900 + seed)
    res = float(rng.choice([0.025, 0.05, 0.1]))
    g = GridGeometry(float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), res, 41, 57)
    config = CostmapConfig(
        raytrace_min_range_m=float(rng.choice([0.0, 0.3, 0.9])),
        raytrace_max_range_m=float(rng.uniform(1.0, 6.0)),
        obstacle_max_range_m=float(rng.uniform(0.5, 5.0)),
    )
    centre = (g.origin_x_m + 28 * res, g.origin_y_m + 20.5 * res)
    sensors = [centre, (g.origin_x_m - 1.1, centre[1]), (g.origin_x_m, g.origin_y_m)]
    scans = []
    for sensor in sensors:
        n = int(rng.integers(0, 400))
        angles = rng.uniform(-math.pi, math.pi, n)
        r = rng.uniform(0.0, 6.0, n)
        p = np.column_stack((sensor[0] + r * np.cos(angles), sensor[1] + r * np.sin(angles)))
        stacked = np.asarray(centre) + rng.normal(0.0, 0.2 * res, (12, 2))  # one cell, many
        scans.append((np.concatenate((p, stacked)), sensor))
    scans.append((np.empty((0, 2)), centre))
    results = []
    for lib in (native.LIB, None):
        monkeypatch.setattr(native, "LIB", lib)
        for discs in (True, False):
            layer = ObstacleLayer(config, g, discs=discs)
            layer.costs[::3] = LETHAL_OBSTACLE
            out = []
            for points, sensor in scans:
                layer.update(points, sensor, g)
                out += [layer.costs.copy(), layer.last_returns.copy()]
            results.append([*out, layer.hit_xy, layer.hit_spread_m])
    for compiled, interpreted in zip(results[:2], results[2:], strict=True):
        for a, b in zip(compiled, interpreted, strict=True):
            assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
    assert np.count_nonzero(results[0][0] == LETHAL_OBSTACLE) > 0
    assert np.count_nonzero(results[0][-1]) > 0 or config.obstacle_max_range_m < 0.6


@pytest.mark.parametrize("seed", range(6))
def test_the_checkers_discs_and_classes_are_numpys(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A costmap version's footprint checker made compiled (the discs of the returns and of the
    static map's cells, the bounds, the padded ids, the cell classes) and by numpy: the same
    arrays and distances, byte for byte, with obstacles and without any."""
    from jackson.host.nav.costmap import FootprintChecker

    cm = _scene(np.random.default_rng(30 + seed))
    if seed == 5:
        cm.clear_obstacles()
    master = cm.costs.copy()
    lethal = master == LETHAL_OBSTACLE
    dist = cm.lethal_distance_m
    args = (cm.config, cm.geometry, master, lethal, dist, cm.static.costs, cm.obstacles, 1)
    made = []
    for lib in (native.LIB, None):
        monkeypatch.setattr(native, "LIB", lib)
        made.append(FootprintChecker(*args))
    a, b = made
    for name in ("_obstacle_xy", "_obstacle_r_m", "_obstacle_cells", "_ids_padded",
                 "_class_padded", "_neighbour_offsets"):  # fmt: skip
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes(), name
    assert (a._near_m, a._deep_m, a._pad_k) == (b._near_m, b._deep_m, b._pad_k)
    assert (len(a._obstacle_cells) > 0) == (seed != 5 or np.any(cm.static.costs == LETHAL_OBSTACLE))


@pytest.mark.parametrize("seed", range(4))
def test_the_escape_rule_is_numpys_at_starts_near_and_among_obstacles(seed: int) -> None:
    """The escape rule's allowance and floor for a start pose (how many obstacles it already
    overlaps with each margin, its clearance), compiled and by numpy: the same numbers at starts
    in the clear, near, deep among and on obstacles, with repeated and distinct margins."""
    rng = np.random.default_rng(60 + seed)
    cm = _scene(rng)
    checker = cm.checker
    g = cm.geometry
    classes = set()
    for _ in range(60):
        start = (
            float(rng.uniform(g.origin_x_m, g.origin_x_m + g.cols * g.resolution_m)),
            float(rng.uniform(g.origin_y_m, g.origin_y_m + g.rows * g.resolution_m)),
            float(rng.uniform(-math.pi, math.pi)),
        )
        margins = rng.choice([0.0, 0.004, 0.0125], int(rng.integers(1, 30)))
        got, want = _both(cm, "_escape", start, margins, True)
        for a, b in zip(got, want, strict=True):  # type: ignore[call-overload]
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), start
        classes.add(int(checker._class_padded[g.padded_index(start[0], start[1])]))
    assert {1, 2} <= classes  # starts near and deep were among them


def test_calls_leave_no_garbage_for_the_collector() -> None:
    """A call builds no reference cycles (numpy's ctypes adapters did, on every call: garbage
    that the daemon's settled collector reaches rarely, so its memory grew while navigating)."""
    import gc

    cm = _scene(np.random.default_rng(5))
    x, y = np.full((20, 10), cm.origin_x_m + 1.5), np.full((20, 10), cm.origin_y_m + 1.5)
    yaw = np.zeros((20, 10))
    cm.trajectories_collide(x, y, yaw)
    gc.collect()
    gc.disable()
    try:
        before = len(gc.get_objects())
        for _ in range(300):
            cm.trajectories_collide(x, y, yaw)
            cm.footprint_collides(x[0], y[0], yaw[0])
            cm.update(np.array([[cm.origin_x_m + 2.0, cm.origin_y_m + 2.0]]), (0.0, 0.0))
        grown = len(gc.get_objects()) - before
    finally:
        gc.enable()
    assert grown < 100, grown


@pytest.mark.parametrize("seed", range(4))
def test_dwb_distance_maps_are_scipys_search_bit_for_bit(seed: int) -> None:
    # the compiled breadth-first search against grid_graph + grid_distance (scipy's search):
    # random grids with walls, sources on obstacles, no sources at all, one row or column
    from jackson.host.nav.dwb.core.distance import grid_distance, grid_graph

    rng = np.random.default_rng(seed)
    for trial in range(60):
        rows, cols = (int(x) for x in rng.integers(1, 70, 2))
        free = rng.random((rows, cols)) < rng.uniform(0.3, 1.0)
        sources = rng.random((rows, cols)) < (0.0 if trial % 9 == 0 else rng.uniform(0.0, 0.05))
        want = grid_distance(grid_graph(free), (rows, cols), sources)
        got = native.grid_distance(free, sources)
        assert got.tobytes() == want.tobytes(), (seed, trial)
        if not sources.any():
            assert (got == rows * cols).all()


@pytest.mark.parametrize("seed", range(4))
def test_the_distance_transform_is_scipys_bit_for_bit(seed: int) -> None:
    # the compiled two-pass transform against scipy's, on grids of every density (none and
    # every cell a feature among them), one row or one column, and a costmap-sized one
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    for trial in range(80):
        rows, cols = (int(x) for x in rng.integers(1, 90, 2))
        density = [0.0, 1.0, 0.001, 0.02, 0.3, 0.8][trial % 6]
        feature = rng.random((rows, cols)) < density
        got = native.distance_to(feature)
        if feature.any():
            want = np.asarray(ndimage.distance_transform_edt(~feature), np.float64)
        else:
            want = np.full((rows, cols), np.inf)
        assert got.tobytes() == want.tobytes(), (seed, trial)


def test_the_costmap_inflates_as_with_scipys_transform(monkeypatch: pytest.MonkeyPatch) -> None:
    # the same scans on costmaps with the compiled transform and with the library switched off:
    # a local one (collision checks, the whole grid) and a global one (windowed updates)
    grid = OccupancyGrid.empty(4.0, 4.0, 0.05, -2.0, -2.0)
    rng = np.random.default_rng(7)
    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    scans = [
        (np.column_stack((r * np.cos(angles), r * np.sin(angles))) + sensor, sensor)
        for sensor, r in (
            (np.array([0.0, 0.0]), 1.0 + 0.6 * rng.random(720)),
            (np.array([0.4, -0.2]), 0.8 + 0.2 * rng.random(720)),
        )
    ]
    probe = (scans[0][0][:, 0] * 0.5, scans[0][0][:, 1] * 0.5)
    results = []
    for lib in (native.LIB, None):
        monkeypatch.setattr(native, "LIB", lib)
        maps = [Costmap.from_map(grid, CostmapConfig(), checks) for checks in (True, False)]
        for costmap in maps:
            for points, sensor in scans:
                costmap.update(points, (float(sensor[0]), float(sensor[1])))
        results.append(
            [m.costs.tobytes() for m in maps]
            + [m.lethal_distance_m.tobytes() for m in maps]
            + [maps[0].clear_reach_m(*probe).tobytes()]
        )
    assert results[0] == results[1]


@pytest.mark.parametrize("seed", range(6))
def test_layers_combine_and_inflate_as_numpy_does(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Random static and obstacle layers (free, unknown, lethal, costs between) at several
    resolutions and inflation radii, with and without a distance cap: the compiled combination
    and inflation give numpy's costs, lethal cells and distances, byte for byte."""
    rng = np.random.default_rng(900 + seed)
    res = float(rng.choice([0.025, 0.05, 0.1]))
    config = CostmapConfig(
        inflation_radius_m=float(rng.uniform(0.2, 0.8)),
        cost_scaling_factor=float(rng.uniform(1.0, 12.0)),
    )
    rows, cols = (int(n) for n in rng.integers(5, 90, 2))
    values = np.array([0, 0, 0, 255, 254, 100, 253], np.uint8)
    static = values[rng.integers(0, len(values), (rows, cols))]
    obstacle = np.where(rng.random((rows, cols)) < 0.05, 254, 255).astype(np.uint8)
    obstacle[rng.random((rows, cols)) < 0.3] = 0
    if seed == 0:
        static[...] = 0
        obstacle[...] = 255  # no lethal cell anywhere
    cm = Costmap.from_map(
        OccupancyGrid.empty(cols * res, rows * res, res, 0.0, 0.0), config, seed % 2 == 0
    )
    cm.static.costs, cm.obstacles.costs = static, obstacle
    everything = (slice(None), slice(None))
    for far in (math.inf, config.inflation_radius_m):
        got = cm._combined(everything, far)
        monkeypatch.setattr(native, "LIB", None)  # each layer's update_costs in turn
        want = cm._combined(everything, far)
        monkeypatch.undo()
        for a, b in zip(got, want, strict=True):
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes()


def test_a_checker_pickled_with_the_library_tests_with_numpy_where_it_is_not(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A run folder's snapshot written by a daemon with the build, replayed in a checkout
    without one: its costmap's checker loads with numpy's tests (it failed on an assertion),
    and answers as it did."""
    import pickle

    cm = _scene(np.random.default_rng(11))
    x, y = np.full((6, 8), cm.origin_x_m + 1.5), np.full((6, 8), cm.origin_y_m + 1.5)
    x += np.linspace(0.0, 2.5, 8)
    yaw = np.zeros((6, 8))
    want = cm.trajectories_collide(x, y, yaw)
    blob = pickle.dumps(cm)
    monkeypatch.setattr(native, "LIB", None)
    loaded = pickle.loads(blob)
    assert not loaded.checker.compiled
    assert np.array_equal(loaded.trajectories_collide(x, y, yaw), want)


@pytest.mark.parametrize("seed", range(4))
def test_costs_at_points_are_numpys(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Points on and off the grid, on cell edges (where the division rounds), far off it and
    infinite, in arrays of several shapes; a NaN goes to numpy's path (which raises)."""
    rng = np.random.default_rng(seed)
    costmap = _scene(rng)
    g = costmap.geometry
    edges_x = g.origin_x_m + np.arange(-2, g.cols + 3) * g.resolution_m
    edges_y = g.origin_y_m + np.arange(-2, g.rows + 3) * g.resolution_m
    ex, ey = np.meshgrid(edges_x, edges_y)
    span = max(g.rows, g.cols) * g.resolution_m
    cases = [
        (rng.uniform(g.origin_x_m - 1, g.origin_x_m + span + 1, 5000),
         rng.uniform(g.origin_y_m - 1, g.origin_y_m + span + 1, 5000)),
        (ex, ey),
        (np.nextafter(ex, -np.inf), np.nextafter(ey, np.inf)),
        (np.array([np.inf, -np.inf, 1e300, -1e300, 0.0]),
         np.array([0.0, 0.0, 1e300, -1e300, -0.0])),
        (rng.uniform(-3, 3, (7, 11, 3)), rng.uniform(-3, 3, (7, 11, 3))),
    ]  # fmt: skip
    for x, y in cases:
        got = costmap.cost_at(x, y)
        with monkeypatch.context() as m:
            m.setattr(native, "LIB", None)
            want = costmap.cost_at(x, y)
        assert got.dtype == want.dtype == np.uint8 and got.shape == want.shape
        assert np.array_equal(got, want)
    assert (costmap.cost_at(*cases[0]) == LETHAL_OBSTACLE).any()
    # a NaN: numpy's path answers, whatever it answers (an index error, or the cell its cast
    # of NaN lands on), and never the compiled loop
    for x, y in ((np.array([0.0, np.nan]), np.zeros(2)), (np.zeros(2), np.array([0.0, np.nan]))):
        outcomes = []
        for lib in (native.LIB, None):
            with monkeypatch.context() as m, np.errstate(invalid="ignore"):
                m.setattr(native, "LIB", lib)
                try:
                    outcomes.append(costmap.cost_at(x, y).tolist())
                except IndexError as e:
                    outcomes.append(str(e))
        assert outcomes[0] == outcomes[1]


@pytest.mark.parametrize("seed", range(6))
def test_the_path_ahead_is_blocked_where_numpy_says(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Paths through free space and through walls, robots on and off the path, two points
    equally near (argmin's first), a path leaving the window, an empty path."""
    from jackson.host.control.navigator_config import NavigatorConfig
    from jackson.host.control.replanning import GlobalPlanning
    from jackson.host.nav.types import Pose2D

    rng = np.random.default_rng(seed)
    local = _scene(rng)
    static = OccupancyGrid.empty(12.0, 9.0, 0.05, -6.0, -4.5, fill=0)
    static.data[rng.integers(0, 180), 20:200] = 100
    glob = Costmap.from_map(static, CostmapConfig(), collision_checks=False)
    planning = GlobalPlanning(NavigatorConfig(), glob, glob, local)
    answers = []
    for _ in range(60):
        n = int(rng.integers(0, 400))
        start = rng.uniform(-5.0, 5.0, 2)
        steps = rng.normal(0.0, 0.05, (n, 2)).cumsum(axis=0)
        path = start + steps if n else np.zeros((0, 2))
        if n > 4 and rng.random() < 0.3:
            path[n // 2] = path[n // 4]  # two points equally near
        planning.path = path
        xy = path[int(rng.integers(0, n))] if n and rng.random() < 0.5 else rng.uniform(-5, 5, 2)
        pose = Pose2D(float(xy[0]), float(xy[1]), 0.0)
        got = planning.path_blocked(pose)
        with monkeypatch.context() as m:
            m.setattr(native, "LIB", None)
            want = planning.path_blocked(pose)
        assert got is want
        answers.append(got)
    assert True in answers and False in answers


def test_the_path_ahead_starts_at_the_first_nearest_point_and_leaves_out_exactly_near(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A path through a wall and back to where the robot stands (the first of the two nearest
    points counts: blocked), and a wall point exactly ``near`` away (left out: not blocked)."""
    from jackson.host.control.navigator_config import NavigatorConfig
    from jackson.host.control.replanning import GlobalPlanning
    from jackson.host.nav.types import Pose2D

    config = NavigatorConfig()
    near = config.costmap.robot_radius_m + 0.05

    def planning_with_wall_at(x_m: float) -> GlobalPlanning:
        static = OccupancyGrid.empty(4.0, 4.0, 0.05, -2.0, -2.0, fill=0)
        col = int((x_m + 2.0) / 0.05)
        static.data[:, col] = 100
        glob = Costmap.from_map(static, CostmapConfig(), collision_checks=False)
        assert glob.resolution_m == 0.05
        local = Costmap.rolling_window(CostmapConfig(), -1.5, -1.5)
        return GlobalPlanning(config, glob, glob, local)

    back = np.array([[0.0, 0.0], [1.05, 0.0], [0.0, 0.0], [0.0, 0.5]])
    exact = np.array([[0.0, 0.0], [near, 0.0]])
    assert math.hypot(exact[1, 0] - 0.0, 0.0) == near
    for path, wall_x, expected in ((back, 1.05, True), (exact, near, False)):
        planning = planning_with_wall_at(wall_x)
        assert int(planning.global_costmap.cost_at(path[1:2, 0], path[1:2, 1])[0]) >= 253
        planning.path = path
        got = planning.path_blocked(Pose2D(0.0, 0.0, 0.0))
        with monkeypatch.context() as m:
            m.setattr(native, "LIB", None)
            want = planning.path_blocked(Pose2D(0.0, 0.0, 0.0))
        assert got is want is expected
