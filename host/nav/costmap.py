"""Layered 2-D costmaps as Nav2 builds them: static layer, obstacle layer, inflation.

Cost values follow ``nav2_costmap_2d``: 0 free, 1-252 inflated (the closer to an obstacle the
higher), 253 inscribed (the robot's centre here puts its body on an obstacle), 254 lethal (an
obstacle cell), 255 no information. A cell's cost is the maximum over the layers, and the
inflation layer spreads every lethal cell over the distance d from its centre:

    c(d) = 254                                       d = 0 (the lethal cell itself)
    c(d) = 253                                       0 < d <= r_inscribed
    c(d) = floor(252 exp(-k (d - r_inscribed)))      r_inscribed < d <= r_inflation
    c(d) = 0                                         d > r_inflation

with k the cost scaling factor (REFERENCE Stage 3: r_inscribed = robot radius 0.16 m,
r_inflation = 0.25 m, k = 10.0). d comes from one Euclidean distance transform of the lethal
cells (``scipy.ndimage.distance_transform_edt``'s values, compiled in
:func:`jackson.host.nav.native.distance_to` where the library is built), so the whole grid
inflates at once.

The obstacle layer is marked from LiDAR returns (within ``obstacle_max_range_m``) and cleared
along each return's ray from the sensor (within ``raytrace_max_range_m``), all rays at once:
every ray is sampled every half cell and the samples index the grid together. Static walls
are never cleared by a scan. A :class:`Costmap` either covers a whole map (the global costmap)
or is a rolling window that moves with the robot (the local costmap: 3 m x 3 m at 0.05 m in
Nav2's bringup), keeping the overlapping part of its obstacle layer as it moves.

Unknown cells: with ``track_unknown_space`` (Nav2's global costmap in bringup) an unknown cell
of the static map, or an obstacle-layer cell no ray has crossed yet, stays NO_INFORMATION (255)
and inflation only raises it to inscribed or lethal; without it (Nav2's default, used for the
local window) unknown counts as free.

Collision tests (:meth:`Costmap.footprint_collides`, :meth:`Costmap.trajectories_collide`) do
not stop at cells. Every lethal cell also stands for a disc: the centroid of the returns that
marked it with their spread as radius, or, for a static-map cell, the cell's circumscribed
disc. The robot is the disc of the robot radius (Nav2's circular robot) joined with the
oriented envelope rectangle, and a pose collides when it overlaps a disc. A half-cell of
quantisation plus LiDAR noise otherwise makes a robot passing a few centimetres from an
obstacle "touch" a cell and freeze. Cell distances bound the true clearances, so most poses
are settled by one table lookup: far from every obstacle, certainly overlapping one, or (only
these get the exact test) in between.

The recoveries test the robot's body alone, more closely, at their handful of poses
(:meth:`Costmap.body_contacts`): the envelope rectangle against the last scan's returns, each
marked cell the capsule of its own and its neighbours' returns with the range noise taken out.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import GridCells
from jackson.common.robot import ENVELOPE_X_M as ENVELOPE_X_M  # re-exported
from jackson.common.robot import ENVELOPE_Y_M as ENVELOPE_Y_M
from jackson.host.nav import native
from jackson.host.nav.grid import OccupancyGrid

T = TypeVar("T", bound=np.generic)

FREE_SPACE = 0
INSCRIBED_INFLATED_OBSTACLE = 253
LETHAL_OBSTACLE = 254
NO_INFORMATION = 255
MAX_NON_OBSTACLE = INSCRIBED_INFLATED_OBSTACLE - 1  # 252, the top of the inflated band
BODY_STEP_M = 0.01  # [m] discs along a capsule in the body test (Costmap.body_contacts)

# per-cell classes for collision checks: far from obstacles, near enough for the robot to reach
# one, so near that the robot's disc certainly overlaps one, a centre on a lethal or unknown
# cell or off the grid
_CLEAR, _NEAR, _DEEP, _BLOCKED = 0, 1, 2, 3
_ONE_CALL_POSES = 2048  # up to this many poses need the exact test: all in one call


FloatArray = npt.NDArray[np.float64]
CostArray = npt.NDArray[np.uint8]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int_]


@dataclass(frozen=True)
class CostmapConfig:
    """Robot shape, inflation and the obstacle layer's ranges.

    Attributes
    ----------
    robot_radius_m : float
        Inscribed radius used by the inflation (REFERENCE: robot radius 0.16 m).
    inflation_radius_m : float
        Distance from an obstacle cell beyond which no cost is added (REFERENCE: 0.25 m).
    cost_scaling_factor : float
        k of the exponential decay [1/m] (REFERENCE: 10.0).
    footprint_x_m, footprint_y_m : tuple of float
        The oriented collision envelope, robot frame [m] (REFERENCE App. D.3), checked on top
        of the inscribed circle by :meth:`Costmap.footprint_collides`.
    obstacle_max_range_m, obstacle_min_range_m : float
        Returns farther or nearer than these do not mark (Nav2 bringup: 2.5 m, 0 m).
    raytrace_max_range_m, raytrace_min_range_m : float
        Rays are cleared up to this length; returns nearer than the minimum clear nothing
        (Nav2 bringup: 3.0 m, 0 m).
    lethal_threshold_percent : int
        A static-map cell at or above this occupancy is lethal (map_server's occupied
        threshold, 65 %).
    track_unknown_space : bool
        Keep unknown cells as NO_INFORMATION (True) or treat them as free (False).
    range_noise_m : float
        The LiDAR's range noise, one standard deviation [m] (REFERENCE: 0.010 m): the
        recoveries' body test (:meth:`Costmap.body_contacts`) tells a wall's noise from its
        extent with it.
    """

    robot_radius_m: float = 0.16
    inflation_radius_m: float = 0.25
    cost_scaling_factor: float = 10.0
    footprint_x_m: tuple[float, float] = ENVELOPE_X_M
    footprint_y_m: tuple[float, float] = ENVELOPE_Y_M
    obstacle_max_range_m: float = 2.5
    obstacle_min_range_m: float = 0.0
    raytrace_max_range_m: float = 3.0
    raytrace_min_range_m: float = 0.0
    lethal_threshold_percent: int = 65
    track_unknown_space: bool = False
    range_noise_m: float = 0.010

    def __post_init__(self) -> None:
        if not 0.0 < self.robot_radius_m < math.inf:
            raise ValueError(f"CostmapConfig.robot_radius_m must be > 0, got {self.robot_radius_m}")
        if not self.robot_radius_m <= self.inflation_radius_m < math.inf:
            raise ValueError(
                "CostmapConfig.inflation_radius_m must be >= robot_radius_m, "
                f"got {self.inflation_radius_m}"
            )
        if not 0.0 <= self.cost_scaling_factor < math.inf:
            raise ValueError(
                f"CostmapConfig.cost_scaling_factor must be >= 0, got {self.cost_scaling_factor}"
            )
        for name in ("footprint_x_m", "footprint_y_m"):
            low, high = getattr(self, name)
            if not low < 0.0 < high:
                raise ValueError(f"CostmapConfig.{name} must bracket 0, got {(low, high)}")
        for name in ("obstacle", "raytrace"):
            low, high = getattr(self, f"{name}_min_range_m"), getattr(self, f"{name}_max_range_m")
            if not 0.0 <= low < high:
                raise ValueError(
                    f"CostmapConfig.{name}_max_range_m must exceed {name}_min_range_m >= 0, "
                    f"got {low}, {high}"
                )
        if not 0.0 <= self.range_noise_m < math.inf:
            raise ValueError(f"CostmapConfig.range_noise_m must be >= 0, got {self.range_noise_m}")
        if not 0 < self.lethal_threshold_percent <= 100:
            raise ValueError(
                "CostmapConfig.lethal_threshold_percent must be in 1..100, "
                f"got {self.lethal_threshold_percent}"
            )

    @property
    def circumscribed_radius_m(self) -> float:
        """Distance from the robot's origin to the farthest corner of the footprint [m]."""
        return max(math.hypot(x, y) for x in self.footprint_x_m for y in self.footprint_y_m)


def inflation_cost(
    distance_m: npt.ArrayLike,
    inscribed_radius_m: float,
    inflation_radius_m: float,
    cost_scaling_factor: float,
) -> CostArray:
    """Nav2's inflation cost of a cell at ``distance_m`` from the nearest lethal cell.

    254 at d = 0, 253 for d <= r_inscribed, floor(252 exp(-k (d - r_inscribed))) up to the
    inflation radius, 0 beyond it.

    Parameters
    ----------
    distance_m : array_like
        Distances between cell centres [m].
    inscribed_radius_m : float
        r_inscribed [m].
    inflation_radius_m : float
        r_inflation [m].
    cost_scaling_factor : float
        k [1/m].

    Returns
    -------
    ndarray of uint8
        Costs, the shape of ``distance_m``.
    """
    d = np.asarray(distance_m, np.float64)
    decay = MAX_NON_OBSTACLE * np.exp(-cost_scaling_factor * (d - inscribed_radius_m))
    cost = np.where(d <= inflation_radius_m, np.floor(np.minimum(decay, MAX_NON_OBSTACLE)), 0)
    cost = np.where(d <= inscribed_radius_m, INSCRIBED_INFLATED_OBSTACLE, cost)
    cost = np.where(d <= 0.0, LETHAL_OBSTACLE, cost)
    return cost.astype(np.uint8)


def occupancy_from_costs(costs: npt.NDArray[np.uint8]) -> npt.NDArray[np.int8]:
    """Costs as ``nav_msgs/OccupancyGrid`` values, the way Nav2 publishes a costmap.

    0 -> 0, 1..252 -> 1 + 97 (c - 1) / 251 (integer division), 253 -> 99, 254 -> 100,
    255 -> -1.

    Parameters
    ----------
    costs : ndarray of uint8
        Costmap values.

    Returns
    -------
    ndarray of int8
        Occupancy values, same shape.
    """
    c = costs.astype(np.int32)
    out = np.where(c == 0, 0, 1 + (97 * (c - 1)) // 251)
    out = np.where(c == INSCRIBED_INFLATED_OBSTACLE, 99, out)
    out = np.where(c == LETHAL_OBSTACLE, 100, out)
    out = np.where(c == NO_INFORMATION, -1, out)
    return out.astype(np.int8)


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
        Keep what :meth:`footprint_collides` and :meth:`trajectories_collide` need (the local
        costmap). Without them (the global costmap, which A* and the blocked-path test read)
        a scan re-inflates only the part of the grid it can change, so its cost does not grow
        with the map, and ``lethal_distance_m`` is exact only up to the inflation radius
        (farther cells read ``inf``).

    Attributes
    ----------
    config : CostmapConfig
        As given.
    resolution_m, origin_x_m, origin_y_m : float
        The grid's cell edge and current origin [m].
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
        self.resolution_m = float(resolution_m)
        self.origin_x_m = float(origin_x_m)
        self.origin_y_m = float(origin_y_m)
        self._rolling = rolling
        self._collision_checks = collision_checks
        self._native: native.Obstacles | None = None  # the compiled tests, when built
        self._static_map = static_map
        self._unknown = NO_INFORMATION if config.track_unknown_space else FREE_SPACE
        self._obstacle = np.full((rows, cols), self._unknown, np.uint8)
        # where the returns marking each obstacle cell lay: their centroid and spread [m]
        # (for the collision tests only)
        disc_shape = (rows, cols) if collision_checks else (0, 0)
        self._hit_xy = np.zeros((*disc_shape, 2))
        self._hit_spread_m = np.zeros(disc_shape)
        # the last scan's marking returns [m] (the recoveries' body test), and the body test's
        # obstacles made from them, for the costmap's version they were made at
        self._last_returns: FloatArray = np.zeros((0, 2))
        self._body_cache: tuple[int, FloatArray, FloatArray] | None = None
        self._static = self._sample_static()
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
            Keep the collision tests' tables (see the class); False for a planning costmap.

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
        ox, oy = cls._window_origin(centre_x_m, centre_y_m, n, resolution_m)
        return cls(config, n, n, resolution_m, ox, oy, static_map=static_map, rolling=True)

    @staticmethod
    def _window_origin(x_m: float, y_m: float, n: int, resolution_m: float) -> tuple[float, float]:
        """Origin of an n-cell window centred near (x, y), snapped to whole cells."""
        half = 0.5 * n * resolution_m
        return (
            math.floor((x_m - half) / resolution_m) * resolution_m,
            math.floor((y_m - half) / resolution_m) * resolution_m,
        )

    def _sample_static(self) -> CostArray:
        """The static layer: the static map's cells at this grid's cell centres."""
        rows, cols = self._obstacle.shape
        if self._static_map is None:
            return np.full((rows, cols), NO_INFORMATION, np.uint8)  # no layer: never wins
        g = self._static_map
        x, y = self.cell_to_world(np.arange(rows)[:, None], np.arange(cols)[None, :])
        r, c = np.broadcast_arrays(*g.world_to_cell(x, y))
        inside = g.inside(r, c)
        values = np.full((rows, cols), -1, np.int16)
        values[inside] = g.data[r[inside], c[inside]]
        layer = np.full((rows, cols), self._unknown, np.uint8)
        layer[values >= 0] = FREE_SPACE
        layer[values >= self.config.lethal_threshold_percent] = LETHAL_OBSTACLE
        return layer

    # ------------------------------------------------------------------ geometry

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return (int(self.costs.shape[0]), int(self.costs.shape[1]))

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
        return np.take(self._costs_padded, self._padded_index(x_m, y_m))

    def _padded_index(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> IntArray:
        """Flat indices into the grid padded by one ring; off-grid points land on the ring."""
        rows, cols = self.shape
        fx = (np.asarray(x_m, np.float64) - self.origin_x_m) / self.resolution_m + 1.0
        fy = (np.asarray(y_m, np.float64) - self.origin_y_m) / self.resolution_m + 1.0
        # clipped into [0, size + 1] first, so truncation is the floor
        col = np.clip(fx, 0.0, cols + 1.0).astype(np.intp)
        row = np.clip(fy, 0.0, rows + 1.0).astype(np.intp)
        row *= cols + 2
        row += col
        return row

    # ------------------------------------------------------------------ layers

    def recentre(self, x_m: float, y_m: float) -> None:
        """Move a rolling window so it is centred on (x, y), keeping the overlap.

        Does nothing for a fixed grid or when the window would not move a whole cell. A
        jump farther than the window's own size (a start far from where the window was
        made, a relocalisation) keeps nothing: the window starts unknown where it lands.

        Parameters
        ----------
        x_m, y_m : float
            New centre (the robot) [m].
        """
        if not self._rolling:
            return
        rows, cols = self.shape
        ox, oy = self._window_origin(x_m, y_m, rows, self.resolution_m)
        dc = round((ox - self.origin_x_m) / self.resolution_m)
        dr = round((oy - self.origin_y_m) / self.resolution_m)
        if dc == 0 and dr == 0:
            return
        moved = np.full_like(self._obstacle, self._unknown)
        hit_xy = np.zeros_like(self._hit_xy)
        spread = np.zeros_like(self._hit_spread_m)
        if abs(dr) < rows and abs(dc) < cols:  # else no overlap: the window starts afresh
            src_r = slice(max(0, dr), min(rows, rows + dr))
            dst_r = slice(max(0, -dr), min(rows, rows - dr))
            src_c = slice(max(0, dc), min(cols, cols + dc))
            dst_c = slice(max(0, -dc), min(cols, cols - dc))
            moved[dst_r, dst_c] = self._obstacle[src_r, src_c]
            if self._collision_checks:
                hit_xy[dst_r, dst_c] = self._hit_xy[src_r, src_c]
                spread[dst_r, dst_c] = self._hit_spread_m[src_r, src_c]
        self._obstacle = moved
        self._hit_xy = hit_xy
        self._hit_spread_m = spread
        self.origin_x_m += dc * self.resolution_m
        self.origin_y_m += dr * self.resolution_m
        self._static = self._sample_static()
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
        self._static_map = static_map
        self._static = self._sample_static()
        self._update_master()

    def update(self, points_xy: npt.ArrayLike, sensor_xy: tuple[float, float]) -> None:
        """Clear the rays to one scan's returns, mark the returns, re-inflate.

        Clearing comes first, so every return of the scan stays marked. The ray to a return
        is cleared from the sensor up to one cell short of the return (or up to
        ``raytrace_max_range_m``); returns within ``obstacle_max_range_m`` mark their cell.

        Parameters
        ----------
        points_xy : array_like, shape (N, 2)
            The scan's valid returns in the map frame [m].
        sensor_xy : tuple of float
            The sensor's position in the map frame [m].
        """
        p = np.asarray(points_xy, np.float64).reshape(-1, 2)
        cfg = self.config
        d = p - np.asarray(sensor_xy, np.float64)
        length = np.hypot(d[:, 0], d[:, 1])
        self._clear_rays(p, d, length, sensor_xy)
        mark = (length >= cfg.obstacle_min_range_m) & (length <= cfg.obstacle_max_range_m)
        r, c = self.world_to_cell(p[mark, 0], p[mark, 1])
        ok = self.inside(r, c)
        r, c, q = r[ok], c[ok], p[mark][ok]
        self._obstacle[r, c] = LETHAL_OBSTACLE
        self._last_returns = q
        if len(q) and self._collision_checks:
            cells, inv = np.unique(r * self.shape[1] + c, return_inverse=True)
            count = np.bincount(inv)
            centroid = np.column_stack(
                (np.bincount(inv, q[:, 0]) / count, np.bincount(inv, q[:, 1]) / count)
            )
            spread = np.zeros(len(cells))
            np.maximum.at(spread, inv, np.hypot(*(q - centroid[inv]).T))
            cr, cc = np.divmod(cells, self.shape[1])
            self._hit_xy[cr, cc] = centroid
            self._hit_spread_m[cr, cc] = spread
        if self._collision_checks:
            self._update_master()
            return
        # the scan changed cells within reach of the sensor only (rays are cleared up to
        # raytrace_max_range_m, returns marked up to obstacle_max_range_m)
        reach = max(cfg.raytrace_max_range_m, cfg.obstacle_max_range_m) + self.resolution_m
        (r0, r1), (c0, c1) = self.world_to_cell(
            [sensor_xy[0] - reach, sensor_xy[0] + reach],
            [sensor_xy[1] - reach, sensor_xy[1] + reach],
        )
        self._update_window(int(r0), int(r1) + 1, int(c0), int(c1) + 1)

    def _clear_rays(
        self, p: FloatArray, d: FloatArray, length: FloatArray, sensor_xy: tuple[float, float]
    ) -> None:
        """Set the obstacle layer free along every ray, all rays at once."""
        cfg = self.config
        res = self.resolution_m
        rows, cols = self.shape
        # nothing beyond the grid's farthest corner from the sensor can be cleared
        corners_x = np.array([self.origin_x_m, self.origin_x_m + cols * res])
        corners_y = np.array([self.origin_y_m, self.origin_y_m + rows * res])
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
            base = ((sensor_xy[0] - self.origin_x_m) * inv, (sensor_xy[1] - self.origin_y_m) * inv)
            native.clear_rays(unit, stop, base, step, self._obstacle, FREE_SPACE)
            return
        k = np.arange(n, dtype=np.float64)
        keep = (k[None, :] * step <= stop[:, None]).ravel()
        fx = ((sensor_xy[0] - self.origin_x_m) * inv + unit[:, 0:1] * k[None, :]).ravel()[keep]
        fy = ((sensor_xy[1] - self.origin_y_m) * inv + unit[:, 1:2] * k[None, :]).ravel()[keep]
        c = np.floor(fx, out=fx)
        r = np.floor(fy, out=fy)
        ok = (r >= 0.0) & (r < rows) & (c >= 0.0) & (c < cols)
        flat = (r[ok] * cols + c[ok]).astype(np.intp)
        self._obstacle.ravel()[flat] = FREE_SPACE

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
        if beyond_m <= 0.0:
            self._obstacle.fill(self._unknown)
        else:
            rows, cols = self.shape
            x, y = self.cell_to_world(np.arange(rows)[:, None], np.arange(cols)[None, :])
            far = np.hypot(x - centre_xy[0], y - centre_xy[1]) > beyond_m
            self._obstacle[far] = self._unknown
        self._update_master()

    def _combined(
        self, static: CostArray, obstacle: CostArray, far_m: float = math.inf
    ) -> tuple[CostArray, BoolArray, FloatArray]:
        """The layers combined (maximum, unknown yields to knowledge) and inflated.

        Distances to the nearest lethal cell beyond ``far_m`` may read ``inf``.

        Returns
        -------
        tuple of ndarray
            (costs, lethal mask, distance to the nearest lethal cell centre [m]).
        """
        if native.LIB is not None:
            return native.combine_inflate(
                static, obstacle, self.resolution_m, far_m, self._inflation_by_d2()
            )
        master = static.copy()
        known = obstacle != NO_INFORMATION
        take = known & ((master == NO_INFORMATION) | (obstacle > master))
        master[take] = obstacle[take]
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
        return master, lethal, dist

    def _inflation_by_d2(self) -> CostArray:
        """:func:`inflation_cost` at each distance the transform gives, sqrt(d2) cells, by the
        whole number d2 of squared cells, up to the first beyond the inflation radius (the
        compiled :meth:`_combined` reads it: the same costs from the same distances)."""
        table: CostArray | None = getattr(self, "_inflation_table", None)
        if table is None:
            cfg, res = self.config, self.resolution_m
            n = (math.ceil(cfg.inflation_radius_m / res) + 1) ** 2  # sqrt(n) res > the radius
            dist = np.sqrt(np.arange(n, dtype=np.float64)) * res
            table = inflation_cost(
                dist, cfg.robot_radius_m, cfg.inflation_radius_m, cfg.cost_scaling_factor
            )
            self._inflation_table = table
        return table

    def _update_window(self, r0: int, r1: int, c0: int, c1: int) -> None:
        """Re-inflate after a change of the obstacle layer within rows r0:r1, cols c0:c1.

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
        window = (slice(wr0, wr1), slice(wc0, wc1))
        master, _, dist = self._combined(
            self._static[window], self._obstacle[window], self.config.inflation_radius_m
        )
        keep = (slice(kr0 - wr0, kr1 - wr0), slice(kc0 - wc0, kc1 - wc0))
        self._costs_2d[kr0 + 1 : kr1 + 1, kc0 + 1 : kc1 + 1] = master[keep]
        self.lethal_distance_m[kr0:kr1, kc0:kc1] = dist[keep]
        self.version += 1

    def __getstate__(self) -> dict[str, object]:
        """The state without :attr:`costs` and ``_costs_padded``, which are views of the padded
        grid: a pickle would copy them apart from it, and a later partial update (which writes
        the padded grid in place) would leave them stale (a core's snapshot,
        docs/recording.md)."""
        state = dict(self.__dict__)
        state.pop("costs", None)
        state.pop("_costs_padded", None)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._costs_padded = self._costs_2d.ravel()
        self.costs = self._costs_2d[1:-1, 1:-1]

    def _update_master(self) -> None:
        """Combine the layers (maximum, unknown yields to knowledge) and inflate, everywhere."""
        far = math.inf if self._collision_checks else self.config.inflation_radius_m
        master, lethal, dist = self._combined(self._static, self._obstacle, far)
        self.version += 1
        self.lethal_distance_m = dist
        # the costs live inside a grid padded by one unknown ring (off-grid lookups land on
        # it); ``costs`` is a view of its inside, updated in place
        self._costs_2d = _ringed(master, NO_INFORMATION)
        self._costs_padded = self._costs_2d.ravel()
        self.costs = self._costs_2d[1:-1, 1:-1]
        if not self._collision_checks:
            return
        self._lethal_padded = _ringed(self.lethal_distance_m, -1.0).ravel()
        self._index_obstacles(lethal)
        cls = np.where(dist <= self._near_m, _NEAR, _CLEAR).astype(np.uint8)
        cls[dist < self._deep_m] = _DEEP
        cls[master >= LETHAL_OBSTACLE] = _BLOCKED  # lethal or unknown under the centre
        self._class_padded = _ringed(cls, _BLOCKED).ravel()
        self._clear_reach_padded: FloatArray | None = None

    def _index_obstacles(self, lethal: BoolArray) -> None:
        """The obstacle discs the footprint test uses, and a padded grid of their ids.

        A lethal cell marked by returns (and not by the static map) is the disc around the
        returns' centroid of radius their spread; any other lethal cell is the disc around
        its centre that covers the cell (radius res / sqrt 2).
        """
        rows, cols = self.shape
        res = self.resolution_m
        rr, cc = np.nonzero(lethal)
        cx, cy = self.cell_to_world(rr, cc)
        pts = np.column_stack((cx, cy))
        radius = np.full(len(rr), res / math.sqrt(2.0))
        scan = (self._obstacle[rr, cc] == LETHAL_OBSTACLE) & (
            self._static[rr, cc] != LETHAL_OBSTACLE
        )
        pts[scan] = self._hit_xy[rr[scan], cc[scan]]
        radius[scan] = self._hit_spread_m[rr[scan], cc[scan]]
        self._obstacle_xy = pts
        self._obstacle_r_m = radius
        self._obstacle_cells = rr * cols + cc
        # how far from its cell centre an obstacle disc reaches, at most, and how far it may
        # fall short of it: bounds between cell-centre distances and true clearances
        # bounds between cell-centre distances and true clearances: how far beyond its cell
        # centre a disc may reach (sqrt 2 h: the grown rectangle's corner), how far short of
        # it it may stop, and a pose's offset from its own cell centre
        off = np.hypot(pts[:, 0] - cx, pts[:, 1] - cy)
        reach = float((off + math.sqrt(2.0) * radius).max()) if len(rr) else 0.0
        short = float((off - radius).max()) if len(rr) else 0.0
        half_cell = res / math.sqrt(2.0)
        cfg = self.config
        self._near_m = (
            max(cfg.circumscribed_radius_m, cfg.robot_radius_m)
            + reach
            + half_cell
            + self.max_margin_m
        )
        self._deep_m = cfg.robot_radius_m - max(short, 0.0) - half_cell
        k = max(1, math.ceil(self._near_m / res))
        self._pad_k = k
        ids = np.full((rows + 2 * k, cols + 2 * k), -1, np.int32)
        ids[k + rr, k + cc] = np.arange(len(rr), dtype=np.int32)
        self._ids_padded = ids.ravel()
        self._neighbour_offsets = _disc_offsets(k, cols + 2 * k, res, self._near_m)
        self._native = (
            native.Obstacles(
                ids, ids.shape, k, self._neighbour_offsets, pts, radius,
                (self.origin_x_m, self.origin_y_m, res),
                (cfg.robot_radius_m, cfg.circumscribed_radius_m, *cfg.footprint_x_m,
                 *cfg.footprint_y_m),
            )
            if native.LIB is not None
            else None
        )  # fmt: skip

    @property
    def max_margin_m(self) -> float:
        """The largest ``margin_m`` :meth:`trajectories_collide` accepts: a quarter cell [m]."""
        return 0.25 * self.resolution_m

    @property
    def obstacle_layer(self) -> CostArray:
        """The obstacle layer (LETHAL marked, FREE cleared, else unknown), read-only view."""
        view = self._obstacle.view()
        view.flags.writeable = False
        return view

    # ------------------------------------------------------------------ collision checks

    def clear_reach_m(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> FloatArray:
        """How far the robot's centre may move from each point and stay clear of every check.

        Within this distance of the point every pose is settled as clear by the one lookup of
        :meth:`trajectories_collide` (far from every obstacle, on a known cell of the grid),
        whatever the heading and margin, so it can never collide there: d(c) - sqrt 2 h, with
        d(c) the distance from the point's cell centre c to the nearest centre of a cell that
        is not clear (the ring around the grid included) and h the cell edge, since two
        points s apart lie in cells whose centres are at most s + sqrt 2 h apart. The
        distances come from one Euclidean distance transform per change of the costmap.

        Parameters
        ----------
        x_m, y_m : array_like
            Points in the map frame [m], matching shapes.

        Returns
        -------
        ndarray
            The distance [m] (negative where the point itself needs a check).
        """
        return np.take(self.clear_reach_table(), self._padded_index(x_m, y_m))

    def clear_reach_table(self) -> FloatArray:
        """:meth:`clear_reach_m` of every cell of the grid padded by one cell (the ring off the
        grid), flat, row-major over (rows + 2, cols + 2) [m]; read-only, made once per change.

        Returns
        -------
        ndarray, shape ((rows + 2) (cols + 2),)
            The clear reach of a point in each cell [m].
        """
        if self._clear_reach_padded is None:
            rows, cols = self.shape
            clear = self._class_padded.reshape(rows + 2, cols + 2) == _CLEAR
            d = native.distance_to(~clear)
            table = (d * self.resolution_m - math.sqrt(2.0) * self.resolution_m).ravel()
            table.flags.writeable = False
            self._clear_reach_padded = table
        return self._clear_reach_padded

    def footprint_collides(
        self, x_m: npt.ArrayLike, y_m: npt.ArrayLike, yaw_rad: npt.ArrayLike
    ) -> BoolArray:
        """Whether the robot at each pose overlaps an obstacle.

        The robot is the disc of ``robot_radius_m`` (Nav2's circular robot, REFERENCE 0.16 m)
        joined with the oriented footprint rectangle (the Stage 3 envelope), tested against
        the obstacles themselves rather than their cells (:meth:`_footprint_hits`); a centre
        on a lethal or unknown cell, or off the grid, collides too. Only poses within reach
        of a lethal cell are tested in detail.

        Parameters
        ----------
        x_m, y_m, yaw_rad : array_like
            Poses in the map frame, matching shapes.

        Returns
        -------
        ndarray of bool
            True where the robot overlaps an obstacle.
        """
        x, y, yaw = (
            np.ravel(a)
            for a in np.broadcast_arrays(
                np.asarray(x_m, np.float64), np.asarray(y_m, np.float64), np.asarray(yaw_rad)
            )
        )
        shape = np.broadcast_shapes(np.shape(x_m), np.shape(y_m), np.shape(yaw_rad))
        cls = np.take(self._class_padded, self._padded_index(x, y))
        out = cls >= _DEEP
        near = np.flatnonzero(cls == _NEAR)
        out[near] = self._footprint_hits(x[near], y[near], yaw[near])[0] > 0
        return out.reshape(shape)

    def body_contacts(
        self,
        x_m: npt.ArrayLike,
        y_m: npt.ArrayLike,
        yaw_rad: npt.ArrayLike,
        margin_m: float = 0.0,
    ) -> tuple[FloatArray, FloatArray]:
        """The robot's body alone against the obstacles, at a few poses (every obstacle is
        tested; for the recoveries' handful of poses, not DWB's batches).

        The body is the envelope rectangle (the footprint test's rectangle, without Nav2's
        disc of ``robot_radius_m`` around it). Each cell the last scan marked is the capsule
        of the returns in it and its eight neighbours (:func:`_capsules`): a segment along the
        direction they spread most, as long as they reach along it, grown across it by what
        remains of their spread once the range noise is taken out. A wall then reads where
        its returns' mean lies, not where the shortest of them fell: the footprint test's
        disc, as wide across a wall as along it, and a cell holding only returns that fell
        short (a wall near a cell's edge) put a wall 19 cm away 3 cm nearer, where a robot
        facing along it can neither turn nor back away from it. Any other lethal cell is the
        footprint test's disc. A capsule is tested as discs along its segment, at most
        :data:`BODY_STEP_M` apart, each grown by half that step.

        Parameters
        ----------
        x_m, y_m, yaw_rad : array_like, shape (P,)
            Poses, map frame.
        margin_m : float
            Grow the rectangle by this much on every side [m].

        Returns
        -------
        tuple of ndarray
            (depth [m] (P,): how far the rectangle, grown by each disc's radius, reaches past
            the disc's centre, its largest over the discs inside it, ``-inf`` where none is, so
            that the body touches an obstacle where it is >= 0; the centre's clearance [m]
            (P,): its distance to the nearest disc's edge, ``inf`` without any obstacle).

        Raises
        ------
        RuntimeError
            If the costmap was made without collision checks.
        """
        if not self._collision_checks:
            raise RuntimeError("body_contacts needs a costmap with collision checks")
        x, y, yaw = (
            np.ravel(a).astype(np.float64)
            for a in np.broadcast_arrays(np.asarray(x_m), np.asarray(y_m), np.asarray(yaw_rad))
        )
        centre, radius = self._body_obstacles()
        if len(centre) == 0:
            return np.full(x.shape, -math.inf), np.full(x.shape, math.inf)
        cx = centre[None, :, 0] - x[:, None]  # (P, N), from each pose
        cy = centre[None, :, 1] - y[:, None]
        h = radius[None, :]
        clearance: FloatArray = (np.hypot(cx, cy) - h).min(axis=1)
        cos, sin = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        lx, ly = cos * cx + sin * cy, cos * cy - sin * cx
        g = h + margin_m
        (x0, x1), (y0, y1) = self.config.footprint_x_m, self.config.footprint_y_m
        inside = np.minimum(
            np.minimum(lx - (x0 - g), (x1 + g) - lx), np.minimum(ly - (y0 - g), (y1 + g) - ly)
        )
        depth: FloatArray = np.where(inside >= 0.0, inside, -math.inf).max(axis=1)
        return depth, clearance

    def _body_obstacles(self) -> tuple[FloatArray, FloatArray]:
        """The obstacles of :meth:`body_contacts` as discs: centres (N, 2) [m] and radii
        (N,) [m]; made once per version of the costmap (a recovery's tick tests several
        motions against the same ones)."""
        cache = getattr(self, "_body_cache", None)
        if cache is not None and cache[0] == self.version:
            return cache[1], cache[2]
        cols = self.shape[1]
        q: FloatArray = self._last_returns
        r, c = self.world_to_cell(q[:, 0], q[:, 1])
        ok = self.inside(r, c)  # the window may have moved since
        q, r, c = q[ok], r[ok], c[ok]
        ok = self._obstacle[r, c] == LETHAL_OBSTACLE  # and a recovery cleared it
        q, r, c = q[ok], r[ok], c[ok]
        marked = np.unique(r * cols + c)
        centres, capsules = _capsules(q, r, c, marked, cols, self.config.range_noise_m)
        # each capsule as discs along its segment
        pieces = np.maximum(np.ceil(2.0 * capsules[:, 2] / BODY_STEP_M), 1.0).astype(np.intp)
        which = np.repeat(np.arange(len(centres)), pieces + 1)
        first = np.repeat(np.cumsum(pieces + 1) - (pieces + 1), pieces + 1)
        f = (np.arange(len(which)) - first) / pieces[which] * 2.0 - 1.0  # -1 .. 1
        along = f * capsules[which, 2]
        points = centres[which] + along[:, None] * capsules[which, 0:2]
        grown = capsules[which, 3] + 0.5 * (2.0 * capsules[which, 2] / pieces[which])
        # the footprint test's discs of the other lethal cells
        k = np.flatnonzero(~np.isin(self._obstacle_cells, marked))
        centre = np.concatenate((points, self._obstacle_xy[k]))
        radius = np.concatenate((grown, self._obstacle_r_m[k]))
        self._body_cache = (self.version, centre, radius)
        return centre, radius

    def trajectories_collide(
        self,
        x_m: FloatArray,
        y_m: FloatArray,
        yaw_rad: FloatArray,
        escape: bool = True,
        margin_m: float | FloatArray = 0.0,
    ) -> BoolArray:
        """Which trajectories make the robot overlap an obstacle anywhere along them.

        A pose collides as in :meth:`footprint_collides`. One lookup classifies every pose;
        only poses near a lethal cell, on trajectories not yet rejected, get the exact test.

        Escape: when the start pose already overlaps obstacles (an obstacle appeared beside
        the robot, or a noisy return was marked next to it), a pose is allowed to overlap as
        many obstacles as the start, no more, and its centre may come no nearer any obstacle
        than the start's. Without this every trajectory would include the start and be
        rejected, and only a recovery could move the robot.

        Parameters
        ----------
        x_m, y_m, yaw_rad : ndarray, shape (M, K)
            Poses of M trajectories of K poses each, all starting at one pose, map frame.
        escape : bool
            Apply the escape rule (with each trajectory's margin at the start pose).
        margin_m : float or ndarray, shape (M,)
            Grow the robot's disc and rectangle by this much [m] (one value, or one per
            trajectory), at most :attr:`max_margin_m`: for poses checked s apart (the
            farthest any point of the robot moves between them), s / 2 makes the test catch
            every overlap in between.

        Returns
        -------
        ndarray of bool, shape (M,)
            True for a trajectory that collides.

        Raises
        ------
        ValueError
            If ``margin_m`` is negative or above :attr:`max_margin_m`.
        """
        margins = np.asarray(margin_m, np.float64)
        if margins.ndim not in (0, 1) or (margins.ndim == 1 and margins.shape != x_m.shape[:1]):
            raise ValueError(f"margin_m: one value or one per trajectory, got {margins.shape}")
        if not np.all((margins >= 0.0) & (margins <= self.max_margin_m + 1e-12)):
            raise ValueError(f"margin_m must be in [0, {self.max_margin_m:g}] m, got {margin_m}")
        m = x_m.shape[0]
        start = (float(x_m.flat[0]), float(y_m.flat[0]), float(yaw_rad.flat[0])) if m else None
        allowed, floor_m = self._escape(start, np.broadcast_to(margins, (m,)), escape)
        if self._native is not None:
            rule = native.Rule(
                np.broadcast_to(margins, (m,)), allowed, floor_m, self._class_padded, self.shape
            )
            return self._native.trajectories_collide(x_m, y_m, yaw_rad, rule)
        cls = np.take(self._class_padded, self._padded_index(x_m, y_m))
        escaping = allowed > 0
        any_escaping = bool(np.any(escaping))
        if not any_escaping:
            hit = np.any(cls >= _DEEP, axis=1)
            test = cls == _NEAR
        elif np.all(escaping):
            hit = np.any(cls == _BLOCKED, axis=1)
            test = (cls == _NEAR) | (cls == _DEEP)
        else:
            hit = np.where(escaping, np.any(cls == _BLOCKED, axis=1), np.any(cls >= _DEEP, axis=1))
            test = (cls == _NEAR) | ((cls == _DEEP) & escaping[:, None])
        test &= ~hit[:, None]
        k = cls.shape[1]
        # many poses to test: in chunks along time, so that early collisions spare the rest
        chunk = k if np.count_nonzero(test) <= _ONE_CALL_POSES else max(1, math.ceil(k / 8))
        for c0 in range(0, k, chunk):
            sub = test[:, c0 : c0 + chunk] & ~hit[:, None]
            rows, cols = np.nonzero(sub)
            if rows.size == 0:
                continue
            cols += c0
            count, clearance = self._footprint_hits(
                x_m[rows, cols], y_m[rows, cols], yaw_rad[rows, cols], any_escaping,
                margins if margins.ndim == 0 else margins[rows],
            )  # fmt: skip
            bad = count > allowed[rows]
            if any_escaping:
                bad |= (count > 0) & (clearance < floor_m[rows])
            hit[rows[bad]] = True
        return np.asarray(hit, bool)

    def _escape(
        self, start: tuple[float, float, float] | None, margins: FloatArray, escape: bool
    ) -> tuple[IntArray, FloatArray]:
        """The escape rule's allowance per trajectory: the obstacles its start pose overlaps
        (with its margin) and the clearance its centre must keep (``-inf``: none)."""
        m = margins.shape[0]
        allowed: IntArray = np.zeros(m, np.int_)
        floor_m: FloatArray = np.full(m, -math.inf)
        if not escape or start is None or m == 0:
            return allowed, floor_m
        start_cls = int(self._class_padded[self._padded_index(start[0], start[1])])
        if _NEAR <= start_cls <= _DEEP:
            # per distinct margin, the start pose's overlaps and clearance
            values, which = np.unique(margins, return_inverse=True)
            count0, clear0 = self._footprint_hits(
                np.repeat(start[0], len(values)), np.repeat(start[1], len(values)),
                np.repeat(start[2], len(values)), True, values,
            )  # fmt: skip
            allowed = count0[which]
            floor_m = np.where(allowed > 0, clear0[which] - 1e-9, -math.inf)
        return allowed, floor_m

    @property
    def compiled(self) -> bool:
        """Whether the collision tests run compiled (:mod:`jackson.host.nav.native`)."""
        return self._native is not None

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
        """:meth:`trajectories_collide` of factored roll-outs, each evaluated only at the poses
        read, compiled only (:attr:`compiled`; DWB's numpy path evaluates the poses itself).

        Roll-out t starts at ``start`` (x [m], y [m], yaw [rad]) and steps ``ds_m[iv[t], i]``
        along (cos, sin) ``cos_sin[iw[t], i]``, ``cos_sin[W + iw[t], i]`` (W angular ramps);
        its heading at pose j is ``yaw_rad[iw[t], j]`` (its start pose's heading is the
        start's). It is read at poses 0, s, 2 s, ... and K (s = ``stride[t]``), its position
        there the running sum of its steps plus the start, as numpy sums them. The escape
        rule applies.

        Parameters
        ----------
        start : tuple of float
            The start pose, map frame.
        ds_m : ndarray, shape (V, K)
            Path length of each step of each linear ramp [m].
        cos_sin : ndarray, shape (2 W, K)
            Cosines, then sines, of each step's heading of each angular ramp.
        yaw_rad : ndarray, shape (W, K + 1)
            Heading of each pose of each angular ramp [rad].
        iv, iw, stride : ndarray of int, shape (R,)
            The ramps and the stride of each roll-out.
        margin_m : ndarray, shape (R,)
            As :meth:`trajectories_collide`'s, per roll-out [m].
        stop_at_clear : bool
            Test the roll-outs in their order only up to the first that does not collide.

        Returns
        -------
        tuple
            (True for a roll-out that collides (False after the first clear one when stopping
            there), shape (R,); the index of the first that does not collide, R if none).

        Raises
        ------
        RuntimeError
            If the collision tests are not compiled.
        ValueError
            On a margin outside [0, :attr:`max_margin_m`], or inconsistent tables.
        """
        if self._native is None:
            raise RuntimeError("rollouts_collide needs the compiled collision tests (make setup)")
        margins = np.ascontiguousarray(margin_m, np.float64)
        if margins.shape != np.shape(iv):
            raise ValueError(f"margin_m: one per roll-out, got {margins.shape}")
        if not np.all((margins >= 0.0) & (margins <= self.max_margin_m + 1e-12)):
            raise ValueError(f"margin_m must be in [0, {self.max_margin_m:g}] m")
        allowed, floor_m = self._escape(start, margins, True)
        rule = native.Rule(margins, allowed, floor_m, self._class_padded, self.shape)
        return self._native.rollouts_collide(
            (start[0], start[1]), ds_m, cos_sin, yaw_rad, iv, iw, stride, rule, stop_at_clear
        )

    def _footprint_hits(
        self,
        x: FloatArray,
        y: FloatArray,
        yaw: FloatArray,
        with_clearance: bool = False,
        margin_m: float | FloatArray = 0.0,
    ) -> tuple[IntArray, FloatArray]:
        """Obstacles overlapping the robot, and the centre's clearance, at each pose.

        An obstacle disc (centre c, radius h) overlaps the robot when it meets the disc of
        ``robot_radius_m`` (|c - p| < r + h) or when c lies in the footprint rectangle grown
        by h on every side (exact for a point, conservative at the corners for a disc). The
        clearance is min |c - p| - h over the discs near the pose (``inf`` without any).
        The discs near each distinct cell are gathered once and shared by its poses.

        Parameters
        ----------
        x, y, yaw : ndarray, shape (P,)
            Poses, map frame.
        with_clearance : bool
            Compute the clearance (else it is all ``inf``).
        margin_m : float or ndarray, shape (P,)
            Grow the disc and the rectangle by this much [m] (one value, or one per pose).

        Returns
        -------
        tuple of ndarray
            (overlap count (P,), clearance [m] (P,)).
        """
        if self._native is not None:
            return self._native.footprint_hits(x, y, yaw, with_clearance, margin_m)
        clearance = np.full(x.shape, math.inf)
        n = x.size
        if n == 0:
            return np.zeros(0, np.int_), clearance
        rows, cols = self.shape
        k = self._pad_k
        res = self.resolution_m
        col = np.clip((x - self.origin_x_m) / res + k, 0.0, cols + 2 * k - 1).astype(np.intp)
        row = np.clip((y - self.origin_y_m) / res + k, 0.0, rows + 2 * k - 1).astype(np.intp)
        cells, cell_of = np.unique(row * (cols + 2 * k) + col, return_inverse=True)
        cand = cells[:, None] + self._neighbour_offsets[None, :]
        np.clip(cand, 0, self._ids_padded.size - 1, out=cand)
        ids = np.take(self._ids_padded, cand)
        cell_i, slot = np.nonzero(ids >= 0)
        if cell_i.size == 0:
            return np.zeros(n, np.int_), clearance
        obs_of_cell = ids[cell_i, slot]
        per_cell = np.bincount(cell_i, minlength=len(cells))
        first = np.cumsum(per_cell) - per_cell
        per_pose = per_cell[cell_of]
        pose_i = np.repeat(np.arange(n), per_pose)
        within = np.arange(pose_i.size) - np.repeat(np.cumsum(per_pose) - per_pose, per_pose)
        obs = obs_of_cell[np.repeat(first[cell_of], per_pose) + within]
        dx = self._obstacle_xy[obs, 0] - x[pose_i]
        dy = self._obstacle_xy[obs, 1] - y[pose_i]
        h = self._obstacle_r_m[obs]
        gap = np.hypot(dx, dy) - h
        if with_clearance:
            np.minimum.at(clearance, pose_i, gap)
        cfg = self.config
        margin = np.asarray(margin_m, np.float64)
        if margin.ndim:
            margin = margin[pose_i]
        hit = gap < cfg.robot_radius_m + margin
        # only discs within the grown rectangle's corner radius can touch it
        grown = h + margin
        reach = cfg.circumscribed_radius_m + math.sqrt(2.0) * grown - h
        maybe = np.flatnonzero(~hit & (gap < reach))
        if maybe.size:
            pi = pose_i[maybe]
            cos, sin = np.cos(yaw[pi]), np.sin(yaw[pi])
            mx, my, g = dx[maybe], dy[maybe], grown[maybe]
            lx = cos * mx + sin * my
            ly = cos * my - sin * mx
            (x0, x1), (y0, y1) = cfg.footprint_x_m, cfg.footprint_y_m
            hit[maybe] = (lx >= x0 - g) & (lx <= x1 + g) & (ly >= y0 - g) & (ly <= y1 + g)
        return np.bincount(pose_i[hit], minlength=n).astype(np.int_), clearance


def _ringed(inner: npt.NDArray[T], value: float) -> npt.NDArray[T]:
    """``np.pad(inner, 1, constant_values=value)`` without its generality's cost (a costmap
    update pads three grids)."""
    out = np.empty((inner.shape[0] + 2, inner.shape[1] + 2), inner.dtype)
    out[0] = out[-1] = value
    out[1:-1, 0] = out[1:-1, -1] = value
    out[1:-1, 1:-1] = inner
    return out


def _disc_offsets(k: int, row_stride: int, resolution_m: float, reach_m: float) -> IntArray:
    """Flat offsets (rows of ``row_stride`` cells) of the cells within ``reach_m`` of a cell,
    centre to centre, in a square of 2 k + 1 cells."""
    dr, dc, distance_m = _square(k, resolution_m)
    disc = distance_m <= reach_m
    offsets: IntArray = (dr[disc] * row_stride + dc[disc]).astype(np.intp)
    return offsets


@functools.lru_cache(maxsize=32)
def _square(k: int, resolution_m: float) -> tuple[IntArray, IntArray, FloatArray]:
    """The cells of a square of 2 k + 1 cells around one, as row and column offsets, and their
    centres' distance to its centre [m] (read-only, shared: the reach changes with every scan,
    the square does not)."""
    dr, dc = np.mgrid[-k : k + 1, -k : k + 1]
    distance_m = np.hypot(dr, dc) * resolution_m
    for a in (dr, dc, distance_m):
        a.flags.writeable = False
    return dr, dc, distance_m


def _capsules(
    q: FloatArray,
    r: IntArray,
    c: IntArray,
    cells: IntArray,
    cols: int,
    noise_m: float,
) -> tuple[FloatArray, FloatArray]:
    """Each of ``cells`` (row * cols + col, sorted) as the capsule of the returns ``q`` (in
    cells ``r``, ``c``) that lie in it or its eight neighbours: their centroid (n, 2) and
    (unit direction of their largest spread, half-length along it, radius) (n, 4) [m].

    Across a wall the returns spread by the range noise alone, about the wall, while their
    centroid lies within 2 sigma / sqrt(n) of it: the radius is the farthest return across
    less sigma sqrt(2 ln n) (about as far as the farthest of n noises reaches), no less than
    0, plus 2 sigma / sqrt(n). An obstacle that really extends across keeps its extent; a
    noisier LiDAR than ``noise_m`` only makes the capsules wider.
    """
    n = len(cells)
    if n == 0:
        return np.zeros((0, 2)), np.zeros((0, 4))
    member, target = [], []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            key = (r + dr) * cols + (c + dc)
            k = np.minimum(np.searchsorted(cells, key), n - 1)
            # a column off the window's edge is not the next row's first or last cell
            hit = (cells[k] == key) & (c + dc >= 0) & (c + dc < cols)
            member.append(np.flatnonzero(hit))
            target.append(k[hit])
    i, g = np.concatenate(member), np.concatenate(target)
    count = np.bincount(g, minlength=n).astype(np.float64)
    centre = np.column_stack(
        (np.bincount(g, q[i, 0], n) / count, np.bincount(g, q[i, 1], n) / count)
    )
    d = q[i] - centre[g]
    sxx = np.bincount(g, d[:, 0] * d[:, 0], n)
    sxy = np.bincount(g, d[:, 0] * d[:, 1], n)
    syy = np.bincount(g, d[:, 1] * d[:, 1], n)
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    out = np.zeros((n, 4))
    out[:, 0], out[:, 1] = np.cos(theta), np.sin(theta)
    along = d[:, 0] * out[g, 0] + d[:, 1] * out[g, 1]
    across = d[:, 1] * out[g, 0] - d[:, 0] * out[g, 1]
    np.maximum.at(out[:, 2], g, np.abs(along))
    np.maximum.at(out[:, 3], g, np.abs(across))
    noise = noise_m * np.sqrt(2.0 * np.log(count))  # how far the farthest of n noises reaches
    out[:, 3] = np.maximum(out[:, 3] - noise, 0.0) + 2.0 * noise_m / np.sqrt(count)
    return centre, out
