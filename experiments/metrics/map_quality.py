"""A built map judged against the true geometry of the world it was made in.

Four figures, each answering a question a user of the map asks:

- **Wall coverage**: is every wall the survey's scans hit in the map? Every true wall segment
  (and every cylinder's outline) is sampled every :data:`SAMPLE_STEP_M`. A sample counts as
  *seen* when one of the survey's beams, cast exactly at the true pose of each revolution
  (the sensor's own beam angles, its mount), ends on it within ``max_range_m`` (the sample
  nearest the beam's end, within one sample step). Given LiDAR positions only, a sample is
  seen when one of them lies within ``max_range_m`` of it with a clear line of sight (no
  other wall or cylinder in between, tested exactly against the segments and circles): that
  counts faces no beam returns from, such as one seen only edge-on. A seen sample is
  *covered* when an occupied map cell (value at least
  :data:`OCCUPIED_VALUE`, map_server's ``occupied_thresh`` 0.65) has its centre within
  ``tol_m`` of it. A segment's coverage is the fraction of its seen samples that are covered;
  segments seen over less than :data:`MIN_SEEN_SAMPLES` samples are not judged.
- **Precision**: is what the map calls occupied really there? The fraction of occupied map
  cells whose centre lies within ``tol_m`` of an occupied cell of the world's own raster
  (:func:`jackson.sim.raster.raster` on the map's grid, cell-centre distances by a Euclidean
  distance transform). At 5 cm cells and 7.5 cm, a cell next to the wall's own cell passes
  (5 cm, or 7.1 cm diagonally), one two cells off does not.
- **SSIM** (Eq. 15) of the map against the raster, only the free space connected to the start
  counting as free in the truth, as ``jackson map`` reports it
  (:func:`jackson.experiments.metrics.maps.map_ssim`).
- **Misplacement**: how far off is the worst of it? The 99th percentile and the maximum of
  the same cell-centre distances.

The map frame is the world frame (the survey's mapper starts at the world's start pose).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.spatial import cKDTree

from jackson.experiments.metrics.inputs import MetricInputError
from jackson.experiments.metrics.maps import map_ssim

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from jackson.host.nav.grid import OccupancyGrid
    from jackson.sim.config import WorldSpec

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int_]

OCCUPIED_VALUE = 65  # [%] map_server's occupied_thresh 0.65: a cell at or above is occupied
TOL_M = 0.075  # [m] how far an occupied cell may lie from a true wall and still count
SAMPLE_STEP_M = 0.025  # [m] spacing of the samples along a wall or a cylinder's outline
POSE_STEP_M = 0.05  # [m] survey positions closer than this to the last one kept add nothing
MIN_SEEN_SAMPLES = 4  # a segment seen over fewer samples (10 cm) is not judged
COVERED = 0.9  # a segment at least this covered counts as mapped
_LOS_EPS_M = 1e-6  # [m] an obstacle this close to the sample's end of a sight line is its own


@dataclass(frozen=True, eq=False)
class WallSamples:
    """The samples along the true walls and cylinder outlines, and what became of each.

    Attributes
    ----------
    xy : ndarray, shape (S, 2)
        World-frame positions [m].
    segment : ndarray of int, shape (S,)
        The segment each belongs to: walls first (``world.walls`` order), then cylinders.
    seen : ndarray of bool, shape (S,)
        In range and in sight of some survey position.
    covered : ndarray of bool, shape (S,)
        An occupied map cell's centre within ``tol_m``.
    """

    xy: FloatArray
    segment: IntArray
    seen: BoolArray
    covered: BoolArray


@dataclass(frozen=True)
class SegmentCoverage:
    """One true wall or cylinder outline: how much of it the survey saw and the map holds.

    Attributes
    ----------
    index : int
        Walls first in ``world.walls`` order, then cylinders in ``world.cylinders`` order.
    name : str
        ``wall 3 (x1, y1)-(x2, y2)`` or ``cylinder 0 (x, y)``.
    seen_m : float
        Length seen [m].
    coverage : float
        Covered fraction of the seen samples; nan when fewer than
        :data:`MIN_SEEN_SAMPLES` were seen (not judged).
    """

    index: int
    name: str
    seen_m: float
    coverage: float


@dataclass(frozen=True, eq=False)
class MapQuality:
    """A map's figures against the world (module docstring).

    Attributes
    ----------
    segments : tuple of SegmentCoverage
        Every wall and cylinder, judged or not.
    covered_fraction : float
        Fraction of the judged segments at least :data:`COVERED` covered (nan: none judged).
    worst : SegmentCoverage or None
        The judged segment of least coverage.
    sample_coverage : float
        Covered fraction of all seen samples.
    precision : float
        Fraction of occupied cells within ``tol_m`` of a true obstacle (nan: none occupied).
    ssim : float
        SSIM of the map against the world's raster (Eq. 15).
    misplacement_p99_m, misplacement_max_m : float
        99th percentile and maximum distance of occupied cells from a true obstacle [m].
    occupied_cells : int
        Cells at or above :data:`OCCUPIED_VALUE`.
    tol_m, max_range_m : float
        The tolerance and range judged with [m].
    samples : WallSamples
        Per sample, for a figure.
    stray_xy : ndarray, shape (K, 2)
        Centres of the occupied cells farther than ``tol_m`` from any true obstacle [m].
    """

    segments: tuple[SegmentCoverage, ...]
    covered_fraction: float
    worst: SegmentCoverage | None
    sample_coverage: float
    precision: float
    ssim: float
    misplacement_p99_m: float
    misplacement_max_m: float
    occupied_cells: int
    tol_m: float
    max_range_m: float
    samples: WallSamples
    stray_xy: FloatArray

    @property
    def judged(self) -> tuple[SegmentCoverage, ...]:
        """The segments seen enough to be judged."""
        return tuple(s for s in self.segments if not math.isnan(s.coverage))

    def summary(self) -> dict[str, float | int | str]:
        """The headline figures, for a table or metrics.json."""
        return {
            "segments_judged": len(self.judged),
            "segments_covered_fraction": self.covered_fraction,
            "worst_segment": self.worst.name if self.worst is not None else "",
            "worst_segment_coverage": self.worst.coverage if self.worst is not None else math.nan,
            "sample_coverage": self.sample_coverage,
            "precision": self.precision,
            "ssim": self.ssim,
            "misplacement_p99_m": self.misplacement_p99_m,
            "misplacement_max_m": self.misplacement_max_m,
            "occupied_cells": self.occupied_cells,
        }


def judge_map(
    grid: OccupancyGrid,
    world: WorldSpec,
    poses_xy: npt.ArrayLike,
    max_range_m: float,
    tol_m: float = TOL_M,
    beam_angles_rad: npt.ArrayLike | None = None,
) -> MapQuality:
    """Judge ``grid`` against ``world``'s true walls and cylinders (module docstring).

    Parameters
    ----------
    grid : OccupancyGrid
        The built map, in the world frame.
    world : WorldSpec
        The world it was built in (its triggered cylinders are not judged).
    poses_xy : array_like, shape (N, 2) or (N, 3)
        Where the LiDAR was during the survey, from the ground truth [m]; with
        ``beam_angles_rad``, its pose (x, y [m], heading [rad]) at each revolution.
    max_range_m : float
        Range within which the mapper takes a return [m].
    tol_m : float
        Distance within which an occupied cell counts as on a wall [m].
    beam_angles_rad : array_like, optional
        The sensor's beam angles in its own frame [rad]: a sample is seen when a beam cast
        from one of the poses ends on it (module docstring); without them, when a position
        has it in sight.

    Returns
    -------
    MapQuality

    Raises
    ------
    MetricInputError
        No poses, a range or tolerance that is not > 0, a world without walls or cylinders.
    """
    poses = np.asarray(poses_xy, np.float64)
    width = 2 if beam_angles_rad is None else 3
    if poses.ndim != 2 or poses.shape[1] != width or len(poses) == 0:
        raise MetricInputError(
            f"poses_xy: expected an (N, {width}) array, N >= 1, got {poses.shape}"
        )
    if not (0.0 < max_range_m < math.inf and 0.0 < tol_m < math.inf):
        raise MetricInputError(f"max_range_m, tol_m: expected > 0, got {max_range_m}, {tol_m}")
    walls = np.asarray(world.walls, np.float64).reshape(-1, 4)
    circles = np.asarray([(c.x, c.y, c.radius) for c in world.cylinders], np.float64)
    circles = circles.reshape(-1, 3)
    if len(walls) + len(circles) == 0:
        raise MetricInputError(f"world {world.name}: no walls or cylinders to judge a map by")
    xy, segment = _samples(walls, circles)
    if beam_angles_rad is None:
        seen = _seen(xy, _thin(poses), walls, circles, max_range_m)
    else:
        seen = _hit(xy, poses, np.asarray(beam_angles_rad, np.float64), walls, circles, max_range_m)
    occupied = grid.data >= OCCUPIED_VALUE
    rows, cols = np.nonzero(occupied)
    cx, cy = grid.cell_to_world(rows, cols)
    centres = np.column_stack((cx, cy))
    covered = np.zeros(len(xy), np.bool_)
    if len(centres):
        d, _ = cKDTree(centres).query(xy, distance_upper_bound=tol_m * (1 + 1e-9))
        covered = np.isfinite(d)
    samples = WallSamples(xy, segment, seen, covered)
    segments = _segments(world, samples)
    judged = [s for s in segments if not math.isnan(s.coverage)]
    truth, distance_m = _truth(grid, world)
    d_occ = distance_m[occupied]
    near = d_occ <= tol_m + 1e-9
    return MapQuality(
        segments=segments,
        covered_fraction=float(np.mean([s.coverage >= COVERED for s in judged]))
        if judged
        else math.nan,
        worst=min(judged, key=lambda s: s.coverage) if judged else None,
        sample_coverage=float(covered[seen].mean()) if seen.any() else math.nan,
        precision=float(near.mean()) if len(d_occ) else math.nan,
        ssim=map_ssim(grid.data, truth),
        misplacement_p99_m=float(np.percentile(d_occ, 99)) if len(d_occ) else math.nan,
        misplacement_max_m=float(d_occ.max()) if len(d_occ) else math.nan,
        occupied_cells=len(d_occ),
        tol_m=tol_m,
        max_range_m=max_range_m,
        samples=samples,
        stray_xy=centres[~near],
    )


def judge_run(
    folder: str | Path,
    world: WorldSpec | None = None,
    max_range_m: float | None = None,
    map_yaml: str | Path | None = None,
) -> MapQuality:
    """Judge the map a mapping run wrote (``jackson map --out FOLDER``).

    Reads ``built_map.yaml`` (+ PGM), the true path ``ground_truth.csv`` and, from
    ``meta.json``, the world and robot the run used. The samples seen are those the A1M8's
    1080 beams hit, cast from the true pose at every revolution's end (one scan period
    apart) moved by the robot's LiDAR mount.

    Parameters
    ----------
    folder : str or Path
        The run folder.
    world : WorldSpec, optional
        The world to judge against; default the one named in ``meta.json``.
    max_range_m : float, optional
        The mapper's range; default :class:`jackson.host.nav.slam.mapper.MappingConfig`'s.
    map_yaml : str or Path, optional
        The map to judge; default the run's own ``built_map.yaml`` (another: the run mapped
        again from its recording, ``jackson map --from FOLDER``).

    Returns
    -------
    MapQuality

    Raises
    ------
    MetricInputError
        A missing or unreadable file, naming it.
    """
    from jackson.host.nav.grid import OccupancyGrid
    from jackson.host.nav.slam.mapper import MappingConfig
    from jackson.sim.config import load_robot, load_world
    from jackson.sim.lidar import LidarSpec

    run = Path(folder)
    needed = ("ground_truth.csv", "meta.json") + (() if map_yaml else ("built_map.yaml",))
    for name in needed:
        if not (run / name).is_file():
            raise MetricInputError(f"{run}: no {name}; is this the folder of a mapping run?")
    map_path = Path(map_yaml) if map_yaml else run / "built_map.yaml"
    if not map_path.is_file():
        raise MetricInputError(f"{map_path}: no such map")
    meta = json.loads((run / "meta.json").read_text())
    if world is None:
        world = load_world(meta["world"])
    mount = load_robot(meta.get("robot", "jackson_physical")).lidar
    spec = LidarSpec()
    t, x, y, yaw = truth_path(run / "ground_truth.csv")
    # the true pose at each revolution's end, one scan period apart
    at = np.arange(t[0] + spec.scan_period_s, t[-1] + 1e-9, spec.scan_period_s)
    x, y = np.interp(at, t, x), np.interp(at, t, y)
    yaw = np.interp(at, t, np.unwrap(yaw))
    c, s = np.cos(yaw), np.sin(yaw)
    lidar = np.column_stack(
        (
            x + c * mount.mount_x_m - s * mount.mount_y_m,
            y + s * mount.mount_x_m + c * mount.mount_y_m,
            yaw + mount.mount_yaw_rad,
        )
    )
    angles = spec.angle_min_rad + spec.angle_increment_rad * np.arange(spec.beams)
    grid = OccupancyGrid.load(map_path)
    rng = MappingConfig().max_range_m if max_range_m is None else max_range_m
    return judge_map(grid, world, lidar, rng, beam_angles_rad=angles)


# ------------------------------------------------------------------------------ the pieces


def truth_path(path: Path) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """t [s], x, y [m] and yaw [rad] of the true path in a run's ``ground_truth.csv``.

    Raises
    ------
    MetricInputError
        The file is missing or unreadable, has no rows or lacks one of those columns.
    """
    columns = ("t_s", "x_m", "y_m", "yaw_rad")
    try:
        with path.open() as f:
            header = f.readline().strip().split(",")
            data = np.loadtxt(f, delimiter=",", ndmin=2).reshape(-1, len(header))
    except (OSError, ValueError) as exc:
        raise MetricInputError(f"{path}: not a ground truth ({exc})") from exc
    missing = [k for k in columns if k not in header]
    if missing or len(data) == 0:
        raise MetricInputError(f"{path}: no rows or no column {', '.join(missing)}")
    t, x, y, yaw = (data[:, header.index(k)] for k in columns)
    return t, x, y, yaw


def _samples(walls: FloatArray, circles: FloatArray) -> tuple[FloatArray, IntArray]:
    """Points every :data:`SAMPLE_STEP_M` along each wall (the midpoints of equal pieces, so
    none sits on a junction) and each cylinder's outline, and their segment's index."""
    pts: list[FloatArray] = []
    idx: list[IntArray] = []
    for k, (x1, y1, x2, y2) in enumerate(walls):
        n = max(1, math.ceil(math.hypot(x2 - x1, y2 - y1) / SAMPLE_STEP_M))
        t = (np.arange(n) + 0.5) / n
        pts.append(np.column_stack((x1 + t * (x2 - x1), y1 + t * (y2 - y1))))
        idx.append(np.full(n, k))
    for k, (cx, cy, r) in enumerate(circles, len(walls)):
        n = max(8, math.ceil(2 * math.pi * r / SAMPLE_STEP_M))
        a = 2 * math.pi * (np.arange(n) + 0.5) / n
        pts.append(np.column_stack((cx + r * np.cos(a), cy + r * np.sin(a))))
        idx.append(np.full(n, k))
    return np.concatenate(pts), np.concatenate(idx)


def _thin(poses: FloatArray) -> FloatArray:
    """The poses with each closer than :data:`POSE_STEP_M` to the last one kept dropped."""
    keep = [0]
    for k in range(1, len(poses)):
        if np.hypot(*(poses[k] - poses[keep[-1]])) >= POSE_STEP_M:
            keep.append(k)
    return poses[keep]


def _seen(
    xy: FloatArray, poses: FloatArray, walls: FloatArray, circles: FloatArray, max_range_m: float
) -> BoolArray:
    """Which samples some pose has within range and in sight; a pose tests only the samples
    no earlier pose saw, so the work shrinks as the survey proceeds."""
    seen = np.zeros(len(xy), np.bool_)
    for p in poses:
        todo = np.flatnonzero(~seen)
        if len(todo) == 0:
            break
        d = xy[todo] - p
        todo = todo[np.einsum("ij,ij->i", d, d) <= max_range_m**2]
        if len(todo):
            seen[todo[_clear(p, xy[todo], walls, circles)]] = True
    return seen


def _hit(
    xy: FloatArray,
    poses: FloatArray,
    angles: FloatArray,
    walls: FloatArray,
    circles: FloatArray,
    max_range_m: float,
) -> BoolArray:
    """Which samples a beam cast from one of the sensor ``poses`` (x, y, heading) at the
    sensor-frame ``angles`` ends on within range (the sample nearest its end, within one
    sample step): the twin's exact cast, without noise."""
    from jackson.sim.lidar import Obstacles, cast

    obstacles = Obstacles(walls, circles)
    tree = cKDTree(xy)
    hit = np.zeros(len(xy), np.bool_)
    for x, y, heading in poses:
        a = angles + heading
        r = cast((x, y), a, obstacles, max_range_m)
        ok = np.isfinite(r)
        if ok.any():
            ends = np.column_stack((x + r[ok] * np.cos(a[ok]), y + r[ok] * np.sin(a[ok])))
            d, i = tree.query(ends, distance_upper_bound=SAMPLE_STEP_M)
            hit[i[np.isfinite(d)]] = True
    return hit


def _clear(p: FloatArray, q: FloatArray, walls: FloatArray, circles: FloatArray) -> BoolArray:
    """Whether the sight line from ``p`` to each of ``q`` (M, 2) passes no wall or cylinder
    before its end (an obstacle within :data:`_LOS_EPS_M` of the end is the sample's own)."""
    d = q - p  # (M, 2)
    length = np.hypot(d[:, 0], d[:, 1])
    t_end = 1.0 - _LOS_EPS_M / np.maximum(length, _LOS_EPS_M)  # (M,)
    blocked = np.zeros(len(q), np.bool_)
    if len(walls):
        a, e = walls[:, :2], walls[:, 2:] - walls[:, :2]  # (W, 2)
        w = a - p
        den = d[:, :1] * e[:, 1] - d[:, 1:] * e[:, 0]  # (M, W)
        ok = np.abs(den) > 1e-12
        den = np.where(ok, den, 1.0)
        t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den  # along the sight line
        u = (w[:, 0] * d[:, 1:] - w[:, 1] * d[:, :1]) / den  # along the wall
        hit = ok & (t > 0.0) & (t < t_end[:, None]) & (u >= 0.0) & (u <= 1.0)
        blocked |= hit.any(axis=1)
    if len(circles):
        f = p - circles[:, :2]  # (C, 2)
        aa = np.maximum(length**2, 1e-24)[:, None]  # (M, 1)
        bb = 2.0 * (d[:, :1] * f[:, 0] + d[:, 1:] * f[:, 1])  # (M, C)
        cc = np.einsum("ij,ij->i", f, f) - circles[:, 2] ** 2  # (C,)
        disc = bb**2 - 4.0 * aa * cc
        root = np.sqrt(np.maximum(disc, 0.0))
        t_in = (-bb - root) / (2.0 * aa)  # where the line enters the disc
        t_out = (-bb + root) / (2.0 * aa)
        inside = (disc > 0.0) & (t_in < t_end[:, None]) & (t_out > 0.0)
        blocked |= inside.any(axis=1)
    return ~blocked


def _segments(world: WorldSpec, s: WallSamples) -> tuple[SegmentCoverage, ...]:
    """Per wall and cylinder: the length seen and the covered fraction of it."""
    n = len(world.walls) + len(world.cylinders)
    seen_n = np.bincount(s.segment, weights=s.seen, minlength=n)
    both_n = np.bincount(s.segment, weights=s.seen & s.covered, minlength=n)
    all_n = np.bincount(s.segment, minlength=n)
    names = [
        f"wall {k} ({x1:g}, {y1:g})-({x2:g}, {y2:g})"
        for k, (x1, y1, x2, y2) in enumerate(world.walls)
    ] + [f"cylinder {k} ({c.x:g}, {c.y:g})" for k, c in enumerate(world.cylinders)]
    lengths = [math.hypot(x2 - x1, y2 - y1) for x1, y1, x2, y2 in world.walls] + [
        2 * math.pi * c.radius for c in world.cylinders
    ]
    return tuple(
        SegmentCoverage(
            k,
            names[k],
            float(lengths[k] * seen_n[k] / all_n[k]),
            float(both_n[k] / seen_n[k]) if seen_n[k] >= MIN_SEEN_SAMPLES else math.nan,
        )
        for k in range(n)
    )


def _truth(grid: OccupancyGrid, world: WorldSpec) -> tuple[npt.NDArray[np.int8], FloatArray]:
    """The world on the map's cells: the truth image for SSIM (occupied, the free space
    connected to the start, the rest unknown) and each cell's distance to the nearest truly
    occupied cell centre [m]. The raster reaches past the map by the world's extent, so a
    wall just off the map's edge still counts."""
    from jackson.sim.raster import raster, reachable_free

    res = grid.resolution_m
    origin = np.array([grid.origin_x_m, grid.origin_y_m])
    ends = [(w[0], w[1]) for w in world.walls] + [(w[2], w[3]) for w in world.walls]
    ends += [(c.x + k * c.radius, c.y + k * c.radius) for c in world.cylinders for k in (-1, 1)]
    pts = np.asarray(ends, np.float64).reshape(-1, 2)
    lo = np.minimum(np.floor((pts.min(axis=0) - origin) / res) - 2, 0).astype(int)  # [cells]
    hi = np.maximum(np.ceil((pts.max(axis=0) - origin) / res) + 2, (grid.width, grid.height))
    x0, y0 = origin + lo * res
    x1, y1 = origin + hi * res
    occ, ox, oy = raster(world, res, bounds=(x0, y0, x1, y1))
    distance = ndimage.distance_transform_edt(~occ) * res if occ.any() else np.inf + occ
    free = reachable_free(occ, ox, oy, res, world.start_pose[:2])
    window = (slice(-lo[1], -lo[1] + grid.height), slice(-lo[0], -lo[0] + grid.width))
    truth = np.full(occ.shape, -1, np.int8)
    truth[free] = 0
    truth[occ] = 100
    return truth[window], np.asarray(distance, np.float64)[window]


# ------------------------------------------------------------------------------ the figure


def draw_map(ax: Axes, grid: OccupancyGrid) -> None:
    """The map on ``ax`` in world coordinates: free white, occupied dark grey, unknown light
    grey (cells as squares)."""
    image = np.full(grid.data.shape, 0.75)
    image[(grid.data >= 0) & (grid.data < OCCUPIED_VALUE)] = 1.0
    image[grid.data >= OCCUPIED_VALUE] = 0.25
    x1 = grid.origin_x_m + grid.width * grid.resolution_m
    y1 = grid.origin_y_m + grid.height * grid.resolution_m
    ax.imshow(
        image,
        origin="lower",
        cmap="gray",
        vmin=0.0,
        vmax=1.0,
        extent=(grid.origin_x_m, x1, grid.origin_y_m, y1),
        interpolation="nearest",
    )
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")


def draw_quality(ax: Axes, quality: MapQuality, scale: float = 1.0) -> None:
    """The judgement over a map drawn by :func:`draw_map`: the true walls' samples green where
    covered, red where seen but missed, faint grey where never seen; occupied cells farther
    than the tolerance from any true obstacle in magenta. ``scale`` multiplies the markers'
    areas (smaller for a large floor)."""
    s = quality.samples
    layers = (
        (s.xy[~s.seen], 0.6, "0.55", "o", "wall not in view"),
        (s.xy[s.seen & s.covered], 2.0, "tab:green", "o", "wall covered"),
        (s.xy[s.seen & ~s.covered], 4.0, "red", "o", "wall missed"),
        (quality.stray_xy, 4.0, "magenta", "s", f"occupied > {quality.tol_m * 100:g} cm off"),
    )
    for xy, size, colour, marker, label in layers:
        if len(xy):
            ax.scatter(
                xy[:, 0], xy[:, 1], s=size * scale, c=colour, marker=marker, lw=0, label=label
            )


def quality_text(quality: MapQuality) -> str:
    """The figures of ``quality`` in two lines, for a title."""
    worst = quality.worst
    return (
        f"{quality.covered_fraction:.0%} of {len(quality.judged)} segments in view "
        f"≥ {COVERED:.0%} covered (worst {worst.coverage if worst else math.nan:.0%}), "
        f"precision {quality.precision:.1%}, SSIM {quality.ssim:.3f},\n"
        f"misplacement p99 {quality.misplacement_p99_m * 100:.1f} cm, "
        f"max {quality.misplacement_max_m * 100:.1f} cm"
    )


def plot_map_quality(
    path: str | Path,
    grid: OccupancyGrid,
    world: WorldSpec,
    quality: MapQuality,
    poses_xy: npt.ArrayLike | None = None,
) -> Path:
    """A PNG (and PDF beside it) of the map with the true walls drawn over it: green where
    covered, red where seen but missed, faint grey where never seen; occupied cells farther
    than the tolerance from any true obstacle in magenta; the survey's path if given.

    Parameters
    ----------
    path : str or Path
        The PNG to write.
    grid : OccupancyGrid
        The map judged.
    world : WorldSpec
        The world (its name titles the figure).
    quality : MapQuality
        The judgement of ``grid`` (:func:`judge_map`).
    poses_xy : array_like, shape (N, 2), optional
        The LiDAR's path [m].

    Returns
    -------
    Path
        The PNG.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jackson.common.figures import save_figure

    png = Path(path)
    width_in = 9.0
    aspect = grid.height / max(grid.width, 1)
    fig, ax = plt.subplots(figsize=(width_in, min(14.0, width_in * aspect + 1.2)))
    draw_map(ax, grid)
    draw_quality(ax, quality)
    if poses_xy is not None:
        p = np.asarray(poses_xy, np.float64)
        ax.plot(p[:, 0], p[:, 1], c="tab:blue", lw=0.6, alpha=0.7, label="LiDAR path")
    ax.set_title(f"{world.name}: {quality_text(quality)}", fontsize=9)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, markerscale=3)
    save_figure(fig, png, bbox_inches="tight")
    return png
