"""Planar geometry every layer uses: angle wrapping and a grid's world <-> cell mapping, each
written once.

Two angle conventions are in use, each where it belongs, and each is kept bit for bit as the
code that uses it was recorded with (``jackson replay``): :func:`wrap_angle` and
:func:`wrap_angles`, ``(a + pi) mod 2 pi - pi`` in [-pi, pi), for differences of headings
(controllers, the EKF, AMCL, the metrics); :func:`angle_of`, ``atan2(sin a, cos a)`` in
[-pi, pi], for the heading of a composed rotation (poses, frames).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
_EXACT = 2.0**62  # cell coordinates a float64's floor takes to an int64 exactly
IntArray = npt.NDArray[np.int_]


def wrap_angle(angle_rad: float) -> float:
    """The angle in [-pi, pi) [rad]: ``(a + pi) mod 2 pi - pi``."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def wrap_angles(angles_rad: npt.ArrayLike) -> FloatArray:
    """:func:`wrap_angle` elementwise (the same arithmetic, numpy's floor modulo), any shape."""
    a = np.asarray(angles_rad, dtype=np.float64)
    return np.asarray(np.mod(a + math.pi, 2.0 * math.pi) - math.pi, np.float64)


def angle_of(angle_rad: float) -> float:
    """The heading of the rotation by ``angle_rad``, in [-pi, pi] [rad]: ``atan2(sin, cos)``."""
    return math.atan2(math.sin(angle_rad), math.cos(angle_rad))


def world_to_cell(
    x_m: npt.ArrayLike,
    y_m: npt.ArrayLike,
    origin_x_m: float,
    origin_y_m: float,
    resolution_m: float,
) -> tuple[IntArray, IntArray]:
    """(row, col) of the grid cells holding world points (rows along y, columns along x, cell
    (0, 0)'s corner at the origin; the cells may lie outside the grid).

    Parameters
    ----------
    x_m, y_m : array_like
        Points [m].
    origin_x_m, origin_y_m : float
        The grid's lower-left corner [m].
    resolution_m : float
        Cell edge [m].

    Returns
    -------
    row, col : ndarray of int
        ``floor((p - origin) / resolution)``.
    """
    if isinstance(x_m, float) and isinstance(y_m, float):  # one point, in plain floats
        fx = (x_m - origin_x_m) / resolution_m
        fy = (y_m - origin_y_m) / resolution_m
        if abs(fx) < _EXACT and abs(fy) < _EXACT:  # (NaN, infinity and beyond: numpy's path)
            return (
                cast(IntArray, np.int_(math.floor(fy))),
                cast(IntArray, np.int_(math.floor(fx))),
            )  # as numpy gives them: scalars
    col = np.floor((np.asarray(x_m, np.float64) - origin_x_m) / resolution_m)
    row = np.floor((np.asarray(y_m, np.float64) - origin_y_m) / resolution_m)
    return row.astype(np.int_), col.astype(np.int_)


def cell_to_world(
    row: npt.ArrayLike,
    col: npt.ArrayLike,
    origin_x_m: float,
    origin_y_m: float,
    resolution_m: float,
) -> tuple[FloatArray, FloatArray]:
    """World centres (x, y) [m] of grid cells (the inverse of :func:`world_to_cell` up to the
    cell)."""
    if isinstance(row, int | np.integer) and isinstance(col, int | np.integer):  # one cell
        return (
            cast(FloatArray, np.float64(origin_x_m + (float(col) + 0.5) * resolution_m)),
            cast(FloatArray, np.float64(origin_y_m + (float(row) + 0.5) * resolution_m)),
        )  # as numpy gives them: scalars
    x = origin_x_m + (np.asarray(col, np.float64) + 0.5) * resolution_m
    y = origin_y_m + (np.asarray(row, np.float64) + 0.5) * resolution_m
    return x, y


class GridCells:
    """World <-> cell arithmetic of a grid in the map frame, shared by the occupancy grid, the
    likelihood field, the costmaps, their layers and the planner's copy of their costs: the
    grid gives its lower-left corner (``origin_x_m``, ``origin_y_m``), its cell edge
    (``resolution_m``) and its ``shape`` (rows, cols); rows run along y, columns along x.
    :attr:`geometry` is the same as one :class:`GridGeometry` value."""

    origin_x_m: float
    origin_y_m: float
    resolution_m: float

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        raise NotImplementedError

    def world_to_cell(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> tuple[IntArray, IntArray]:
        """(row, col) of the cells holding map-frame points (may lie outside the grid)."""
        return world_to_cell(x_m, y_m, self.origin_x_m, self.origin_y_m, self.resolution_m)

    def cell_to_world(
        self, row: npt.ArrayLike, col: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Map-frame centres of cells [m]."""
        return cell_to_world(row, col, self.origin_x_m, self.origin_y_m, self.resolution_m)

    def inside(self, row: npt.ArrayLike, col: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """Which (row, col) lie on the grid."""
        r, c = np.asarray(row), np.asarray(col)
        rows, cols = self.shape
        return (r >= 0) & (r < rows) & (c >= 0) & (c < cols)

    @property
    def geometry(self) -> GridGeometry:
        """The grid's place and size as one value."""
        return GridGeometry(self.origin_x_m, self.origin_y_m, self.resolution_m, *self.shape)

    def centres(self) -> tuple[FloatArray, FloatArray]:
        """Map-frame centres of every cell [m]: x of shape (1, cols), y of shape (rows, 1)."""
        rows, cols = self.shape
        return self.cell_to_world(np.arange(rows)[:, None], np.arange(cols)[None, :])

    def padded_index(self, x_m: npt.ArrayLike, y_m: npt.ArrayLike) -> IntArray:
        """Flat indices into the grid padded by one ring of cells, row-major over (rows + 2,
        cols + 2): a point on the grid lands on its cell, a point off it on the ring.

        Parameters
        ----------
        x_m, y_m : array_like
            Map-frame points [m], broadcast against each other.

        Returns
        -------
        ndarray of int
            The indices, the broadcast shape of the inputs.
        """
        rows, cols = self.shape
        if isinstance(x_m, float) and isinstance(y_m, float):  # one point, in plain floats
            one = self._padded_one(x_m, y_m)
            if one is not None:
                return cast(IntArray, np.intp(one))  # as numpy gives it: a scalar
        fx = (np.asarray(x_m, np.float64) - self.origin_x_m) / self.resolution_m + 1.0
        fy = (np.asarray(y_m, np.float64) - self.origin_y_m) / self.resolution_m + 1.0
        # clipped into [0, size + 1] first, so truncation is the floor
        col = np.clip(fx, 0.0, cols + 1.0).astype(np.intp)
        row = np.clip(fy, 0.0, rows + 1.0).astype(np.intp)
        row *= cols + 2
        row += col
        return row

    def _padded_one(self, x_m: float, y_m: float) -> int | None:
        """:meth:`padded_index` of one point by the same IEEE operations on plain floats (a
        tenth of numpy's calls' cost); None for NaN, which numpy's path takes."""
        rows, cols = self.shape
        fx = (x_m - self.origin_x_m) / self.resolution_m + 1.0
        fy = (y_m - self.origin_y_m) / self.resolution_m + 1.0
        if fx != fx or fy != fy:
            return None
        return int(min(max(fy, 0.0), rows + 1.0)) * (cols + 2) + int(min(max(fx, 0.0), cols + 1.0))


@dataclass(frozen=True)
class GridGeometry(GridCells):
    """A grid's place in the map frame as one value: the lower-left corner of cell (0, 0)
    [m], the cell edge [m] and the size [cells] (Nav2's costmap_2d keeps the same four).

    The costmap's layers share their master's, a rolling window moves it by whole cells
    (:meth:`moved`), and the compiled tests take it as one argument (:meth:`as_tuple`).
    """

    origin_x_m: float
    origin_y_m: float
    resolution_m: float
    rows: int
    cols: int

    def __post_init__(self) -> None:
        if self.rows < 1 or self.cols < 1:
            raise ValueError(f"a grid must be at least 1 x 1 cells, got {self.rows} x {self.cols}")
        if not 0.0 < self.resolution_m < math.inf:
            raise ValueError(f"a grid's resolution_m must be > 0, got {self.resolution_m}")

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        return (self.rows, self.cols)

    @property
    def geometry(self) -> GridGeometry:
        """Itself."""
        return self

    @classmethod
    def centred(cls, x_m: float, y_m: float, n: int, resolution_m: float) -> GridGeometry:
        """An n x n grid centred near (x, y), its origin snapped to whole cells of the map
        frame (a rolling window's)."""
        half = 0.5 * n * resolution_m
        return cls(
            math.floor((x_m - half) / resolution_m) * resolution_m,
            math.floor((y_m - half) / resolution_m) * resolution_m,
            resolution_m, n, n,
        )  # fmt: skip

    def moved(self, rows: int, cols: int) -> GridGeometry:
        """The same grid moved by whole cells (rows along y, cols along x)."""
        return GridGeometry(
            self.origin_x_m + cols * self.resolution_m,
            self.origin_y_m + rows * self.resolution_m,
            self.resolution_m, self.rows, self.cols,
        )  # fmt: skip

    def as_tuple(self) -> tuple[float, float, float, int, int]:
        """(origin x, origin y, resolution, rows, cols)."""
        return (self.origin_x_m, self.origin_y_m, self.resolution_m, self.rows, self.cols)
