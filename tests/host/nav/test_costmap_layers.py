"""The costmap as layers: the grid geometry they share, each layer behind the one interface, the
footprint checker of each version of the costs, and costmaps pickled before the layers."""

from __future__ import annotations

import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from jackson.common.geometry import GridGeometry
from jackson.host.nav import native
from jackson.host.nav.costmap import (
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    Costmap,
    CostmapConfig,
    FootprintChecker,
    InflationLayer,
    Layer,
    ObstacleLayer,
    StaticLayer,
)
from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.likelihood import LikelihoodField

DATA = Path(__file__).parent / "data"


def _circle(cx: float, cy: float, r: float, n: int, phase: float) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False) + phase
    return np.column_stack((cx + r * np.cos(a), cy + r * np.sin(a)))


def _map() -> OccupancyGrid:
    data = np.zeros((40, 40), np.int8)
    data[25, 5:30] = 100  # a wall
    data[0:5, 0:5] = -1  # unknown
    return OccupancyGrid(data, 0.05, -1.0, -1.0)


def test_a_grid_geometry_places_cells_as_the_grids_do() -> None:
    grid = _map()
    g = grid.geometry
    assert g == GridGeometry(-1.0, -1.0, 0.05, 40, 40) and g.shape == grid.shape
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-1.5, 1.5, (2, 500))  # on and off the grid
    for a, b in zip(g.world_to_cell(x, y), grid.world_to_cell(x, y), strict=True):
        assert np.array_equal(a, b)
    field = LikelihoodField.from_grid(grid)
    assert field.geometry == g
    # the padded index: a point on the grid lands on its cell, off it on the ring
    r, c = g.world_to_cell(x, y)
    inside = g.inside(r, c)
    index = g.padded_index(x, y)
    assert np.array_equal(index[inside], (r[inside] + 1) * 42 + c[inside] + 1)
    pr, pc = np.divmod(index[~inside], 42)
    assert np.all((pr == 0) | (pr == 41) | (pc == 0) | (pc == 41))
    # one point at a time (plain floats, numpy's floats, on cell edges, -0, NaN, infinity): the
    # index of the whole array's
    edges = (g.origin_x_m + np.arange(-2, 45) * g.resolution_m).tolist()
    points = [*zip(x.tolist(), y.tolist(), strict=True), *zip(edges, edges[::-1], strict=True)]
    for xi, yi in points:
        for px, py in ((xi, yi), (np.float64(xi), np.float64(yi))):
            assert g.padded_index(px, py) == g.padded_index(np.array([px]), np.array([py]))[0]
    for px, py in ((-0.0, 0.0), (math.inf, -math.inf), (1e300, -1e300)):
        assert g.padded_index(px, py) == g.padded_index(np.array([px]), np.array([py]))[0]
    # and a point's cell, a cell's centre: numpy's scalars, of the same values
    for px, py in [*points, (-0.0, 0.0)]:
        one = g.world_to_cell(px, py)
        many = g.world_to_cell(np.array([px]), np.array([py]))
        assert [type(v) for v in one] == [np.int_, np.int_]
        assert (int(one[0]), int(one[1])) == (int(many[0][0]), int(many[1][0]))
    for r, c in ((0, 0), (-3, 57), (np.int64(12), np.int64(-1)), (2**40, 7)):
        one_xy = g.cell_to_world(r, c)
        many_xy = g.cell_to_world(np.array([r]), np.array([c]))
        assert [type(v) for v in one_xy] == [np.float64, np.float64]
        assert one_xy[0] == many_xy[0][0] and one_xy[1] == many_xy[1][0]
    # a rolling window moves by whole cells and stays on the map frame's cells
    w = GridGeometry.centred(0.33, -0.21, 60, 0.05)
    assert (w.origin_x_m, w.origin_y_m) == (
        math.floor(-1.17 / 0.05) * 0.05,
        math.floor(-1.71 / 0.05) * 0.05,
    )
    moved = w.moved(2, -3)
    assert (
        moved.origin_x_m == w.origin_x_m - 3 * 0.05 and moved.origin_y_m == w.origin_y_m + 2 * 0.05
    )
    with pytest.raises(ValueError, match="at least 1 x 1"):
        GridGeometry(0.0, 0.0, 0.05, 0, 3)


def test_the_layers_combine_in_order_through_their_one_interface() -> None:
    """The master's costs are the static layer written, the obstacle layer over it, then the
    inflation: each layer's ``update_costs`` in turn gives them, over any window."""
    cm = Costmap.from_map(_map(), CostmapConfig(track_unknown_space=True))
    cm.update(_circle(0.0, 0.0, 0.6, 90, 0.0), (0.0, 0.0))
    layers: list[Layer] = [cm.static, cm.obstacles, cm.inflation]
    assert [type(x) for x in layers] == [StaticLayer, ObstacleLayer, InflationLayer]
    everything = (slice(None), slice(None))
    master = np.empty(cm.shape, np.uint8)
    for layer in layers:
        layer.update_costs(master, everything)
    assert np.array_equal(master, cm.costs)
    assert cm.static.costs[25, 10] == LETHAL_OBSTACLE and cm.static.costs[2, 2] == NO_INFORMATION
    assert np.count_nonzero(cm.obstacles.costs == LETHAL_OBSTACLE) > 50
    # a window of the grid: the same costs where inflation cannot reach past its edge
    window = (slice(5, 30), slice(8, 33))
    part = np.empty((25, 25), np.uint8)
    for layer in layers:
        layer.update_costs(part, window)
    k = math.ceil(cm.config.inflation_radius_m / cm.resolution_m) + 1
    assert np.array_equal(part[k:-k, k:-k], cm.costs[5 + k : 30 - k, 8 + k : 33 - k])


def test_each_version_of_the_costs_has_its_own_footprint_checker() -> None:
    cm = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0, size_m=1.5)
    first = cm.checker
    assert isinstance(first, FootprintChecker) and first.version == cm.version
    assert not cm.footprint_collides(0.0, 0.0, 0.0)
    cm.update(_circle(0.5, 0.0, 0.1, 60, 0.0), (0.0, 0.0))  # a post 0.4 m ahead
    assert cm.checker is not first and cm.checker.version == cm.version
    assert cm.footprint_collides(0.3, 0.0, 0.0) and not cm.footprint_collides(0.0, 0.0, 0.0)
    assert cm.compiled == (native.LIB is not None)
    planning = Costmap.from_map(_map(), CostmapConfig(), collision_checks=False)
    assert not planning.compiled
    with pytest.raises(RuntimeError, match="without collision checks"):
        planning.footprint_collides(0.0, 0.0, 0.0)


def _further(glob: Costmap, local: Costmap) -> dict[str, np.ndarray]:
    """The operations the fixture's expected values were recorded after (in this order)."""
    out = {}
    glob.update(_circle(0.1, 0.1, 0.5, 80, 0.3), (0.1, 0.1))
    out["glob_costs"] = glob.costs.copy()
    out["glob_dist"] = glob.lethal_distance_m.copy()
    local.recentre(0.2, 0.1)
    local.update(_circle(0.2, 0.1, 0.40, 120, 0.05), (0.2, 0.1))
    out["local_costs"] = local.costs.copy()
    out["local_dist"] = local.lethal_distance_m.copy()
    rng = np.random.default_rng(7)
    x = 0.2 + rng.uniform(-0.25, 0.25, 200)
    y = 0.1 + rng.uniform(-0.25, 0.25, 200)
    yaw = rng.uniform(-3, 3, 200)
    out["poses"] = np.stack((x, y, yaw))
    out["footprint"] = local.footprint_collides(x, y, yaw)
    heading = np.linspace(-3, 3, 30)[:, None]
    tx = 0.2 + np.cumsum(np.full((30, 12), 0.012) * np.cos(heading), axis=1)
    ty = 0.1 + np.cumsum(np.full((30, 12), 0.012) * np.sin(heading), axis=1)
    tyaw = np.broadcast_to(heading, (30, 12)).copy()
    tx[:, 0] = 0.2
    ty[:, 0] = 0.1
    out["traj"] = np.stack((tx, ty, tyaw))
    out["traj_collide"] = local.trajectories_collide(tx, ty, tyaw, margin_m=0.01)
    out["body_depth"], out["body_clear"] = local.body_contacts(x[:10], y[:10], yaw[:10])
    out["reach"] = local.clear_reach_table().copy()
    local.clear_obstacles(0.3, (0.2, 0.1))
    out["cleared_costs"] = local.costs.copy()
    return out


def test_a_costmap_pickled_before_the_layers_answers_and_updates_as_it_did() -> None:
    """``costmap_single_class.pickle``: a global costmap (tracking unknown space, without
    collision checks) and a rolling local one with a static map, after scans and a move,
    pickled by the costmap when it was one class (a core's snapshot holds them). The ``.npz``
    holds what that costmap gave for :func:`_further`: a restored one gives the same, byte
    for byte, and so does one built and updated now."""
    want = np.load(DATA / "costmap_single_class.npz")
    old = pickle.loads((DATA / "costmap_single_class.pickle").read_bytes())
    assert isinstance(old["local"].static, StaticLayer)
    got = _further(old["global"], old["local"])
    assert sorted(got) == sorted(want.files)
    for key in want.files:
        assert got[key].tobytes() == want[key].tobytes(), key
    assert 0 < np.count_nonzero(want["footprint"]) < 200
    assert 0 < np.count_nonzero(want["traj_collide"]) < 30
    # built now from the same map and scans
    grid = _map()
    glob = Costmap.from_map(grid, CostmapConfig(track_unknown_space=True), collision_checks=False)
    glob.update(_circle(0.0, 0.0, 0.6, 90, 0.0), (0.0, 0.0))
    local = Costmap.rolling_window(CostmapConfig(), 0.0, 0.0, size_m=1.2, static_map=grid)
    local.update(_circle(0.0, 0.0, 0.45, 120, 0.01), (0.0, 0.0))
    local.recentre(0.12, 0.07)
    local.update(_circle(0.12, 0.07, 0.42, 120, 0.02), (0.12, 0.07))
    restored = pickle.loads(pickle.dumps({"global": glob, "local": local}))
    for maps in ((glob, local), (restored["global"], restored["local"])):
        got = _further(*maps)
        for key in want.files:
            assert got[key].tobytes() == want[key].tobytes(), key
