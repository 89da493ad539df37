"""The costmap's layers, as ``nav2_costmap_2d`` stacks them: static, obstacle, inflation.

Every layer keeps its own grid on its master's :class:`~jackson.common.geometry.GridGeometry`
and answers the same :class:`Layer` interface: :meth:`Layer.update_costs` combines it into
the master's cells of a window, in the master's order (static, then obstacle, then
inflation), and :meth:`Layer.match` follows the master's grid when a rolling window moves.

- :class:`StaticLayer`: the map's cells sampled at the grid's cell centres: lethal at or above
  the map's occupied threshold, free below it, unknown where the map is unknown or absent. It
  writes the master's cells as they are (the first layer).
- :class:`ObstacleLayer`: marked from LiDAR returns (within ``obstacle_max_range_m``) and
  cleared along each return's ray from the sensor (within ``raytrace_max_range_m``), all rays
  at once: every ray is sampled every half cell and the samples index the grid together
  (compiled in :func:`jackson.host.nav.native.clear_rays` where the library is built).
  Static walls are never cleared by a scan: the obstacle layer's free cells do not lower the
  master. It combines as Nav2's ``updateWithMax``, except that its unknown cells yield to
  what the static layer knows.
- :class:`InflationLayer`: spreads every lethal cell of the combined grid over the inflation
  radius with Nav2's cost function (:func:`~jackson.host.nav.costmap.values.inflation_cost`),
  from one Euclidean distance transform of the lethal cells.

Unknown cells: with ``track_unknown_space`` (Nav2's global costmap in bringup) an unknown
cell of the static map, or an obstacle-layer cell no ray has crossed yet, stays
NO_INFORMATION and inflation only raises it to inscribed or lethal; without it (Nav2's
default, used for the local window) unknown counts as free.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import GridGeometry
from jackson.host.nav import native, native_grid
from jackson.host.nav.costmap.values import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
    BoolArray,
    CostArray,
    CostmapConfig,
    FloatArray,
    inflation_cost,
)
from jackson.host.nav.grid import OccupancyGrid

Window = tuple[slice, slice]


class Layer(ABC):
    """One layer of a costmap (Nav2's ``costmap_2d::Layer``)."""

    @abstractmethod
    def update_costs(self, master: CostArray, window: Window) -> None:
        """Combine this layer into ``master``, the master's cells in ``window``, in place.

        Parameters
        ----------
        master : ndarray of uint8
            The combined costs so far of the window's cells (its shape).
        window : tuple of slice
            The window's rows and columns on the grid.
        """

    @abstractmethod
    def match(self, geometry: GridGeometry, moved: tuple[int, int] | None) -> None:
        """Follow the master's grid, now ``geometry``.

        Parameters
        ----------
        geometry : GridGeometry
            The master's grid.
        moved : tuple of int or None
            How far it moved (rows, cols) since the layer last saw it (a rolling window);
            None when only what the layer depends on changed.
        """


class StaticLayer(Layer):
    """The static map's occupied cells (Nav2's static layer).

    Parameters
    ----------
    config : CostmapConfig
        The occupied threshold and the unknown rule.
    geometry : GridGeometry
        The master's grid.
    static_map : OccupancyGrid or None
        The map; None for no static layer (every cell unknown: it never wins).

    Attributes
    ----------
    map : OccupancyGrid or None
        As given.
    costs : ndarray of uint8, shape (rows, cols)
        The map at the grid's cell centres.
    """

    def __init__(
        self, config: CostmapConfig, geometry: GridGeometry, static_map: OccupancyGrid | None
    ) -> None:
        self.config = config
        self.map = static_map
        self.costs = self._sample(geometry)

    def set_map(self, static_map: OccupancyGrid | None, geometry: GridGeometry) -> None:
        """Take a new map (a SLAM node publishes one every few seconds)."""
        self.map = static_map
        self.costs = self._sample(geometry)

    def update_costs(self, master: CostArray, window: Window) -> None:
        master[...] = self.costs[window]

    def match(self, geometry: GridGeometry, moved: tuple[int, int] | None) -> None:
        self.costs = self._sample(geometry)

    def _sample(self, geometry: GridGeometry) -> CostArray:
        """The static map's cells at the grid's cell centres."""
        rows, cols = geometry.shape
        if self.map is None:
            return np.full((rows, cols), NO_INFORMATION, np.uint8)  # no layer: never wins
        g = self.map
        x, y = geometry.centres()
        r, c = np.broadcast_arrays(*g.world_to_cell(x, y))
        inside = g.inside(r, c)
        values = np.full((rows, cols), -1, np.int16)
        values[inside] = g.data[r[inside], c[inside]]
        layer = np.full((rows, cols), _unknown(self.config), np.uint8)
        layer[values >= 0] = FREE_SPACE
        layer[values >= self.config.lethal_threshold_percent] = LETHAL_OBSTACLE
        return layer


class ObstacleLayer(Layer):
    """Obstacles marked and cleared by the LiDAR's scans (Nav2's obstacle layer).

    Parameters
    ----------
    config : CostmapConfig
        Marking and clearing ranges, the unknown rule.
    geometry : GridGeometry
        The master's grid.
    discs : bool
        Keep where the returns marking each cell lay (the footprint checker's obstacle
        discs).

    Attributes
    ----------
    costs : ndarray of uint8, shape (rows, cols)
        LETHAL where marked, FREE where cleared, else unknown (or free without
        ``track_unknown_space``).
    hit_xy : ndarray, shape (rows, cols, 2)
        The centroid of the returns that marked each cell [m] (empty without ``discs``).
    hit_spread_m : ndarray, shape (rows, cols)
        How far those returns lie from it, at most [m].
    last_returns : ndarray, shape (N, 2)
        The last scan's marking returns [m] (the recoveries' body test).
    """

    def __init__(self, config: CostmapConfig, geometry: GridGeometry, discs: bool) -> None:
        self.config = config
        self.discs = discs
        rows, cols = geometry.shape
        self.costs: CostArray = np.full((rows, cols), _unknown(config), np.uint8)
        disc_shape = (rows, cols) if discs else (0, 0)
        self.hit_xy: FloatArray = np.zeros((*disc_shape, 2))
        self.hit_spread_m: FloatArray = np.zeros(disc_shape)
        self.last_returns: FloatArray = np.zeros((0, 2))

    def update(
        self, points_xy: npt.ArrayLike, sensor_xy: tuple[float, float], geometry: GridGeometry
    ) -> None:
        """Clear the rays to one scan's returns, then mark the returns.

        Clearing comes first, so every return of the scan stays marked. The ray to a return
        is cleared from the sensor up to one cell short of the return (or up to
        ``raytrace_max_range_m``); returns within ``obstacle_max_range_m`` mark their cell.

        Parameters
        ----------
        points_xy : array_like, shape (N, 2)
            The scan's valid returns in the map frame [m].
        sensor_xy : tuple of float
            The sensor's position in the map frame [m].
        geometry : GridGeometry
            The master's grid.
        """
        p = np.asarray(points_xy, np.float64).reshape(-1, 2)
        cfg = self.config
        if native.LIB is not None:  # the same arithmetic, in one call
            self.last_returns = native_grid.obstacle_update(
                p, sensor_xy,
                (cfg.raytrace_min_range_m, cfg.raytrace_max_range_m, cfg.obstacle_min_range_m,
                 cfg.obstacle_max_range_m),
                (geometry.origin_x_m, geometry.origin_y_m, geometry.resolution_m), self.costs,
                (FREE_SPACE, LETHAL_OBSTACLE),
                (self.hit_xy, self.hit_spread_m) if self.discs else None,
            )  # fmt: skip
            return
        d = p - np.asarray(sensor_xy, np.float64)
        length = np.hypot(d[:, 0], d[:, 1])
        self._clear_rays(p, d, length, sensor_xy, geometry)
        mark = (length >= cfg.obstacle_min_range_m) & (length <= cfg.obstacle_max_range_m)
        r, c = geometry.world_to_cell(p[mark, 0], p[mark, 1])
        ok = geometry.inside(r, c)
        r, c, q = r[ok], c[ok], p[mark][ok]
        self.costs[r, c] = LETHAL_OBSTACLE
        self.last_returns = q
        if len(q) and self.discs:
            cols = geometry.cols
            cells, inv = np.unique(r * cols + c, return_inverse=True)
            count = np.bincount(inv)
            centroid = np.column_stack(
                (np.bincount(inv, q[:, 0]) / count, np.bincount(inv, q[:, 1]) / count)
            )
            spread = np.zeros(len(cells))
            np.maximum.at(spread, inv, np.hypot(*(q - centroid[inv]).T))
            cr, cc = np.divmod(cells, cols)
            self.hit_xy[cr, cc] = centroid
            self.hit_spread_m[cr, cc] = spread

    def _clear_rays(
        self,
        p: FloatArray,
        d: FloatArray,
        length: FloatArray,
        sensor_xy: tuple[float, float],
        geometry: GridGeometry,
    ) -> None:
        """Set the layer free along every ray, all rays at once."""
        cfg = self.config
        res = geometry.resolution_m
        ox, oy = geometry.origin_x_m, geometry.origin_y_m
        rows, cols = geometry.shape
        # nothing beyond the grid's farthest corner from the sensor can be cleared
        corners_x = np.array([ox, ox + cols * res])
        corners_y = np.array([oy, oy + rows * res])
        reach = float(
            np.hypot(np.abs(corners_x - sensor_xy[0]).max(), np.abs(corners_y - sensor_xy[1]).max())
        )
        use = length >= max(cfg.raytrace_min_range_m, 1e-9)
        if not np.any(use):
            return
        end = np.minimum(length[use], min(cfg.raytrace_max_range_m, reach))
        stop = np.where(length[use] <= end, end - res, end)  # spare the return's own cell
        step = 0.5 * res
        n = math.ceil(float(stop.max()) / step) + 1 if stop.max() > 0.0 else 0
        if n == 0:
            return
        # in cell units: sample k of a ray lies at (f0 + k u) cells from the grid's origin
        inv = 1.0 / res
        unit = d[use] * (step * inv / length[use, None])
        if native.LIB is not None:
            base = ((sensor_xy[0] - ox) * inv, (sensor_xy[1] - oy) * inv)
            native.clear_rays(unit, stop, base, step, self.costs, FREE_SPACE)
            return
        k = np.arange(n, dtype=np.float64)
        keep = (k[None, :] * step <= stop[:, None]).ravel()
        fx = ((sensor_xy[0] - ox) * inv + unit[:, 0:1] * k[None, :]).ravel()[keep]
        fy = ((sensor_xy[1] - oy) * inv + unit[:, 1:2] * k[None, :]).ravel()[keep]
        c = np.floor(fx, out=fx)
        r = np.floor(fy, out=fy)
        ok = (r >= 0.0) & (r < rows) & (c >= 0.0) & (c < cols)
        flat = (r[ok] * cols + c[ok]).astype(np.intp)
        self.costs.ravel()[flat] = FREE_SPACE

    def clear(
        self, geometry: GridGeometry, beyond_m: float, centre_xy: tuple[float, float]
    ) -> None:
        """Forget the cells farther than ``beyond_m`` from ``centre_xy`` (0: all of them)."""
        if beyond_m <= 0.0:
            self.costs.fill(_unknown(self.config))
        else:
            x, y = geometry.centres()
            far = np.hypot(x - centre_xy[0], y - centre_xy[1]) > beyond_m
            self.costs[far] = _unknown(self.config)

    def update_costs(self, master: CostArray, window: Window) -> None:
        obstacle = self.costs[window]
        known = obstacle != NO_INFORMATION
        take = known & ((master == NO_INFORMATION) | (obstacle > master))
        master[take] = obstacle[take]

    def match(self, geometry: GridGeometry, moved: tuple[int, int] | None) -> None:
        """Keep the cells the moved grid still covers; the rest start unknown (all of them
        after a jump farther than the grid's own size)."""
        if moved is None or moved == (0, 0):
            return
        dr, dc = moved
        rows, cols = geometry.shape
        costs = np.full_like(self.costs, _unknown(self.config))
        hit_xy = np.zeros_like(self.hit_xy)
        spread = np.zeros_like(self.hit_spread_m)
        if abs(dr) < rows and abs(dc) < cols:  # else no overlap: the window starts afresh
            src_r = slice(max(0, dr), min(rows, rows + dr))
            dst_r = slice(max(0, -dr), min(rows, rows - dr))
            src_c = slice(max(0, dc), min(cols, cols + dc))
            dst_c = slice(max(0, -dc), min(cols, cols - dc))
            costs[dst_r, dst_c] = self.costs[src_r, src_c]
            if self.discs:
                hit_xy[dst_r, dst_c] = self.hit_xy[src_r, src_c]
                spread[dst_r, dst_c] = self.hit_spread_m[src_r, src_c]
        self.costs = costs
        self.hit_xy = hit_xy
        self.hit_spread_m = spread


class InflationLayer(Layer):
    """Costs spread around every lethal cell of the layers below (Nav2's inflation layer).

    Parameters
    ----------
    config : CostmapConfig
        Radii and the cost scaling factor.
    resolution_m : float
        The grid's cell edge [m].
    """

    def __init__(self, config: CostmapConfig, resolution_m: float) -> None:
        self.config = config
        self.resolution_m = resolution_m
        self._table: CostArray | None = None

    def update_costs(self, master: CostArray, window: Window) -> None:
        self.inflate(master)

    def match(self, geometry: GridGeometry, moved: tuple[int, int] | None) -> None:
        if geometry.resolution_m != self.resolution_m:
            self.resolution_m = geometry.resolution_m
            self._table = None

    def inflate(self, master: CostArray, far_m: float = math.inf) -> tuple[BoolArray, FloatArray]:
        """Inflate the combined costs in place.

        A known cell takes the inflation cost where it is higher; an unknown cell only where
        it is inscribed or lethal.

        Parameters
        ----------
        master : ndarray of uint8
            The static and obstacle layers combined.
        far_m : float
            Distances beyond this may read ``inf`` [m].

        Returns
        -------
        tuple of ndarray
            (the lethal cells, each cell centre's distance to the nearest lethal cell centre
            [m], ``inf`` without any).
        """
        lethal = master == LETHAL_OBSTACLE
        dist = native.distance_to(lethal)  # scipy's EDT, bit for bit; inf without lethal cells
        dist *= self.resolution_m
        if far_m < math.inf:
            dist[dist > far_m] = math.inf
        cfg = self.config
        inflated = inflation_cost(
            dist, cfg.robot_radius_m, cfg.inflation_radius_m, cfg.cost_scaling_factor
        )
        unknown = master == NO_INFORMATION
        raise_known = ~unknown & (inflated > master)
        raise_unknown = unknown & (inflated >= INSCRIBED_INFLATED_OBSTACLE)
        master[raise_known | raise_unknown] = inflated[raise_known | raise_unknown]
        return lethal, dist

    def table(self) -> CostArray:
        """:func:`inflation_cost` at each distance a distance transform gives, sqrt(d2) cells,
        by the whole number d2 of squared cells, up to the first beyond the inflation radius
        (the compiled combination reads it: the same costs from the same distances)."""
        if self._table is None:
            cfg, res = self.config, self.resolution_m
            n = (math.ceil(cfg.inflation_radius_m / res) + 1) ** 2  # sqrt(n) res > the radius
            dist = np.sqrt(np.arange(n, dtype=np.float64)) * res
            self._table = inflation_cost(
                dist, cfg.robot_radius_m, cfg.inflation_radius_m, cfg.cost_scaling_factor
            )
        return self._table


def _unknown(config: CostmapConfig) -> int:
    """What an unknown cell holds: NO_INFORMATION when tracking unknown space, else free."""
    return NO_INFORMATION if config.track_unknown_space else FREE_SPACE
