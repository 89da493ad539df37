"""AMCL's weighing compiled (``jackson_amcl_weigh``, host/nav/native/collide.cpp) against numpy's
likelihood field model: the same likelihoods bit for bit on random fields, particles and beams
(every branch of numpy's pairwise summation, poses off the grid, NaN and infinity), and a
filter that weighs, resamples and estimates exactly as numpy's does."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from jackson.host.nav import native
from jackson.host.nav.amcl import AmclConfig, ParticleFilter
from jackson.host.nav.amcl import sensor_model as sm
from jackson.host.nav.grid import FREE, OCCUPIED, OccupancyGrid
from jackson.host.nav.likelihood import LikelihoodField
from jackson.host.nav.types import Pose2D, Scan

pytestmark = pytest.mark.skipif(native.LIB is None, reason=f"no compiled build: {native.REASON}")

MODEL = (0.5, 0.5, 0.2, 8.0)  # z_hit, z_rand, sigma_hit, max range


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()


# beams on each side of numpy's summation blocks: < 8, one block of 8 accumulators (with and
# without a remainder), and halves split on a multiple of 8 above 128
@pytest.mark.parametrize("beams", [1, 5, 7, 8, 13, 60, 128, 129, 300, 1031])
def test_likelihoods_are_numpys_bit_for_bit(beams: int) -> None:
    rng = np.random.default_rng(beams)
    for trial in range(6):
        rows, cols = rng.integers(2, 80, 2)
        distance = np.minimum(rng.random((rows, cols)) * 3.0, 2.0)
        res = float(rng.choice([0.05, 0.025, 0.1, 1 / 30]))
        field = LikelihoodField(distance, res, float(rng.normal()), float(rng.normal()), 2.0)
        n = int(rng.integers(1, 900))
        spread = float(rng.choice([0.1, 3.0]))  # a tight cloud, or poses well off the grid
        particles = np.column_stack(
            (rng.normal(0.5, spread, n), rng.normal(0.5, spread, n), rng.uniform(-7, 7, n))
        )
        if trial == 0:
            particles[0] = (np.nan, 0.0, 0.0)
            particles[-1] = (np.inf, -np.inf, 1.0)
        end_points = rng.normal(0.0, 2.0, (beams, 2))
        model = tuple(float(v) for v in (rng.uniform(0.1, 1), rng.uniform(0, 1), 0.2, 8.0))
        want = sm.likelihood_field_model(particles, end_points, field, *model)
        cubes = sm.beam_cubes(field, *model)
        got = sm.likelihood_field_model(particles, end_points, field, *model, cubes=cubes)
        assert _same(got, want), (trial, n, np.max(np.abs(got - want)))


def test_end_points_on_cell_edges_fall_in_numpys_cells() -> None:
    """Each particle placed so that its first beam ends within an ulp or two of a cell edge: the
    end point's arithmetic in another order would put many of them in the next cell."""
    rng = np.random.default_rng(5)
    res = 0.05
    field = LikelihoodField(rng.random((40, 60)) * 2.0, res, -1.0, -0.5, 2.0)
    cubes = sm.beam_cubes(field, *MODEL)
    n = 4000
    yaw = rng.uniform(-math.pi, math.pi, n)
    end_points = np.vstack((rng.uniform(-1.0, 1.0, (1, 2)), rng.normal(0.0, 1.0, (2, 2))))
    bx, by = end_points[0]
    edge_x = -1.0 + res * rng.integers(5, 55, n)
    edge_y = -0.5 + res * rng.integers(5, 35, n)
    particles = np.column_stack(
        (
            edge_x - (np.cos(yaw) * bx - np.sin(yaw) * by),
            edge_y - (np.sin(yaw) * bx + np.cos(yaw) * by),
            yaw,
        )
    )
    want = sm.likelihood_field_model(particles, end_points, field, *MODEL)
    got = sm.likelihood_field_model(particles, end_points, field, *MODEL, cubes=cubes)
    assert _same(got, want)


def test_the_call_refuses_arrays_of_the_wrong_shape() -> None:
    from jackson.host.nav.native_grid import amcl_weigh

    field = LikelihoodField(np.ones((4, 5)), 0.05, 0.0, 0.0, 2.0)
    cubes = sm.beam_cubes(field, *MODEL)
    other = sm.beam_cubes(LikelihoodField(np.ones((5, 4)), 0.05, 0.0, 0.0, 2.0), *MODEL)
    with pytest.raises(ValueError, match="not this field"):
        sm.likelihood_field_model(np.zeros((2, 3)), np.ones((3, 2)), field, *MODEL, cubes=other)
    with pytest.raises(ValueError, match="amcl_weigh"):
        amcl_weigh(np.zeros((3, 2)), np.ones(3), np.zeros(3), np.zeros((4, 2)), (0, 0, 0.05), cubes)
    with pytest.raises(ValueError, match="amcl_weigh"):
        amcl_weigh(np.zeros((3, 3)), np.ones(2), np.zeros(3), np.zeros((4, 2)), (0, 0, 0.05), cubes)


def _room() -> OccupancyGrid:
    """A 3 m x 2 m room with two inner walls and a pillar, 5 cm cells."""
    grid = OccupancyGrid.empty(3.0, 2.0, 0.05, 0.0, 0.0, fill=FREE)
    d = grid.data
    d[0, :] = d[-1, :] = d[:, 0] = d[:, -1] = OCCUPIED
    d[:22, 20] = OCCUPIED
    d[18:, 40] = OCCUPIED
    d[8:11, 30:33] = OCCUPIED
    return grid


def _scans(grid: OccupancyGrid, rng: np.random.Generator, count: int) -> list[Scan]:
    """Scans whose returns end near the room's walls (noisy, some missing)."""
    field = LikelihoodField.from_grid(grid)
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    scans = []
    for k in range(count):
        ranges = rng.uniform(0.2, 2.5, len(angles))
        ranges[rng.random(len(angles)) < 0.1] = np.inf
        # pull each return onto the nearest obstacle a little: the weights differ between poses
        ranges = ranges - 0.5 * field.distance_xy(1.0 + ranges * np.cos(angles), 1.0)
        scans.append(Scan(0.1 * k, angles, np.maximum(ranges, 0.05), range_max_m=8.0))
    return scans


def _run(grid: OccupancyGrid, scans: list[Scan], seed: int) -> ParticleFilter:
    pf = ParticleFilter(
        grid, AmclConfig(update_min_d=0.0, update_min_a=0.0), np.random.default_rng(seed)
    )
    pf.initialise(Pose2D(1.0, 1.0, 0.2), 0.2, 0.3)
    for k, scan in enumerate(scans):
        pf.update(Pose2D(0.02 * k, 0.01 * k, 0.03 * k), scan, Pose2D(0.05, 0.0, 0.0))
    return pf


@pytest.mark.parametrize("seed", range(3))
def test_a_filter_weighs_resamples_and_estimates_as_with_numpy(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    grid = _room()
    scans = _scans(grid, np.random.default_rng(100 + seed), 12)
    compiled = _run(grid, scans, seed)
    assert compiled._cubes is not None  # the compiled path ran
    monkeypatch.setattr(native, "LIB", None)
    interpreted = _run(grid, scans, seed)
    assert interpreted._cubes is None
    assert compiled.sensor_updates == interpreted.sensor_updates == 12
    assert _same(compiled.particles, interpreted.particles)
    assert _same(compiled.weights, interpreted.weights)
    assert compiled.estimate() == interpreted.estimate()
    assert _same(compiled.covariance(), interpreted.covariance())


def test_a_pickled_filter_leaves_its_table_behind_and_weighs_the_same() -> None:
    grid = _room()
    scans = _scans(grid, np.random.default_rng(7), 6)
    pf = _run(grid, scans[:3], 3)
    assert pf._cubes is not None
    data = pickle.dumps(pf)
    assert "_cubes" not in pickle.loads(data).__dict__
    copy = pickle.loads(data)
    assert copy._cubes is None  # made again at its next weighing
    for k, scan in enumerate(scans[3:], start=3):
        for f in (pf, copy):
            f.update(Pose2D(0.02 * k, 0.01 * k, 0.03 * k), scan, Pose2D(0.05, 0.0, 0.0))
    assert _same(pf.particles, copy.particles)
    assert _same(pf.weights, copy.weights)
