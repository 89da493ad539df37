"""The twin's ground-truth occupancy raster of a world, to score maps against (Eq. 15).

:func:`raster` marks the cells a world's obstacles occupy on a regular grid in the world frame,
in the layout of ``nav_msgs/OccupancyGrid`` (row 0 at the lowest y, the origin at the lower-left
corner of cell (0, 0)) but as plain arrays, because the twin does not know the host's types:

- a wall is a segment of zero thickness (as the ray caster sees it) and marks every cell its
  interior passes through, found exactly from the parameters at which it crosses the grid lines
  (a supercover line; Bresenham's line would skip cells it clips at a corner). A stretch that runs
  along a grid line touches the cells on both sides and marks both;
- a cylinder marks the cells whose centre lies within its radius plus half a cell, so a disc
  at least as wide as a cell always shows, and its interior is solid.

A map made from inside a closed world can at best know the free space connected to where the
robot was; :func:`reachable_free` finds it, so a truth image can leave the rest unknown as the
map does (the world outside the walls is unknown to the robot, not free).

Without ``bounds`` the raster covers the world's obstacles and start position plus
``margin_m``, its edges snapped outward to multiples of the resolution: any grid whose origin is
a multiple of the resolution (such as the host's mapper) then lines up with it cell for cell.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from jackson.common.geometry import world_to_cell
from jackson.sim.config import Cylinder, WorldSpec

BoolArray = npt.NDArray[np.bool_]

MARGIN_M = 0.5  # [m] room around the world's extent in the default bounds
_ON_LINE = 1e-9  # [cells] a coordinate this close to an integer lies on a grid line


def raster(
    world: WorldSpec,
    resolution_m: float = 0.05,
    bounds: tuple[float, float, float, float] | None = None,
    include_triggers: bool = False,
    margin_m: float = MARGIN_M,
) -> tuple[BoolArray, float, float]:
    """Occupied cells of ``world`` on a grid of ``resolution_m``.

    Parameters
    ----------
    world : WorldSpec
        The world: its walls and cylinders.
    resolution_m : float
        Cell edge [m].
    bounds : tuple of float, optional
        ``(x_min, y_min, x_max, y_max)`` of the grid in the world frame [m], used as given (the
        grid has ``ceil((x_max - x_min) / resolution_m)`` columns); default the world's extent
        plus ``margin_m``, snapped outward to multiples of ``resolution_m``.
    include_triggers : bool
        Also mark the cylinders the world's triggers insert during a run.
    margin_m : float
        Room around the world's extent in the default bounds [m].

    Returns
    -------
    occupied : ndarray of bool, shape (rows, cols)
        True where an obstacle is; row 0 is the lowest y.
    origin_x_m, origin_y_m : float
        World-frame position of the lower-left corner of cell (0, 0) [m].

    Raises
    ------
    ValueError
        A resolution that is not > 0, a negative margin, or bounds with no area.
    """
    if not 0.0 < resolution_m < math.inf:
        raise ValueError(f"resolution_m: expected a number > 0, got {resolution_m}")
    if not 0.0 <= margin_m < math.inf:
        raise ValueError(f"margin_m: expected a number >= 0, got {margin_m}")
    cylinders = list(world.cylinders)
    if include_triggers:
        cylinders += [t.cylinder for t in world.triggers]
    if bounds is None:
        bounds = _extent(world, cylinders, resolution_m, margin_m)
    x_min, y_min, x_max, y_max = (float(b) for b in bounds)
    if not (math.isfinite(x_max - x_min) and math.isfinite(y_max - y_min)):
        raise ValueError(f"bounds: expected finite numbers, got {bounds}")
    if not (x_max > x_min and y_max > y_min):
        raise ValueError(f"bounds: expected x_min < x_max and y_min < y_max, got {bounds}")
    cols = max(1, math.ceil((x_max - x_min) / resolution_m - _ON_LINE))
    rows = max(1, math.ceil((y_max - y_min) / resolution_m - _ON_LINE))
    occupied = np.zeros((rows, cols), np.bool_)
    for x1, y1, x2, y2 in world.walls:
        u1, v1 = (x1 - x_min) / resolution_m, (y1 - y_min) / resolution_m
        u2, v2 = (x2 - x_min) / resolution_m, (y2 - y_min) / resolution_m
        _mark_segment(occupied, u1, v1, u2, v2)
    for c in cylinders:
        _mark_disc(occupied, c, x_min, y_min, resolution_m)
    return occupied, x_min, y_min


def reachable_free(
    occupied: BoolArray,
    origin_x_m: float,
    origin_y_m: float,
    resolution_m: float,
    start_xy_m: tuple[float, float],
) -> BoolArray:
    """Free cells edge-connected to the cell holding ``start_xy_m``.

    Edge (4-) connectivity, so free space does not leak through a diagonal wall whose cells only
    meet at corners.

    Parameters
    ----------
    occupied : ndarray of bool, shape (rows, cols)
        A raster from :func:`raster`.
    origin_x_m, origin_y_m : float
        World-frame position of the lower-left corner of cell (0, 0) [m].
    resolution_m : float
        Cell edge [m].
    start_xy_m : tuple of float
        A world-frame point in the free space, e.g. the robot's start position [m].

    Returns
    -------
    ndarray of bool, shape (rows, cols)
        True for the free cells connected to the start; all False when the start lies off the
        raster or on an occupied cell.
    """
    cell = world_to_cell(start_xy_m[0], start_xy_m[1], origin_x_m, origin_y_m, resolution_m)
    row, col = int(cell[0]), int(cell[1])
    h, w = occupied.shape
    if not (0 <= row < h and 0 <= col < w) or occupied[row, col]:
        return np.zeros(occupied.shape, np.bool_)
    labels, _ = ndimage.label(~occupied)
    result: BoolArray = labels == labels[row, col]
    return result


def _extent(
    world: WorldSpec, cylinders: list[Cylinder], resolution_m: float, margin_m: float
) -> tuple[float, float, float, float]:
    """The world's obstacles and start position plus the margin, snapped outward."""
    xs = [world.start_pose[0]]
    ys = [world.start_pose[1]]
    for x1, y1, x2, y2 in world.walls:
        xs += [x1, x2]
        ys += [y1, y2]
    for c in cylinders:
        xs += [c.x - c.radius, c.x + c.radius]
        ys += [c.y - c.radius, c.y + c.radius]
    lo_x = math.floor((min(xs) - margin_m) / resolution_m + _ON_LINE)
    lo_y = math.floor((min(ys) - margin_m) / resolution_m + _ON_LINE)
    hi_x = math.ceil((max(xs) + margin_m) / resolution_m - _ON_LINE)
    hi_y = math.ceil((max(ys) + margin_m) / resolution_m - _ON_LINE)
    hi_x, hi_y = max(hi_x, lo_x + 1), max(hi_y, lo_y + 1)
    return lo_x * resolution_m, lo_y * resolution_m, hi_x * resolution_m, hi_y * resolution_m


def _crossings(a: float, b: float) -> npt.NDArray[np.float64]:
    """Parameters t in (0, 1) at which ``a + t (b - a)`` crosses an integer."""
    if a == b:
        return np.zeros(0)
    lines = np.arange(math.ceil(min(a, b)), math.floor(max(a, b)) + 1, dtype=np.float64)
    t: npt.NDArray[np.float64] = (lines - a) / (b - a)
    return t[(t > 0.0) & (t < 1.0)]


def _mark_segment(occupied: BoolArray, u1: float, v1: float, u2: float, v2: float) -> None:
    """Mark the cells the segment from (u1, v1) to (u2, v2), in cell units, passes through.

    Between consecutive grid-line crossings the segment stays inside one cell: the one holding
    the midpoint of that stretch.
    """
    t = np.unique(np.concatenate(([0.0, 1.0], _crossings(u1, u2), _crossings(v1, v2))))
    mid = 0.5 * (t[:-1] + t[1:]) if t.size > 1 else np.zeros(1)
    u = u1 + mid * (u2 - u1)
    v = v1 + mid * (v2 - v1)
    cols = [np.floor(u)]
    rows = [np.floor(v)]
    if u1 == u2 and abs(u1 - round(u1)) < _ON_LINE:  # along a vertical grid line
        cols = [np.full_like(u, round(u1)), np.full_like(u, round(u1) - 1)]
        rows *= 2
    elif v1 == v2 and abs(v1 - round(v1)) < _ON_LINE:  # along a horizontal grid line
        rows = [np.full_like(v, round(v1)), np.full_like(v, round(v1) - 1)]
        cols *= 2
    col = np.concatenate(cols).astype(np.intp)
    row = np.concatenate(rows).astype(np.intp)
    h, w = occupied.shape
    inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
    occupied[row[inside], col[inside]] = True


def _mark_disc(
    occupied: BoolArray, c: Cylinder, x_min: float, y_min: float, resolution_m: float
) -> None:
    """Mark the cells whose centre lies within ``c.radius + resolution_m / 2`` of its centre."""
    reach = c.radius + 0.5 * resolution_m
    h, w = occupied.shape
    c0 = max(0, math.floor((c.x - reach - x_min) / resolution_m))
    c1 = min(w, math.ceil((c.x + reach - x_min) / resolution_m) + 1)
    r0 = max(0, math.floor((c.y - reach - y_min) / resolution_m))
    r1 = min(h, math.ceil((c.y + reach - y_min) / resolution_m) + 1)
    if c0 >= c1 or r0 >= r1:
        return
    x = x_min + (np.arange(c0, c1) + 0.5) * resolution_m - c.x
    y = y_min + (np.arange(r0, r1) + 0.5) * resolution_m - c.y
    occupied[r0:r1, c0:c1] |= (y * y)[:, None] + (x * x)[None, :] <= reach * reach
