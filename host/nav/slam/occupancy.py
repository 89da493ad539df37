"""The map's cells as counts: how many scans ended a beam in each cell, how many passed through
it, and where in it the returns fell (:class:`CountGrid`).

A cell is occupied when at least ``occupancy_threshold`` of the scans that saw it ended a beam
in it, once ``min_observations`` scans saw it; free when fewer did; unknown before (Karto's
and slam_toolbox's model: occupancy threshold 0.1, minimum pass-through 2). Against log-odds
this keeps thin walls: a partition seen along its length is hit by the few beams that reach it
and crossed by many that pass beside it, since a beam 1 cm from a wall runs through the wall's
cell. With log-odds every pass takes back most of a hit, so the partition fades as the robot
drives by (with OctoMap's 0.7 / 0.4, three passes erase two hits); with counts a cell that one
scan in ten hits stays a wall. A lone return beyond a wall (a 2-sigma range error) is seen by
one scan only and stays unknown. What the counts give up is forgetting: an obstacle that moved
away stays occupied until the passes outnumber its hits tenfold, which a survey of a static
floor does not need.

The counts are sums over scans, so the same scans written at other poses (after the pose graph
moved them) give the map again from scratch (:meth:`CountGrid.clear` and writing each scan).

Each scan updates a cell at most once, a hit winning over a pass (Cartographer's insertion
rule). The cells a beam crosses are found without a per-beam loop: points along all beams at
``trace_step_cells`` of a cell, mapped to cells and de-duplicated through a boolean mask over
the scan's bounding window. Returns beyond ``max_range_m`` clear up to it without a hit (Karto's
range threshold); beams with no return clear up to ``no_return_free_m`` when it is above 0 and
nothing by default (on the A1M8 a missing return is as often a dark surface as open space).

The grid grows as needed, by ``grow_margin_m`` whenever a scan reaches past its edge, its
origin on a multiple of the resolution, so cells never shift and a ground-truth raster of the
same resolution lines up cell for cell.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.host.nav.grid import UNKNOWN, OccupancyGrid
from jackson.host.nav.likelihood import PointField
from jackson.host.nav.types import Pose2D, Scan

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

OCCUPIED = 100
FREE = 0


@dataclass(frozen=True)
class Insertion:
    """How scans are written into a :class:`CountGrid`.

    Attributes
    ----------
    resolution_m : float
        Cell edge [m].
    occupancy_threshold : float
        Share of the scans that saw a cell that must have hit it for it to be occupied.
    min_observations : int
        Scans that must have seen a cell before it is known.
    max_range_m : float
        Returns farther than this clear up to it and mark no hit [m].
    no_return_free_m : float
        Beams with no return clear this far [m]; 0 clears nothing.
    trace_step_cells : float
        Spacing of the points sampled along a beam [cells].
    grow_margin_m : float
        Room added beyond a scan whenever the grid grows [m].
    wall_hits : int
        A cell hit by at least this many scans, and by ``wall_share`` of those that saw it,
        is a wall that beams do not pass: a beam that crosses one more than ``wall_margin_m``
        before its return ends there, its return unwritten (0: beams pass everything).
    wall_share : float
        See ``wall_hits``.
    wall_margin_m : float
        See ``wall_hits`` [m].
    wall_extent_sigmas, wall_extent_floor_m : float
        Above 0: a wall cell stops only the beams that pass within this many standard
        deviations of its returns (their mean and covariance in the cell, the covariance
        widened by ``wall_extent_floor_m`` squared on both axes), not those that pass beside
        the returns, as a beam does that grazes the end of a wall within the end's cell.
    """

    resolution_m: float = 0.05
    occupancy_threshold: float = 0.1
    min_observations: int = 2
    max_range_m: float = 8.0
    no_return_free_m: float = 0.0
    trace_step_cells: float = 0.5
    grow_margin_m: float = 1.0
    wall_hits: int = 3
    wall_share: float = 0.3
    wall_margin_m: float = 0.1
    wall_extent_sigmas: float = 2.0
    wall_extent_floor_m: float = 0.005


class CountGrid:
    """Hit and pass counts per cell, and the mean return in each (the module's notes)."""

    def __init__(self, insertion: Insertion) -> None:
        self.insertion = insertion
        self._passes = np.zeros((0, 0), np.int32)
        # per cell: the sums of the returns' x and y offsets from its lower-left corner [m] and
        # the count of scans that hit it, so a cell's mean return places its obstacle finely
        self._hits = np.zeros((3, 0, 0), np.float64)
        # per cell, the sums over the scans that hit it of their returns' mean x^2, x y and y^2
        # offsets (as ``_hits`` sums their mean x and y): the spread of the returns in the cell
        self._moments = np.zeros((3, 0, 0), np.float64)
        self._row0 = 0  # map-frame cell index of the grid's row 0 (origin_y = row0 * res)
        self._col0 = 0
        self._field: PointField | None = None
        self._field_window = (0, 0, 0, 0)
        self._occupied: npt.NDArray[np.bool_] | None = None
        self._walls: npt.NDArray[np.bool_] | None = None
        self._frozen_walls = False  # the walls of a first pass, kept through the second
        self._wall_sums: tuple[FloatArray, FloatArray] | None = None  # and their returns

    def clear(self) -> None:
        """Forget every scan, keeping the grid's extent."""
        self._passes[:] = 0
        self._hits[:] = 0.0
        self._moments[:] = 0.0
        self._changed()

    def _changed(self) -> None:
        self._field = None
        self._occupied = None
        if not self._frozen_walls:
            self._walls = None

    def walls(self) -> npt.NDArray[np.bool_]:
        """The cells beams do not pass (``Insertion.wall_hits``), over the whole grid."""
        if self._walls is None:
            ins = self.insertion
            hits = self._hits[2]
            self._walls = (hits >= max(1, ins.wall_hits)) & (
                hits >= ins.wall_share * (hits + self._passes)
            )
        return self._walls

    def write_all(self, scans: Sequence[tuple[Scan, Pose2D]]) -> None:
        """Write these scans (each with its map-frame sensor pose) from scratch, in two
        passes: the first finds the walls, the second writes every scan again against them, so
        a beam written before a wall was known to stop it (a scan whose pose erred, its returns
        behind the wall) is judged as a beam written after."""
        self.clear()
        if self.insertion.wall_hits <= 0:
            for scan, sensor in scans:
                self.write(scan, sensor)
            return
        self._frozen_walls = True
        self._walls = None
        try:
            for scan, sensor in scans:
                self.write(scan, sensor, through=True)
            self.walls()
            # the walls' returns too, for wall_extent_sigmas
            self._wall_sums = (self._hits.copy(), self._moments.copy())
            self.clear()  # the counts only: the walls stay frozen for the second pass
            for scan, sensor in scans:
                self.write(scan, sensor)
        finally:
            self._frozen_walls = False
            self._wall_sums = None
        self._changed()

    def occupied(self) -> npt.NDArray[np.bool_]:
        """Which cells are occupied (the module's rule), over the whole grid."""
        if self._occupied is None:
            ins = self.insertion
            hits = self._hits[2]
            seen = hits + self._passes
            self._occupied = (
                (seen >= ins.min_observations)
                & (hits >= ins.occupancy_threshold * seen)
                & (hits > 0)
            )
        return self._occupied

    def grid(self) -> OccupancyGrid:
        """The map: 100 occupied, 0 free, -1 unknown (seen by fewer than ``min_observations``
        scans). One unknown cell at the origin before the first scan."""
        res = self.insertion.resolution_m
        if self._passes.size == 0:
            return OccupancyGrid(np.full((1, 1), UNKNOWN, np.int8), res)
        seen = self._hits[2] + self._passes
        data = np.full(self._passes.shape, UNKNOWN, np.int8)
        data[seen >= self.insertion.min_observations] = FREE
        data[self.occupied()] = OCCUPIED
        return OccupancyGrid(data, res, self._col0 * res, self._row0 * res)

    def match_field(self, centre_xy: tuple[float, float] | None, reach_m: float) -> PointField:
        """The field a scan is matched against: the mean return of every cell occupied by the
        threshold, seen by ``min_observations`` scans or not.

        Parameters
        ----------
        centre_xy : tuple of float or None
            Build it only over the cells within ``reach_m`` of this point [m] (a scan matched
            there cannot reach farther), so that its cost stays bounded however large the map
            grows; None for the whole map.
        reach_m : float
            That reach [m].

        Returns
        -------
        PointField
            Cached until the next write or another window.
        """
        res = self.insertion.resolution_m
        rows_n, cols_n = self._passes.shape
        r0, r1, c0, c1 = 0, rows_n, 0, cols_n
        if centre_xy is not None:
            half = math.ceil(reach_m / res)
            rc = math.floor(centre_xy[1] / res) - self._row0
            cc = math.floor(centre_xy[0] / res) - self._col0
            r0, r1 = max(0, rc - half), min(rows_n, rc + half + 1)
            c0, c1 = max(0, cc - half), min(cols_n, cc + half + 1)
            if r0 >= r1 or c0 >= c1:
                r0, r1, c0, c1 = 0, rows_n, 0, cols_n
        window = (r0, r1, c0, c1)
        if self._field is None or self._field_window != window:
            sum_x, sum_y, n = (a[r0:r1, c0:c1] for a in self._hits)
            # hit often enough by the scans that saw them, however few: the second scan is
            # matched against the first
            seen = n + self._passes[r0:r1, c0:c1]
            occupied = (n > 0) & (n >= self.insertion.occupancy_threshold * seen)
            inv_n = np.divide(1.0, n, out=np.zeros_like(n), where=occupied)
            rows, cols = np.indices(n.shape)
            x = (cols + self._col0 + c0) * res + sum_x * inv_n
            y = (rows + self._row0 + r0) * res + sum_y * inv_n
            self._field = PointField.from_cells(
                occupied, x, y, res, (self._col0 + c0) * res, (self._row0 + r0) * res
            )
            self._field_window = window
        return self._field

    def write(self, scan: Scan, sensor: Pose2D, through: bool = False) -> None:
        """Write one scan taken from the map-frame sensor pose; a beam ends at the first wall
        it crosses (:meth:`walls`) unless ``through``."""
        ins = self.insertion
        res = ins.resolution_m
        r = scan.ranges_m.astype(np.float64)
        with np.errstate(invalid="ignore"):
            returned = scan.valid
            hit = returned & (r <= ins.max_range_m)
            free_m = np.where(hit, r, 0.0)
            free_m[returned & ~hit] = ins.max_range_m
            if ins.no_return_free_m > 0.0:
                none = np.isposinf(r) | (np.isfinite(r) & (r > scan.range_max_m))
                free_m[none] = min(ins.no_return_free_m, ins.max_range_m)
        a = scan.angles_rad + sensor.yaw
        cos_a, sin_a = np.cos(a), np.sin(a)
        inv = 1.0 / res

        # cells of the returns, in map-frame cell indices
        hit_x = sensor.x + r[hit] * cos_a[hit]
        hit_y = sensor.y + r[hit] * sin_a[hit]
        hit_col = np.floor(hit_x * inv).astype(np.intp)
        hit_row = np.floor(hit_y * inv).astype(np.intp)

        # points along every beam at trace_step, ragged: beam b contributes n[b] of them
        step = ins.trace_step_cells * res
        n = np.ceil(free_m / step).astype(np.intp)
        beam = np.repeat(np.arange(n.size), n)
        k = np.arange(beam.size) - np.repeat(np.cumsum(n) - n, n)
        t: FloatArray = k * np.float64(step)
        free_col = np.floor((sensor.x + t * cos_a[beam]) * inv).astype(np.intp)
        free_row = np.floor((sensor.y + t * sin_a[beam]) * inv).astype(np.intp)
        if not through and ins.wall_hits > 0 and self._passes.size:
            stop = self._stops(beam, t, free_row, free_col, free_m, sensor, cos_a, sin_a)
            if stop is not None:
                keep = t < stop[beam]
                beam, t, free_col, free_row = beam[keep], t[keep], free_col[keep], free_row[keep]
                ended = hit & np.isfinite(stop)
                if ended.any():
                    kept = ~ended[hit]
                    hit_x, hit_y = hit_x[kept], hit_y[kept]
                    hit_col, hit_row = hit_col[kept], hit_row[kept]

        s_col, s_row = math.floor(sensor.x * inv), math.floor(sensor.y * inv)
        lo_row, hi_row = _span(s_row, hit_row, free_row)
        lo_col, hi_col = _span(s_col, hit_col, free_col)
        self._cover(lo_row, hi_row, lo_col, hi_col)

        # one update per cell and scan, a hit winning over a pass, in the scan's window
        r0, c0 = lo_row - self._row0, lo_col - self._col0
        h, w = hi_row - lo_row + 1, hi_col - lo_col + 1
        hit_k = (hit_row - lo_row) * w + (hit_col - lo_col)
        hits = np.zeros(h * w, np.bool_)
        hits[hit_k] = True
        passes = np.zeros(h * w, np.bool_)
        passes[(free_row - lo_row) * w + (free_col - lo_col)] = True
        passes &= ~hits
        self._passes[r0 : r0 + h, c0 : c0 + w] += passes.reshape(h, w)
        sums = self._hits[:, r0 : r0 + h, c0 : c0 + w]
        # each scan adds the mean of its returns in a cell (and of their squares, for the
        # returns' spread), so a cell's sums count every scan that hit it once
        per = np.maximum(np.bincount(hit_k, None, h * w), 1).reshape(h, w)
        ox, oy = hit_x - hit_col * res, hit_y - hit_row * res
        sums[0] += np.bincount(hit_k, ox, h * w).reshape(h, w) / per
        sums[1] += np.bincount(hit_k, oy, h * w).reshape(h, w) / per
        sums[2] += hits.reshape(h, w)
        if ins.wall_extent_sigmas > 0.0:
            moments = self._moments[:, r0 : r0 + h, c0 : c0 + w]
            for m, v in enumerate((ox * ox, ox * oy, oy * oy)):
                moments[m] += np.bincount(hit_k, v, h * w).reshape(h, w) / per
        self._changed()

    def _stops(
        self,
        beam: IntArray,
        t: FloatArray,
        row: IntArray,
        col: IntArray,
        free_m: FloatArray,
        sensor: Pose2D,
        cos_a: FloatArray,
        sin_a: FloatArray,
    ) -> FloatArray | None:
        """Per beam, where along it [m] it first crosses a wall more than ``wall_margin_m``
        before its end (inf: never); None when no beam does."""
        walls = self.walls()
        rows, cols = walls.shape
        r, c = row - self._row0, col - self._col0
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        on = np.zeros(beam.size, np.bool_)
        on[inside] = walls[r[inside], c[inside]]
        on &= t < free_m[beam] - self.insertion.wall_margin_m
        if not on.any():
            return None
        k_sig = self.insertion.wall_extent_sigmas
        if k_sig > 0.0:
            idx = np.flatnonzero(on)
            rr, cc, bb = r[idx], c[idx], beam[idx]
            hits, moments = self._wall_sums or (self._hits, self._moments)
            n = hits[2, rr, cc]  # >= wall_hits >= 1 on a wall
            res = self.insertion.resolution_m
            mx = hits[0, rr, cc] / n
            my = hits[1, rr, cc] / n
            floor2 = self.insertion.wall_extent_floor_m**2
            sxx = moments[0, rr, cc] / n - mx * mx + floor2
            sxy = moments[1, rr, cc] / n - mx * my
            syy = moments[2, rr, cc] / n - my * my + floor2
            # the returns' mean relative to the sensor, and the beam's direction
            wx = (cc + self._col0) * res + mx - sensor.x
            wy = (rr + self._row0) * res + my - sensor.y
            dx, dy = cos_a[bb], sin_a[bb]
            det = sxx * syy - sxy * sxy
            # the squared Mahalanobis distance from the mean to the beam's line:
            # w'S^-1 w - (d'S^-1 w)^2 / d'S^-1 d, with S^-1 = [[syy, -sxy], [-sxy, sxx]] / det
            ww = syy * wx * wx - 2.0 * sxy * wx * wy + sxx * wy * wy
            dw = syy * dx * wx - sxy * (dx * wy + dy * wx) + sxx * dy * wy
            dd = syy * dx * dx - 2.0 * sxy * dx * dy + sxx * dy * dy
            m2 = (ww - dw * dw / dd) / det
            on[idx[m2 > k_sig * k_sig]] = False
            if not on.any():
                return None
        stop = np.full(free_m.size, np.inf)
        np.minimum.at(stop, beam[on], t[on])
        return stop

    def _cover(self, lo_row: int, hi_row: int, lo_col: int, hi_col: int) -> None:
        """Grow the grid (by ``grow_margin_m`` beyond the request) to hold these cells."""
        rows, cols = self._passes.shape
        if (
            rows > 0
            and lo_row >= self._row0
            and hi_row < self._row0 + rows
            and lo_col >= self._col0
            and hi_col < self._col0 + cols
        ):
            return
        m = math.ceil(self.insertion.grow_margin_m / self.insertion.resolution_m)
        if rows == 0:
            new_r0, new_c0 = lo_row - m, lo_col - m
            new_r1, new_c1 = hi_row + m + 1, hi_col + m + 1
        else:
            r1, c1 = self._row0 + rows, self._col0 + cols
            new_r0 = self._row0 if lo_row >= self._row0 else lo_row - m
            new_c0 = self._col0 if lo_col >= self._col0 else lo_col - m
            new_r1 = r1 if hi_row < r1 else hi_row + m + 1
            new_c1 = c1 if hi_col < c1 else hi_col + m + 1
        passes = np.zeros((new_r1 - new_r0, new_c1 - new_c0), np.int32)
        hits = np.zeros((3, *passes.shape), np.float64)
        moments = np.zeros((3, *passes.shape), np.float64)
        if rows > 0:
            dr, dc = self._row0 - new_r0, self._col0 - new_c0
            passes[dr : dr + rows, dc : dc + cols] = self._passes
            hits[:, dr : dr + rows, dc : dc + cols] = self._hits
            moments[:, dr : dr + rows, dc : dc + cols] = self._moments
        self._passes, self._hits, self._moments = passes, hits, moments
        self._row0, self._col0 = new_r0, new_c0
        self._changed()


def _span(start: int, a: IntArray, b: IntArray) -> tuple[int, int]:
    """Smallest and largest of ``start`` and the elements of ``a`` and ``b``."""
    lo = hi = start
    for v in (a, b):
        if v.size:
            lo, hi = min(lo, int(v.min())), max(hi, int(v.max()))
    return lo, hi
