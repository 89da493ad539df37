"""KLD sampling (Fox 2003) and the histogram behind it: how many particles the filter keeps.

The particles are binned into a histogram over ``(x, y, yaw)`` (AMCL's kd-tree leaves: 0.5 m,
0.5 m, 10 degrees). After resampling, the set keeps as many particles as needed for the
Kullback-Leibler distance between the sampled and the true distribution to stay under
``pf_err`` with probability ``pf_z``, given the number of bins the particles occupy
(:func:`kld_particle_limit`, :func:`kld_sample_count`). The same bins, joined where they touch,
are the clusters of the pose estimate (:func:`heaviest_cluster`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy.ndimage import label

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

TWO_PI = 2.0 * math.pi


def kld_particle_limit(
    bins: IntArray, pf_err: float, pf_z: float, min_particles: int, max_particles: int
) -> IntArray:
    """Particles needed when they occupy ``bins`` histogram bins (KLD sampling, Fox 2003).

    ``n = (k - 1) / (2 err) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z)^3``, clamped to
    [min_particles, max_particles]. For one bin (``k = 1``) the bound is 0, so the minimum
    applies (AMCL returns the maximum there instead, which makes a well-converged cloud that
    happens to fit in one bin four times as costly as one that straddles two).

    Parameters
    ----------
    bins : ndarray of int
        Occupied bin counts ``k``.
    pf_err, pf_z : float
        The bound's error and quantile.
    min_particles, max_particles : int
        The clamp.

    Returns
    -------
    ndarray of int
        The required counts, elementwise.
    """
    km1 = np.maximum(np.asarray(bins, np.float64) - 1.0, 1.0)
    b = 2.0 / (9.0 * km1)
    x = 1.0 - b + np.sqrt(b) * pf_z
    n = np.ceil(km1 / (2.0 * pf_err) * x * x * x)
    n[np.asarray(bins) <= 1] = 0.0
    return np.clip(n, min_particles, max_particles).astype(np.int64)


def kld_sample_count(
    draws: FloatArray,
    bin_xy_m: float,
    bin_yaw_rad: float,
    pf_err: float,
    pf_z: float,
    min_particles: int,
) -> int:
    """How many of ``draws``, taken in order, KLD sampling keeps (Fox's loop, run at once).

    Fox's loop adds one draw at a time and stops once the draws so far number at least
    :func:`kld_particle_limit` of the bins they occupy. Here the bins occupied by every prefix
    come from where each bin is first filled, and the first prefix that is large enough is
    taken; the draws should be in random order, so that each prefix is a fair sample.

    Parameters
    ----------
    draws : ndarray of float, shape (M, 3)
        Poses ``(x [m], y [m], yaw [rad])``, yaw in [-pi, pi); ``M`` is ``max_particles``.
    bin_xy_m, bin_yaw_rad : float
        Histogram bin [m], [rad].
    pf_err, pf_z : float
        The bound's error and quantile.
    min_particles : int
        The fewest particles kept.

    Returns
    -------
    int
        Particles kept (the first that many of ``draws``), from ``min_particles`` to ``M``.
    """
    m = len(draws)
    bins, yaw_bins = histogram_bins(draws, bin_xy_m, bin_yaw_rad)
    bins -= bins.min(axis=0)
    span = bins.max(axis=0) + 1
    codes = (bins[:, 0] * span[1] + bins[:, 1]) * yaw_bins + bins[:, 2]
    _, first = np.unique(codes, return_index=True)
    # the prefixes of n draws with k bins filled are those with f[k-1] < n <= f[k] (f the
    # sorted draws where each bin is first filled, f[0] = 0): the first of them that needs no
    # more draws is max(f[k-1] + 1, need(k)), when still in that range. The bounds are
    # searched per bin count, not per prefix: a converged cloud fills a handful of bins.
    starts = np.sort(first) + 1  # the shortest prefix with k bins, k = 1, 2, ...
    ends = np.append(starts[1:] - 1, m)  # the longest
    need = kld_particle_limit(np.arange(1, len(starts) + 1), pf_err, pf_z, min_particles, m)
    n = np.maximum(starts, need)
    enough = np.flatnonzero(n <= ends)
    return int(n[enough[0]]) if len(enough) else m


def histogram_bins(
    particles: FloatArray, bin_xy_m: float, bin_yaw_rad: float
) -> tuple[IntArray, int]:
    """The histogram bin of each particle (AMCL's kd-tree leaves) as ``(ix, iy, iyaw)``.

    Parameters
    ----------
    particles : ndarray of float, shape (N, 3)
        Poses, yaw in [-pi, pi).
    bin_xy_m, bin_yaw_rad : float
        Bin size [m], [rad].

    Returns
    -------
    bins : ndarray of int, shape (N, 3)
        ``floor(x / bin_xy)``, ``floor(y / bin_xy)`` and the yaw bin counted from -pi.
    yaw_bins : int
        Yaw bins in a turn.
    """
    yaw_bins = math.ceil(TWO_PI / bin_yaw_rad - 1e-9)
    bins = np.empty((len(particles), 3), np.int64)
    bins[:, 0:2] = np.floor(particles[:, 0:2] / bin_xy_m)
    bins[:, 2] = np.minimum(np.floor((particles[:, 2] + math.pi) / bin_yaw_rad), yaw_bins - 1)
    return bins, yaw_bins


def heaviest_cluster(bins: IntArray, yaw_bins: int, weights: FloatArray) -> npt.NDArray[np.bool_]:
    """Which particles belong to the cluster holding the most weight (AMCL's pose estimate).

    Occupied bins that touch (faces, edges or corners) form one cluster, as AMCL joins its
    kd-tree leaves; the clusters are the connected components of the occupied bins
    (``scipy.ndimage.label``). The yaw axis is cut at an empty yaw bin when there is one, so
    a cloud around +-pi stays one cluster.

    Parameters
    ----------
    bins : ndarray of int, shape (N, 3)
        Bins from :func:`histogram_bins`.
    yaw_bins : int
        Yaw bins in a turn.
    weights : ndarray of float, shape (N,)
        Particle weights.

    Returns
    -------
    ndarray of bool, shape (N,)
        Membership of the heaviest cluster.
    """
    ix = bins[:, 0] - bins[:, 0].min()
    iy = bins[:, 1] - bins[:, 1].min()
    per_yaw = np.bincount(bins[:, 2], minlength=yaw_bins)
    empty = np.flatnonzero(per_yaw == 0)
    if len(empty) and ix.max() <= 1 and iy.max() <= 1:
        # within 2 x 2 bins of x and y every two bins of neighbouring (or the same) yaw touch,
        # so occupied yaw bins in one run (the yaw axis cut at an empty one) are one cluster
        # (a converged cloud: labelling it would find the same)
        occupied_yaw = np.flatnonzero(np.roll(per_yaw, -int(empty[0])))
        if occupied_yaw[-1] - occupied_yaw[0] + 1 == len(occupied_yaw):
            return np.ones(len(bins), np.bool_)
    iyaw = (bins[:, 2] - (empty[0] if len(empty) else 0)) % yaw_bins
    occupied = np.zeros((int(ix.max()) + 1, int(iy.max()) + 1, yaw_bins), bool)
    occupied[ix, iy, iyaw] = True
    labels, _ = label(occupied, structure=np.ones((3, 3, 3), bool))
    mine = np.asarray(labels, np.int64)[ix, iy, iyaw]
    return np.asarray(mine == np.argmax(np.bincount(mine, weights=weights)), np.bool_)
