"""The particle filter localizes the robot on a known map as AMCL would.

A small maze-like room (2.5 m x 1.5 m, two inner walls, a cylinder) is rasterised into an
occupancy grid; the twin's exact ray caster (``jackson.sim.lidar``) gives scans with the A1M8's
0.01 m noise from the true poses, and odometry drifts from the truth by a scale error on
distance and on rotation plus noise.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import pytest
from scipy.ndimage import distance_transform_edt

from jackson.host.nav.amcl import (
    AmclConfig,
    LocalizationError,
    ParticleFilter,
    heaviest_cluster,
    histogram_bins,
    kld_particle_limit,
    sample_motion_model_odometry,
    systematic_resample,
)
from jackson.host.nav.grid import FREE, OCCUPIED, OccupancyGrid
from jackson.host.nav.likelihood import LikelihoodField
from jackson.host.nav.types import Pose2D, Scan
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles

FloatArray = npt.NDArray[np.float64]

SCAN_PERIOD_S = 0.13465  # REFERENCE: A1M8 scan period
RESOLUTION_M = 0.05
ROOM = [(0.0, 0.0), (2.5, 0.0), (2.5, 1.5), (0.0, 1.5)]
INNER_WALLS = [(0.8, 0.0, 0.8, 0.75), (1.7, 1.5, 1.7, 0.8)]
CYLINDER = (1.0, 0.4, 0.1)
MOUNT = Pose2D(0.05, 0.0, 0.0)
START = Pose2D(0.35, 0.35, math.pi / 2)
# Straight legs and in-place turns through both gaps of the maze [m], [rad].
ROUTE: list[tuple[str, float]] = [
    ("drive", 0.8),
    ("turn", -math.pi / 2),
    ("drive", 0.9),
    ("turn", -math.pi / 2),
    ("drive", 0.75),
    ("turn", math.pi / 2),
    ("drive", 0.85),
    ("turn", math.pi / 2),
    ("drive", 0.75),
]
V_M_S = 0.1
OMEGA_RAD_S = 0.5


def _world() -> Obstacles:
    world = Obstacles(INNER_WALLS, [CYLINDER])
    world.add_polygon(ROOM)
    return world


def _rasterise(world: Obstacles) -> OccupancyGrid:
    """Free room, the shapes' cells occupied (points every quarter cell along each shape).

    The origin puts every wall on a row or column of cell centres, so the map is not offset
    from the world by the rasterisation (which would add up to half a cell of bias).
    """
    grid = OccupancyGrid.empty(2.85, 1.85, RESOLUTION_M, -0.175, -0.175, fill=FREE)
    step = RESOLUTION_M / 4
    points = []
    for x1, y1, x2, y2 in world.segments:
        n = max(2, math.ceil(math.hypot(x2 - x1, y2 - y1) / step) + 1)
        t = np.linspace(0.0, 1.0, n)
        points.append(np.column_stack((x1 + t * (x2 - x1), y1 + t * (y2 - y1))))
    for cx, cy, r in world.circles:
        a = np.linspace(0.0, 2 * math.pi, max(8, math.ceil(2 * math.pi * r / step)))
        points.append(np.column_stack((cx + r * np.cos(a), cy + r * np.sin(a))))
    xy = np.vstack(points)
    row, col = grid.world_to_cell(xy[:, 0], xy[:, 1])
    inside = grid.inside(row, col)
    grid.data[row[inside], col[inside]] = OCCUPIED
    return grid


@dataclass
class Drive:
    """A drive through the room: true poses, drifting odometry and scans at each scan time."""

    truth: list[Pose2D]
    odom: list[Pose2D]
    scans: list[Scan]


def _drive(
    seed: int = 7,
    distance_scale: float = 1.015,
    yaw_scale: float = 1.015,
    unmapped: tuple[tuple[float, float, float], ...] = (),
) -> Drive:
    rng = np.random.default_rng(seed)
    world = _world()
    for circle in unmapped:
        world.add_circle(*circle)
    lidar = Lidar(LidarSpec(mount_x_m=MOUNT.x), rng)
    angles = lidar.angles()
    steps: list[tuple[float, float]] = []  # (ds [m], dyaw [rad]) per scan period
    for kind, amount in ROUTE:
        rate = V_M_S if kind == "drive" else OMEGA_RAD_S
        n = math.ceil(abs(amount) / (rate * SCAN_PERIOD_S))
        per = amount / n
        steps += [(per, 0.0) if kind == "drive" else (0.0, per)] * n
    truth, odom = [START], [Pose2D()]
    for ds, dyaw in steps:
        truth.append(truth[-1].compose(Pose2D(ds, 0.0, dyaw)))
        ods = ds * distance_scale + rng.normal(0.0, 0.0005)
        odyaw = dyaw * yaw_scale + rng.normal(0.0, 0.002)
        odom.append(odom[-1].compose(Pose2D(ods, 0.0, odyaw)))
    scans = [
        Scan(
            SCAN_PERIOD_S * k,
            angles,
            lidar.scan(p.x, p.y, p.yaw, world).astype(np.float64),
            range_max_m=8.0,
        )
        for k, p in enumerate(truth)
    ]
    return Drive(truth, odom, scans)


@dataclass
class Errors:
    position_m: FloatArray
    yaw_rad: FloatArray
    estimates: list[Pose2D]


def _run(pf: ParticleFilter, drive: Drive, initial: Pose2D, std_xy_m: float = 0.1) -> Errors:
    pf.initialise(initial, std_xy_m, 0.1)
    pos, yaw, est = [], [], []
    for truth, odom, scan in zip(drive.truth, drive.odom, drive.scans, strict=True):
        pf.update(odom, scan, MOUNT)
        e = pf.estimate()
        est.append(e)
        pos.append(e.distance(truth))
        yaw.append(abs(math.remainder(e.yaw - truth.yaw, 2 * math.pi)))
    return Errors(np.array(pos), np.array(yaw), est)


@pytest.fixture(scope="module")
def grid() -> OccupancyGrid:
    return _rasterise(_world())


@pytest.fixture(scope="module")
def drive() -> Drive:
    return _drive()


def test_odometry_of_the_test_drive_drifts(drive: Drive) -> None:
    # what the filter has to correct: odometry alone, anchored at the start
    ends = [START.compose(o) for o in drive.odom]
    drift = [e.distance(t) for e, t in zip(ends, drive.truth, strict=True)]
    yaw = [
        abs(math.remainder(e.yaw - t.yaw, 2 * math.pi))
        for e, t in zip(ends, drive.truth, strict=True)
    ]
    print(f"\nodometry drift: max {max(drift):.3f} m, {math.degrees(max(yaw)):.1f} deg")
    assert max(drift) > 0.05
    assert math.degrees(max(yaw)) > 2.0


def test_tracks_the_twin_through_the_maze(grid: OccupancyGrid, drive: Drive) -> None:
    pf = ParticleFilter(grid, AmclConfig(), np.random.default_rng(1))
    err = _run(pf, drive, START)
    print(
        f"\ntracking: position error mean {err.position_m.mean():.4f} m, "
        f"max {err.position_m.max():.4f} m; yaw error mean "
        f"{math.degrees(err.yaw_rad.mean()):.2f} deg, max {math.degrees(err.yaw_rad.max()):.2f} "
        f"deg; {pf.sensor_updates} sensor updates, {pf.resamples} resamples over "
        f"{len(drive.scans)} scans, {pf.particle_count} particles"
    )
    assert err.position_m.mean() < 0.03
    assert err.position_m.max() < 0.08
    assert err.yaw_rad.mean() < math.radians(1.5)
    assert err.yaw_rad.max() < math.radians(5.0)
    assert pf.resamples == pf.sensor_updates > len(drive.scans) // 6
    assert pf.motion_updates == pf.sensor_updates - 1  # the first scan only anchors
    cov = pf.covariance()
    assert cov.shape == (3, 3) and np.allclose(cov, cov.T)
    assert np.all(np.linalg.eigvalsh(cov) >= 0.0)
    sd = np.sqrt(np.diag(cov))
    print(f"final spread: sd x {sd[0]:.3f} m, y {sd[1]:.3f} m, yaw {math.degrees(sd[2]):.1f} deg")
    # AMCL's flat weighting keeps the cloud wider than the error: cautious, not optimistic
    assert sd[0] < 0.1 and sd[1] < 0.1 and sd[2] < 0.2
    assert err.position_m[-1] < 2 * min(sd[0], sd[1]) and err.yaw_rad[-1] < 2 * sd[2]


def test_recovers_from_an_initial_pose_off_by_0_2_m_and_0_2_rad(
    grid: OccupancyGrid, drive: Drive
) -> None:
    off = START.compose(Pose2D(0.2 / math.sqrt(2), -0.2 / math.sqrt(2), 0.2))
    assert off.distance(START) == pytest.approx(0.2)
    pf = ParticleFilter(grid, AmclConfig(), np.random.default_rng(2))
    err = _run(pf, drive, off)
    near = np.flatnonzero(err.position_m < 0.05)[0]
    settled = np.flatnonzero((err.position_m < 0.05) & (err.yaw_rad < math.radians(3.0)))[0]
    later = round(15.0 / SCAN_PERIOD_S)
    print(
        f"\nrecovery: error {err.position_m[0]:.3f} m / {math.degrees(err.yaw_rad[0]):.1f} deg "
        f"at the start; within 5 cm after {near * SCAN_PERIOD_S:.1f} s, within 5 cm and 3 deg "
        f"after {settled * SCAN_PERIOD_S:.1f} s; after 15 s: position mean "
        f"{err.position_m[later:].mean():.4f} m, max {err.position_m[later:].max():.4f} m, yaw "
        f"max {math.degrees(err.yaw_rad[later:].max()):.2f} deg"
    )
    assert err.position_m[0] > 0.15 and err.yaw_rad[0] > 0.15
    assert near * SCAN_PERIOD_S < 6.0
    assert settled * SCAN_PERIOD_S < 15.0
    assert err.position_m[later:].max() < 0.05
    assert err.yaw_rad[later:].max() < math.radians(5.0)


def test_tracks_past_an_obstacle_missing_from_the_map(grid: OccupancyGrid) -> None:
    # Stage 3's cylinder (r 0.125 m) appears after the map was made; here one stands beside
    # the lower gap and another in the upper left, neither in the grid
    drive = _drive(unmapped=((1.45, 0.13, 0.125), (0.6, 0.85, 0.12)))
    pf = ParticleFilter(grid, AmclConfig(), np.random.default_rng(3))
    err = _run(pf, drive, START)
    print(
        f"\nunmapped cylinders: position error mean {err.position_m.mean():.4f} m, max "
        f"{err.position_m.max():.4f} m; yaw error max {math.degrees(err.yaw_rad.max()):.2f} deg"
    )
    assert err.position_m.mean() < 0.03
    assert err.position_m.max() < 0.07
    assert err.yaw_rad.max() < math.radians(8.0)


def test_same_seed_same_inputs_bit_identical(grid: OccupancyGrid, drive: Drive) -> None:
    short = Drive(drive.truth[:60], drive.odom[:60], drive.scans[:60])
    runs = []
    for _ in range(2):
        pf = ParticleFilter(grid, AmclConfig(), np.random.default_rng(123))
        err = _run(pf, short, START)
        runs.append((err.estimates, pf.particles, pf.weights))
    assert runs[0][0] == runs[1][0]
    assert np.array_equal(runs[0][1], runs[1][1]) and np.array_equal(runs[0][2], runs[1][2])
    other = ParticleFilter(grid, AmclConfig(), np.random.default_rng(124))
    _run(other, short, START)
    assert not np.array_equal(other.particles[:10], runs[0][1][:10])


@pytest.mark.parametrize("motion", [Pose2D(0.3, 0.0, 0.0), Pose2D(0.0, 0.0, 1.0)])
def test_motion_spread_grows_with_alpha(motion: Pose2D) -> None:
    start = np.zeros((4000, 3))
    spreads = []
    for alpha in (0.0, 0.05, 0.2, 0.8):
        moved = sample_motion_model_odometry(
            start, Pose2D(), motion, (alpha,) * 4, np.random.default_rng(5)
        )
        assert moved[:, 0].mean() == pytest.approx(motion.x, abs=0.02)
        assert np.median(moved[:, 2]) == pytest.approx(motion.yaw, abs=0.02)
        spreads.append(float(np.linalg.det(np.cov(moved.T) + 1e-12 * np.eye(3))))
    assert spreads[0] < 1e-30  # no noise at all
    assert spreads[0] < spreads[1] < spreads[2] < spreads[3]


def test_motion_model_follows_odometry_in_each_particles_frame() -> None:
    particles = np.array([[1.0, 2.0, 0.0], [0.0, 0.0, math.pi / 2]])
    # odometry: forward 0.5 m along its own heading of pi, then a 0.3 rad turn
    moved = sample_motion_model_odometry(
        particles,
        Pose2D(5.0, 5.0, math.pi),
        Pose2D(4.5, 5.0, math.pi + 0.3),
        (0.0,) * 4,
        np.random.default_rng(0),
    )
    assert moved[0] == pytest.approx([1.5, 2.0, 0.3])
    assert moved[1] == pytest.approx([0.0, 0.5, math.pi / 2 + 0.3])


def test_backward_driving_is_as_noisy_as_forward_driving() -> None:
    spread = []
    for dx in (0.3, -0.3):
        moved = sample_motion_model_odometry(
            np.zeros((4000, 3)),
            Pose2D(),
            Pose2D(dx, 0.0, 0.0),
            (0.2,) * 4,
            np.random.default_rng(3),
        )
        spread.append(float(np.std(moved[:, 2])))
    assert spread[1] == pytest.approx(spread[0], rel=0.1)


def test_map_to_odom_composed_with_odometry_gives_the_estimate(
    grid: OccupancyGrid, drive: Drive
) -> None:
    pf = ParticleFilter(grid, AmclConfig(), np.random.default_rng(4))
    pf.initialise(START)
    for k, (odom, scan) in enumerate(zip(drive.odom, drive.scans, strict=True)):
        pf.update(odom, scan if k % 3 == 0 else None, MOUNT)
        correction = pf.map_to_odom(odom)
        mine, again = correction.compose(odom), pf.estimate()
        assert (mine.x, mine.y, mine.yaw) == pytest.approx((again.x, again.y, again.yaw))
    # and it is the true correction: the map pose of the odometry frame's origin
    true_correction = drive.truth[-1].compose(drive.odom[-1].inverse())
    assert correction.distance(true_correction) < 0.08
    assert abs(math.remainder(correction.yaw - true_correction.yaw, 2 * math.pi)) < 0.05


def test_sensor_update_only_after_moving_update_min_d_or_a(
    grid: OccupancyGrid, drive: Drive
) -> None:
    pf = ParticleFilter(
        grid, AmclConfig(update_min_d=0.1, update_min_a=0.3), np.random.default_rng(0)
    )
    pf.initialise(START)
    scan = drive.scans[0]
    assert pf.update(Pose2D(), None) is False
    assert pf.update(Pose2D(), scan, MOUNT) is True  # the first scan
    assert pf.update(Pose2D(0.09, 0.0, 0.0), scan, MOUNT) is False
    assert pf.update(Pose2D(0.0, 0.0, 0.29), scan, MOUNT) is False
    assert pf.update(Pose2D(0.08, 0.08, 0.0), scan, MOUNT) is True  # each < 0.1, 0.113 m apart
    assert pf.update(Pose2D(0.08, 0.08, -0.31), scan, MOUNT) is True
    assert (pf.sensor_updates, pf.resamples, pf.motion_updates) == (3, 3, 2)
    nothing = Scan(1.0, scan.angles_rad, np.full(scan.ranges_m.shape, np.inf))
    assert pf.update(Pose2D(1.0, 0.0, 0.0), nothing, MOUNT) is False
    assert pf.sensor_updates == 3


def test_kld_count_follows_the_spread_of_the_cloud(grid: OccupancyGrid, drive: Drive) -> None:
    limits = kld_particle_limit(np.arange(1, 400), 0.05, 0.99, 500, 2000)
    assert limits[0] == 500 and limits[-1] == 2000
    assert np.all(np.diff(limits) >= 0)
    assert kld_particle_limit(np.array([100]), 0.05, 0.99, 1, 10**6)[0] == pytest.approx(
        99 / 0.1 * (1 - 2 / 891 + math.sqrt(2 / 891) * 0.99) ** 3, abs=1
    )
    pf = ParticleFilter(grid, AmclConfig(), np.random.default_rng(6))
    pf.initialise(Pose2D(1.25, 0.75, 0.0), std_xy_m=1.0, std_yaw_rad=3.0)
    assert pf.particle_count == 2000
    pf.update(drive.odom[0], drive.scans[0], MOUNT)
    wide = pf.particle_count
    pf.initialise(START, std_xy_m=0.02, std_yaw_rad=0.02)
    pf.update(drive.odom[0], drive.scans[0], MOUNT)
    assert wide > 1000 and pf.particle_count == 500


def test_estimate_is_the_mean_of_the_heaviest_cluster() -> None:
    rng = np.random.default_rng(0)
    heavy = rng.normal((1.0, 1.0, 3.1), (0.05, 0.05, 0.05), (300, 3))  # straddles +-pi
    light = rng.normal((3.0, 1.0, 0.0), (0.05, 0.05, 0.05), (200, 3))
    particles = np.vstack((heavy, light))
    particles[:, 2] = (particles[:, 2] + math.pi) % (2 * math.pi) - math.pi
    bins, yaw_bins = histogram_bins(particles, 0.5, math.radians(10.0))
    assert yaw_bins == 36
    members = heaviest_cluster(bins, yaw_bins, np.full(500, 1 / 500))
    assert members[:300].all() and not members[300:].any()
    weights = np.r_[np.full(300, 0.2 / 300), np.full(200, 0.8 / 200)]
    members = heaviest_cluster(bins, yaw_bins, weights)
    assert not members[:300].any() and members[300:].all()


def test_systematic_resampling_draws_each_particle_floor_or_ceil_of_its_share() -> None:
    w = np.array([0.5, 0.25, 0.125, 0.0, 0.125])
    for seed in range(5):
        counts = np.bincount(systematic_resample(w, 10, np.random.default_rng(seed)), minlength=5)
        assert counts.sum() == 10 and counts[3] == 0
        assert np.all(np.abs(counts - w * 10) < 1.0)


@pytest.mark.parametrize("alphas", [(0.0, 0.0), (0.001, 0.5)])
def test_random_particles_are_injected_when_the_scan_stops_fitting(
    grid: OccupancyGrid, drive: Drive, alphas: tuple[float, float]
) -> None:
    config = AmclConfig(recovery_alpha_slow=alphas[0], recovery_alpha_fast=alphas[1])
    pf = ParticleFilter(grid, config, np.random.default_rng(8))
    pf.initialise(START)
    most = 0
    for odom, scan in zip(drive.odom[:40], drive.scans[:40], strict=True):
        before = pf.injected
        pf.update(odom, scan, MOUNT)
        most = max(most, pf.injected - before)
    # kidnapped: the scan from the other end of the room arrives with the next odometry
    before = pf.injected
    assert pf.update(drive.odom[44], drive.scans[-1], MOUNT)
    kidnap = pf.injected - before
    here = pf.estimate()
    far = np.hypot(*(pf.particles[:, :2] - (here.x, here.y)).T) > 0.5
    print(f"\ninjected: at most {most} per tracking update, {kidnap} at the kidnapping")
    if alphas == (0.0, 0.0):
        assert pf.injected == 0 and not far.any()  # Nav2's default: off
    else:
        assert kidnap > max(20, 3 * most)
        assert np.count_nonzero(far) >= kidnap * 0.6
        assert grid.data[grid.world_to_cell(*pf.particles[far, :2].T)].max() == FREE


def test_distance_field_and_config_checks(grid: OccupancyGrid) -> None:
    with pytest.raises(ValueError, match="max_particles"):
        AmclConfig(min_particles=600, max_particles=500)
    with pytest.raises(ValueError, match="sigma_hit"):
        AmclConfig(sigma_hit=0.0)
    with pytest.raises(ValueError, match="max_beams"):
        AmclConfig(max_beams=1)
    with pytest.raises(ValueError, match="laser_max_range"):
        AmclConfig(laser_min_range=9.0)
    pf = ParticleFilter(grid, AmclConfig(), np.random.default_rng(0))
    with pytest.raises(LocalizationError, match="initialise"):
        pf.update(Pose2D(), None)
    with pytest.raises(ValueError, match="std_xy_m"):
        pf.initialise(Pose2D(), std_xy_m=-1.0)
    field = pf._field
    # on the inner wall x = 0.8, two cells beside it, near the cylinder, far off the map
    points = np.array([[0.8, 0.65], [0.9, 0.65], [1.0, 0.2], [9.0, 9.0]])
    d = field.distance_at(points)
    assert d[0] == 0.0 and d[1] == pytest.approx(0.1)
    assert d[2] == pytest.approx(0.1, abs=0.03) and d[3] == 2.0
    assert field.distance_at(points.reshape(2, 2, 2)).shape == (2, 2)


def test_the_likelihood_field_keeps_the_arithmetic_recorded_runs_replay(
    grid: OccupancyGrid,
) -> None:
    # to the last bit: the transform in cells times the resolution (not sampling=resolution)
    # and a point's cell floor((x - origin) * (1 / resolution)), off the map the cap
    field = ParticleFilter(grid, AmclConfig(), np.random.default_rng(0))._field
    assert isinstance(field, LikelihoodField)
    cells = np.asarray(distance_transform_edt(~grid.occupied()), np.float64)
    assert np.array_equal(field.distance_m, np.minimum(cells * grid.resolution_m, 2.0))
    res, inv = grid.resolution_m, 1.0 / grid.resolution_m
    edges_x = grid.origin_x_m + np.arange(-2, grid.width + 3) * res
    edges_y = grid.origin_y_m + np.arange(-2, grid.height + 3) * res
    x = np.concatenate([edges_x, np.nextafter(edges_x, -1e9), np.nextafter(edges_x, 1e9)])
    y = np.concatenate([edges_y, np.nextafter(edges_y, -1e9), np.nextafter(edges_y, 1e9)])
    x, y = np.meshgrid(x, y)
    col = np.floor((x - grid.origin_x_m) * inv).astype(np.int64)
    row = np.floor((y - grid.origin_y_m) * inv).astype(np.int64)
    inside = grid.inside(row, col)
    rows, cols = np.clip(row, 0, grid.height - 1), np.clip(col, 0, grid.width - 1)
    expected = np.where(inside, field.distance_m[rows, cols], 2.0)
    assert np.array_equal(field.distance_xy(x, y), expected)
    assert np.array_equal(field.distance_at(np.stack((x, y), axis=-1)), expected)


def test_sensor_update_fits_in_the_scan_period(grid: OccupancyGrid, drive: Drive) -> None:
    # reference in the same run: the twin casting one full 1080-beam scan
    lidar, world = Lidar(LidarSpec(), np.random.default_rng(0)), _world()
    t0 = time.perf_counter()
    for _ in range(20):
        lidar.scan(1.0, 1.0, 0.0, world)
    cast_ms = (time.perf_counter() - t0) / 20 * 1e3
    report = []
    for n in (500, 2000):
        config = AmclConfig(min_particles=n, max_particles=n, update_min_d=0.0, update_min_a=0.0)
        pf = ParticleFilter(grid, config, np.random.default_rng(0))
        pf.initialise(START)
        pf.update(drive.odom[0], drive.scans[0], MOUNT)
        best = math.inf
        for k in range(1, 16):
            t0 = time.perf_counter()
            assert pf.update(drive.odom[k], drive.scans[k], MOUNT)
            pf.estimate()
            pf.covariance()
            best = min(best, time.perf_counter() - t0)
        ms = best * 1e3
        report.append(
            f"{n} particles x 60 beams: {ms:.2f} ms per update and estimate "
            f"({ms / cast_ms:.1f} x one 1080-beam cast of {cast_ms:.2f} ms; "
            f"{ms / (SCAN_PERIOD_S * 1e3):.1%} of the 134.65 ms scan period)"
        )
        assert ms < SCAN_PERIOD_S * 1e3 / 2
    print("\n" + "\n".join(report))


def test_config_replace_keeps_validation() -> None:
    with pytest.raises(ValueError, match="resample_interval"):
        replace(AmclConfig(), resample_interval=0)
