"""Online occupancy mapping with scan matching: what slam_toolbox does for the robot, in numpy.

:class:`Mapper` keeps a log-odds occupancy grid and the map -> odom correction. For each scan it
is given the odometry (or EKF) pose of the base; it

1. predicts the map-frame pose, ``map_to_odom ⊕ odom_pose``;
2. returns that prediction unless the robot has moved at least ``min_travel_m`` or turned at
   least ``min_heading_rad`` since the last integrated scan (or this is the first scan), as
   slam_toolbox's ``minimum_travel_distance`` / ``minimum_travel_heading`` (0.5 m / 0.5 rad by
   default there; a 0.2 m robot in a 3 m maze needs 0.05 m / 0.05 rad);
3. searches a window around the prediction (default +-0.1 m, +-0.1 rad) for the pose at which
   the scan best agrees with the map built so far: a correlative search, coarse to fine, of the
   mean likelihood ``exp(-d^2 / 2 sigma^2)`` of the returns, d being the distance to the
   nearest obstacle, weighted by a weak prior around the prediction (as slam_toolbox's
   distance and angle variance penalties) that only breaks ties along directions the scan
   cannot see, such as along a featureless corridor. The best pose replaces the prediction
   when its score reaches ``min_match_score``; otherwise the prediction stands;
4. updates ``map_to_odom = corrected ⊕ odom_pose⁻¹`` and integrates the scan at the corrected
   pose with an inverse sensor model.

The inverse sensor model adds ``hit_log_odds`` to the cell of every return and
``free_log_odds`` to every cell a beam crosses before it, then clamps the log-odds to
[``min_log_odds``, ``max_log_odds``] (p = 0.634 per hit, OctoMap's 0.4 per pass, clamped to
OctoMap's 0.12 .. 0.97), so a map stays able to forget a moved obstacle. One hit leaves a cell
below map_saver's occupied threshold 0.65 and a second one crosses it: a lone return beyond a
wall (a 2-sigma range error, about one beam in 40 of those that hit it) does not print as a
second wall, since no beam ever passes that cell to clear it. (OctoMap's 0.7 per hit does, and
costs about 0.02 of SSIM on the test room.) Each cell takes at most one update per scan, and
a hit wins over a pass: a cell that some beam ends in is not cleared by a
neighbouring beam that grazes it (Cartographer's insertion rule), which keeps thin walls seen at
shallow angles. Free cells are found without a per-beam loop: points along all beams at
``trace_step_cells`` of a cell are generated at once (a ragged ``np.repeat`` layout), mapped to
cells and de-duplicated through a boolean mask over the scan's bounding window; a sampling step
of half a cell finds every cell a beam crosses except corner clips shorter than half a cell,
which neighbouring beams cover. Returns beyond ``max_range_m`` clear up to it without a hit
(Karto's range threshold). Beams with no return clear up to ``no_return_free_m`` when it is above
0 and nothing by default: on the A1M8 a missing return is as often a dark or glossy surface as
open space, and clearing along it would erase real walls (the paper's G04 drops 5 % of beams).

The obstacles the matcher measures d to are not cell centres: every cell keeps the mean of the
returns that fell in it, and d is the distance to the mean return of the nearest cell with
positive log-odds (:class:`~jackson.host.nav.likelihood.PointField`). Against cell centres
(:class:`~jackson.host.nav.likelihood.LikelihoodField`) the matcher pulls each scan up to half a
cell towards them: on the paper's Stage 3 corridor, whose walls lie on cell edges, driven
1.9 m with odometry that ends 4.0 cm off, the pose then strays up to 3.4 cm, against 0.9 cm
with the mean returns. (slam_toolbox
sidesteps the same limit by matching against the raw points of recent scans on a 0.01 m grid,
its correlation_search_space_resolution.)

The grid grows as needed: it starts around the first scan and is padded by ``grow_margin_m``
whenever a scan reaches past its edge. Its origin stays on a multiple of the resolution, so
cells never shift and a ground-truth raster of the same resolution lines up cell for cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.host.nav.grid import UNKNOWN, OccupancyGrid
from jackson.host.nav.likelihood import LikelihoodField, PointField
from jackson.host.nav.types import Pose2D, Scan

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

ORIGIN = Pose2D()  # the identity pose: a sensor mounted on the base origin


@dataclass(frozen=True)
class MappingConfig:
    """Parameters of :class:`Mapper`.

    Attributes
    ----------
    resolution_m : float
        Cell edge [m] (slam_toolbox's default resolution).
    hit_log_odds : float
        Log-odds added to the cell of a return (p = 0.634: two hits make a cell occupied).
    free_log_odds : float
        Log-odds added to a cell a beam crosses (OctoMap's prob_miss 0.4); negative.
    min_log_odds, max_log_odds : float
        Clamp of a cell's log-odds (OctoMap's clamping thresholds 0.12 and 0.97).
    max_range_m : float
        Returns farther than this clear up to it and mark no hit [m] (REFERENCE: the robot's
        8 m software cap).
    no_return_free_m : float
        Beams with no return clear this far [m]; 0 clears nothing.
    trace_step_cells : float
        Spacing of the points sampled along a beam to find the cells it crosses [cells].
    grow_margin_m : float
        Room added beyond a scan whenever the grid grows [m].
    min_travel_m : float
        Odometry travel since the last integrated scan that makes the next one integrate [m].
    min_heading_rad : float
        Odometry turn since the last integrated scan that makes the next one integrate [rad].
    scan_matching : bool
        Correct the pose by scan matching; False integrates at the odometry prediction.
    search_xy_m, search_yaw_rad : float
        Half-widths of the search window around the prediction [m], [rad].
    coarse_xy_step_m, coarse_yaw_step_rad : float
        Steps of the first, exhaustive level of the search [m], [rad]; each further level halves
        them around the best pose so far (3 x 3 x 3 candidates) until they reach the fine steps.
    fine_xy_step_m, fine_yaw_step_rad : float
        Steps of the last level [m], [rad] (slam_toolbox: 0.01 m, 0.00349 rad).
    match_sigma_m : float
        Standard deviation of the likelihood field's Gaussian [m]; a level with a coarser
        translation step uses that step instead, which widens its basin.
    prior_sigma_m, prior_sigma_rad : float
        Standard deviations of the Gaussian weight around the prediction [m], [rad].
    min_match_score : float
        Mean likelihood in [0, 1] a match needs to be accepted.
    min_match_points : int
        Returns a scan needs before it is matched at all.
    max_match_points : int
        Returns used by the search, evenly thinned out of the scan's (every return is still
        integrated into the map).
    """

    resolution_m: float = 0.05
    hit_log_odds: float = 0.55
    free_log_odds: float = -0.4
    min_log_odds: float = -2.0
    max_log_odds: float = 3.5
    max_range_m: float = 8.0
    no_return_free_m: float = 0.0
    trace_step_cells: float = 0.5
    grow_margin_m: float = 1.0
    min_travel_m: float = 0.05
    min_heading_rad: float = 0.05
    scan_matching: bool = True
    search_xy_m: float = 0.1
    search_yaw_rad: float = 0.1
    coarse_xy_step_m: float = 0.05
    coarse_yaw_step_rad: float = 0.05
    fine_xy_step_m: float = 0.005
    fine_yaw_step_rad: float = 0.0035
    match_sigma_m: float = 0.05
    prior_sigma_m: float = 0.5
    prior_sigma_rad: float = 1.0
    min_match_score: float = 0.5
    min_match_points: int = 30
    max_match_points: int = 540

    def __post_init__(self) -> None:
        positive = (
            "resolution_m",
            "hit_log_odds",
            "max_log_odds",
            "max_range_m",
            "trace_step_cells",
            "coarse_xy_step_m",
            "coarse_yaw_step_rad",
            "fine_xy_step_m",
            "fine_yaw_step_rad",
            "match_sigma_m",
            "prior_sigma_m",
            "prior_sigma_rad",
        )
        for name in positive:
            value = getattr(self, name)
            if not 0.0 < value < math.inf:
                raise ValueError(f"MappingConfig.{name}: expected a number > 0, got {value}")
        for name in ("free_log_odds", "min_log_odds"):
            value = getattr(self, name)
            if not -math.inf < value < 0.0:
                raise ValueError(f"MappingConfig.{name}: expected a number < 0, got {value}")
        nonnegative = (
            "no_return_free_m",
            "grow_margin_m",
            "min_travel_m",
            "min_heading_rad",
            "search_xy_m",
            "search_yaw_rad",
        )
        for name in nonnegative:
            value = getattr(self, name)
            if not 0.0 <= value < math.inf:
                raise ValueError(f"MappingConfig.{name}: expected a number >= 0, got {value}")
        if self.trace_step_cells > 1.0:
            raise ValueError(
                f"MappingConfig.trace_step_cells: expected at most 1 cell, "
                f"got {self.trace_step_cells}"
            )
        if not 0.0 <= self.min_match_score <= 1.0:
            raise ValueError(
                f"MappingConfig.min_match_score: expected 0..1, got {self.min_match_score}"
            )
        if self.min_match_points < 1:
            raise ValueError(
                f"MappingConfig.min_match_points: expected >= 1, got {self.min_match_points}"
            )
        if self.max_match_points < self.min_match_points:
            raise ValueError(
                f"MappingConfig.max_match_points: expected >= min_match_points "
                f"({self.min_match_points}), got {self.max_match_points}"
            )


class Mapper:
    """Builds an occupancy grid from scans and odometry, correcting the pose by scan matching.

    Parameters
    ----------
    config : MappingConfig
        Parameters.

    Attributes
    ----------
    config : MappingConfig
        Parameters.
    map_to_odom : Pose2D
        The correction ``corrected ⊕ odom_pose⁻¹`` from the last integrated scan; identity
        before the first, so the map frame is the odometry frame at the first scan.
    scans_integrated : int
        Scans written into the map.
    matches_accepted, matches_rejected : int
        Scan matches whose score reached ``min_match_score`` or did not (a scan with fewer
        than ``min_match_points`` returns counts as rejected).
    last_match_score : float
        Score of the last match, NaN before the first.
    """

    def __init__(self, config: MappingConfig = MappingConfig()) -> None:
        self.config = config
        self.map_to_odom = Pose2D()
        self.scans_integrated = 0
        self.matches_accepted = 0
        self.matches_rejected = 0
        self.last_match_score = math.nan
        self._log_odds = np.zeros((0, 0), np.float32)
        self._seen = np.zeros((0, 0), np.bool_)
        # per cell: the sums of the returns' x and y offsets from its lower-left corner [m] and
        # their count, so a cell's mean return places its obstacle below the cell size
        self._hits = np.zeros((3, 0, 0), np.float64)
        self._row0 = 0  # map-frame cell index of the grid's row 0 (origin_y = row0 * res)
        self._col0 = 0
        self._last_odom: Pose2D | None = None
        self._field: PointField | None = None
        self._field_window = (0, 0, 0, 0)

    # ------------------------------------------------------------------ public

    def update(self, scan: Scan, odom_pose: Pose2D, mount: Pose2D = ORIGIN) -> Pose2D:
        """Take one scan with the odometry pose of the base at its time.

        Parameters
        ----------
        scan : Scan
            The scan, in the sensor frame.
        odom_pose : Pose2D
            The base's pose in the odometry frame (wheel odometry or the EKF).
        mount : Pose2D
            The sensor's pose on the base.

        Returns
        -------
        Pose2D
            The base's map-frame pose: the scan-matched pose when the scan was integrated and
            its match accepted, else ``map_to_odom ⊕ odom_pose``.
        """
        predicted = self.map_to_odom.compose(odom_pose)
        last = self._last_odom
        if last is not None:
            turned = abs(math.remainder(odom_pose.yaw - last.yaw, math.tau))
            if (
                odom_pose.distance(last) < self.config.min_travel_m
                and turned < self.config.min_heading_rad
            ):
                return predicted
        corrected = predicted
        if last is not None and self.config.scan_matching:
            corrected = self._match(scan, mount, predicted)
        self.map_to_odom = corrected.compose(odom_pose.inverse())
        self._integrate(scan, corrected.compose(mount))
        self._last_odom = odom_pose
        self.scans_integrated += 1
        return corrected

    @property
    def resolution_m(self) -> float:
        """Cell edge [m]."""
        return self.config.resolution_m

    def grid(self) -> OccupancyGrid:
        """The map: occupancy 0-100 [%] from the log-odds, -1 where no beam has reached.

        Returns
        -------
        OccupancyGrid
            A copy; one unknown cell at the origin before the first scan.
        """
        res = self.config.resolution_m
        if self._log_odds.size == 0:
            return OccupancyGrid(np.full((1, 1), UNKNOWN, np.int8), res)
        p = 1.0 / (1.0 + np.exp(-self._log_odds.astype(np.float64)))
        data = np.rint(p * 100.0).astype(np.int8)
        data[~self._seen] = UNKNOWN
        return OccupancyGrid(data, res, self._col0 * res, self._row0 * res)

    def likelihood_field(self) -> LikelihoodField:
        """The cell-centred likelihood field of the current map (what a localiser would use)."""
        return LikelihoodField.from_grid(self.grid())

    def match_field(self, centre_xy: tuple[float, float] | None = None) -> PointField:
        """The field the scan matcher uses: the mean return of every cell with log-odds > 0.

        Parameters
        ----------
        centre_xy : tuple of float or None
            Build it only over the cells within ``max_range_m`` + ``search_xy_m`` + 1 m of
            this point [m] (the scan being matched there cannot reach farther), so that its
            cost stays that of an 18 m map however large the map grows; None for the whole
            map.

        Returns
        -------
        PointField
            Cached until the next integration or another window.
        """
        res = self.config.resolution_m
        rows_n, cols_n = self._log_odds.shape
        r0, r1, c0, c1 = 0, rows_n, 0, cols_n
        if centre_xy is not None:
            half = math.ceil((self.config.max_range_m + self.config.search_xy_m + 1.0) / res)
            rc = math.floor(centre_xy[1] / res) - self._row0
            cc = math.floor(centre_xy[0] / res) - self._col0
            r0, r1 = max(0, rc - half), min(rows_n, rc + half + 1)
            c0, c1 = max(0, cc - half), min(cols_n, cc + half + 1)
            if r0 >= r1 or c0 >= c1:
                r0, r1, c0, c1 = 0, rows_n, 0, cols_n
        window = (r0, r1, c0, c1)
        if self._field is None or self._field_window != window:
            sum_x, sum_y, n = (a[r0:r1, c0:c1] for a in self._hits)
            occupied = (self._log_odds[r0:r1, c0:c1] > 0.0) & (n > 0.0)
            inv_n = np.divide(1.0, n, out=np.zeros_like(n), where=occupied)
            rows, cols = np.indices(n.shape)
            x = (cols + self._col0 + c0) * res + sum_x * inv_n
            y = (rows + self._row0 + r0) * res + sum_y * inv_n
            self._field = PointField.from_cells(
                occupied, x, y, res, (self._col0 + c0) * res, (self._row0 + r0) * res
            )
            self._field_window = window
        return self._field

    # ------------------------------------------------------------------ scan matching

    def _match(self, scan: Scan, mount: Pose2D, predicted: Pose2D) -> Pose2D:
        """The accepted scan-matched pose, or ``predicted``; counts the outcome."""
        cfg = self.config
        r = scan.ranges_m
        ok = scan.valid & (r <= cfg.max_range_m)
        if np.count_nonzero(ok) < cfg.min_match_points:
            self.matches_rejected += 1
            return predicted
        idx = np.flatnonzero(ok)
        if idx.size > cfg.max_match_points:
            idx = idx[np.linspace(0, idx.size - 1, cfg.max_match_points).astype(np.intp)]
        a = scan.angles_rad[idx] + mount.yaw
        bx = mount.x + r[idx] * np.cos(a)
        by = mount.y + r[idx] * np.sin(a)
        field = self.match_field((predicted.x, predicted.y))
        pose, score = self._search(field, bx, by, predicted)
        self.last_match_score = score
        if score >= cfg.min_match_score:
            self.matches_accepted += 1
            return pose
        self.matches_rejected += 1
        return predicted

    def _search(
        self, field: PointField, bx: FloatArray, by: FloatArray, predicted: Pose2D
    ) -> tuple[Pose2D, float]:
        """Coarse-to-fine correlative search of the base pose; returns it and its score.

        ``bx, by`` are the returns in the base frame. Level 0 scores every pose of the window
        at the coarse steps; each further level halves the steps and scores the 3 x 3 x 3 poses
        around the best so far, itself included (rescored: the Gaussian narrows with the step).
        """
        cfg = self.config
        step_xy, step_yaw = cfg.coarse_xy_step_m, cfg.coarse_yaw_step_rad
        nxy = round(cfg.search_xy_m / step_xy)
        nyaw = round(cfg.search_yaw_rad / step_yaw)
        dx: FloatArray = np.arange(-nxy, nxy + 1, dtype=np.float64) * step_xy
        dyaw: FloatArray = np.arange(-nyaw, nyaw + 1, dtype=np.float64) * step_yaw
        best = (0.0, 0.0, 0.0)
        while True:
            sigma = max(cfg.match_sigma_m, step_xy)
            ox, oy, oyaw = best
            weighted, raw = self._score(
                field, bx, by, predicted, ox + dx, oy + dx, oyaw + dyaw, sigma
            )
            k = int(np.argmax(weighted))
            iyaw, ix, iy = np.unravel_index(k, weighted.shape)
            best = (ox + float(dx[ix]), oy + float(dx[iy]), oyaw + float(dyaw[iyaw]))
            score = float(raw.flat[k])
            if step_xy <= cfg.fine_xy_step_m and step_yaw <= cfg.fine_yaw_step_rad:
                break
            step_xy = max(step_xy / 2.0, cfg.fine_xy_step_m)
            step_yaw = max(step_yaw / 2.0, cfg.fine_yaw_step_rad)
            dx = np.array((-step_xy, 0.0, step_xy))
            dyaw = np.array((-step_yaw, 0.0, step_yaw))
        yaw = math.remainder(predicted.yaw + best[2], math.tau)
        pose = Pose2D(predicted.x + best[0], predicted.y + best[1], yaw)
        return pose, score

    def _score(
        self,
        field: PointField,
        bx: FloatArray,
        by: FloatArray,
        predicted: Pose2D,
        ox: FloatArray,
        oy: FloatArray,
        oyaw: FloatArray,
        sigma_m: float,
    ) -> tuple[FloatArray, FloatArray]:
        """Scores of the poses ``predicted + (ox[i], oy[j], oyaw[k])``, shape (yaw, x, y).

        Returns the prior-weighted and the raw mean likelihoods.
        """
        cfg = self.config
        yaw = predicted.yaw + oyaw
        c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        rx = c * bx - s * by  # (yaw, N)
        ry = s * bx + c * by
        x = rx[:, None, None, :] + (predicted.x + ox)[None, :, None, None]
        y = ry[:, None, None, :] + (predicted.y + oy)[None, None, :, None]
        d = field.distance_xy(x, y)
        d *= d
        d *= -0.5 / (sigma_m * sigma_m)
        raw: FloatArray = np.exp(d, out=d).mean(axis=-1)
        prior = ((ox * ox)[None, :, None] + (oy * oy)[None, None, :]) / cfg.prior_sigma_m**2 + (
            oyaw * oyaw
        )[:, None, None] / cfg.prior_sigma_rad**2
        weighted: FloatArray = raw * np.exp(-0.5 * prior)
        return weighted, raw

    # ------------------------------------------------------------------ integration

    def _integrate(self, scan: Scan, sensor: Pose2D) -> None:
        """Write one scan taken from the map-frame sensor pose into the log-odds grid."""
        cfg = self.config
        res = cfg.resolution_m
        r = scan.ranges_m.astype(np.float64)
        with np.errstate(invalid="ignore"):
            returned = scan.valid
            hit = returned & (r <= cfg.max_range_m)
            free_m = np.where(hit, r, 0.0)
            free_m[returned & ~hit] = cfg.max_range_m
            if cfg.no_return_free_m > 0.0:
                none = np.isposinf(r) | (np.isfinite(r) & (r > scan.range_max_m))
                free_m[none] = min(cfg.no_return_free_m, cfg.max_range_m)
        a = scan.angles_rad + sensor.yaw
        cos_a, sin_a = np.cos(a), np.sin(a)
        inv = 1.0 / res

        # cells of the returns, in map-frame cell indices
        hit_x = sensor.x + r[hit] * cos_a[hit]
        hit_y = sensor.y + r[hit] * sin_a[hit]
        hit_col = np.floor(hit_x * inv).astype(np.intp)
        hit_row = np.floor(hit_y * inv).astype(np.intp)

        # points along every beam at trace_step, ragged: beam b contributes n[b] of them
        step = cfg.trace_step_cells * res
        n = np.ceil(free_m / step).astype(np.intp)
        beam = np.repeat(np.arange(n.size), n)
        k = np.arange(beam.size) - np.repeat(np.cumsum(n) - n, n)
        t = k * step
        free_col = np.floor((sensor.x + t * cos_a[beam]) * inv).astype(np.intp)
        free_row = np.floor((sensor.y + t * sin_a[beam]) * inv).astype(np.intp)

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
        hits2, passes2 = hits.reshape(h, w), passes.reshape(h, w)
        window = self._log_odds[r0 : r0 + h, c0 : c0 + w]
        window[hits2] += np.float32(cfg.hit_log_odds)
        window[passes2] += np.float32(cfg.free_log_odds)
        np.clip(window, cfg.min_log_odds, cfg.max_log_odds, out=window)
        self._seen[r0 : r0 + h, c0 : c0 + w] |= hits2 | passes2
        sums = self._hits[:, r0 : r0 + h, c0 : c0 + w]
        sums[0] += np.bincount(hit_k, hit_x - hit_col * res, h * w).reshape(h, w)
        sums[1] += np.bincount(hit_k, hit_y - hit_row * res, h * w).reshape(h, w)
        sums[2] += np.bincount(hit_k, None, h * w).reshape(h, w)
        self._field = None

    def _cover(self, lo_row: int, hi_row: int, lo_col: int, hi_col: int) -> None:
        """Grow the grid (by ``grow_margin_m`` beyond the request) to hold these cells."""
        rows, cols = self._log_odds.shape
        if (
            rows > 0
            and lo_row >= self._row0
            and hi_row < self._row0 + rows
            and lo_col >= self._col0
            and hi_col < self._col0 + cols
        ):
            return
        m = math.ceil(self.config.grow_margin_m / self.config.resolution_m)
        if rows == 0:
            new_r0, new_c0 = lo_row - m, lo_col - m
            new_r1, new_c1 = hi_row + m + 1, hi_col + m + 1
        else:
            r1, c1 = self._row0 + rows, self._col0 + cols
            new_r0 = self._row0 if lo_row >= self._row0 else lo_row - m
            new_c0 = self._col0 if lo_col >= self._col0 else lo_col - m
            new_r1 = r1 if hi_row < r1 else hi_row + m + 1
            new_c1 = c1 if hi_col < c1 else hi_col + m + 1
        log_odds = np.zeros((new_r1 - new_r0, new_c1 - new_c0), np.float32)
        seen = np.zeros(log_odds.shape, np.bool_)
        hits = np.zeros((3, *log_odds.shape), np.float64)
        if rows > 0:
            dr, dc = self._row0 - new_r0, self._col0 - new_c0
            log_odds[dr : dr + rows, dc : dc + cols] = self._log_odds
            seen[dr : dr + rows, dc : dc + cols] = self._seen
            hits[:, dr : dr + rows, dc : dc + cols] = self._hits
        self._log_odds, self._seen, self._hits = log_odds, seen, hits
        self._row0, self._col0 = new_r0, new_c0


def _span(start: int, a: IntArray, b: IntArray) -> tuple[int, int]:
    """Smallest and largest of ``start`` and the elements of ``a`` and ``b``."""
    lo = hi = start
    for v in (a, b):
        if v.size:
            lo, hi = min(lo, int(v.min())), max(hi, int(v.max()))
    return lo, hi
