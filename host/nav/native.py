"""The costmap's collision tests compiled (``host/nav/native/collide.cpp``), used when current.

The exact footprint test of :class:`jackson.host.nav.costmap.FootprintChecker` loops over poses
and the obstacle discs near each; numpy runs it as passes over whole arrays, which is where a
navigating daemon spent half its time. ``make setup`` compiles the C++ loops with the system's
C++ compiler (``tools/build_compiled.py``, ``-ffp-contract=off``) into
``build/compiled-nav/<digest>/libjackson_nav.so``, named by the digest of the source, and this
module loads them with :mod:`ctypes` (no Python headers needed) only while the source still
has that digest. The arithmetic is the numpy code's, operation for operation, with the C
library's ``hypot``, ``cos`` and ``sin`` (numpy's, where numpy does not use its own SIMD
versions): the answers are the same bit for bit (``tests/host/
test_nav_native.py``), only the speed differs. Without a build, or with
``JACKSON_NAV_INTERPRETED=1``, the costmap uses its numpy code.

``python -m jackson.host.nav.native`` prints which one is in use.

Attributes
----------
LIB : ctypes.CDLL or None
    The loaded library (None: numpy).
REASON : str
    Why, one line.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from jackson.common import native_lib

ENV_INTERPRETED = "JACKSON_NAV_INTERPRETED"
LIBRARY = "libjackson_nav.so"

# Arrays go in as bare addresses (c_void_p, jackson.common.native_lib.pointer).
_P = ctypes.c_void_p  # an array's address
_N = ctypes.c_int64
_D = ctypes.c_double
_F, _L = np.float64, np.int64  # the element types the C++ reads
F64, I64 = _F, _L
FloatArray = npt.NDArray[np.float64]


_ptr = native_lib.pointer  # an array's address, its type and layout checked
address = native_lib.address  # a buffer made to measure: no checks
pointer = native_lib.pointer  # for the modules that wrap more of the library's calls


def source_path() -> Path:
    """``host/nav/native/collide.cpp`` of this checkout (links of an editable install resolved)."""
    return Path(__file__).resolve().parent / "native" / "collide.cpp"


def source_digest(source: bytes) -> str:
    """A build's name (:func:`jackson.common.native_lib.source_digest`)."""
    return native_lib.source_digest(source)


def builds_dir(source: Path) -> Path:
    """``build/compiled-nav`` of the checkout that holds ``source``."""
    return source.parents[3] / "build" / "compiled-nav"


def build_path(builds: Path, digest: str) -> Path:
    """``<builds>/<digest>/libjackson_nav.so``."""
    return builds / digest / LIBRARY


def load_library(path: Path) -> ctypes.CDLL:
    """Load a build and declare its functions' arguments.

    Raises
    ------
    OSError
        It does not load or lacks a function.
    """
    lib = ctypes.CDLL(str(path))
    try:
        hits = lib.jackson_footprint_hits
        traj = lib.jackson_trajectories_collide
        rolls = lib.jackson_rollouts_collide
        lib.jackson_clear_rays  # noqa: B018  (present)
        bfs = lib.jackson_grid_distance
        edt = lib.jackson_edt
        tables = lib.jackson_dwb_tables
        coarse = lib.jackson_dwb_coarse
        plan = lib.jackson_dwb_collision_plan
        combine = lib.jackson_combine_inflate
        front = lib.jackson_dwb_front
        mark = lib.jackson_obstacle_update
        cells = lib.jackson_dwb_plan_cells
        trajectory = lib.jackson_dwb_trajectory
        discs = lib.jackson_obstacle_discs
        classes = lib.jackson_obstacle_classes
        escape = lib.jackson_escape
        weigh = lib.jackson_amcl_weigh
        cost_at = lib.jackson_cost_at
        blocked = lib.jackson_path_blocked
    except AttributeError as e:
        raise OSError(f"{path}: {e}") from e
    hits.restype = None
    hits.argtypes = [
        _N, _P, _P, _P, _P, _N, ctypes.c_int32,
        _P, _N, _N, _N, _P, _N, _P, _P, _P, _P, _P, _P,
    ]  # fmt: skip
    traj.restype = None
    traj.argtypes = [
        _N, _N, _P, _P, _P, _P, _P, _P, _P, _N, _N,
        _P, _N, _N, _N, _P, _N, _P, _P, _P, _P, _P,
    ]  # fmt: skip
    rolls.restype = _N
    rolls.argtypes = [
        _N, _N, _P, _P, _P, _P, _P, _N, _P, ctypes.c_double, ctypes.c_double, _P, _P, _P,
        _P, _N, _N, _P, _N, _N, _N, _P, _N, _P, _P, _P, _P, _N, _P,
    ]  # fmt: skip
    rays = lib.jackson_clear_rays
    rays.restype = None
    rays.argtypes = [
        _N, _P, _P, _P, ctypes.c_double, ctypes.c_double, ctypes.c_double, _N, _N, _P,
        ctypes.c_uint8,
    ]  # fmt: skip
    bfs.restype = None
    bfs.argtypes = [_N, _N, _P, _P, _P, _P]
    edt.restype = None
    edt.argtypes = [_N, _N, _P, _P, _P, _P, _P, _P]
    tables.restype = None
    tables.argtypes = [_N, _P, _D, _D, _D, _N, _P, _D, _D, _D, _N, _P, _D, _D, _P, _P, _P]
    coarse.restype = None
    coarse.argtypes = [_N, _N, _N, _P, _P, _P, _P, _N, _D, _D, _P, _P, _P]
    plan.restype = None
    plan.argtypes = [
        _N, _P, _P, _D, _D, _D, _D, _D, _N, _N, _P, _P, _P, _P, _P, _N, _N, _P, _P, _P,
    ]  # fmt: skip
    front.restype = _N
    front.argtypes = [_P, _N, _N, _N, _P, _P, _N, _N, _N, _P, _P, _P, _P, _P, _P, _P, _P, _P]
    mark.restype = _N
    mark.argtypes = [
        _N, _P, _D, _D, _P, _P, _N, _N, _P, ctypes.c_uint8, ctypes.c_uint8, _P, _P, _P,
    ]  # fmt: skip
    cells.restype = _N
    cells.argtypes = [_N, _P, _D, _D, _D, _D, _P, _N, _N, _P, _N, _P, _P, _P, _P]
    trajectory.restype = None
    trajectory.argtypes = [_N, _P, _P, _P, _P, _D, _D, _P]
    discs.restype = None
    discs.argtypes = [_N, _N, _P, _P, _P, _P, _P, _P, ctypes.c_uint8, _P, _P, _P, _P]
    classes.restype = None
    classes.argtypes = [_N, _N, _N, _P, _N, _P, _P, _P, ctypes.c_uint8, _D, _D, _P]
    escape.restype = None
    escape.argtypes = [_N, _P, _D, _D, _D, _P, _N, _N, _N, _P, _N, _P, _P, _P, _P, _P, _P]
    cost_at.restype = _N
    cost_at.argtypes = [_N, _P, _P, _D, _D, _D, _N, _N, _P, _P]
    blocked.restype = _N
    blocked.argtypes = [_N, _P, _D, _D, _D, _P, _P, _P, ctypes.c_uint8, ctypes.c_uint8]
    weigh.restype = None
    weigh.argtypes = [_N, _P, _P, _P, _N, _P, _P, _N, _N, _P, _P]
    combine.restype = None
    combine.argtypes = [_N, _N, _P, _P, _D, _D, _P, _N, _P, _P, _P, _P, _P, _P, _P]
    return lib


def combine_inflate(
    static: npt.NDArray[np.uint8],
    obstacle: npt.NDArray[np.uint8],
    resolution_m: float,
    far_m: float,
    cost_by_d2: npt.NDArray[np.uint8],
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_], FloatArray]:
    """:meth:`jackson.host.nav.costmap.Costmap._combined`, compiled: the static and obstacle
    layers combined, the distance to the nearest lethal cell and the inflation raised into the
    costs (the three layers' ``update_costs`` in one call).

    Parameters
    ----------
    static, obstacle : ndarray of uint8, shape (rows, cols)
        The layers.
    resolution_m : float
        Cell edge [m].
    far_m : float
        Distances beyond it read ``inf`` [m].
    cost_by_d2 : ndarray of uint8
        The inflation cost at each whole number of squared cells to the nearest lethal cell
        (0 beyond its end).

    Returns
    -------
    tuple of ndarray, shape (rows, cols)
        (costs, lethal mask, distance to the nearest lethal cell centre [m]).
    """
    assert LIB is not None
    rows, cols = static.shape
    stat = np.ascontiguousarray(static, np.uint8)
    obst = np.ascontiguousarray(obstacle, np.uint8)
    table = np.ascontiguousarray(cost_by_d2, np.uint8)
    if obst.shape != stat.shape:
        raise ValueError(f"layers of shapes {stat.shape} and {obst.shape}")
    master = np.empty((rows, cols), np.uint8)
    lethal = np.empty((rows, cols), np.bool_)
    dist = np.empty((rows, cols), np.float64)
    g = np.empty(rows * cols, np.int64)
    v = np.empty(cols + 1, np.int64)
    zn = np.empty(cols + 1, np.int64)
    zd = np.empty(cols + 1, np.int64)
    LIB.jackson_combine_inflate(
        rows, cols, _ptr(stat, np.uint8), _ptr(obst, np.uint8), resolution_m, far_m,
        _ptr(table, np.uint8), table.size, _ptr(master, np.uint8),
        _ptr(lethal.view(np.uint8), np.uint8), _ptr(dist, _F), _ptr(g, _L), _ptr(v, _L),
        _ptr(zn, _L), _ptr(zd, _L),
    )  # fmt: skip
    return master, lethal, dist


def distance_to(feature: npt.NDArray[np.bool_]) -> FloatArray:
    """Each cell's distance to the nearest centre of a ``feature`` cell [cells]: the value
    ``scipy.ndimage.distance_transform_edt(~feature)`` has, bit for bit (the square root of a
    whole number), compiled (Felzenszwalb and Huttenlocher's two passes, linear in the cells);
    ``inf`` everywhere when no cell is a feature. Without the compiled library, scipy's.

    Parameters
    ----------
    feature : ndarray of bool, shape (rows, cols)
        The cells distances are measured to.

    Returns
    -------
    ndarray of float64, shape (rows, cols)
    """
    if LIB is None:
        from scipy import ndimage

        if not feature.any():
            return np.full(feature.shape, np.inf)
        return np.asarray(ndimage.distance_transform_edt(~feature), np.float64)
    rows, cols = feature.shape
    f = np.ascontiguousarray(feature, np.bool_).view(np.uint8)
    out = np.empty((rows, cols), np.float64)
    g = np.empty(rows * cols, np.int64)
    v = np.empty(cols + 1, np.int64)
    zn = np.empty(cols + 1, np.int64)
    zd = np.empty(cols + 1, np.int64)
    LIB.jackson_edt(
        rows, cols, _ptr(f, np.uint8), _ptr(out, _F), _ptr(g, _L), _ptr(v, _L), _ptr(zn, _L),
        _ptr(zd, _L),
    )  # fmt: skip
    return out


def grid_distance(free: npt.NDArray[np.bool_], sources: npt.NDArray[np.bool_]) -> FloatArray:
    """:func:`jackson.host.nav.dwb.core.distance.grid_distance` over the graph of ``free``,
    compiled: one breadth-first search from the sources, the same distances [cells].

    Parameters
    ----------
    free : ndarray of bool, shape (rows, cols)
        Cells that may be crossed.
    sources : ndarray of bool, shape (rows, cols)
        Source cells.

    Returns
    -------
    ndarray of float64, shape (rows, cols)
        Distances; rows x cols where no source reaches.
    """
    assert LIB is not None
    rows, cols = free.shape
    f = np.ascontiguousarray(free, np.bool_).view(np.uint8)  # numpy's bools are bytes: no copy
    s = np.ascontiguousarray(sources, np.bool_).view(np.uint8)
    out = np.empty((rows, cols), np.float64)
    queue = np.empty(rows * cols, np.int64)
    LIB.jackson_grid_distance(
        rows, cols, _ptr(f, np.uint8), _ptr(s, np.uint8), _ptr(out, _F), _ptr(queue, _L)
    )
    return out


def clear_rays(
    unit: npt.NDArray[np.float64],
    stop: npt.NDArray[np.float64],
    base: tuple[float, float],
    step: float,
    obstacle: npt.NDArray[np.uint8],
    free: int,
) -> None:
    """:meth:`ObstacleLayer._clear_rays`' sampling, compiled: ray i's samples k (k ``step`` up to
    ``stop[i]``) at ``base + k unit[i]`` cells set to ``free`` in ``obstacle`` (rows, cols)."""
    assert LIB is not None
    rows, cols = obstacle.shape
    ux = np.ascontiguousarray(unit[:, 0], np.float64)
    uy = np.ascontiguousarray(unit[:, 1], np.float64)
    stops = np.ascontiguousarray(stop, np.float64)
    LIB.jackson_clear_rays(
        len(stops), _ptr(ux, _F), _ptr(uy, _F), _ptr(stops, _F), base[0], base[1], step, rows,
        cols, _ptr(obstacle, np.uint8), free,
    )  # fmt: skip


def dwb_tables(
    linear: tuple[FloatArray, float, float, float],
    angular: tuple[FloatArray, float, float, float],
    t_s: FloatArray,
    dt_s: float,
    yaw0_rad: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`jackson.host.nav.dwb.core.rollouts.build_rollouts`' tables, compiled: the same
    velocity profiles (:func:`~jackson.host.nav.dwb.core.window.velocity_profile`) and sums.

    Parameters
    ----------
    linear, angular : tuple
        (distinct targets (V,) or (W,), current velocity, acceleration, deceleration).
    t_s : ndarray, shape (K + 1,)
        The pose times [s].
    dt_s : float
        The step [s].
    yaw0_rad : float
        The start heading [rad].

    Returns
    -------
    tuple of ndarray
        (ds (V, K) [m], yaw (W, K + 1) [rad], yaw at the middle of each step (W, K) [rad]).
    """
    assert LIB is not None
    uv, v0, accel_v, decel_v = linear
    uw, w0, accel_w, decel_w = angular
    uvs = np.ascontiguousarray(uv, np.float64)
    uws = np.ascontiguousarray(uw, np.float64)
    t = np.ascontiguousarray(t_s, np.float64)
    k = t.size - 1
    ds = np.empty((uvs.size, k))
    yaw = np.empty((uws.size, k + 1))
    mid = np.empty((uws.size, k))
    LIB.jackson_dwb_tables(
        uvs.size, _ptr(uvs, _F), v0, accel_v, decel_v, uws.size, _ptr(uws, _F), w0, accel_w,
        decel_w, k, _ptr(t, _F), dt_s, yaw0_rad, _ptr(ds, _F), _ptr(yaw, _F), _ptr(mid, _F),
    )  # fmt: skip
    return ds, yaw, mid


def dwb_coarse(
    ds_m: FloatArray,
    cos_sin: FloatArray,
    iv: npt.NDArray[np.intp],
    iw: npt.NDArray[np.intp],
    stride: int,
    start: tuple[float, float],
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:meth:`jackson.host.nav.dwb.core.rollouts.Rollouts.coarse`, compiled: the same running
    sums.

    Returns
    -------
    tuple of ndarray
        (x (B + 1, M) [m], y (B + 1, M) [m], path length of each block (B, M) [m]).
    """
    assert LIB is not None
    ds = np.ascontiguousarray(ds_m, np.float64)
    cs = np.ascontiguousarray(cos_sin, np.float64)
    ivs = np.ascontiguousarray(iv, np.int64)
    iws = np.ascontiguousarray(iw, np.int64)
    v, k = ds.shape
    w = cs.shape[0] // 2
    m = ivs.size
    if cs.shape != (2 * w, k) or (m and not (
        0 <= ivs.min() and ivs.max() < v and 0 <= iws.min() and iws.max() < w
    )) or stride < 1:  # fmt: skip
        raise ValueError(f"roll-out tables: ds {ds.shape}, cos_sin {cs.shape}, stride {stride}")
    blocks = -(-k // stride)
    x = np.empty((blocks + 1, m))
    y = np.empty((blocks + 1, m))
    length = np.empty((blocks, m))
    LIB.jackson_dwb_coarse(
        m, k, stride, _ptr(ivs, _L), _ptr(iws, _L), _ptr(ds, _F), _ptr(cs, _F), w, start[0],
        start[1], _ptr(x, _F), _ptr(y, _F), _ptr(length, _F),
    )  # fmt: skip
    return x, y, length


def dwb_collision_plan(
    targets: tuple[FloatArray, FloatArray],
    velocity: tuple[float, float],
    sweep: tuple[float, float, float, int],
    coarse: tuple[FloatArray, FloatArray, FloatArray],
    reach_padded: FloatArray,
    grid: tuple[float, float, float, int, int],
) -> tuple[npt.NDArray[np.int64], FloatArray, npt.NDArray[np.bool_]]:
    """:func:`jackson.host.nav.dwb.critics.base_obstacle.collisions`' plan, compiled: each
    roll-out's stride group and margin, and whether it comes within reach of an obstacle.

    Parameters
    ----------
    targets : tuple of ndarray, shape (M,)
        (v [m/s], w [rad/s]).
    velocity : tuple of float
        Current (v [m/s], w [rad/s]).
    sweep : tuple
        (circumscribed radius [m], step [s], half a cell [m], steps K).
    coarse : tuple of ndarray
        (x, y) (B + 1, M) [m] and block lengths (B, M) [m] (:meth:`Rollouts.coarse`).
    reach_padded : ndarray
        The costmap's clear reach per cell of the grid padded by one cell, flat [m].
    grid : tuple
        (origin x [m], origin y [m], resolution [m], rows, cols).

    Returns
    -------
    tuple of ndarray, shape (M,)
        (stride group, margin [m], near).
    """
    assert LIB is not None
    v = np.ascontiguousarray(targets[0], np.float64)
    w = np.ascontiguousarray(targets[1], np.float64)
    x = np.ascontiguousarray(coarse[0], np.float64)
    y = np.ascontiguousarray(coarse[1], np.float64)
    length = np.ascontiguousarray(coarse[2], np.float64)
    reach = np.ascontiguousarray(reach_padded, np.float64)
    geometry = np.array(grid[:3], np.float64)
    rows, cols = grid[3], grid[4]
    m = v.size
    blocks = length.shape[0]
    if w.size != m or x.shape != (blocks + 1, m) or y.shape != x.shape or length.shape[1:] != (
        m,
    ) or reach.size != (rows + 2) * (cols + 2):  # fmt: skip
        raise ValueError("collision plan: inconsistent roll-outs, coarse poses or grid")
    group = np.empty(m, np.int64)
    margin = np.empty(m)
    near = np.empty(m, np.uint8)
    r_m, dt_s, half_cell, k = sweep
    LIB.jackson_dwb_collision_plan(
        m, _ptr(v, _F), _ptr(w, _F), velocity[0], velocity[1], r_m, dt_s, half_cell, k, blocks,
        _ptr(x, _F), _ptr(y, _F), _ptr(length, _F), _ptr(reach, _F), _ptr(geometry, _F), rows,
        cols, _ptr(group, _L), _ptr(margin, _F), _ptr(near, np.uint8),
    )  # fmt: skip
    return group, margin, near.view(np.bool_)


LIB, REASON = native_lib.select(
    source_path(),
    lambda digest: build_path(builds_dir(source_path()), digest),
    load_library,
    ENV_INTERPRETED,
)


@dataclass(frozen=True)
class Rule:
    """What a trajectory test decides by, besides the poses: per trajectory the margin [m],
    the escape rule's allowance and floor [m]; the cell classes of the grid padded by one
    cell, and the grid's (rows, cols)."""

    margin_m: npt.NDArray[np.float64]
    allowed: npt.NDArray[np.int_]
    floor_m: npt.NDArray[np.float64]
    classes_padded: npt.NDArray[np.uint8]
    grid_shape: tuple[int, int]

    def arguments(self) -> tuple[tuple[npt.NDArray[Any], ...], tuple[int, ...]]:
        """The arrays as the C functions read them, which the caller keeps until the call
        returns, and the arguments."""
        margin = np.ascontiguousarray(self.margin_m, np.float64)
        allow = np.ascontiguousarray(self.allowed, np.int64)
        floor = np.ascontiguousarray(self.floor_m, np.float64)
        classes = np.ascontiguousarray(self.classes_padded, np.uint8)
        args = (
            _ptr(margin, _F), _ptr(allow, _L), _ptr(floor, _F), _ptr(classes, np.uint8),
            self.grid_shape[0], self.grid_shape[1],
        )  # fmt: skip
        return (margin, allow, floor, classes), args


class Obstacles:
    """The obstacle index of one costmap version, as the compiled tests read it.

    Parameters
    ----------
    ids_padded : ndarray of int32
        Obstacle id per cell of the grid padded by ``k`` cells (-1: none), flat.
    padded_shape : tuple of int
        Its (rows, cols).
    k : int
        The padding.
    offsets : ndarray of int
        Flat offsets of the cells within reach of a pose's cell.
    xy, radius : ndarray
        Disc centres (n, 2) [m] and radii (n,) [m].
    grid : tuple of float
        (origin x [m], origin y [m], resolution [m]).
    robot : tuple of float
        (robot radius, circumscribed radius, footprint x0, x1, y0, y1) [m].
    """

    def __init__(
        self,
        ids_padded: npt.NDArray[np.int32],
        padded_shape: tuple[int, int],
        k: int,
        offsets: npt.NDArray[np.intp],
        xy: npt.NDArray[np.float64],
        radius: npt.NDArray[np.float64],
        grid: tuple[float, float, float],
        robot: tuple[float, float, float, float, float, float],
    ) -> None:
        self.ids = np.ascontiguousarray(ids_padded, np.int32)
        self.rows, self.cols = padded_shape
        self.k = k
        self.offsets = np.ascontiguousarray(offsets, np.int64)
        self.xy = np.ascontiguousarray(xy, np.float64).reshape(-1, 2)
        self.radius = np.ascontiguousarray(radius, np.float64)
        self.grid = np.array(grid, np.float64)
        self.robot = np.array(robot, np.float64)
        self._arguments: tuple[int, ...] | None = None

    def __getstate__(self) -> dict[str, object]:
        """The arrays without the addresses taken of them (a copy or a pickle has its own)."""
        return {**self.__dict__, "_arguments": None}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update({"_arguments": None, **state})

    def _index(self) -> tuple[int, ...]:
        """The obstacle index as the C functions take it: ids, padded rows, cols, k, offsets
        and their count, disc centres, radii, grid and robot (addresses of arrays it keeps,
        taken once)."""
        if self._arguments is None:
            self._arguments = (
                _ptr(self.ids, np.int32), self.rows, self.cols, self.k, _ptr(self.offsets, _L),
                len(self.offsets), _ptr(self.xy, _F), _ptr(self.radius, _F),
                _ptr(self.grid, _F), _ptr(self.robot, _F),
            )  # fmt: skip
        return self._arguments

    def footprint_hits(
        self,
        x: npt.NDArray[np.float64],
        y: npt.NDArray[np.float64],
        yaw: npt.NDArray[np.float64],
        with_clearance: bool,
        margin_m: float | npt.NDArray[np.float64],
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """:meth:`FootprintChecker.footprint_hits`, compiled (:data:`LIB` must be loaded)."""
        assert LIB is not None
        x = np.ascontiguousarray(x, np.float64).ravel()
        y = np.ascontiguousarray(y, np.float64).ravel()
        yaw = np.ascontiguousarray(yaw, np.float64).ravel()
        n = x.size
        margin = np.ascontiguousarray(margin_m, np.float64).ravel()
        step = 0 if margin.size == 1 else 1
        if margin.size == 0:
            margin, step = np.zeros(1), 0
        counts = np.empty(n, np.int64)
        clearance = np.empty(n, np.float64)
        LIB.jackson_footprint_hits(
            n, _ptr(x, _F), _ptr(y, _F), _ptr(yaw, _F), _ptr(margin, _F), step, int(with_clearance),
            *self._index(), _ptr(counts, _L), _ptr(clearance, _F),
        )  # fmt: skip
        return counts, clearance

    def escape(
        self, start: tuple[float, float, float], margin_m: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
        """:meth:`FootprintChecker._escape`'s allowance and floor for a start on a near or deep
        cell, compiled: each margin's overlaps at the start and its clearance less 1e-9."""
        assert LIB is not None
        margin = np.ascontiguousarray(margin_m, np.float64)
        allowed = np.empty(margin.size, np.int64)
        floor = np.empty(margin.size, np.float64)
        LIB.jackson_escape(
            margin.size, _ptr(margin, _F), start[0], start[1], start[2], *self._index(),
            _ptr(allowed, _L), _ptr(floor, _F),
        )  # fmt: skip
        return allowed, floor

    def trajectories_collide(
        self,
        x: npt.NDArray[np.float64],
        y: npt.NDArray[np.float64],
        yaw: npt.NDArray[np.float64],
        rule: Rule,
    ) -> npt.NDArray[np.bool_]:
        """The per-trajectory loop of :meth:`FootprintChecker.trajectories_collide`, compiled."""
        assert LIB is not None
        m, length = x.shape
        x = np.ascontiguousarray(x, np.float64)
        y = np.ascontiguousarray(y, np.float64)
        yaw = np.ascontiguousarray(yaw, np.float64)
        hit = np.zeros(m, np.uint8)
        kept, args = rule.arguments()
        LIB.jackson_trajectories_collide(
            m, length, _ptr(x, _F), _ptr(y, _F), _ptr(yaw, _F), *args, *self._index(),
            _ptr(hit, np.uint8),
        )  # fmt: skip
        del kept
        return hit.astype(bool)

    def rollouts_collide(
        self,
        start: tuple[float, float],
        ds_m: npt.NDArray[np.float64],
        cos_sin: npt.NDArray[np.float64],
        yaw_rad: npt.NDArray[np.float64],
        iv: npt.NDArray[np.int_],
        iw: npt.NDArray[np.int_],
        stride: npt.NDArray[np.int_],
        rule: Rule,
        stop_at_clear: bool = False,
    ) -> tuple[npt.NDArray[np.bool_], int]:
        """:meth:`FootprintChecker.rollouts_collide`, compiled: which roll-outs collide, and the
        first that does not (R: none). With ``stop_at_clear`` they are tested in order up to that
        one only (the answers after it are not tested: False)."""
        assert LIB is not None
        steps = int(ds_m.shape[1])
        ds = np.ascontiguousarray(ds_m, np.float64)
        cs = np.ascontiguousarray(cos_sin, np.float64)
        yaw = np.ascontiguousarray(yaw_rad, np.float64)
        if cs.shape[1] != steps or yaw.shape[1] != steps + 1 or cs.shape[0] != 2 * yaw.shape[0]:
            raise ValueError(f"roll-out tables: ds {ds.shape}, cos_sin {cs.shape}, yaw {yaw.shape}")
        ivs = np.ascontiguousarray(iv, np.int64)
        iws = np.ascontiguousarray(iw, np.int64)
        strides = np.ascontiguousarray(stride, np.int64)
        m = ivs.size
        if m and not (
            0 <= ivs.min() and ivs.max() < ds.shape[0] and 0 <= iws.min()
            and iws.max() < yaw.shape[0] and strides.min() >= 1
        ):  # fmt: skip
            raise ValueError("roll-outs: ramp index off its table, or a stride below 1")
        hit = np.zeros(m, np.uint8)
        kept, args = rule.arguments()
        first_clear = LIB.jackson_rollouts_collide(
            m, steps, _ptr(ivs, _L), _ptr(iws, _L), _ptr(strides, _L), _ptr(ds, _F),
            _ptr(cs, _F), yaw.shape[0], _ptr(yaw, _F), start[0], start[1], *args,
            *self._index(), int(stop_at_clear), _ptr(hit, np.uint8),
        )  # fmt: skip
        del kept
        collides = hit.astype(bool)
        if not stop_at_clear:
            clear = np.flatnonzero(~collides)
            first_clear = int(clear[0]) if clear.size else m
        return collides, int(first_clear)


def main() -> None:
    """``python -m jackson.host.nav.native``: print which collision tests the costmap runs."""
    print(f"jackson.host.nav collision tests: {REASON}")


if __name__ == "__main__":
    main()
