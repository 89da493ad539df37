"""KLD sampling's count and the heaviest cluster against their definitions: Fox's loop, one draw
at a time, and the connected components of the occupied bins (scipy's labelling), on converged
clouds (the shortcuts' case), spread ones and clouds around +-pi."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import label

from jackson.host.nav.amcl import heaviest_cluster, histogram_bins, kld_particle_limit
from jackson.host.nav.amcl.kld import kld_sample_count

BIN_XY, BIN_YAW = 0.5, math.radians(10.0)


def _cloud(rng: np.random.Generator, n: int, kind: int) -> np.ndarray:
    centre = rng.uniform(-5.0, 5.0, 2)
    if kind == 0:  # converged: a few bins
        xy, yaw_sd = rng.normal(centre, 0.05, (n, 2)), 0.05
    elif kind == 1:  # spread over many bins
        xy, yaw_sd = rng.normal(centre, 1.0, (n, 2)), 1.0
    else:  # two clouds apart
        xy = np.where(rng.random((n, 1)) < 0.5, rng.normal(centre, 0.1, (n, 2)),
                      rng.normal(centre + 2.0, 0.1, (n, 2)))  # fmt: skip
        yaw_sd = 0.3
    yaw0 = rng.choice([0.0, math.pi - 0.02, rng.uniform(-math.pi, math.pi)])
    yaw = (yaw0 + rng.normal(0.0, yaw_sd, n) + math.pi) % (2 * math.pi) - math.pi
    return np.column_stack((xy, yaw))


def _fox(draws: np.ndarray, err: float, z: float, least: int) -> int:
    """Fox's loop: add draws one by one until they number the limit of the bins they fill."""
    bins, _ = histogram_bins(draws, BIN_XY, BIN_YAW)
    seen: set[tuple[int, ...]] = set()
    m = len(draws)
    for n in range(1, m + 1):
        seen.add(tuple(bins[n - 1]))
        if n >= kld_particle_limit(np.array([len(seen)]), err, z, least, m)[0]:
            return n
    return m


@pytest.mark.parametrize("seed", range(8))
def test_the_count_is_foxs_loops(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for kind in (0, 1, 2):
        draws = _cloud(rng, 2000, kind)
        for err, z, least in ((0.05, 0.99, 500), (0.01, 3.0, 100), (0.2, 0.5, 10)):
            assert kld_sample_count(draws, BIN_XY, BIN_YAW, err, z, least) == _fox(
                draws, err, z, least
            )


def _labelled(bins: np.ndarray, yaw_bins: int, weights: np.ndarray) -> np.ndarray:
    """The definition: occupied bins joined where they touch (the yaw axis cut at an empty bin),
    the component holding the most weight."""
    ix, iy = bins[:, 0] - bins[:, 0].min(), bins[:, 1] - bins[:, 1].min()
    empty = np.flatnonzero(np.bincount(bins[:, 2], minlength=yaw_bins) == 0)
    iyaw = (bins[:, 2] - (empty[0] if len(empty) else 0)) % yaw_bins
    occupied = np.zeros((ix.max() + 1, iy.max() + 1, yaw_bins), bool)
    occupied[ix, iy, iyaw] = True
    labels, _ = label(occupied, structure=np.ones((3, 3, 3), bool))
    mine = labels[ix, iy, iyaw]
    return mine == np.argmax(np.bincount(mine, weights=weights))


@pytest.mark.parametrize("seed", range(10))
def test_the_heaviest_cluster_is_the_labelled_one(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    for kind in (0, 0, 1, 2):
        particles = _cloud(rng, int(rng.integers(50, 2000)), kind)
        bins, yaw_bins = histogram_bins(particles, BIN_XY, BIN_YAW)
        weights = rng.random(len(particles))
        assert np.array_equal(
            heaviest_cluster(bins, yaw_bins, weights), _labelled(bins, yaw_bins, weights)
        )


def test_a_tight_cloud_with_a_gap_in_yaw_is_two_clusters() -> None:
    """The shortcut's one condition that a cloud in one 2 x 2 square can fail: yaw bins that do
    not follow each other."""
    particles = np.array([[0.1, 0.1, 0.05]] * 30 + [[0.1, 0.1, 0.6]] * 10)  # bins 18 and 21
    bins, yaw_bins = histogram_bins(particles, BIN_XY, BIN_YAW)
    members = heaviest_cluster(bins, yaw_bins, np.full(40, 1 / 40))
    assert members.tolist() == [True] * 30 + [False] * 10


@pytest.mark.parametrize("axis", [0, 1])
def test_bins_two_apart_in_x_or_y_are_two_clusters(axis: int) -> None:
    """Bins 0 and 2 (none between) do not touch, whatever the yaw."""
    far = [0.1, 0.1, 0.05]
    far[axis] = 1.1
    particles = np.array([[0.1, 0.1, 0.05]] * 30 + [far] * 10)
    bins, yaw_bins = histogram_bins(particles, BIN_XY, BIN_YAW)
    members = heaviest_cluster(bins, yaw_bins, np.full(40, 1 / 40))
    assert members.tolist() == [True] * 30 + [False] * 10
