"""The costmap's, DWB's and AMCL's grid loops compiled (``host/nav/native/collide.cpp``): a scan's
update of the obstacle layer, the footprint checker's discs and classes, the path's cells in the
window, the chosen roll-out's poses and the particles' likelihoods, each one call with numpy's
operations in numpy's order (the library and its loading: :mod:`jackson.host.nav.native`;
docs/compiled.md). The callers take their numpy path when :data:`jackson.host.nav.native.LIB` is
None.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from jackson.host.nav import native
from jackson.host.nav.native import F64, I64, pointer

FloatArray = npt.NDArray[np.float64]


def obstacle_update(
    points: FloatArray,
    sensor: tuple[float, float],
    ranges: tuple[float, float, float, float],
    grid: tuple[float, float, float],
    costs: npt.NDArray[np.uint8],
    values: tuple[int, int],
    discs: tuple[FloatArray, FloatArray] | None,
) -> FloatArray:
    """:meth:`jackson.host.nav.costmap.layers.ObstacleLayer.update`, compiled: one scan's rays
    cleared and its returns marked in ``costs`` (rows, cols), with each marked cell's disc.

    Parameters
    ----------
    points : ndarray, shape (N, 2)
        The returns, map frame [m].
    sensor : tuple of float
        The sensor's position [m].
    ranges : tuple of float
        Ray tracing's least and greatest range, marking's least and greatest [m].
    grid : tuple of float
        The grid's origin x, origin y [m] and resolution [m].
    costs : ndarray of uint8, shape (rows, cols)
        The layer's costs, written in place.
    values : tuple of int
        (free, lethal) costs.
    discs : tuple of ndarray or None
        The centroids (rows, cols, 2) [m] and spreads (rows, cols) [m] to write, or None.

    Returns
    -------
    ndarray, shape (M, 2)
        The marked returns, in order [m].
    """
    lib = native.LIB
    assert lib is not None
    p = np.ascontiguousarray(points, np.float64).reshape(-1, 2)
    rows, cols = costs.shape
    if costs.dtype != np.uint8 or not costs.flags.c_contiguous or not costs.flags.writeable:
        raise ValueError("obstacle_update: costs must be a writable C-contiguous uint8 grid")
    if discs is not None and (discs[0].shape != (rows, cols, 2) or discs[1].shape != (rows, cols)):
        raise ValueError(f"obstacle_update: discs of {discs[0].shape} for a {rows} x {cols} grid")
    q = np.empty_like(p)
    r = np.array(ranges, np.float64)
    g = np.array(grid, np.float64)
    hit_xy = None if discs is None else pointer(discs[0], F64)
    spread = None if discs is None else pointer(discs[1], F64)
    marked = lib.jackson_obstacle_update(
        len(p), pointer(p, F64), sensor[0], sensor[1], pointer(r, F64), pointer(g, F64), rows, cols,
        pointer(costs, np.uint8), values[0], values[1], hit_xy, spread, pointer(q, F64),
    )  # fmt: skip
    return q[:marked]


def dwb_plan_cells(
    path: FloatArray,
    position: tuple[float, float],
    prune_m: tuple[float, float],
    grid: tuple[float, float, float, int, int],
    costs_padded: npt.NDArray[np.uint8],
) -> tuple[tuple[int, int], npt.NDArray[np.intp], npt.NDArray[np.intp], bool] | None:
    """:func:`jackson.host.nav.dwb.core.path.plan_span` and
    :func:`~jackson.host.nav.dwb.core.path.plan_cells`, compiled: the same slice and cells.

    Parameters
    ----------
    path : ndarray, shape (N, 2), N >= 1
        The global path [m].
    position : tuple of float
        The robot's (x, y) [m].
    prune_m : tuple of float
        How far behind and ahead of the nearest point the slice reaches [m].
    grid : tuple
        (origin x [m], origin y [m], resolution [m], rows, cols) of the local costmap.
    costs_padded : ndarray of uint8
        Its costs with a ring of unknown cells, flat over (rows + 2) x (cols + 2).

    Returns
    -------
    tuple or None
        (the slice's (begin, end), rows, cols, whether the last cell is the path's end); None
        when no point of the slice lies on a known cell.
    """
    lib = native.LIB
    assert lib is not None
    p = np.ascontiguousarray(path, np.float64).reshape(-1, 2)
    rows, cols = grid[3], grid[4]
    if len(p) == 0 or costs_padded.size != (rows + 2) * (cols + 2):
        raise ValueError("dwb_plan_cells: an empty path, or costs of another grid")
    g = np.array(grid[:3], np.float64)
    c = np.ascontiguousarray(costs_padded, np.uint8)
    span = np.empty(2, np.int64)
    end = np.empty(1, np.uint8)
    room = 256
    while True:
        r_out = np.empty(room, np.int64)
        c_out = np.empty(room, np.int64)
        count = lib.jackson_dwb_plan_cells(
            len(p), pointer(p, F64), position[0], position[1], prune_m[0], prune_m[1],
            pointer(g, F64), rows, cols, pointer(c, np.uint8), room, pointer(span, I64),
            pointer(r_out, I64), pointer(c_out, I64), pointer(end, np.uint8),
        )  # fmt: skip
        if count >= 0:
            break
        room = -count
    if count == 0:
        return None
    return (int(span[0]), int(span[1])), r_out[:count], c_out[:count], bool(end[0])


def dwb_trajectory(
    ds_m: FloatArray,
    cos_sin: FloatArray,
    yaw_rad: FloatArray,
    ramps: tuple[int, int],
    start: tuple[float, float],
) -> FloatArray:
    """:meth:`jackson.host.nav.dwb.core.rollouts.Rollouts.trajectory`, compiled: the same
    running sums.

    Parameters
    ----------
    ds_m, cos_sin, yaw_rad : ndarray
        The roll-outs' tables, (V, K), (2 W, K), (W, K + 1).
    ramps : tuple of int
        The roll-out's linear and angular ramp.
    start : tuple of float
        The start (x, y) [m].

    Returns
    -------
    ndarray, shape (K + 1, 3)
        (x [m], y [m], yaw [rad]) per pose.
    """
    lib = native.LIB
    assert lib is not None
    iv, iw = ramps
    w, k = yaw_rad.shape[0], ds_m.shape[1]
    ds = np.ascontiguousarray(ds_m[iv], np.float64)
    c = np.ascontiguousarray(cos_sin[iw], np.float64)
    s = np.ascontiguousarray(cos_sin[w + iw], np.float64)
    yaw = np.ascontiguousarray(yaw_rad[iw], np.float64)
    if c.size != k or yaw.size != k + 1:
        raise ValueError("dwb_trajectory: tables of different step counts")
    out = np.empty((k + 1, 3))
    lib.jackson_dwb_trajectory(
        k, pointer(ds, F64), pointer(c, F64), pointer(s, F64), pointer(yaw, F64), start[0],
        start[1], pointer(out, F64),
    )  # fmt: skip
    return out


def obstacle_discs(
    lethal: npt.NDArray[np.bool_],
    obstacle_costs: npt.NDArray[np.uint8],
    static_costs: npt.NDArray[np.uint8],
    hits: tuple[FloatArray, FloatArray],
    grid: tuple[float, float, float],
    lethal_cost: int,
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.int64], tuple[float, float]]:
    """The footprint checker's obstacle discs
    (:class:`jackson.host.nav.costmap.footprint.FootprintChecker`), compiled: the same discs
    and bounds.

    Parameters
    ----------
    lethal : ndarray of bool, shape (rows, cols)
        The lethal cells.
    obstacle_costs, static_costs : ndarray of uint8, shape (rows, cols)
        The obstacle and static layers' costs.
    hits : tuple of ndarray
        The obstacle layer's centroids (rows, cols, 2) [m] and spreads (rows, cols) [m].
    grid : tuple of float
        (origin x [m], origin y [m], resolution [m]).
    lethal_cost : int
        The lethal cost.

    Returns
    -------
    tuple
        (centres (n, 2) [m], radii (n,) [m], flat cells (n,), (largest reach beyond a cell
        centre [m], largest shortfall [m])).
    """
    lib = native.LIB
    assert lib is not None
    rows, cols = lethal.shape
    arrays = [np.ascontiguousarray(a) for a in (lethal, obstacle_costs, static_costs, *hits)]
    if any(a.shape[:2] != (rows, cols) for a in arrays):
        raise ValueError("obstacle_discs: layers of different grids")
    n = int(np.count_nonzero(lethal))
    xy = np.empty((n, 2))
    r = np.empty(n)
    cells = np.empty(n, np.int64)
    bounds = np.zeros(2)
    g = np.array(grid, np.float64)
    flags, obstacle, stat, hit_xy, spread = arrays
    lib.jackson_obstacle_discs(
        rows, cols, pointer(flags.view(np.uint8), np.uint8), pointer(obstacle, np.uint8),
        pointer(stat, np.uint8), pointer(hit_xy, F64), pointer(spread, F64), pointer(g, F64),
        lethal_cost, pointer(xy, F64), pointer(r, F64), pointer(cells, I64),
        pointer(bounds, F64),
    )  # fmt: skip
    return xy, r, cells, (float(bounds[0]), float(bounds[1]))


def obstacle_classes(
    cells: npt.NDArray[np.int64],
    k: int,
    shape: tuple[int, int],
    distance_m: FloatArray,
    costs: npt.NDArray[np.uint8],
    lethal_cost: int,
    bounds_m: tuple[float, float],
) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.uint8]]:
    """The footprint checker's obstacle ids and cell classes, compiled: the same grids.

    Parameters
    ----------
    cells : ndarray of int64, shape (n,)
        The discs' flat cells.
    k : int
        The ids' padding [cells].
    shape : tuple of int
        (rows, cols).
    distance_m : ndarray, shape (rows, cols)
        The distance of each cell centre to the nearest lethal one [m].
    costs : ndarray of uint8, shape (rows, cols)
        The combined costs.
    lethal_cost : int
        The lethal cost.
    bounds_m : tuple of float
        The near and deep distances [m].

    Returns
    -------
    tuple of ndarray
        (ids over the grid padded by k, (rows + 2 k, cols + 2 k), -1 where none; the classes
        over the grid padded by one blocked ring, flat).
    """
    lib = native.LIB
    assert lib is not None
    rows, cols = shape
    c = np.ascontiguousarray(cells, np.int64)
    d = np.ascontiguousarray(distance_m, np.float64)
    cost = np.ascontiguousarray(costs, np.uint8)
    if d.shape != (rows, cols) or cost.shape != (rows, cols) or k < 0:
        raise ValueError("obstacle_classes: grids of different shapes")
    if c.size and not (0 <= c.min() and c.max() < rows * cols):
        raise ValueError("obstacle_classes: a cell off the grid")
    ids = np.empty((rows + 2 * k, cols + 2 * k), np.int32)
    cls = np.empty((rows + 2) * (cols + 2), np.uint8)
    lib.jackson_obstacle_classes(
        rows, cols, c.size, pointer(c, I64), k, pointer(ids, np.int32), pointer(d, F64),
        pointer(cost, np.uint8), lethal_cost, bounds_m[0], bounds_m[1], pointer(cls, np.uint8),
    )  # fmt: skip
    return ids, cls


def amcl_weigh(
    particles: FloatArray,
    cos_yaw: FloatArray,
    sin_yaw: FloatArray,
    beams: FloatArray,
    grid: tuple[float, float, float],
    cubes: FloatArray,
) -> FloatArray:
    """:func:`jackson.host.nav.amcl.sensor_model.likelihood_field_model`, compiled: each
    particle's beam end points in the map, their cells of the padded field, the cubes of their
    scores summed (numpy's pairwise order) plus one.

    Parameters
    ----------
    particles : ndarray, shape (N, 3)
        Poses (x [m], y [m], yaw [rad]).
    cos_yaw, sin_yaw : ndarray, shape (N,) or (N, 1)
        Their headings' cosines and sines (numpy's).
    beams : ndarray, shape (B, 2)
        End points in the base frame [m].
    grid : tuple of float
        The field's origin x, origin y [m] and resolution [m].
    cubes : ndarray, shape (rows + 2, cols + 2)
        Each padded cell's beam score cubed
        (:func:`jackson.host.nav.amcl.sensor_model.beam_cubes`).

    Returns
    -------
    ndarray, shape (N,)
        The likelihoods.
    """
    lib = native.LIB
    assert lib is not None
    p = np.ascontiguousarray(particles, np.float64)
    c = np.ascontiguousarray(cos_yaw, np.float64).reshape(-1)
    s = np.ascontiguousarray(sin_yaw, np.float64).reshape(-1)
    b = np.ascontiguousarray(beams, np.float64)
    n = len(p)
    if p.shape != (n, 3) or c.shape != (n,) or s.shape != (n,) or b.ndim != 2 or b.shape[1] != 2:
        raise ValueError(f"amcl_weigh: particles {p.shape}, headings {c.shape}, beams {b.shape}")
    if cubes.ndim != 2 or cubes.dtype != np.float64 or not cubes.flags.c_contiguous:
        raise ValueError("amcl_weigh: cubes must be a C-contiguous float64 grid")
    g = np.array((grid[0], grid[1], 1.0 / grid[2]), np.float64)
    out = np.empty(n, np.float64)
    rows_p, cols_p = cubes.shape
    lib.jackson_amcl_weigh(
        n, pointer(p, F64), pointer(c, F64), pointer(s, F64), len(b), pointer(b, F64),
        pointer(g, F64), rows_p, cols_p, pointer(cubes, F64), pointer(out, F64),
    )  # fmt: skip
    return out


def cost_at(
    x_m: npt.ArrayLike,
    y_m: npt.ArrayLike,
    grid: tuple[float, float, float, int, int],
    costs_padded: npt.NDArray[np.uint8],
) -> npt.NDArray[np.uint8] | None:
    """:meth:`jackson.host.nav.costmap.Costmap.cost_at` of points given as two float64 arrays of
    one shape, compiled: the same padded indices and costs.

    Parameters
    ----------
    x_m, y_m : array_like
        Map-frame points [m], float64 arrays of one shape.
    grid : tuple
        (origin x [m], origin y [m], resolution [m], rows, cols).
    costs_padded : ndarray of uint8
        The costs padded by one ring, flat.

    Returns
    -------
    ndarray of uint8 or None
        The costs, the points' shape; None at a NaN (numpy's path answers that).
    """
    assert native.LIB is not None
    x = np.ascontiguousarray(x_m, np.float64)
    y = np.ascontiguousarray(y_m, np.float64)
    ox, oy, res, rows, cols = grid
    if costs_padded.size != (rows + 2) * (cols + 2) or x.shape != y.shape:
        raise ValueError(f"cost_at: points {x.shape} and {y.shape}, grid {rows} x {cols}")
    out = np.empty(x.shape, np.uint8)
    if out.size == 0:
        return out
    failed = native.LIB.jackson_cost_at(
        x.size, pointer(x, F64), pointer(y, F64), ox, oy, res, rows, cols,
        pointer(costs_padded, np.uint8), native.address(out),
    )  # fmt: skip
    return None if failed else out


def path_blocked(
    path: FloatArray,
    xy: tuple[float, float],
    near_m: float,
    grids: tuple[tuple[float, float, float, int, int], tuple[float, float, float, int, int]],
    costs_padded: tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]],
    blocking: tuple[int, int],
) -> bool | None:
    """:meth:`jackson.host.control.replanning.GlobalPlanning.path_blocked`'s test, compiled: the
    path from its point nearest ``xy`` on, without the points within ``near_m`` of it, on a
    ``blocking`` cost (inscribed, lethal) of either costmap.

    Parameters
    ----------
    path : ndarray, shape (N, 2)
        The path [m].
    xy : tuple of float
        The robot [m].
    near_m : float
        Points this near the robot are left out [m].
    grids : tuple
        Each costmap's (origin x [m], origin y [m], resolution [m], rows, cols).
    costs_padded : tuple of ndarray of uint8
        Each costmap's costs padded by one ring, flat.
    blocking : tuple of int
        The two costs that block.

    Returns
    -------
    bool or None
        Whether the path ahead is blocked; None at a NaN (numpy's path answers that).
    """
    assert native.LIB is not None
    p = np.ascontiguousarray(path, np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"path_blocked: a path of shape {p.shape}, not (N, 2)")
    for (_, _, _, rows, cols), costs in zip(grids, costs_padded, strict=True):
        if costs.size != (rows + 2) * (cols + 2):
            raise ValueError(f"path_blocked: {costs.size} costs for a {rows} x {cols} grid")
    g = np.array((*grids[0], *grids[1]), np.float64)
    found = native.LIB.jackson_path_blocked(
        len(p), pointer(p, F64) if len(p) else 0, xy[0], xy[1], near_m, native.address(g),
        pointer(costs_padded[0], np.uint8), pointer(costs_padded[1], np.uint8), *blocking,
    )  # fmt: skip
    return None if found < 0 else bool(found)
