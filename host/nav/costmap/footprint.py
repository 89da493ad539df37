"""The footprint collision checker of the local costmap (Nav2's FootprintCollisionChecker,
with the obstacles themselves rather than their cells).

Collision tests do not stop at cells. Every lethal cell also stands for a disc: the centroid
of the returns that marked it with their spread as radius, or, for a static-map cell, the
cell's circumscribed disc. The robot is the disc of the robot radius (Nav2's circular robot)
joined with the oriented envelope rectangle, and a pose collides when it overlaps a disc. A
half-cell of quantisation plus LiDAR noise otherwise makes a robot passing a few centimetres
from an obstacle "touch" a cell and freeze. Cell distances bound the true clearances, so most
poses are settled by one table lookup: far from every obstacle, certainly overlapping one, or
(only these get the exact test) in between.

The recoveries test the robot's body alone, more closely, at their handful of poses
(:meth:`FootprintChecker.body_contacts`): the envelope rectangle against the last scan's
returns, each marked cell the capsule of its own and its neighbours' returns with the range
noise taken out.

A checker is made by its costmap at every change of the costs (:attr:`version`) and reads
that version only.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import numpy.typing as npt

from jackson.common.geometry import GridGeometry
from jackson.host.nav import native, native_grid
from jackson.host.nav.costmap.layers import ObstacleLayer
from jackson.host.nav.costmap.values import (
    LETHAL_OBSTACLE,
    BoolArray,
    CostArray,
    CostmapConfig,
    FloatArray,
    IntArray,
)

BODY_STEP_M = 0.01  # [m] discs along a capsule in the body test (FootprintChecker.body_contacts)

# per-cell classes for collision checks: far from obstacles, near enough for the robot to reach
# one, so near that the robot's disc certainly overlaps one, a centre on a lethal or unknown
# cell or off the grid
_CLEAR, _NEAR, _DEEP, _BLOCKED = 0, 1, 2, 3
_ONE_CALL_POSES = 2048  # up to this many poses need the exact test: all in one call


class FootprintChecker:
    """Whether the robot at poses, or along trajectories, overlaps an obstacle of one version
    of a costmap.

    Parameters
    ----------
    config : CostmapConfig
        The robot's disc and envelope.
    geometry : GridGeometry
        The costmap's grid.
    costs : ndarray of uint8, shape (rows, cols)
        The costmap's combined costs.
    lethal : ndarray of bool, shape (rows, cols)
        Its lethal cells.
    distance_m : ndarray, shape (rows, cols)
        Each cell centre's distance to the nearest lethal cell centre [m].
    static_costs : ndarray of uint8, shape (rows, cols)
        The static layer (its lethal cells are cell discs, not returns' discs).
    obstacles : ObstacleLayer
        The obstacle layer, with where its marking returns lay.
    version : int
        The costmap's version these are.

    Attributes
    ----------
    version : int
        As given.
    """

    def __init__(
        self,
        config: CostmapConfig,
        geometry: GridGeometry,
        costs: CostArray,
        lethal: BoolArray,
        distance_m: FloatArray,
        static_costs: CostArray,
        obstacles: ObstacleLayer,
        version: int,
    ) -> None:
        self.config = config
        self.geometry = geometry
        self.version = version
        self._obstacles = obstacles
        self._body_cache: tuple[int, FloatArray, FloatArray] | None = None
        self._clear_reach_padded: FloatArray | None = None
        layer = obstacles
        compiled = native.LIB is not None and layer.hit_xy.shape[:2] == geometry.shape
        if compiled:
            g = geometry
            pts, radius, cells, (reach, short) = native_grid.obstacle_discs(
                lethal, layer.costs, static_costs, (layer.hit_xy, layer.hit_spread_m),
                (g.origin_x_m, g.origin_y_m, g.resolution_m), LETHAL_OBSTACLE,
            )  # fmt: skip
        else:
            pts, radius, cells, reach, short = self._discs(lethal, static_costs)
        self._obstacle_xy = pts
        self._obstacle_r_m = radius
        self._obstacle_cells = cells
        self._bound(reach, short)
        rows, cols = geometry.shape
        k = self._pad_k
        if compiled:
            ids, self._class_padded = native_grid.obstacle_classes(
                cells, k, (rows, cols), distance_m, costs, LETHAL_OBSTACLE,
                (self._near_m, self._deep_m),
            )  # fmt: skip
        else:
            ids = np.full((rows + 2 * k, cols + 2 * k), -1, np.int32)
            rr, cc = np.divmod(cells, cols)
            ids[k + rr, k + cc] = np.arange(len(cells), dtype=np.int32)
            cls = np.where(distance_m <= self._near_m, _NEAR, _CLEAR).astype(np.uint8)
            cls[distance_m < self._deep_m] = _DEEP
            cls[costs >= LETHAL_OBSTACLE] = _BLOCKED  # lethal or unknown under the centre
            self._class_padded = ringed(cls, _BLOCKED).ravel()
        self._ids_padded = ids.ravel()
        res = geometry.resolution_m
        self._neighbour_offsets = _disc_offsets(k, cols + 2 * k, res, self._near_m)
        cfg = config
        self._native = (
            native.Obstacles(
                ids, (rows + 2 * k, cols + 2 * k), k, self._neighbour_offsets, pts, radius,
                (geometry.origin_x_m, geometry.origin_y_m, res),
                (cfg.robot_radius_m, cfg.circumscribed_radius_m, *cfg.footprint_x_m,
                 *cfg.footprint_y_m),
            )
            if native.LIB is not None
            else None
        )  # fmt: skip

    def _discs(
        self, lethal: BoolArray, static_costs: CostArray
    ) -> tuple[FloatArray, FloatArray, IntArray, float, float]:
        """The obstacle discs the footprint test uses: (centres, radii, flat cells, the largest
        reach of a disc beyond its cell centre, the largest shortfall).

        A lethal cell marked by returns (and not by the static map) is the disc around the
        returns' centroid of radius their spread; any other lethal cell is the disc around
        its centre that covers the cell (radius res / sqrt 2).
        """
        g = self.geometry
        res = g.resolution_m
        rr, cc = np.nonzero(lethal)
        cx, cy = g.cell_to_world(rr, cc)
        pts = np.column_stack((cx, cy))
        radius = np.full(len(rr), res / math.sqrt(2.0))
        layer = self._obstacles
        scan = (layer.costs[rr, cc] == LETHAL_OBSTACLE) & (static_costs[rr, cc] != LETHAL_OBSTACLE)
        pts[scan] = layer.hit_xy[rr[scan], cc[scan]]
        radius[scan] = layer.hit_spread_m[rr[scan], cc[scan]]
        # bounds between cell-centre distances and true clearances: how far beyond its cell
        # centre a disc may reach (sqrt 2 h: the grown rectangle's corner), how far short of
        # it it may stop
        off = np.hypot(pts[:, 0] - cx, pts[:, 1] - cy)
        reach = float((off + math.sqrt(2.0) * radius).max()) if len(rr) else 0.0
        short = float((off - radius).max()) if len(rr) else 0.0
        return pts, radius, rr * g.cols + cc, reach, short

    def _bound(self, reach: float, short: float) -> None:
        """The near and deep distances of the cell classes from the discs' bounds (and a
        pose's offset from its own cell centre), and the padding k of the obstacle ids."""
        cfg = self.config
        res = self.geometry.resolution_m
        half_cell = res / math.sqrt(2.0)
        self._near_m = (
            max(cfg.circumscribed_radius_m, cfg.robot_radius_m)
            + reach
            + half_cell
            + self.max_margin_m
        )
        self._deep_m = cfg.robot_radius_m - max(short, 0.0) - half_cell
        self._pad_k = max(1, math.ceil(self._near_m / res))

    def __setstate__(self, state: dict[str, object]) -> None:
        """A checker pickled where the library was, loaded where it is not (a snapshot replayed
        in a checkout without a build, or with ``JACKSON_NAV_INTERPRETED``): tests with numpy,
        the same answers."""
        self.__dict__.update(state)
        if native.LIB is None:
            self._native = None

    @property
    def max_margin_m(self) -> float:
        """The largest ``margin_m`` :meth:`trajectories_collide` accepts: a quarter cell [m]."""
        return 0.25 * self.geometry.resolution_m

    @property
    def compiled(self) -> bool:
        """Whether the tests run compiled (:mod:`jackson.host.nav.native`)."""
        return self._native is not None

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
        return np.take(self.clear_reach_table(), self.geometry.padded_index(x_m, y_m))

    def clear_reach_table(self) -> FloatArray:
        """:meth:`clear_reach_m` of every cell of the grid padded by one cell (the ring off the
        grid), flat, row-major over (rows + 2, cols + 2) [m]; read-only, made once per change.

        Returns
        -------
        ndarray, shape ((rows + 2) (cols + 2),)
            The clear reach of a point in each cell [m].
        """
        if self._clear_reach_padded is None:
            rows, cols = self.geometry.shape
            clear = self._class_padded.reshape(rows + 2, cols + 2) == _CLEAR
            d = native.distance_to(~clear)
            table = (
                d * self.geometry.resolution_m - math.sqrt(2.0) * self.geometry.resolution_m
            ).ravel()
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
        cls = np.take(self._class_padded, self.geometry.padded_index(x, y))
        out = cls >= _DEEP
        near = np.flatnonzero(cls == _NEAR)
        out[near] = self.footprint_hits(x[near], y[near], yaw[near])[0] > 0
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

        """
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
        cache = self._body_cache
        if cache is not None and cache[0] == self.version:
            return cache[1], cache[2]
        g = self.geometry
        cols = g.cols
        q: FloatArray = self._obstacles.last_returns
        r, c = g.world_to_cell(q[:, 0], q[:, 1])
        ok = g.inside(r, c)  # the window may have moved since
        q, r, c = q[ok], r[ok], c[ok]
        ok = self._obstacles.costs[r, c] == LETHAL_OBSTACLE  # and a recovery cleared it
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
                np.broadcast_to(margins, (m,)), allowed, floor_m, self._class_padded,
                self.geometry.shape,
            )  # fmt: skip
            return self._native.trajectories_collide(x_m, y_m, yaw_rad, rule)
        cls = np.take(self._class_padded, self.geometry.padded_index(x_m, y_m))
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
            count, clearance = self.footprint_hits(
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
        start_cls = int(self._class_padded[self.geometry.padded_index(start[0], start[1])])
        if _NEAR <= start_cls <= _DEEP and self._native is not None:
            return self._native.escape(start, margins)  # the same, in one call
        if _NEAR <= start_cls <= _DEEP:
            # per distinct margin, the start pose's overlaps and clearance
            values, which = np.unique(margins, return_inverse=True)
            count0, clear0 = self.footprint_hits(
                np.repeat(start[0], len(values)), np.repeat(start[1], len(values)),
                np.repeat(start[2], len(values)), True, values,
            )  # fmt: skip
            allowed = count0[which]
            floor_m = np.where(allowed > 0, clear0[which] - 1e-9, -math.inf)
        return allowed, floor_m

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
        rule = native.Rule(margins, allowed, floor_m, self._class_padded, self.geometry.shape)
        return self._native.rollouts_collide(
            (start[0], start[1]), ds_m, cos_sin, yaw_rad, iv, iw, stride, rule, stop_at_clear
        )

    def footprint_hits(
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
        g = self.geometry
        rows, cols = g.shape
        k = self._pad_k
        res = g.resolution_m
        col = np.clip((x - g.origin_x_m) / res + k, 0.0, cols + 2 * k - 1).astype(np.intp)
        row = np.clip((y - g.origin_y_m) / res + k, 0.0, rows + 2 * k - 1).astype(np.intp)
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


def ringed(inner: CostArray, value: int) -> CostArray:
    """``np.pad(inner, 1, constant_values=value)`` without its generality's cost."""
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
