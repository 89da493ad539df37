"""How direct the patrol's paths were: each reached goal's path on the truth against the
shortest collision-free path between the same two points.

The shortest path is found on the world's true raster (:func:`jackson.sim.raster.raster`, the
static walls and cylinders, no dropped obstacle) with every cell closer than the robot's radius
to an obstacle taken away (clearance from the Euclidean distance transform), the obstacles
inflated as the planner inflates them. On what is left:

1. the cheapest 8-connected path of cells between the two points (scikit-image's
   ``MCP_Geometric``, a step costing its length), a point in a taken-away cell moved to the
   nearest kept one;
2. pulled taut (string pulling): from each vertex the path jumps to the last later vertex it
   still sees along a straight line through kept cells, which removes the grid's zig-zag; the
   two ends are the points themselves.

Its length is within a cell or two of the true any-angle shortest path (a straight run gives
its length exactly). The ratio of a goal is

    rho = L_executed / L_shortest,

with L_executed the length of the truth's polyline (the twin's rows, every telemetry period)
from the MCU time the goal was sent to the time it ended.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from jackson.common.geometry import world_to_cell
from jackson.sim.config import WorldSpec

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

RESOLUTION_M = 0.05  # [m] the raster the shortest paths are found on (the host's maps')
MIN_SHORTEST_M = 0.5  # [m] a shorter trip gives no ratio (the robot was already there)
RATIO_LIMIT = 1.25  # an executed path longer than this many times the shortest is a detour


def path_length(xy_m: npt.ArrayLike) -> float:
    """The length of a polyline of points (N, 2) [m]."""
    xy = np.asarray(xy_m, dtype=np.float64).reshape(-1, 2)
    return float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0


class ShortestPaths:
    """Shortest collision-free paths on an occupancy raster for a disc robot (module
    docstring).

    Parameters
    ----------
    occupied : array of bool, shape (rows, cols)
        True where an obstacle is; row 0 at the lowest y.
    origin_x_m, origin_y_m : float
        The lower-left corner of cell (0, 0) [m].
    resolution_m : float
        Cell edge [m].
    radius_m : float
        The robot's radius [m]: cells whose centre lies closer to an obstacle cell's centre
        are taken away.
    """

    def __init__(
        self,
        occupied: npt.ArrayLike,
        origin_x_m: float,
        origin_y_m: float,
        resolution_m: float,
        radius_m: float,
    ) -> None:
        from skimage.graph import MCP_Geometric

        occ = np.asarray(occupied, dtype=bool)
        self.origin = (float(origin_x_m), float(origin_y_m))
        self.res = float(resolution_m)
        clearance = ndimage.distance_transform_edt(~occ) * self.res
        self.free: BoolArray = clearance > radius_m
        self._mcp = MCP_Geometric(np.where(self.free, 1.0, np.inf))
        _, nearest = ndimage.distance_transform_edt(~self.free, return_indices=True)
        self._nearest = nearest

    @classmethod
    def of_world(cls, world: WorldSpec, radius_m: float) -> ShortestPaths:
        """On the world's true raster at :data:`RESOLUTION_M`."""
        from jackson.sim.raster import raster

        occupied, ox, oy = raster(world, RESOLUTION_M)
        return cls(occupied, ox, oy, RESOLUTION_M, radius_m)

    def _cell(self, p: tuple[float, float]) -> tuple[int, int] | None:
        (r,), (c,) = (np.atleast_1d(a) for a in world_to_cell(p[0], p[1], *self.origin, self.res))
        rows, cols = self.free.shape
        if not (0 <= r < rows and 0 <= c < cols):
            return None
        r, c = int(self._nearest[0][r, c]), int(self._nearest[1][r, c])
        return (r, c) if self.free[r, c] else None

    def _centre(self, cells: npt.ArrayLike) -> FloatArray:
        rc = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
        x = self.origin[0] + (rc[:, 1] + 0.5) * self.res
        y = self.origin[1] + (rc[:, 0] + 0.5) * self.res
        return np.column_stack((x, y))

    def _sees(self, a: FloatArray, b: FloatArray) -> bool:
        """Every point of the segment a-b (sampled every quarter cell) lies in a kept cell."""
        n = max(2, math.ceil(4.0 * math.hypot(*(b - a)) / self.res) + 1)
        s = np.linspace(0.0, 1.0, n)[:, None]
        pts = a + s * (b - a)
        r, c = world_to_cell(pts[:, 0], pts[:, 1], *self.origin, self.res)
        rows, cols = self.free.shape
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        return bool(inside.all() and self.free[r, c].all())

    def _pulled(self, pts: FloatArray) -> FloatArray:
        """The polyline pulled taut (module docstring, step 2)."""
        out = [pts[0]]
        i, n = 0, len(pts)
        while i < n - 1:
            j = i + 1
            while j + 1 < n and self._sees(pts[i], pts[j + 1]):
                j += 1
            out.append(pts[j])
            i = j
        return np.array(out)

    def path(self, a: tuple[float, float], b: tuple[float, float]) -> FloatArray | None:
        """The shortest path from ``a`` to ``b`` [m], shape (N, 2); None when none exists."""
        ca, cb = self._cell(a), self._cell(b)
        if ca is None or cb is None:
            return None
        costs, _ = self._mcp.find_costs([ca], [cb])
        if not math.isfinite(costs[cb]):
            return None
        pts = self._centre(self._mcp.traceback(cb))
        pts = np.vstack(([a], pts[1:-1], [b])) if len(pts) > 1 else np.array([a, b], float)
        return self._pulled(pts)

    def length_m(self, a: tuple[float, float], b: tuple[float, float]) -> float:
        """The shortest path's length [m] (NaN when none exists)."""
        p = self.path(a, b)
        return path_length(p) if p is not None else math.nan


def ratio_figures(ratios: npt.ArrayLike) -> dict[str, float | int | None]:
    """Median, 95th percentile and maximum of the ratios (NaN left out), and how many exceed
    :data:`RATIO_LIMIT` (``above_1_25``)."""
    r = np.asarray(ratios, dtype=np.float64)
    r = r[np.isfinite(r)]
    if not r.size:
        return {"median": None, "p95": None, "max": None, "above_1_25": 0, "goals": 0}
    return {
        "median": float(np.median(r)),
        "p95": float(np.percentile(r, 95)),
        "max": float(np.max(r)),
        "above_1_25": int(np.sum(r > RATIO_LIMIT)),
        "goals": int(r.size),
    }
