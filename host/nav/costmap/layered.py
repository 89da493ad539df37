"""The layered costmap (Nav2's ``LayeredCostmap`` with its ``Costmap2DROS``): the master grid,
fixed over a whole map or rolling with the robot, combined from its layers at every change.

A :class:`Costmap` either covers a whole map (the global costmap) or is a rolling window that
moves with the robot (the local costmap: 3 m x 3 m at 0.05 m in Nav2's bringup), keeping the
overlapping part of its obstacle layer as it moves. Its layers (:mod:`.layers`) are combined in
order: the static layer's cells, the obstacle layer's over them, then the inflation. With the
compiled library the three are one call (:func:`jackson.host.nav.native.combine_inflate`,
byte for byte the layers' own result, tested); without it each layer's ``update_costs`` runs.

With collision checks (the local costmap) each version of the costs gets its
:class:`~.footprint.FootprintChecker`, which the costmap's collision methods ask. Without them
(the global costmap, which A* and the blocked-path test read) a scan re-combines only the
part of the grid it can change, so its cost does not grow with the map, and
``lethal_distance_m`` is exact only up to the inflation radius (farther cells read ``inf``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import GridCells, GridGeometry
from jackson.host.nav import native, native_grid
from jackson.host.nav.costmap.footprint import FootprintChecker, ringed
from jackson.host.nav.costmap.layers import InflationLayer, ObstacleLayer, StaticLayer, Window
from jackson.host.nav.costmap.values import (
    NO_INFORMATION,
    BoolArray,
    CostArray,
    CostmapConfig,
    FloatArray,
    IntArray,
)
from jackson.host.nav.grid import OccupancyGrid


class Costmap(GridCells):
    """A static + obstacle + inflation costmap on a fixed or rolling grid (map frame).

    Build one with :meth:`from_map` (the global costmap over a whole map) or
    :meth:`rolling_window` (the local costmap around the robot).

    Parameters
    ----------
    config : CostmapConfig
        Robot shape, inflation and ranges.
    rows, cols : int
        Grid size [cells].
    resolution_m : float
        Cell edge [m].
    origin_x_m, origin_y_m : float
        Lower-left corner of cell (0, 0) in the map frame [m].
    static_map : OccupancyGrid or None
        The map whose occupied cells form the static layer (sampled at this grid's cell
        centres); None for no static layer.
    rolling : bool
        Whether :meth:`recentre` may move the grid.
    collision_checks : bool
        Keep a footprint checker for :meth:`footprint_collides` and the other collision tests
        (the local costmap); without it a scan re-combines only what it can change.

    Attributes
    ----------
    config : CostmapConfig
        As given.
    resolution_m, origin_x_m, origin_y_m : float
        The grid's cell edge and current origin [m].
    static, obstacles, inflation : StaticLayer, ObstacleLayer, InflationLayer
        The layers, in the order they combine.
    costs : ndarray of uint8, shape (rows, cols)
        The master costmap (row 0 at the lowest y), updated by every change.
    lethal_distance_m : ndarray of float, shape (rows, cols)
        Distance from each cell centre to the nearest lethal cell centre [m] (``inf`` when
        there is none).
    version : int
        Counts the changes of ``costs`` (for caches of derived data).
    """

    def __init__(
        self,
        config: CostmapConfig,
        rows: int,
        cols: int,
        resolution_m: float,
        origin_x_m: float = 0.0,
        origin_y_m: float = 0.0,
        static_map: OccupancyGrid | None = None,
        rolling: bool = False,
        collision_checks: bool = True,
    ) -> None:
        if rows < 1 or cols < 1:
            raise ValueError(f"Costmap: size must be at least 1 x 1 cells, got {rows} x {cols}")
        if not 0.0 < resolution_m < math.inf:
            raise ValueError(f"Costmap: resolution_m must be > 0, got {resolution_m}")
        self.config = config
        self._geometry = GridGeometry(
            float(origin_x_m), float(origin_y_m), float(resolution_m), rows, cols
        )
        self.resolution_m = self._geometry.resolution_m
        self.origin_x_m = self._geometry.origin_x_m
        self.origin_y_m = self._geometry.origin_y_m
        self._rolling = rolling
        self._collision_checks = collision_checks
        self.static = StaticLayer(config, self._geometry, static_map)
        self.obstacles = ObstacleLayer(config, self._geometry, collision_checks)
        self.inflation = InflationLayer(config, self._geometry.resolution_m)
        self._checker: FootprintChecker | None = None
        self.costs: CostArray = np.zeros((rows, cols), np.uint8)
        self.lethal_distance_m: FloatArray = np.full((rows, cols), math.inf)
        self.version = 0
        self._update_master()

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_map(
        cls, grid: OccupancyGrid, config: CostmapConfig, collision_checks: bool = True
    ) -> Costmap:
        """The global costmap: the map's grid, its occupied cells as the static layer.

        Parameters
        ----------
        grid : OccupancyGrid
            The static map.
        config : CostmapConfig
            Robot shape, inflation and ranges.
        collision_checks : bool
            Keep the footprint checker (see the class); False for a planning costmap.

        Returns
        -------
        Costmap
            A fixed grid identical in size, resolution and origin to ``grid``.
        """
        return cls(
            config, grid.height, grid.width, grid.resolution_m, grid.origin_x_m,
            grid.origin_y_m, static_map=grid, collision_checks=collision_checks,
        )  # fmt: skip

    @classmethod
    def rolling_window(
        cls,
        config: CostmapConfig,
        centre_x_m: float,
        centre_y_m: float,
        size_m: float = 3.0,
        resolution_m: float = 0.05,
        static_map: OccupancyGrid | None = None,
    ) -> Costmap:
        """A local costmap of ``size_m`` x ``size_m`` centred on a point, moving with it.

        Parameters
        ----------
        config : CostmapConfig
            Robot shape, inflation and ranges.
        centre_x_m, centre_y_m : float
            Initial centre (the robot) [m].
        size_m : float
            Window edge [m] (Nav2 bringup: 3 m).
        resolution_m : float
            Cell edge [m] (Nav2 bringup: 0.05 m).
        static_map : OccupancyGrid or None
            A map to copy into the window's static layer; None (Nav2 bringup's local
            costmap) to build it from the scans alone.

        Returns
        -------
        Costmap
            The rolling window.
        """
        n = max(1, round(size_m / resolution_m))
        g = GridGeometry.centred(centre_x_m, centre_y_m, n, resolution_m)
        return cls(
            config, n, n, resolution_m, g.origin_x_m, g.origin_y_m, static_map=static_map,
            rolling=True,
        )  # fmt: skip

    # ------------------------------------------------------------------ geometry

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return self._geometry.shape

    @property
    def geometry(self) -> GridGeometry:
        """The grid's place and size now."""
        return self._geometry

    @property
    def costs_padded(self) -> CostArray:
        """The master costs with a ring of NO_INFORMATION around them, flat, row-major over
        (rows + 2, cols + 2) (what :meth:`cost_at` reads; the compiled loops take it)."""
        return self._costs_padded

    def cost_at(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> CostArray:
        """Master cost at map-frame points; NO_INFORMATION off the grid.

        Parameters
        ----------
        x_m, y_m : array_like
            Points [m], any matching shapes.

        Returns
        -------
        ndarray of uint8
            Costs, the broadcast shape of the inputs.
        """
        if _float_arrays(x_m, y_m) and native.LIB is not None:
            grid = (self.origin_x_m, self.origin_y_m, self.resolution_m, *self.shape)
            found = native_grid.cost_at(x_m, y_m, grid, self._costs_padded)
            if found is not None:  # the same costs, compiled (None: a NaN, numpy's answer)
                return found
        return np.take(self._costs_padded, self.padded_index(x_m, y_m))

    # ------------------------------------------------------------------ changes

    def recentre(self, x_m: float, y_m: float, scan_follows: bool = False) -> None:
        """Move a rolling window so it is centred on (x, y), keeping the overlap.

        Does nothing for a fixed grid or when the window would not move a whole cell. A
        jump farther than the window's own size (a start far from where the window was
        made, a relocalisation) keeps nothing: the window starts unknown where it lands.

        Parameters
        ----------
        x_m, y_m : float
            New centre (the robot) [m].
        scan_follows : bool
            :meth:`update` comes next with a scan (a control tick with a new scan): the
            layers move now and are combined once, by the update, instead of twice. The
            costs are the same; until the update they are those of the window before.
        """
        if not self._rolling:
            return
        g = self._geometry
        target = GridGeometry.centred(x_m, y_m, g.rows, g.resolution_m)
        dc = round((target.origin_x_m - g.origin_x_m) / g.resolution_m)
        dr = round((target.origin_y_m - g.origin_y_m) / g.resolution_m)
        if dc == 0 and dr == 0:
            return
        self._geometry = g.moved(dr, dc)
        self.origin_x_m = self._geometry.origin_x_m
        self.origin_y_m = self._geometry.origin_y_m
        for layer in (self.static, self.obstacles, self.inflation):
            layer.match(self._geometry, (dr, dc))
        if scan_follows and self._collision_checks:  # update() combines everything
            return
        self._update_master()

    def set_static_map(self, static_map: OccupancyGrid | None) -> None:
        """Take a new map into the static layer and combine the layers again; the obstacle
        layer's marks stay (Nav2's static layer on a new /map, as a SLAM node publishes one
        every few seconds).

        Parameters
        ----------
        static_map : OccupancyGrid or None
            The map, sampled at this grid's cell centres; None for no static layer.
        """
        self.static.set_map(static_map, self._geometry)
        self._update_master()

    def update(self, points_xy: npt.ArrayLike, sensor_xy: tuple[float, float]) -> None:
        """Clear the rays to one scan's returns, mark the returns, combine and inflate
        (:meth:`ObstacleLayer.update`).

        Parameters
        ----------
        points_xy : array_like, shape (N, 2)
            The scan's valid returns in the map frame [m].
        sensor_xy : tuple of float
            The sensor's position in the map frame [m].
        """
        p = np.asarray(points_xy, np.float64).reshape(-1, 2)
        self.obstacles.update(p, sensor_xy, self._geometry)
        if self._collision_checks:
            self._update_master()
            return
        (r0, r1), (c0, c1) = self.world_to_cell(*self._changed_box(p, sensor_xy))
        self._update_window(int(r0), int(r1) + 1, int(c0), int(c1) + 1)

    def _changed_box(
        self, p: FloatArray, sensor_xy: tuple[float, float]
    ) -> tuple[list[float], list[float]]:
        """The x and y bounds [m] of the cells a scan's update of the obstacle layer can
        change, a cell wider on every side: the sensor and each ray to where it stops (rays
        are cleared up to raytrace_max_range_m, returns marked up to obstacle_max_range_m), as
        Nav2's obstacle layer bounds its update. In a corridor that is a strip, not the square
        of the ranges around the sensor, which the costs are combined and inflated over."""
        cfg = self.config
        sx, sy = sensor_xy
        reach = max(cfg.raytrace_max_range_m, cfg.obstacle_max_range_m)
        res = self.resolution_m
        if len(p):
            dx, dy = p[:, 0] - sx, p[:, 1] - sy
            f = np.minimum(1.0, reach / np.maximum(np.hypot(dx, dy), 1e-12))
            dx *= f
            dy *= f
            x0, x1 = min(float(dx.min()), 0.0), max(float(dx.max()), 0.0)
            y0, y1 = min(float(dy.min()), 0.0), max(float(dy.max()), 0.0)
            if math.isfinite(x0 + x1 + y0 + y1):
                return [sx + x0 - res, sx + x1 + res], [sy + y0 - res, sy + y1 + res]
        # no return, or one not finite: the square of the ranges
        return (
            [sx - reach - res, sx + reach + res],
            [sy - reach - res, sy + reach + res],
        )

    def clear_obstacles(
        self, beyond_m: float = 0.0, centre_xy: tuple[float, float] = (0, 0)
    ) -> None:
        """Forget the scans (the clear-costmap recovery); the static layer stays.

        Parameters
        ----------
        beyond_m : float
            Forget only the cells farther than this from ``centre_xy`` [m] (0: all of them).
            Nearer cells are the ones the next scan re-marks or clears along its rays, so
            keeping them means a clearing cannot open a path through an obstacle in view.
        centre_xy : tuple of float
            The centre of the kept disc (the robot) [m].
        """
        self.obstacles.clear(self._geometry, beyond_m, centre_xy)
        self._update_master()

    @property
    def obstacle_layer(self) -> CostArray:
        """The obstacle layer (LETHAL marked, FREE cleared, else unknown), read-only view."""
        view = self.obstacles.costs.view()
        view.flags.writeable = False
        return view

    # ------------------------------------------------------------------ combining

    def _combined(
        self, window: Window, far_m: float = math.inf
    ) -> tuple[CostArray, BoolArray, FloatArray]:
        """The layers combined over ``window`` (static, obstacle, inflation, in that order).

        Distances to the nearest lethal cell beyond ``far_m`` may read ``inf``.

        Returns
        -------
        tuple of ndarray
            (costs, lethal mask, distance to the nearest lethal cell centre [m]).
        """
        if native.LIB is not None:
            return native.combine_inflate(
                self.static.costs[window], self.obstacles.costs[window], self.resolution_m,
                far_m, self.inflation.table(),
            )  # fmt: skip
        master = np.empty(self.static.costs[window].shape, np.uint8)
        self.static.update_costs(master, window)
        self.obstacles.update_costs(master, window)
        lethal, dist = self.inflation.inflate(master, far_m)
        return master, lethal, dist

    def _update_window(self, r0: int, r1: int, c0: int, c1: int) -> None:
        """Re-combine after a change of the obstacle layer within rows r0:r1, cols c0:c1.

        A change moves costs at most the inflation radius (k cells) away, and those costs
        depend on lethal cells at most k cells farther: the layers are combined and inflated
        over the change grown by 2k cells, and the costs of the change grown by k are kept.
        """
        rows, cols = self.shape
        k = math.ceil(self.config.inflation_radius_m / self.resolution_m) + 1
        if (r1 - r0 + 4 * k) * (c1 - c0 + 4 * k) >= rows * cols:
            self._update_master()
            return
        wr0, wr1 = max(0, r0 - 2 * k), min(rows, r1 + 2 * k)
        wc0, wc1 = max(0, c0 - 2 * k), min(cols, c1 + 2 * k)
        kr0, kr1 = max(0, r0 - k), min(rows, r1 + k)
        kc0, kc1 = max(0, c0 - k), min(cols, c1 + k)
        if kr0 >= kr1 or kc0 >= kc1:
            return
        master, _, dist = self._combined(
            (slice(wr0, wr1), slice(wc0, wc1)), self.config.inflation_radius_m
        )
        keep = (slice(kr0 - wr0, kr1 - wr0), slice(kc0 - wc0, kc1 - wc0))
        self._costs_2d[kr0 + 1 : kr1 + 1, kc0 + 1 : kc1 + 1] = master[keep]
        self.lethal_distance_m[kr0:kr1, kc0:kc1] = dist[keep]
        self.version += 1

    def _update_master(self) -> None:
        """Combine the layers everywhere, and give the new costs their footprint checker."""
        far = math.inf if self._collision_checks else self.config.inflation_radius_m
        everything = (slice(None), slice(None))
        master, lethal, dist = self._combined(everything, far)
        self.version += 1
        self.lethal_distance_m = dist
        # the costs live inside a grid padded by one unknown ring (off-grid lookups land on
        # it); ``costs`` is a view of its inside, updated in place
        self._costs_2d = ringed(master, NO_INFORMATION)
        self._costs_padded = self._costs_2d.ravel()
        self.costs = self._costs_2d[1:-1, 1:-1]
        if self._collision_checks:
            self._checker = FootprintChecker(
                self.config, self._geometry, master, lethal, dist, self.static.costs,
                self.obstacles, self.version,
            )  # fmt: skip

    # ------------------------------------------------------------------ collision checks

    @property
    def checker(self) -> FootprintChecker:
        """The footprint checker of the current costs.

        Raises
        ------
        RuntimeError
            If the costmap was made without collision checks.
        """
        if self._checker is None:
            raise RuntimeError(
                "this costmap was made without collision checks (collision_checks=False)"
            )
        return self._checker

    @property
    def compiled(self) -> bool:
        """Whether the collision tests run compiled (:mod:`jackson.host.nav.native`)."""
        return self._checker is not None and self._checker.compiled

    @property
    def max_margin_m(self) -> float:
        """The largest ``margin_m`` :meth:`trajectories_collide` accepts: a quarter cell [m]."""
        return 0.25 * self.resolution_m

    def clear_reach_m(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> FloatArray:
        """:meth:`FootprintChecker.clear_reach_m` of the current costs."""
        return self.checker.clear_reach_m(x_m, y_m)

    def clear_reach_table(self) -> FloatArray:
        """:meth:`FootprintChecker.clear_reach_table` of the current costs."""
        return self.checker.clear_reach_table()

    def footprint_collides(
        self, x_m: npt.ArrayLike, y_m: npt.ArrayLike, yaw_rad: npt.ArrayLike
    ) -> BoolArray:
        """:meth:`FootprintChecker.footprint_collides` of the current costs."""
        return self.checker.footprint_collides(x_m, y_m, yaw_rad)

    def body_contacts(
        self,
        x_m: npt.ArrayLike,
        y_m: npt.ArrayLike,
        yaw_rad: npt.ArrayLike,
        margin_m: float = 0.0,
    ) -> tuple[FloatArray, FloatArray]:
        """:meth:`FootprintChecker.body_contacts` of the current costs."""
        return self.checker.body_contacts(x_m, y_m, yaw_rad, margin_m)

    def trajectories_collide(
        self,
        x_m: FloatArray,
        y_m: FloatArray,
        yaw_rad: FloatArray,
        escape: bool = True,
        margin_m: float | FloatArray = 0.0,
    ) -> BoolArray:
        """:meth:`FootprintChecker.trajectories_collide` of the current costs."""
        return self.checker.trajectories_collide(x_m, y_m, yaw_rad, escape, margin_m)

    def rollouts_collide(
        self,
        start: tuple[float, float, float],
        ds_m: FloatArray,
        cos_sin: FloatArray,
        yaw_rad: FloatArray,
        iv: IntArray,
        iw: IntArray,
        stride: IntArray,
        margin_m: FloatArray,
        stop_at_clear: bool = False,
    ) -> tuple[BoolArray, int]:
        """:meth:`FootprintChecker.rollouts_collide` of the current costs."""
        return self.checker.rollouts_collide(
            start, ds_m, cos_sin, yaw_rad, iv, iw, stride, margin_m, stop_at_clear
        )

    # ------------------------------------------------------------------ pickling

    def __getstate__(self) -> dict[str, object]:
        """The state without :attr:`costs` and ``_costs_padded``, which are views of the padded
        grid: a pickle would copy them apart from it, and a later partial update (which writes
        the padded grid in place) would leave them stale (a core's snapshot,
        docs/recording.md)."""
        state = dict(self.__dict__)
        state.pop("costs", None)
        state.pop("_costs_padded", None)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        if "_obstacle" in state:  # pickled before the costmap had layers
            state = _layered_state(state)
        self.__dict__.update(state)
        self._costs_padded = self._costs_2d.ravel()
        self.costs = self._costs_2d[1:-1, 1:-1]


def _float_arrays(x: object, y: object) -> bool:
    """Two float64 arrays of one shape, not 0-d (what the compiled :meth:`Costmap.cost_at`
    takes)."""
    return (
        isinstance(x, np.ndarray)
        and isinstance(y, np.ndarray)
        and x.shape == y.shape
        and x.ndim > 0
        and x.dtype == y.dtype == np.float64
    )


# what the single-class costmap kept for its collision tests, as the checker keeps it
_CHECKER_STATE = (
    "_obstacle_xy", "_obstacle_r_m", "_obstacle_cells", "_near_m", "_deep_m", "_pad_k",
    "_ids_padded", "_neighbour_offsets", "_native", "_class_padded", "_clear_reach_padded",
)  # fmt: skip


def _layered_state(old: dict[str, Any]) -> dict[str, Any]:
    """The state of a costmap pickled by the single-class costmap, as layers and a checker
    (a core's snapshot written before: docs/recording.md). Nothing is recomputed: the
    restored costmap answers and updates bit for bit as the pickled one did."""
    config: CostmapConfig = old["config"]
    rows, cols = old["_obstacle"].shape
    geometry = GridGeometry(
        old["origin_x_m"], old["origin_y_m"], old["resolution_m"], int(rows), int(cols)
    )
    static = StaticLayer.__new__(StaticLayer)
    static.__dict__.update(config=config, map=old["_static_map"], costs=old["_static"])
    obstacles = ObstacleLayer.__new__(ObstacleLayer)
    obstacles.__dict__.update(
        config=config, discs=old["_collision_checks"], costs=old["_obstacle"],
        hit_xy=old["_hit_xy"], hit_spread_m=old["_hit_spread_m"],
        last_returns=old["_last_returns"],
    )  # fmt: skip
    inflation = InflationLayer(config, geometry.resolution_m)
    checker = None
    if old["_collision_checks"]:
        checker = FootprintChecker.__new__(FootprintChecker)
        checker.__dict__.update({k: old[k] for k in _CHECKER_STATE})
        checker.__dict__.update(
            config=config, geometry=geometry, version=old["version"], _obstacles=obstacles,
            _body_cache=old.get("_body_cache"),
        )  # fmt: skip
    return {
        "config": config, "_geometry": geometry, "resolution_m": old["resolution_m"],
        "origin_x_m": old["origin_x_m"], "origin_y_m": old["origin_y_m"],
        "_rolling": old["_rolling"], "_collision_checks": old["_collision_checks"],
        "static": static, "obstacles": obstacles, "inflation": inflation,
        "_checker": checker, "lethal_distance_m": old["lethal_distance_m"],
        "version": old["version"], "_costs_2d": old["_costs_2d"],
    }  # fmt: skip
