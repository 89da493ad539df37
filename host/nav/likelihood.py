"""A likelihood field of an occupancy grid: how far each point lies from the nearest obstacle.

The field holds, for every cell of an :class:`~jackson.host.nav.grid.OccupancyGrid`, the
Euclidean distance d [m] from its centre to the centre of the nearest occupied cell, capped at
``max_distance_m`` (AMCL's ``laser_likelihood_max_dist``). A range return that lands at distance
d from the nearest obstacle has the likelihood

    p(z | x, m) = exp(-d^2 / (2 sigma^2))

(the likelihood-field sensor model of Thrun, Burgard and Fox, *Probabilistic Robotics* 6.4,
without its random and max-range terms). A particle filter weighs its particles with it; a scan
matcher maximises its mean over a scan.

:class:`LikelihoodField` works on any grid, e.g. a map loaded from map_server files, and measures
between cell centres, so it places an obstacle only to within half a cell. :class:`PointField`
measures to a point given in each occupied cell (where in the cell the obstacle was seen), which
a mapper that keeps its returns can supply; the scan matcher of :mod:`jackson.host.nav.slam.mapper`
uses it to resolve the pose below the cell size.

Unknown cells (-1) count as free: only cells at or above ``occupied_threshold`` attract points.
A point off the grid reads ``max_distance_m``, as does every point of a grid with no occupied
cell. The field is a padded copy of the distance array (one border cell of ``max_distance_m`` on
every side) so a lookup is one clamp and one gather, with no masking.

:class:`LikelihoodField` is the one likelihood field of the project: the particle filter
(:mod:`jackson.host.nav.amcl`) weighs its particles with it and the mapper hands it out. Its
arithmetic is fixed, because recorded runs replay the filter bit for bit: the distances are the
transform in cells times the resolution, ``edt * resolution`` (``sampling=resolution`` differs
from it in the last bit in about one cell in ten), and a point's cell is
``floor((x - origin) * (1 / resolution))`` (adding the padding offset before the ``floor``
rounds some points within an ulp of a cell edge into the next cell). Its grid's place is the
shared :class:`~jackson.common.geometry.GridCells` arithmetic (``geometry``, ``world_to_cell``),
the map's own; only the lookups keep the arithmetic above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.ndimage import distance_transform_edt

from jackson.common.geometry import GridCells
from jackson.host.nav.grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]

MAX_DISTANCE_M = 2.0  # [m] AMCL's laser_likelihood_max_dist default
OCCUPIED_THRESHOLD = 50  # [%] cells at or above this are obstacles
_FAR_M = 1e9  # [m] where a cell with no obstacle point in reach points to


@dataclass(frozen=True)
class LikelihoodField(GridCells):
    """Distance [m] from every cell of a grid to its nearest occupied cell.

    Build it with :meth:`from_grid`.

    Attributes
    ----------
    distance_m : ndarray of float64, shape (rows, cols)
        Distance from each cell's centre to the nearest occupied cell's centre, capped at
        ``max_distance_m`` [m]; row 0 is the lowest y, as in the grid.
    resolution_m : float
        Cell edge [m].
    origin_x_m, origin_y_m : float
        Map-frame position of the lower-left corner of cell (0, 0) [m].
    max_distance_m : float
        The cap, and the distance of any point off the grid [m].
    """

    distance_m: FloatArray
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    max_distance_m: float = MAX_DISTANCE_M
    _padded: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.distance_m.ndim != 2 or self.distance_m.size == 0:
            raise ValueError(
                f"LikelihoodField: distance_m must be a non-empty 2-D array, "
                f"got {self.distance_m.shape}"
            )
        if not 0.0 < self.resolution_m < math.inf:
            raise ValueError(f"LikelihoodField: resolution_m must be > 0, got {self.resolution_m}")
        if not 0.0 < self.max_distance_m < math.inf:
            raise ValueError(
                f"LikelihoodField: max_distance_m must be > 0, got {self.max_distance_m}"
            )
        padded = np.pad(
            np.asarray(self.distance_m, np.float64), 1, constant_values=self.max_distance_m
        )
        padded.flags.writeable = False
        object.__setattr__(self, "_padded", padded)

    @classmethod
    def from_grid(
        cls,
        grid: OccupancyGrid,
        max_distance_m: float = MAX_DISTANCE_M,
        occupied_threshold: int = OCCUPIED_THRESHOLD,
    ) -> LikelihoodField:
        """The field of ``grid`` (scipy's exact Euclidean distance transform, in cells, times the
        resolution).

        Parameters
        ----------
        grid : OccupancyGrid
            The map; cells at or above ``occupied_threshold`` are obstacles, unknown cells
            are not.
        max_distance_m : float
            Cap on the distance [m].
        occupied_threshold : int
            Occupancy [%] from which a cell is an obstacle.

        Returns
        -------
        LikelihoodField
        """
        if not 0.0 < max_distance_m < math.inf:
            raise ValueError(f"max_distance_m: expected a number > 0, got {max_distance_m}")
        occupied = grid.occupied(occupied_threshold)
        if occupied.any():
            cells = np.asarray(distance_transform_edt(~occupied), np.float64)
            distance = np.minimum(cells * grid.resolution_m, max_distance_m)
        else:
            distance = np.full(occupied.shape, max_distance_m, np.float64)
        return cls(distance, grid.resolution_m, grid.origin_x_m, grid.origin_y_m, max_distance_m)

    @property
    def padded_distance_m(self) -> FloatArray:
        """The distances with one border cell of ``max_distance_m`` on every side, read-only:
        what a lookup reads (the grid's cell (0, 0) is its (1, 1))."""
        return self._padded

    @property
    def height(self) -> int:
        """Rows."""
        return int(self.distance_m.shape[0])

    @property
    def width(self) -> int:
        """Columns."""
        return int(self.distance_m.shape[1])

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return (self.height, self.width)

    def distance_at(self, points_xy: npt.ArrayLike, bilinear: bool = False) -> FloatArray:
        """Distance [m] from map-frame points to the nearest obstacle, read off the field.

        Parameters
        ----------
        points_xy : array_like, shape (..., 2)
            Map-frame points [m], e.g. (N, 2) or, for a particle filter, (particles, beams, 2).
        bilinear : bool
            False (AMCL's way): the value of the cell holding each point. True: bilinear
            interpolation between the four nearest cell centres, continuous in the point, as a
            scan matcher that resolves sub-cell shifts needs (within half a cell outside the
            grid it blends towards ``max_distance_m``).

        Returns
        -------
        ndarray of float64, shape (...)
            Distances [m]; ``max_distance_m`` for points off the grid.
        """
        p = np.asarray(points_xy, np.float64)
        if p.ndim < 1 or p.shape[-1] != 2:
            raise ValueError(f"points_xy: expected shape (..., 2), got {p.shape}")
        return self.distance_xy(p[..., 0], p[..., 1], bilinear)

    def distance_xy(
        self, x_m: npt.ArrayLike, y_m: npt.ArrayLike, bilinear: bool = False
    ) -> FloatArray:
        """:meth:`distance_at` for coordinates given as two arrays of any one shape.

        A particle filter or a pose search can pass ``(poses, beams)`` arrays as they are,
        without stacking them into points.

        Parameters
        ----------
        x_m, y_m : array_like
            Map-frame coordinates [m], broadcast against each other.
        bilinear : bool
            Interpolate the field (see :meth:`distance_at`).

        Returns
        -------
        ndarray of float64
            Distances [m] in the broadcast shape of ``x_m`` and ``y_m``.
        """
        padded = self._padded
        rows_p, cols_p = padded.shape
        flat = padded.ravel()
        inv = 1.0 / self.resolution_m
        x = np.asarray(x_m, np.float64)
        y = np.asarray(y_m, np.float64)
        if not bilinear:
            # the grid's cell, clamped to the border (-1 or width, height) off the grid; NaN
            # reads the border too (fmin ignores it). The grid's cell (0, 0) is padded (1, 1).
            col = np.fmax(np.fmin(np.floor((x - self.origin_x_m) * inv), cols_p - 2.0), -1.0)
            row = np.fmax(np.fmin(np.floor((y - self.origin_y_m) * inv), rows_p - 2.0), -1.0)
            index = (row * cols_p + col + (cols_p + 1.0)).astype(np.intp)
            out: FloatArray = flat[index]
            return out
        # padded cell coordinates: the grid's cell (0, 0) is padded cell (1, 1)
        u, v = np.broadcast_arrays(
            (x - self.origin_x_m) * inv + 1.0, (y - self.origin_y_m) * inv + 1.0
        )
        u = np.clip(u - 0.5, 0.0, cols_p - 1.0)  # to coordinates of cell centres
        v = np.clip(v - 0.5, 0.0, rows_p - 1.0)
        c0 = np.minimum(u.astype(np.intp), cols_p - 2)
        r0 = np.minimum(v.astype(np.intp), rows_p - 2)
        fu = u - c0
        fv = v - r0
        i = r0 * cols_p + c0
        bottom: FloatArray = flat[i]
        bottom += (flat[i + 1] - bottom) * fu
        top: FloatArray = flat[i + cols_p]
        top += (flat[i + cols_p + 1] - top) * fu
        top -= bottom
        top *= fv
        top += bottom
        return top

    def score(self, points_xy: npt.ArrayLike, sigma_m: float, bilinear: bool = False) -> float:
        """Mean Gaussian likelihood of points, ``mean exp(-d^2 / (2 sigma^2))``, in [0, 1].

        Parameters
        ----------
        points_xy : array_like, shape (N, 2)
            Map-frame points [m], e.g. a scan's returns at a candidate pose.
        sigma_m : float
            Standard deviation of the Gaussian [m].
        bilinear : bool
            Interpolate the field (see :meth:`distance_at`).

        Returns
        -------
        float
            1 when every point lies on an obstacle, 0 for no points.
        """
        if not sigma_m > 0.0:
            raise ValueError(f"sigma_m: expected a number > 0, got {sigma_m}")
        d = self.distance_at(points_xy, bilinear)
        if d.size == 0:
            return 0.0
        return float(np.mean(np.exp(d * d * (-0.5 / (sigma_m * sigma_m)))))


@dataclass(frozen=True)
class PointField:
    """Distance [m] to the nearest obstacle point, resolved below the cell size.

    A :class:`LikelihoodField` measures from cell centres, so a wall that runs along a cell's
    edge reads half a cell off, and a matcher maximising it pulls a scan up to half a cell
    towards the centres. Here each occupied cell carries a point, where in the cell the obstacle
    is (the mean of the returns that hit it, say), and a lookup finds the occupied cell nearest
    to the query's cell (scipy's feature transform) and measures to that cell's point: exact to
    the points, continuous except where the nearest cell changes. A point off the grid, or
    farther than ``max_distance_m`` from every point, reads ``max_distance_m``.

    Build it with :meth:`from_cells`.

    Attributes
    ----------
    nearest_x_m, nearest_y_m : ndarray of float64, shape (rows + 2, cols + 2)
        Map-frame point of the occupied cell nearest to each cell [m], with a border of one
        cell on every side that holds no point (a far sentinel).
    resolution_m : float
        Cell edge [m].
    origin_x_m, origin_y_m : float
        Map-frame position of the lower-left corner of cell (0, 0) of the unpadded grid [m].
    max_distance_m : float
        The cap on a distance [m].
    """

    nearest_x_m: FloatArray
    nearest_y_m: FloatArray
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    max_distance_m: float = MAX_DISTANCE_M

    @classmethod
    def from_cells(
        cls,
        occupied: npt.NDArray[np.bool_],
        points_x_m: FloatArray,
        points_y_m: FloatArray,
        resolution_m: float,
        origin_x_m: float,
        origin_y_m: float,
        max_distance_m: float = MAX_DISTANCE_M,
    ) -> PointField:
        """The field of the occupied cells of a grid and a point in each.

        Parameters
        ----------
        occupied : ndarray of bool, shape (rows, cols)
            Obstacle cells; row 0 is the lowest y.
        points_x_m, points_y_m : ndarray of float64, shape (rows, cols)
            Map-frame point of the obstacle in each occupied cell [m] (read only there).
        resolution_m : float
            Cell edge [m].
        origin_x_m, origin_y_m : float
            Map-frame position of the lower-left corner of cell (0, 0) [m].
        max_distance_m : float
            Cap on the distance [m].

        Returns
        -------
        PointField
        """
        if occupied.ndim != 2 or occupied.size == 0:
            raise ValueError(f"occupied: expected a non-empty 2-D array, got {occupied.shape}")
        if points_x_m.shape != occupied.shape or points_y_m.shape != occupied.shape:
            raise ValueError(
                f"points: expected the shape of occupied {occupied.shape}, "
                f"got {points_x_m.shape} and {points_y_m.shape}"
            )
        if not 0.0 < resolution_m < math.inf:
            raise ValueError(f"resolution_m: expected a number > 0, got {resolution_m}")
        if not 0.0 < max_distance_m < math.inf:
            raise ValueError(f"max_distance_m: expected a number > 0, got {max_distance_m}")
        far = _FAR_M
        nx = np.full((occupied.shape[0] + 2, occupied.shape[1] + 2), far)
        ny = np.full(nx.shape, far)
        if occupied.any():
            rows, cols = distance_transform_edt(
                ~occupied, return_distances=False, return_indices=True
            )
            nx[1:-1, 1:-1] = points_x_m[rows, cols]
            ny[1:-1, 1:-1] = points_y_m[rows, cols]
        nx.flags.writeable = False
        ny.flags.writeable = False
        return cls(nx, ny, resolution_m, origin_x_m, origin_y_m, max_distance_m)

    def distance_xy(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> FloatArray:
        """Distance [m] from map-frame points to the nearest obstacle point, capped.

        Parameters
        ----------
        x_m, y_m : array_like
            Map-frame coordinates [m], broadcast against each other.

        Returns
        -------
        ndarray of float64
            Distances [m] in the broadcast shape of ``x_m`` and ``y_m``.
        """
        rows_p, cols_p = self.nearest_x_m.shape
        inv = 1.0 / self.resolution_m
        x = np.asarray(x_m, np.float64)
        y = np.asarray(y_m, np.float64)
        c = np.clip((x - self.origin_x_m) * inv + 1.0, 0.0, cols_p - 1.0).astype(np.intp)
        r = np.clip((y - self.origin_y_m) * inv + 1.0, 0.0, rows_p - 1.0).astype(np.intp)
        k = r * cols_p + c
        dx = x - self.nearest_x_m.ravel()[k]
        dy = y - self.nearest_y_m.ravel()[k]
        d: FloatArray = np.asarray(np.hypot(dx, dy))
        return np.minimum(d, self.max_distance_m, out=d)

    def score(self, points_xy: npt.ArrayLike, sigma_m: float) -> float:
        """Mean Gaussian likelihood of points, ``mean exp(-d^2 / (2 sigma^2))``, in [0, 1].

        Parameters
        ----------
        points_xy : array_like, shape (N, 2)
            Map-frame points [m].
        sigma_m : float
            Standard deviation of the Gaussian [m].

        Returns
        -------
        float
            1 when every point lies on an obstacle point, 0 for no points.
        """
        if not sigma_m > 0.0:
            raise ValueError(f"sigma_m: expected a number > 0, got {sigma_m}")
        p = np.asarray(points_xy, np.float64)
        if p.ndim != 2 or p.shape[1] != 2:
            raise ValueError(f"points_xy: expected shape (N, 2), got {p.shape}")
        if p.shape[0] == 0:
            return 0.0
        d = self.distance_xy(p[:, 0], p[:, 1])
        return float(np.mean(np.exp(d * d * (-0.5 / (sigma_m * sigma_m)))))
