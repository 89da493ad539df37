"""2-D LiDAR model of the RPLIDAR A1M8: an exact, vectorised ray caster plus the sensor's noise.

The robot carries an RPLIDAR A1M8 on USB: one turn every 0.13465 s (7.43 Hz), 1080 beams at an
angular increment of 0.005807 rad, range 0.15-12 m, range noise sigma 0.010 m. A scan follows the
ROS ``sensor_msgs/LaserScan`` conventions: beam ``i`` points at ``angle_min + i * angle_increment``
in the sensor frame (x forward, angles counter-clockwise positive, REP-103), and a beam with no
return inside ``[range_min, range_max]`` reads ``+inf``.

Geometry is static and held as numpy arrays (:class:`Obstacles`): walls and boxes as radius-0
segments, cylinders as circles. :func:`cast` gives the exact nearest-hit distance along many rays
at once; :class:`Lidar` turns a robot pose into the rays of one scan and adds the sensor's faults.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jackson.common.robot import LIDAR_RANGE_NOISE_M
from jackson.protocol.rplidar import A1M8_SCAN_PERIOD_S

__all__ = ["Lidar", "LidarSpec", "Obstacles", "cast"]

A1M8_BEAMS = 1080
A1M8_ANGLE_INCREMENT_RAD = 0.005807
A1M8_RANGE_MIN_M = 0.15
A1M8_RANGE_MAX_M = 12.0  # the robot's navigation stack caps it at 8 m in software
A1M8_NOISE_SIGMA_M = LIDAR_RANGE_NOISE_M

COLLINEAR_TOLERANCE_M = 1e-12
"""A point of a degenerate segment counts as on a ray when it is this close to it [m]."""


@dataclass(frozen=True)
class LidarSpec:
    """What the sensor is and where it sits on the robot.

    Attributes
    ----------
    beams : int
        Beams per scan (``len(LaserScan.ranges)``).
    angle_increment_rad : float
        Angle between neighbouring beams [rad].
    angle_min_rad : float
        Angle of the first beam in the sensor frame [rad], x forward,
        counter-clockwise positive.
    range_min_m : float
        Readings below this are reported as ``inf`` [m].
    range_max_m : float
        Readings above this are reported as ``inf`` [m]; also the casting limit.
    scan_period_s : float
        Time of one turn [s] (``LaserScan.scan_time``).
    noise_sigma_m : float
        Standard deviation of the Gaussian range noise [m].
    extra_noise_sigma_m : float
        Further independent Gaussian range noise [m], for degraded-sensor
        runs (the paper's G04 adds 0.03 m); the two add in variance.
    dropout_probability : float
        Probability that a beam returns nothing and reads ``inf``.
    mount_x_m : float
        Sensor origin along the robot base x axis [m].
    mount_y_m : float
        Sensor origin along the robot base y axis [m].
    mount_yaw_rad : float
        Sensor x axis relative to the robot base x axis [rad].
    """

    beams: int = A1M8_BEAMS
    angle_increment_rad: float = A1M8_ANGLE_INCREMENT_RAD
    angle_min_rad: float = -math.pi
    range_min_m: float = A1M8_RANGE_MIN_M
    range_max_m: float = A1M8_RANGE_MAX_M
    scan_period_s: float = A1M8_SCAN_PERIOD_S
    noise_sigma_m: float = A1M8_NOISE_SIGMA_M
    extra_noise_sigma_m: float = 0.0
    dropout_probability: float = 0.0
    mount_x_m: float = 0.0
    mount_y_m: float = 0.0
    mount_yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        if self.beams < 1:
            raise ValueError(f"a scan needs at least one beam, got {self.beams}")
        if not self.angle_increment_rad > 0.0:
            raise ValueError(f"angle increment must be positive, got {self.angle_increment_rad}")
        if not 0.0 <= self.range_min_m < self.range_max_m:
            raise ValueError(
                f"need 0 <= range_min < range_max, got {self.range_min_m} and {self.range_max_m}"
            )
        if not math.isfinite(self.range_max_m):
            raise ValueError("range_max must be finite")
        if not self.scan_period_s > 0.0:
            raise ValueError(f"scan period must be positive, got {self.scan_period_s}")
        if not (self.noise_sigma_m >= 0.0 and self.extra_noise_sigma_m >= 0.0):
            raise ValueError("noise sigmas must be >= 0")
        if not 0.0 <= self.dropout_probability <= 1.0:
            raise ValueError(
                f"dropout probability must be in [0, 1], got {self.dropout_probability}"
            )

    @property
    def angle_max_rad(self) -> float:
        """Angle of the last beam in the sensor frame [rad] (``LaserScan.angle_max``)."""
        return self.angle_min_rad + (self.beams - 1) * self.angle_increment_rad

    @property
    def time_increment_s(self) -> float:
        """Time between neighbouring beams [s] (``LaserScan.time_increment``)."""
        return self.scan_period_s / self.beams

    @property
    def range_sigma_m(self) -> float:
        """Total range noise sigma, ``sqrt(noise_sigma^2 + extra_noise_sigma^2)`` [m]."""
        return math.hypot(self.noise_sigma_m, self.extra_noise_sigma_m)


def _rows(values: ArrayLike, width: int, what: str) -> NDArray[np.float64]:
    rows = np.array(values, dtype=np.float64, ndmin=1)
    if rows.size == 0:
        return np.zeros((0, width))
    if rows.ndim == 1:
        rows = rows.reshape(1, -1)
    if rows.ndim != 2 or rows.shape[1] != width:
        raise ValueError(f"{what} must be rows of {width} numbers, got shape {rows.shape}")
    if not np.isfinite(rows).all():
        raise ValueError(f"{what} must be finite")
    return rows


class Obstacles:
    """Static 2-D geometry in the world frame, as numpy arrays the ray caster broadcasts over.

    Segments are ``[x1, y1, x2, y2]`` rows (walls, box sides: lines of zero thickness), circles are
    ``[cx, cy, r]`` rows (cylinders). Obstacles can be added at run time, e.g. the Stage 3 cylinder
    that appears once the robot has moved 0.12 m; each addition rebuilds the arrays, which is cheap
    for the tens of shapes a room has.

    Parameters
    ----------
    segments : array_like
        ``(N, 4)`` array-like of segments, or a single segment.
    circles : array_like
        ``(M, 3)`` array-like of circles, or a single circle; radii must be >= 0.
    """

    def __init__(self, segments: ArrayLike = (), circles: ArrayLike = ()) -> None:
        self._set_segments(_rows(segments, 4, "segments"))
        self._set_circles(_rows(circles, 3, "circles"))

    def _set_segments(self, segments: NDArray[np.float64]) -> None:
        self._segments = segments
        self._segments.flags.writeable = False
        self._seg_a = np.ascontiguousarray(segments[:, 0:2])
        self._seg_b = np.ascontiguousarray(segments[:, 2:4])
        self._seg_dir = self._seg_b - self._seg_a
        self._seg_dir.flags.writeable = False

    def _set_circles(self, circles: NDArray[np.float64]) -> None:
        if (circles[:, 2] < 0.0).any():
            raise ValueError("circle radii must be >= 0")
        self._circles = circles
        self._circles.flags.writeable = False
        self._circle_c = np.ascontiguousarray(circles[:, 0:2])
        self._circle_r2 = circles[:, 2] * circles[:, 2]

    @property
    def segments(self) -> NDArray[np.float64]:
        """``(N, 4)`` read-only array of segments ``[x1, y1, x2, y2]`` [m]."""
        return self._segments

    @property
    def segment_directions(self) -> NDArray[np.float64]:
        """``(N, 2)`` read-only array of ``(x2 - x1, y2 - y1)`` [m]."""
        return self._seg_dir

    @property
    def circles(self) -> NDArray[np.float64]:
        """``(M, 3)`` read-only array of circles ``[cx, cy, r]`` [m]."""
        return self._circles

    def add_segment(self, x1: float, y1: float, x2: float, y2: float) -> None:
        """Add the segment from ``(x1, y1)`` to ``(x2, y2)`` [m]."""
        row = _rows((x1, y1, x2, y2), 4, "segments")
        self._set_segments(np.concatenate((self._segments, row)))

    def add_polygon(self, vertices: Iterable[Sequence[float]], closed: bool = True) -> None:
        """Add the edges of a polyline through ``vertices`` [m], closing it when ``closed``."""
        points = _rows(list(vertices), 2, "vertices")
        ends = np.roll(points, -1, axis=0) if closed else points[1:]
        starts = points if closed else points[:-1]
        if len(starts) == 0:
            return
        self._set_segments(np.concatenate((self._segments, np.hstack((starts, ends)))))

    def add_circle(self, cx: float, cy: float, r: float) -> None:
        """Add the circle of radius ``r`` centred on ``(cx, cy)`` [m]."""
        row = _rows((cx, cy, r), 3, "circles")
        self._set_circles(np.concatenate((self._circles, row)))

    def copy(self) -> Obstacles:
        """An independent copy (additions to one do not show in the other)."""
        return Obstacles(self._segments, self._circles)

    def __repr__(self) -> str:
        return f"Obstacles({len(self._segments)} segments, {len(self._circles)} circles)"


AHEAD_SHARE = 0.2  # share of a turn an emulated device sends with the turn before (<= 25 ms: 0.19)
MOVING_CHUNKS = 36  # pieces of a turn cast from one pose each (3.7 ms of an A1M8's 134.65 ms)


def _unit_directions(angles_rad: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.vstack((np.cos(angles_rad), np.sin(angles_rad)))


def _cast_directions(
    ox: float, oy: float, d: NDArray[np.float64], obstacles: Obstacles, max_range_m: float
) -> NDArray[np.float64]:
    """:func:`cast` for the ``(2, R)`` array ``d`` of unit ray directions."""
    n_rays = d.shape[1]
    best = np.full(n_rays, np.inf)
    seg_a, seg_b = obstacles._seg_a, obstacles._seg_b
    n_seg, n_circ = len(seg_a), len(obstacles._circle_c)
    if n_seg + n_circ == 0:
        return best

    wa = seg_a - (ox, oy)
    wb = seg_b - (ox, oy)
    k = wa[:, 0] * wb[:, 1] - wa[:, 1] * wb[:, 0]
    e = obstacles._seg_dir
    regular = k != 0.0
    if not regular.all():
        _cast_degenerate(wa[~regular], wb[~regular], d, best)
        wa, wb, k, e = wa[regular], wb[regular], k[regular], e[regular]
        n_seg = len(k)
    g = obstacles._circle_c - (ox, oy)
    q = (g * g).sum(axis=1) - obstacles._circle_r2
    if (q == 0.0).any():
        best[:] = 0.0  # the origin is on a circle
        q[q == 0.0] = 1.0
    if 3 * n_seg + n_circ == 0:
        return best

    # Rows of coefficients that one product with the directions d turns into every per-pair
    # quantity: beta, alpha and 1/t for the segments, d . g for the circles.
    inv_k = 1.0 / k
    w = np.empty((3 * n_seg + n_circ, 2))
    w[0:n_seg, 0] = -wa[:, 1] * inv_k
    w[0:n_seg, 1] = wa[:, 0] * inv_k
    w[n_seg : 2 * n_seg, 0] = wb[:, 1] * inv_k
    w[n_seg : 2 * n_seg, 1] = -wb[:, 0] * inv_k
    w[2 * n_seg : 3 * n_seg, 0] = e[:, 1] * inv_k
    w[2 * n_seg : 3 * n_seg, 1] = -e[:, 0] * inv_k
    w[3 * n_seg :] = g
    p = w @ d

    _nearest(p, n_seg, q[:, None], best, max_range_m)
    return best


def _nearest(
    p: NDArray[np.float64],
    n_seg: int,
    q: NDArray[np.float64],
    best: NDArray[np.float64],
    max_range_m: float,
) -> None:
    """Fold the nearest hit of each ray into ``best`` from ``p``, the per-pair rows
    :func:`_cast_directions` builds (beta, alpha, 1/t of ``n_seg`` segments, then d . g of the
    circles), and ``q = |g|^2 - r^2`` of the circles (``(C, 1)``, or ``(C, R)`` when the rays
    start from different origins); ``p`` is overwritten."""
    # Segments: 1/t where min(alpha, beta) >= 0, else <= 0 (a miss).
    beta = p[0:n_seg]
    np.minimum(p[n_seg : 2 * n_seg], beta, out=beta)
    inv_t = p[2 * n_seg : 3 * n_seg]
    np.multiply(inv_t, beta >= 0.0, out=inv_t)

    # Circles: 1/t = (b +/- sqrt(b^2 - q)) / q, NaN where the ray misses, < 0 behind the origin.
    b = p[3 * n_seg :]
    root = b * b
    root -= q
    with np.errstate(invalid="ignore"):
        np.sqrt(root, out=root)
    root *= np.where(q > 0.0, 1.0, -1.0)
    b += root
    b *= 1.0 / q

    inv_best = np.fmax.reduce(p[2 * n_seg :], axis=0)
    t = np.full(p.shape[1], np.inf)
    np.divide(1.0, inv_best, out=t, where=inv_best > 0.0)
    np.minimum(best, t, out=best)
    best[best > max_range_m] = np.inf


def _cast_pieces(
    origins: NDArray[np.float64],
    d: NDArray[np.float64],
    obstacles: Obstacles,
    max_range_m: float,
) -> NDArray[np.float64] | None:
    """:func:`_cast_directions` for rays from several origins in one pass: ``d`` ((P, 2, M))
    holds ``M`` unit directions for each of the ``P`` ``origins`` ((P, 2)). The per-segment and
    per-circle terms are built once per origin and multiplied with that origin's rays in one
    batched product. Returns the (P * M,) distances, origin by origin; None when an origin is
    collinear with a segment or on a circle (the caller casts origin by origin, which handles
    those)."""
    seg_a, seg_b = obstacles._seg_a, obstacles._seg_b
    n_seg, n_circ = len(seg_a), len(obstacles._circle_c)
    n_org, n_dir = d.shape[0], d.shape[2]
    best = np.full(n_org * n_dir, np.inf)
    if n_seg + n_circ == 0:
        return best
    wa = seg_a[None, :, :] - origins[:, None, :]  # (P, N, 2)
    wb = seg_b[None, :, :] - origins[:, None, :]
    k = wa[:, :, 0] * wb[:, :, 1] - wa[:, :, 1] * wb[:, :, 0]  # (P, N)
    g = obstacles._circle_c[None, :, :] - origins[:, None, :]  # (P, C, 2)
    q = (g * g).sum(axis=2) - obstacles._circle_r2  # (P, C)
    if (k == 0.0).any() or (q == 0.0).any():
        return None
    inv_k = 1.0 / k
    e = obstacles._seg_dir
    w = np.empty((n_org, 3 * n_seg + n_circ, 2))
    w[:, 0:n_seg, 0] = -wa[:, :, 1] * inv_k
    w[:, 0:n_seg, 1] = wa[:, :, 0] * inv_k
    w[:, n_seg : 2 * n_seg, 0] = wb[:, :, 1] * inv_k
    w[:, n_seg : 2 * n_seg, 1] = -wb[:, :, 0] * inv_k
    w[:, 2 * n_seg : 3 * n_seg, 0] = e[:, 1] * inv_k
    w[:, 2 * n_seg : 3 * n_seg, 1] = -e[:, 0] * inv_k
    w[:, 3 * n_seg :] = g
    p = np.matmul(w, d)  # (P, 3N + C, M)
    p = p.transpose(1, 0, 2).reshape(3 * n_seg + n_circ, n_org * n_dir)
    _nearest(p, n_seg, np.repeat(q.T, n_dir, axis=1), best, max_range_m)
    return best


def _cast_degenerate(
    wa: NDArray[np.float64],
    wb: NDArray[np.float64],
    d: NDArray[np.float64],
    best: NDArray[np.float64],
) -> None:
    """Fold in the segments collinear with the ray origin (``cross(a - o, b - o) == 0``).

    Such a segment is seen edge-on: a ray hits it only when it runs along it, at the nearer end,
    or at once (distance 0) for every ray when the origin lies on the segment. A zero-length
    segment is a point, hit only by a ray passing through it.
    """
    contains_origin = np.einsum("ij,ij->i", wa, wb) <= 0.0
    if contains_origin.any():
        best[:] = 0.0
        return
    near = np.where(
        (np.einsum("ij,ij->i", wa, wa) <= np.einsum("ij,ij->i", wb, wb))[:, None], wa, wb
    )
    along = near @ d
    off = np.abs(near[:, 0:1] * d[1] - near[:, 1:2] * d[0])
    t = np.where((off <= COLLINEAR_TOLERANCE_M) & (along > 0.0), along, np.inf)
    np.minimum(best, t.min(axis=0), out=best)


def cast(
    origin_xy: tuple[float, float],
    angles_rad: ArrayLike,
    obstacles: Obstacles,
    max_range_m: float,
) -> NDArray[np.float64]:
    """Exact distance from ``origin_xy`` to the nearest obstacle along each ray.

    Ray ``j`` is ``o + t d_j``, ``t >= 0``, ``d_j = (cos angle_j, sin angle_j)`` in the world frame.

    Segments. With ``w_a = a - o``, ``w_b = b - o`` and ``k = w_a x w_b`` (``x`` the 2-D cross
    product), a ray that meets segment ``ab`` does so at a point ``(alpha w_a + beta w_b) / (alpha
    + beta)`` of the segment with ``alpha = (d x w_b) / k >= 0`` and ``beta = (w_a x d) / k >= 0``:
    the ray lies in the wedge the segment subtends at the origin, and the distance is
    ``t = 1 / (alpha + beta) = k / (d x (b - a))``. All three are linear in ``d``, so one
    ``(3N, 2) @ (2, R)`` product evaluates them for every ray and segment, and the nearest hit is
    the largest valid ``1 / t``. Endpoints belong to the segment (``alpha`` or ``beta`` = 0); a ray
    parallel to a segment never meets it; a segment collinear with the origin (``k = 0``, which
    includes a zero-length segment) is seen edge-on and hit only by a ray running along it, at its
    nearer end (a point within 1e-12 m of the ray counts as on it); an origin on a segment reads 0
    on every ray.

    Circles. With ``g = c - o``, ``b = d . g`` and ``q = |g|^2 - r^2``, ``t^2 - 2 b t + q = 0``
    gives ``t = b -/+ sqrt(b^2 - q)``, evaluated as ``1 / t = (b +/- sqrt(b^2 - q)) / q`` (no
    cancellation, and it joins the segments' ``1 / t`` in one reduction). A circle is its
    boundary, as a segment is a line of zero thickness: from outside (``q > 0``) a ray hits the
    near root when it is ``>= 0``; from inside (``q < 0``) it hits the boundary where it leaves
    the circle (the far root), so a ray never passes through a cylinder unseen (pymunk's segment
    query reports a start inside a shape as a hit at distance 0 instead); an origin on the
    boundary reads 0 on every ray.

    Parameters
    ----------
    origin_xy : tuple of float
        Ray origin ``(x, y)`` in the world frame [m].
    angles_rad : array_like
        ``(R,)`` array of world-frame ray angles [rad], counter-clockwise from +x.
    obstacles : Obstacles
        Geometry to cast against.
    max_range_m : float
        Hits farther than this are misses [m].

    Returns
    -------
    numpy.ndarray
        ``(R,)`` float64 distances [m], ``inf`` where nothing lies within ``max_range_m``.
    """
    angles: NDArray[np.float64] = np.asarray(angles_rad, dtype=np.float64).reshape(-1)
    ox, oy = float(origin_xy[0]), float(origin_xy[1])
    return _cast_directions(ox, oy, _unit_directions(angles), obstacles, max_range_m)


class Lidar:
    """A 2-D scanning LiDAR on the robot: casts one scan per call and adds the sensor's faults.

    A reading is ``r = t + n``, ``n ~ N(0, sigma^2)`` with ``sigma = spec.range_sigma_m``, where
    ``t`` is the exact distance from :func:`cast`. Then, in this order, a beam reads ``inf`` when it
    had no hit within ``range_max``, when it drops out (probability ``dropout_probability``), or
    when ``r`` falls outside ``[range_min, range_max]`` (the limits apply to the noisy reading,
    as the sensor's driver filters what it measured). Random numbers come only from ``rng``: the
    same generator state gives the same scan.

    :meth:`scan` takes the whole scan at the one pose given. The real head turns for
    ``scan_period_s`` while it measures, and a robot that moves meanwhile distorts the scan: the
    first samples of a turn were measured a whole period before its end (3.5 cm and 0.13 rad
    apart at the robot's 0.26 m/s and 1 rad/s). :meth:`scan_moving` models that, given the
    poses at the start and the end of the turn: each beam is cast from the pose at its own
    instant (heading ``h``, clockwise from the head's zero mark, measured at fraction
    ``h / 360°`` of the turn), the pose interpolated linearly between the two in
    :data:`MOVING_CHUNKS` pieces of the turn. The twin calls :meth:`scan_moving` once per
    ``scan_period_s`` of simulated time, from its pose at the scan before to its pose now.

    Parameters
    ----------
    spec : LidarSpec
        The sensor and its mount.
    rng : numpy.random.Generator
        Source of all noise and dropout draws.
    """

    def __init__(self, spec: LidarSpec, rng: np.random.Generator) -> None:
        self._spec = spec
        self._rng = rng
        angles: NDArray[np.float64] = np.arange(spec.beams, dtype=np.float64)
        angles *= spec.angle_increment_rad
        angles += spec.angle_min_rad
        angles.flags.writeable = False
        self._angles = angles
        self._directions = _unit_directions(self._angles)
        self._sigma_m = spec.range_sigma_m
        # fixed per sensor: when in a turn each beam is measured, the beams of each piece of the
        # turn (scan_moving), and those the next turn's beginning re-reads (scan_moving's ahead)
        self._fractions = np.mod(-angles, 2.0 * math.pi) / (2.0 * math.pi)
        piece = np.minimum((self._fractions * MOVING_CHUNKS).astype(np.intp), MOVING_CHUNKS - 1)
        self._pieces = [b for b in (np.flatnonzero(piece == c) for c in range(MOVING_CHUNKS))]
        # the pieces' beams as a (pieces, slots) table for one batched cast (a short piece's
        # spare slots repeat its first beam and are dropped)
        slots = max(len(b) for b in self._pieces)
        table = np.array(
            [np.resize(b, slots) if b.size else np.zeros(slots, np.intp) for b in self._pieces]
        )
        used = np.array([np.arange(slots) < len(b) for b in self._pieces]).reshape(-1)
        self._slot_directions = self._directions[:, table].transpose(1, 0, 2).copy()
        self._slot_used = np.flatnonzero(used)
        self._slot_beams = table.reshape(-1)[self._slot_used]
        self._piece_middles = (np.arange(MOVING_CHUNKS) + 0.5) / MOVING_CHUNKS
        self._near_start = np.flatnonzero(
            (self._fractions < AHEAD_SHARE) | (self._fractions > 0.99)
        )

    @property
    def spec(self) -> LidarSpec:
        return self._spec

    def angles(self) -> NDArray[np.float64]:
        """Beam angles in the sensor frame [rad]: ``angle_min + i * angle_increment``."""
        return self._angles.copy()

    def sensor_pose(
        self, pose_x: float, pose_y: float, pose_yaw: float
    ) -> tuple[float, float, float]:
        """World pose ``(x, y, yaw)`` of the sensor for the robot base at ``(x, y, yaw)``."""
        s = self._spec
        c, sn = math.cos(pose_yaw), math.sin(pose_yaw)
        return (
            pose_x + c * s.mount_x_m - sn * s.mount_y_m,
            pose_y + sn * s.mount_x_m + c * s.mount_y_m,
            pose_yaw + s.mount_yaw_rad,
        )

    def true_ranges(
        self, pose_x: float, pose_y: float, pose_yaw: float, obstacles: Obstacles
    ) -> NDArray[np.float64]:
        """Exact distances along the beams, no noise or limits (``inf`` beyond ``range_max``)."""
        return self._cast((pose_x, pose_y, pose_yaw), obstacles, self._directions)

    def _cast(
        self,
        pose: tuple[float, float, float],
        obstacles: Obstacles,
        directions: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Exact distances along ``directions`` (sensor frame, (2, R)) from the sensor with the
        base at ``pose``."""
        sx, sy, syaw = self.sensor_pose(*pose)
        c, sn = math.cos(syaw), math.sin(syaw)
        d = np.array(((c, -sn), (sn, c))) @ directions
        return _cast_directions(sx, sy, d, obstacles, self._spec.range_max_m)

    def beam_fractions(self) -> NDArray[np.float64]:
        """The share of the turn gone by when each beam is measured, in [0, 1): its heading
        (clockwise from the head's zero mark, ``-angle`` wrapped) over a full turn."""
        return self._fractions.copy()

    def true_ranges_moving(
        self,
        start: tuple[float, float, float],
        end: tuple[float, float, float],
        obstacles: Obstacles,
    ) -> NDArray[np.float64]:
        """Exact distances along the beams, each cast from the base pose at its instant of
        the turn: ``start`` at the turn's beginning, ``end`` at its end, linearly between them
        (the heading along the shorter arc) in :data:`MOVING_CHUNKS` pieces."""
        if start == end:
            return self.true_ranges(*end, obstacles)
        x0, y0, yaw0 = start
        dx, dy = end[0] - x0, end[1] - y0
        dyaw = math.remainder(end[2] - yaw0, 2.0 * math.pi)
        # all pieces in one cast, each beam from its piece's sensor pose
        mid = self._piece_middles
        spec = self._spec
        yaw = yaw0 + mid * dyaw
        cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
        origins = np.column_stack(
            (
                x0 + mid * dx + cos_yaw * spec.mount_x_m - sin_yaw * spec.mount_y_m,
                y0 + mid * dy + sin_yaw * spec.mount_x_m + cos_yaw * spec.mount_y_m,
            )
        )
        syaw = (yaw + spec.mount_yaw_rad)[:, None]
        cb, sb = np.cos(syaw), np.sin(syaw)
        u = self._slot_directions  # (pieces, 2, slots)
        d = np.stack((cb * u[:, 0] - sb * u[:, 1], sb * u[:, 0] + cb * u[:, 1]), axis=1)
        fast = _cast_pieces(origins, d, obstacles, spec.range_max_m)
        if fast is not None:
            out = np.empty(spec.beams)
            out[self._slot_beams] = fast[self._slot_used]
            return out
        out = np.empty(spec.beams)
        for f, beams in zip(mid, self._pieces, strict=True):
            if beams.size:
                pose = (x0 + f * dx, y0 + f * dy, yaw0 + f * dyaw)
                out[beams] = self._cast(pose, obstacles, self._directions[:, beams])
        return out

    def scan_moving(
        self,
        start: tuple[float, float, float],
        end: tuple[float, float, float],
        obstacles: Obstacles,
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
        """One scan over a turn in which the base moved from ``start`` to ``end`` (each
        ``(x [m], y [m], yaw [rad])`` in the world frame): :meth:`scan` with each beam cast
        from the pose at its instant (:meth:`true_ranges_moving`), and what the beams of the
        next turn's beginning read just after this one ended (an emulated device sends those
        with this turn: :mod:`jackson.sim.rplidar`): the same ranges with the beams in the
        first :data:`AHEAD_SHARE` of a turn (and the last 1 %, their neighbours) cast from
        ``end``. One set of noise draws for both, the draws :meth:`scan` makes.
        """
        moving = self.true_ranges_moving(start, end, obstacles)
        ahead = moving.copy()
        if start != end:
            near = self._near_start
            ahead[near] = self._cast(end, obstacles, self._directions[:, near])
        return self._measured(moving, ahead)

    def scan(
        self, pose_x: float, pose_y: float, pose_yaw: float, obstacles: Obstacles
    ) -> NDArray[np.float32]:
        """One scan from the robot base pose ``(x [m], y [m], yaw [rad])`` in the world frame.

        Returns
        -------
        numpy.ndarray
            ``(beams,)`` float32 ranges [m], ``LaserScan.ranges``; ``inf`` for no return.
        """
        return self._measured(self.true_ranges(pose_x, pose_y, pose_yaw, obstacles))

    @overload
    def _measured(self, ranges: NDArray[np.float64]) -> NDArray[np.float32]: ...

    @overload
    def _measured(
        self, ranges: NDArray[np.float64], other: NDArray[np.float64]
    ) -> tuple[NDArray[np.float32], NDArray[np.float32]]: ...

    def _measured(
        self, ranges: NDArray[np.float64], other: NDArray[np.float64] | None = None
    ) -> NDArray[np.float32] | tuple[NDArray[np.float32], NDArray[np.float32]]:
        """The exact ``ranges`` (and ``other``, with the same draws) with the sensor's noise,
        dropout and limits, as float32."""
        spec = self._spec
        out = [ranges] if other is None else [ranges, other]
        if self._sigma_m > 0.0:
            noise = self._rng.normal(0.0, self._sigma_m, spec.beams)
            for r in out:
                r += noise
        if spec.dropout_probability > 0.0:
            lost = self._rng.random(spec.beams) < spec.dropout_probability
            for r in out:
                r[lost] = np.inf
        for r in out:
            r[(r < spec.range_min_m) | (r > spec.range_max_m)] = np.inf
        if other is None:
            return ranges.astype(np.float32)
        return ranges.astype(np.float32), other.astype(np.float32)
