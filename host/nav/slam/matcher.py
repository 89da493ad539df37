"""Correlative scan matching, coarse to fine (:func:`search`): the pose near a prediction at
which a scan's returns lie closest to a map's obstacles.

The score of a pose is the mean likelihood ``exp(-d^2 / 2 sigma^2)`` of the returns, d being
the distance to the nearest obstacle of the :class:`~jackson.host.nav.likelihood.PointField`
(the mean return of each occupied cell, not the cell centres, which would pull each scan up to
half a cell towards them), weighted by a weak Gaussian prior around the prediction (as
slam_toolbox's distance and angle variance penalties) that only breaks ties along directions
the scan cannot see, such as along a featureless corridor. The first level scores every pose
of the window at the coarse steps; each further level halves the steps and scores the
3 x 3 x 3 poses around the best so far until the fine steps are reached. A coarser level uses
its translation step as sigma when that is wider, which widens its basin. The best pose is then
placed between the fine steps, at the peak of a parabola through the scores either side of it
along each axis (Cartographer refines its correlative match continuously for the same reason):
on the steps' lattice the heading errs by up to half a step, about 0.1 degrees, and each scan
written at that heading passes it on to the next scans matched against it.

The first level also says how sure the match is (:class:`Match`'s ``spread``): the
score-weighted covariance of the positions whose score comes within ``SPREAD_MARGIN`` of the
best one's (each position at its best heading), as Karto's correlative matcher computes its
positional covariance. Along a corridor with nothing to see along it the positions the length
of the window score alike and the spread is wide that way; a scan that sees corners scores
one position and its neighbours well below it, and the spread is about a step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from jackson.host.nav.likelihood import PointField
from jackson.host.nav.types import Pose2D, Scan

FloatArray = npt.NDArray[np.float64]

SPREAD_MARGIN = 0.1  # share of the best score: the positions within it make the spread


@dataclass(frozen=True)
class Match:
    """What :func:`search` found.

    Attributes
    ----------
    pose : Pose2D
        The best base pose.
    score : float
        Its mean likelihood in [0, 1].
    spread : ndarray
        2 x 2 covariance of the positions that scored nearly as well [m^2], at least that of
        a uniform spread over one coarse step.
    """

    pose: Pose2D
    score: float
    spread: FloatArray

    def widest_m(self) -> float:
        """The spread's standard deviation along its widest direction [m]."""
        return math.sqrt(float(np.linalg.eigvalsh(self.spread)[-1]))


@dataclass(frozen=True)
class Window:
    """Where and how finely :func:`search` looks.

    Attributes
    ----------
    xy_m, yaw_rad : float
        Half-widths of the window around the prediction [m], [rad].
    coarse_xy_m, coarse_yaw_rad : float
        Steps of the exhaustive first level [m], [rad].
    fine_xy_m, fine_yaw_rad : float
        Steps of the last level [m], [rad].
    sigma_m : float
        The likelihood's standard deviation [m].
    prior_sigma_m, prior_sigma_rad : float
        The prior's standard deviations around the prediction [m], [rad].
    refine : bool
        Place the best pose between the last level's steps: the last level is scored again
        around its best pose until that pose is its middle one (three times at most), and the
        peak of the parabola through its scores and its two neighbours' is taken along each
        axis (within half a step).
    """

    xy_m: float
    yaw_rad: float
    coarse_xy_m: float
    coarse_yaw_rad: float
    fine_xy_m: float
    fine_yaw_rad: float
    sigma_m: float
    prior_sigma_m: float
    prior_sigma_rad: float
    refine: bool = True


def base_points(
    scan: Scan, mount: Pose2D, max_range_m: float, max_points: int
) -> tuple[FloatArray, FloatArray]:
    """The scan's returns within ``max_range_m`` in the base frame, evenly thinned to at most
    ``max_points``."""
    r = scan.ranges_m
    ok = scan.valid & (r <= max_range_m)
    idx = np.flatnonzero(ok)
    if idx.size > max_points:
        idx = idx[np.linspace(0, idx.size - 1, max_points).astype(np.intp)]
    a = scan.angles_rad[idx] + mount.yaw
    return mount.x + r[idx] * np.cos(a), mount.y + r[idx] * np.sin(a)


def search(
    field: PointField, bx: FloatArray, by: FloatArray, predicted: Pose2D, w: Window
) -> Match:
    """The best base pose in the window around ``predicted``, its raw score in [0, 1] and
    how widely nearly as good positions spread.

    Parameters
    ----------
    field : PointField
        The obstacles.
    bx, by : ndarray
        The returns in the base frame [m].
    predicted : Pose2D
        The window's centre.
    w : Window
        The window and its steps.

    Returns
    -------
    Match
        The pose, its mean likelihood and the spread.
    """
    step_xy, step_yaw = w.coarse_xy_m, w.coarse_yaw_rad
    nxy = round(w.xy_m / step_xy)
    nyaw = round(w.yaw_rad / step_yaw)
    dx: FloatArray = np.arange(-nxy, nxy + 1, dtype=np.float64) * step_xy
    dyaw: FloatArray = np.arange(-nyaw, nyaw + 1, dtype=np.float64) * step_yaw
    best = (0.0, 0.0, 0.0)
    spread: FloatArray | None = None
    recentred = 0
    while True:
        sigma = max(w.sigma_m, step_xy)
        ox, oy, oyaw = best
        weighted, raw = _score(field, bx, by, predicted, ox + dx, oy + dx, oyaw + dyaw, sigma, w)
        if spread is None:
            spread = _spread(raw, dx, step_xy)
        k = int(np.argmax(weighted))
        iyaw, ix, iy = np.unravel_index(k, weighted.shape)
        best = (ox + float(dx[ix]), oy + float(dx[iy]), oyaw + float(dyaw[iyaw]))
        score = float(raw.flat[k])
        if step_xy <= w.fine_xy_m and step_yaw <= w.fine_yaw_rad:
            if w.refine and weighted.shape == (3, 3, 3):
                middle = int(iyaw) == int(ix) == int(iy) == 1
                if not middle and recentred < 3:
                    recentred += 1
                    continue
                if middle:
                    best = (
                        best[0] + step_xy * _vertex(weighted[1, :, 1]),
                        best[1] + step_xy * _vertex(weighted[1, 1, :]),
                        best[2] + step_yaw * _vertex(weighted[:, 1, 1]),
                    )
            break
        step_xy = max(step_xy / 2.0, w.fine_xy_m)
        step_yaw = max(step_yaw / 2.0, w.fine_yaw_rad)
        dx = np.array((-step_xy, 0.0, step_xy))
        dyaw = np.array((-step_yaw, 0.0, step_yaw))
    yaw = math.remainder(predicted.yaw + best[2], math.tau)
    return Match(Pose2D(predicted.x + best[0], predicted.y + best[1], yaw), score, spread)


def _vertex(s: FloatArray) -> float:
    """The peak of the parabola through three scores at -1, 0, +1 steps, in steps (within
    half a step; 0 when the middle one is not a peak)."""
    curvature = float(s[0] - 2.0 * s[1] + s[2])
    if curvature >= 0.0:
        return 0.0
    return float(np.clip(0.5 * float(s[0] - s[2]) / curvature, -0.5, 0.5))


def _spread(raw: FloatArray, offsets: FloatArray, step_m: float) -> FloatArray:
    """The score-weighted covariance of the positions (each at its best heading) scoring
    within :data:`SPREAD_MARGIN` of the best, about the best; at least a uniform spread over
    one step."""
    per_xy = raw.max(axis=0)  # (x, y)
    top = float(per_xy.max())
    near = per_xy >= top * (1.0 - SPREAD_MARGIN)
    ix, iy = np.unravel_index(int(np.argmax(per_xy)), per_xy.shape)
    wgt = per_xy[near]
    xs, ys = np.meshgrid(offsets, offsets, indexing="ij")
    ddx, ddy = xs[near] - offsets[ix], ys[near] - offsets[iy]
    total = float(wgt.sum())
    cov = np.array(
        [
            [float((wgt * ddx * ddx).sum()), float((wgt * ddx * ddy).sum())],
            [float((wgt * ddx * ddy).sum()), float((wgt * ddy * ddy).sum())],
        ]
    ) / max(total, 1e-12)
    floor = step_m * step_m / 12.0
    cov[0, 0] += floor
    cov[1, 1] += floor
    return cov


def _score(
    field: PointField,
    bx: FloatArray,
    by: FloatArray,
    predicted: Pose2D,
    ox: FloatArray,
    oy: FloatArray,
    oyaw: FloatArray,
    sigma_m: float,
    w: Window,
) -> tuple[FloatArray, FloatArray]:
    """Scores of the poses ``predicted + (ox[i], oy[j], oyaw[k])``, shape (yaw, x, y): the
    prior-weighted and the raw mean likelihoods."""
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
    prior = ((ox * ox)[None, :, None] + (oy * oy)[None, None, :]) / w.prior_sigma_m**2 + (
        oyaw * oyaw
    )[:, None, None] / w.prior_sigma_rad**2
    weighted: FloatArray = raw * np.exp(-0.5 * prior)
    return weighted, raw
