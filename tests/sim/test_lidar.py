"""The LiDAR model: exact ray casting checked against pymunk, the A1M8's beams, limits, noise."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pymunk
import pytest
from numpy.typing import NDArray

from jackson.sim.bench_lidar import scans_per_second, square_room
from jackson.sim.lidar import MOVING_CHUNKS, Lidar, LidarSpec, Obstacles, cast

EXACT = LidarSpec(noise_sigma_m=0.0)
GRAZE_M = 1e-9  # random tests skip beams passing this close to an endpoint or a tangent point


def room(half_x_m: float, half_y_m: float | None = None) -> Obstacles:
    """Four walls around the origin."""
    hx, hy = half_x_m, half_x_m if half_y_m is None else half_y_m
    obstacles = Obstacles()
    obstacles.add_polygon([(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)])
    return obstacles


def nearest_beam(lidar: Lidar, angle_rad: float) -> int:
    return int(np.argmin(np.abs(lidar.angles() - angle_rad)))


# ---- agreement with pymunk ------------------------------------------------------------------


def pymunk_ranges(
    obstacles: Obstacles, origin: tuple[float, float], angles: NDArray[np.float64], max_range: float
) -> NDArray[np.float64]:
    """``Space.segment_query_first`` from the origin to ``max_range`` along each angle."""
    space = pymunk.Space()
    for x1, y1, x2, y2 in obstacles.segments:
        space.add(pymunk.Segment(space.static_body, (x1, y1), (x2, y2), 0.0))
    for cx, cy, r in obstacles.circles:
        space.add(pymunk.Circle(space.static_body, r, (cx, cy)))
    out = np.full(len(angles), np.inf)
    for i, a in enumerate(angles):
        end = (origin[0] + max_range * math.cos(a), origin[1] + max_range * math.sin(a))
        info = space.segment_query_first(origin, end, 0.0, pymunk.ShapeFilter())
        if info is not None:
            out[i] = info.alpha * max_range
    return out


def random_scene(rng: np.random.Generator, walls: bool) -> tuple[Obstacles, tuple[float, float]]:
    """A 6 m room (or open floor) with random segments and cylinders, and a free origin in it."""
    obstacles = room(3.0) if walls else Obstacles()
    for _ in range(rng.integers(5, 15)):
        x, y = rng.uniform(-2.8, 2.8, 2)
        length, heading = rng.uniform(0.1, 2.0), rng.uniform(-np.pi, np.pi)
        obstacles.add_segment(x, y, x + length * math.cos(heading), y + length * math.sin(heading))
    for _ in range(rng.integers(1, 6)):
        x, y = rng.uniform(-2.5, 2.5, 2)
        obstacles.add_circle(x, y, rng.uniform(0.05, 0.4))
    while True:
        o = rng.uniform(-2.7, 2.7, 2)
        c = obstacles.circles
        if (np.hypot(c[:, 0] - o[0], c[:, 1] - o[1]) > c[:, 2] + 0.01).all():
            return obstacles, (float(o[0]), float(o[1]))


def clear_beams(
    obstacles: Obstacles, origin: tuple[float, float], angles: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Beams that pass no segment endpoint and touch no circle tangentially (within GRAZE_M)."""
    d = np.stack((np.cos(angles), np.sin(angles)), axis=1)
    ends = np.concatenate((obstacles.segments[:, :2], obstacles.segments[:, 2:]))
    rel = ends - origin
    off = np.abs(d[:, :1] * rel[:, 1] - d[:, 1:] * rel[:, 0])
    grazes = ((off < GRAZE_M) & (d @ rel.T > 0.0)).any(axis=1)
    g = obstacles.circles[:, :2] - origin
    miss_by = np.abs(np.abs(d[:, :1] * g[:, 1] - d[:, 1:] * g[:, 0]) - obstacles.circles[:, 2])
    grazes |= (miss_by < GRAZE_M).any(axis=1)
    return np.asarray(~grazes, dtype=np.bool_)


@pytest.mark.parametrize("seed", range(6))
def test_cast_agrees_with_pymunk_in_random_rooms(seed: int) -> None:
    rng = np.random.default_rng(seed)
    obstacles, origin = random_scene(rng, walls=True)
    angles = rng.uniform(-np.pi, np.pi) + Lidar(EXACT, rng).angles()
    keep = clear_beams(obstacles, origin, angles)
    assert keep.sum() > 1000
    ours = cast(origin, angles[keep], obstacles, 12.0)
    theirs = pymunk_ranges(obstacles, origin, angles[keep], 12.0)
    assert np.isfinite(ours).all()
    np.testing.assert_allclose(ours, theirs, rtol=0.0, atol=1e-6)


@pytest.mark.parametrize("seed", range(6))
def test_cast_agrees_with_pymunk_on_hits_and_misses_in_the_open(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    obstacles, origin = random_scene(rng, walls=False)
    angles = rng.uniform(-np.pi, np.pi, 2000)
    keep = clear_beams(obstacles, origin, angles)
    ours = cast(origin, angles[keep], obstacles, 2.5)
    theirs = pymunk_ranges(obstacles, origin, angles[keep], 2.5)
    assert np.isinf(ours).any() and np.isfinite(ours).any()
    np.testing.assert_array_equal(np.isinf(ours), np.isinf(theirs))
    np.testing.assert_allclose(ours, theirs, rtol=0.0, atol=1e-6)


@pytest.mark.parametrize("seed", range(3))
def test_beams_through_segment_endpoints_hit_the_endpoint_or_what_lies_behind(seed: int) -> None:
    rng = np.random.default_rng(200 + seed)
    obstacles, origin = random_scene(rng, walls=True)
    ends = np.concatenate((obstacles.segments[:, :2], obstacles.segments[:, 2:]))
    rel = ends - origin
    angles = np.arctan2(rel[:, 1], rel[:, 0])
    to_end = np.hypot(rel[:, 0], rel[:, 1])
    ours = cast(origin, angles, obstacles, 12.0)
    theirs = pymunk_ranges(obstacles, origin, angles, 12.0)
    for r_ours, r_theirs, r_end in zip(ours, theirs, to_end, strict=True):
        assert (
            math.isclose(r_ours, r_theirs, abs_tol=1e-6)
            or math.isclose(r_ours, r_end, abs_tol=1e-6)
            or math.isclose(r_theirs, r_end, abs_tol=1e-6)
        )


# ---- hand-computed cases --------------------------------------------------------------------


def test_beam_at_0_rad_from_the_centre_of_a_4_m_room_reads_2_m() -> None:
    ranges = cast((0.0, 0.0), np.array([0.0, np.pi / 2, np.pi, -np.pi / 2]), room(2.0), 12.0)
    np.testing.assert_allclose(ranges, 2.0, atol=1e-12)


def test_beam_into_a_room_corner_does_not_escape() -> None:
    ranges = cast((0.0, 0.0), np.array([np.pi / 4, 3 * np.pi / 4, -3 * np.pi / 4]), room(2.0), 12.0)
    np.testing.assert_allclose(ranges, 2.0 * math.sqrt(2.0), atol=1e-9)


def test_cylinder_of_radius_0_125_at_1_m_reads_0_875() -> None:
    obstacles = room(2.0)
    obstacles.add_circle(1.0, 0.0, 0.125)
    assert cast((0.0, 0.0), np.array([0.0]), obstacles, 12.0)[0] == pytest.approx(0.875, abs=1e-12)


def test_an_obstacle_at_0_1_m_reads_inf() -> None:
    obstacles = room(2.0)
    obstacles.add_segment(0.1, -0.5, 0.1, 0.5)
    lidar = Lidar(EXACT, np.random.default_rng(0))
    ranges = lidar.scan(0.0, 0.0, 0.0, obstacles)
    assert np.isinf(ranges[nearest_beam(lidar, 0.0)])
    assert ranges[nearest_beam(lidar, np.pi / 2)] == pytest.approx(2.0, abs=1e-5)


def test_beyond_range_max_reads_inf() -> None:
    assert np.isinf(cast((0.0, 0.0), np.array([0.0, 1.0]), room(2.0), 1.5)).all()
    lidar = Lidar(EXACT, np.random.default_rng(0))
    assert np.isinf(lidar.scan(0.0, 0.0, 0.0, room(15.0))).all()
    inside = lidar.scan(0.0, 0.0, 0.0, room(11.9))
    assert np.isinf(inside).sum() > 0 and np.isfinite(inside).sum() > 0


def test_nothing_to_hit_reads_inf() -> None:
    assert np.isinf(cast((0.0, 0.0), np.linspace(-3, 3, 50), Obstacles(), 12.0)).all()


def test_a_ray_parallel_to_a_segment_misses_it() -> None:
    obstacles = Obstacles([[0.0, 1.0, 5.0, 1.0], [-1.0, -1.0, -1.0, 1.0]])
    assert np.isinf(cast((0.0, 0.0), np.array([0.0]), obstacles, 12.0)).all()
    assert cast((0.0, 0.0), np.array([np.pi]), obstacles, 12.0)[0] == pytest.approx(1.0)


def test_a_segment_along_the_ray_reads_its_near_end() -> None:
    for segment in ([1.0, 0.0, 3.0, 0.0], [3.0, 0.0, 1.0, 0.0]):
        ranges = cast((0.0, 0.0), np.array([0.0, np.pi, 0.5]), Obstacles([segment]), 12.0)
        assert ranges[0] == 1.0
        assert np.isinf(ranges[1:]).all()


def test_a_zero_length_segment_is_a_point() -> None:
    obstacles = Obstacles([[1.0, 0.0, 1.0, 0.0], [0.0, 2.0, 0.0, 2.0]])
    ranges = cast((0.0, 0.0), np.array([0.0, np.pi, 0.3, -np.pi / 2]), obstacles, 12.0)
    assert ranges[0] == 1.0
    assert np.isinf(ranges[1:]).all()


def test_an_origin_on_a_segment_reads_0_on_every_ray() -> None:
    obstacles = Obstacles([[-1.0, 0.0, 1.0, 0.0]])
    ranges = cast((0.25, 0.0), np.linspace(-3.0, 3.0, 7), obstacles, 12.0)
    np.testing.assert_array_equal(ranges, 0.0)


def test_a_ray_from_inside_a_circle_hits_its_boundary_where_it_leaves() -> None:
    obstacles = Obstacles(circles=[[0.0, 0.0, 1.0]])
    ranges = cast((0.5, 0.0), np.array([0.0, np.pi, np.pi / 2]), obstacles, 12.0)
    np.testing.assert_allclose(ranges, [0.5, 1.5, math.sqrt(0.75)], atol=1e-12)


def test_an_origin_on_a_circle_reads_0_on_every_ray() -> None:
    obstacles = Obstacles(circles=[[1.0, 0.0, 1.0]])
    np.testing.assert_array_equal(cast((0.0, 0.0), np.array([0.0, 2.0]), obstacles, 12.0), 0.0)


def test_a_circle_behind_the_origin_is_not_hit() -> None:
    obstacles = Obstacles(circles=[[-1.0, 0.0, 0.2]])
    ranges = cast((0.0, 0.0), np.array([0.0, np.pi]), obstacles, 12.0)
    assert np.isinf(ranges[0])
    assert ranges[1] == pytest.approx(0.8)


def test_the_nearest_of_several_obstacles_is_reported() -> None:
    obstacles = room(2.0)
    obstacles.add_circle(1.5, 0.0, 0.1)
    obstacles.add_segment(1.0, -0.1, 1.0, 0.1)
    assert cast((0.0, 0.0), np.array([0.0]), obstacles, 12.0)[0] == pytest.approx(1.0)


# ---- obstacles ------------------------------------------------------------------------------


def test_obstacles_hold_numpy_arrays_built_from_lists() -> None:
    obstacles = Obstacles([[0, 0, 1, 0], [1, 0, 1, 1]], [[2, 2, 0.5]])
    assert obstacles.segments.shape == (2, 4) and obstacles.segments.dtype == np.float64
    assert obstacles.circles.shape == (1, 3)
    np.testing.assert_array_equal(obstacles.segment_directions, [[1, 0], [0, 1]])
    with pytest.raises(ValueError):
        obstacles.segments[0, 0] = 5.0
    empty = Obstacles()
    assert empty.segments.shape == (0, 4) and empty.circles.shape == (0, 3)


@pytest.mark.parametrize(
    ("segments", "circles"),
    [([[0, 0, 1]], []), ([], [[0, 0]]), ([], [[0, 0, -1.0]]), ([[0, 0, 1, np.nan]], [])],
)
def test_malformed_obstacles_are_rejected(segments: Any, circles: Any) -> None:
    with pytest.raises(ValueError):
        Obstacles(segments, circles)


def test_a_cylinder_inserted_at_run_time_shows_in_the_next_scan() -> None:
    obstacles = room(3.0)
    lidar = Lidar(EXACT, np.random.default_rng(0))
    ahead = nearest_beam(lidar, 0.0)
    before = lidar.scan(-0.5, 0.0, 0.0, obstacles)
    obstacles.add_circle(0.6091 - 0.6909 + 0.5, 0.0, 0.125)
    after = lidar.scan(-0.5, 0.0, 0.0, obstacles)
    assert before[ahead] == pytest.approx(3.5, abs=1e-4)
    assert after[ahead] == pytest.approx(0.4182 + 0.5 - 0.125, abs=1e-4)


def test_a_copy_of_the_obstacles_is_independent() -> None:
    obstacles = room(2.0)
    copy = obstacles.copy()
    copy.add_circle(0.5, 0.0, 0.1)
    assert len(obstacles.circles) == 0 and len(copy.circles) == 1


# ---- the A1M8's beams and mount -------------------------------------------------------------


def test_a_scan_has_1080_beams_0_005807_rad_apart_from_minus_pi() -> None:
    lidar = Lidar(LidarSpec(), np.random.default_rng(0))
    angles = lidar.angles()
    assert len(angles) == 1080 and angles[0] == -math.pi
    np.testing.assert_allclose(np.diff(angles), 0.005807, rtol=0.0, atol=1e-12)
    assert lidar.spec.angle_max_rad == pytest.approx(angles[-1])
    ranges = lidar.scan(0.0, 0.0, 0.0, room(2.0))
    assert ranges.shape == (1080,) and ranges.dtype == np.float32


def test_the_a1m8_defaults() -> None:
    spec = LidarSpec()
    assert (spec.range_min_m, spec.range_max_m, spec.noise_sigma_m) == (0.15, 12.0, 0.01)
    assert 1 / spec.scan_period_s == pytest.approx(7.43, abs=0.005)
    assert spec.time_increment_s == pytest.approx(0.13465 / 1080)


def test_the_mount_offset_moves_the_sensor_origin() -> None:
    lidar = Lidar(LidarSpec(noise_sigma_m=0.0, mount_x_m=0.1), np.random.default_rng(0))
    ranges = lidar.scan(0.0, 0.0, 0.0, room(2.0))
    assert ranges[nearest_beam(lidar, 0.0)] == pytest.approx(1.9, abs=1e-4)
    assert ranges[0] == pytest.approx(2.1, abs=1e-4)  # the beam at -pi looks backwards


def test_the_mount_yaw_rotates_the_beams() -> None:
    obstacles = room(2.0, 3.0)  # walls at x = +/-2 m and y = +/-3 m
    lidar = Lidar(LidarSpec(noise_sigma_m=0.0, mount_yaw_rad=np.pi / 2), np.random.default_rng(0))
    assert lidar.scan(0.0, 0.0, 0.0, obstacles)[nearest_beam(lidar, 0.0)] == pytest.approx(3.0)
    assert lidar.scan(0.0, 0.0, -np.pi / 2, obstacles)[nearest_beam(lidar, 0.0)] == pytest.approx(
        2.0
    )


def test_a_scan_is_cast_from_the_sensor_pose_in_the_world() -> None:
    spec = LidarSpec(noise_sigma_m=0.0, mount_x_m=0.1, mount_y_m=-0.05, mount_yaw_rad=0.3)
    lidar = Lidar(spec, np.random.default_rng(0))
    obstacles = room(2.0, 3.0)
    obstacles.add_circle(0.8, 1.1, 0.125)
    x, y, yaw = 0.5, -0.2, 2.0
    sx = x + 0.1 * math.cos(yaw) + 0.05 * math.sin(yaw)
    sy = y + 0.1 * math.sin(yaw) - 0.05 * math.cos(yaw)
    assert lidar.sensor_pose(x, y, yaw) == pytest.approx((sx, sy, yaw + 0.3))
    expected = cast((sx, sy), yaw + 0.3 + lidar.angles(), obstacles, 12.0)
    np.testing.assert_allclose(lidar.scan(x, y, yaw, obstacles), expected, rtol=1e-6)
    # facing +y from (0.5, 0.1) with the mount yaw undone: ahead 2.9 m, left 2.5 m, right 1.5 m
    lidar = Lidar(LidarSpec(noise_sigma_m=0.0, mount_x_m=0.1), np.random.default_rng(0))
    ranges = lidar.scan(0.5, 0.0, np.pi / 2, room(2.0, 3.0))
    for angle, reading in ((0.0, 2.9), (np.pi / 2, 2.5), (-np.pi / 2, 1.5)):
        assert ranges[nearest_beam(lidar, angle)] == pytest.approx(reading, abs=1e-4)


# ---- noise, dropout, determinism ------------------------------------------------------------


def noise_samples(spec: LidarSpec, scans: int) -> tuple[NDArray[np.float64], NDArray[np.float32]]:
    lidar = Lidar(spec, np.random.default_rng(42))
    obstacles = room(2.0, 3.0)
    obstacles.add_circle(1.0, 1.0, 0.125)
    poses = np.random.default_rng(7).uniform((-1.5, -2.5, -np.pi), (1.5, 2.5, np.pi), (scans, 3))
    true = np.concatenate([lidar.true_ranges(x, y, yaw, obstacles) for x, y, yaw in poses])
    measured = np.concatenate([lidar.scan(x, y, yaw, obstacles) for x, y, yaw in poses])
    return true, measured


def test_range_noise_has_the_spec_sigma_of_0_01_m() -> None:
    true, measured = noise_samples(LidarSpec(), scans=20)
    error = measured[np.isfinite(measured)] - true[np.isfinite(measured)]
    assert len(error) > 20_000
    assert np.std(error) == pytest.approx(0.01, rel=0.05)
    assert abs(np.mean(error)) < 4 * 0.01 / math.sqrt(len(error))


def test_extra_noise_adds_in_variance() -> None:
    spec = LidarSpec(extra_noise_sigma_m=0.03)
    true, measured = noise_samples(spec, scans=20)
    error = measured[np.isfinite(measured)] - true[np.isfinite(measured)]
    assert spec.range_sigma_m == pytest.approx(math.sqrt(0.01**2 + 0.03**2))
    assert np.std(error) == pytest.approx(spec.range_sigma_m, rel=0.05)


def test_dropout_of_5_percent_drops_about_5_percent_of_beams() -> None:
    true, measured = noise_samples(LidarSpec(dropout_probability=0.05), scans=50)
    assert np.isfinite(true).all()
    assert np.isinf(measured).mean() == pytest.approx(0.05, abs=0.005)


def test_without_noise_a_scan_reads_the_exact_distances() -> None:
    true, measured = noise_samples(EXACT, scans=3)
    np.testing.assert_allclose(measured, true, rtol=1e-6)


def test_a_scan_is_deterministic_for_a_seed() -> None:
    spec = LidarSpec(extra_noise_sigma_m=0.03, dropout_probability=0.05)
    obstacles = room(2.0)
    first = Lidar(spec, np.random.default_rng(5))
    second = Lidar(spec, np.random.default_rng(5))
    other = Lidar(spec, np.random.default_rng(6))
    for pose in ((0.0, 0.0, 0.0), (0.3, -0.4, 1.0)):
        a, b, c = (lidar.scan(*pose, obstacles) for lidar in (first, second, other))
        np.testing.assert_array_equal(a, b)
        assert not np.array_equal(a, c)


@pytest.mark.parametrize(
    "bad",
    [
        {"beams": 0},
        {"angle_increment_rad": 0.0},
        {"range_min_m": 12.0},
        {"range_max_m": math.inf},
        {"scan_period_s": 0.0},
        {"noise_sigma_m": -0.01},
        {"dropout_probability": 1.5},
    ],
)
def test_an_impossible_spec_is_rejected(bad: dict[str, Any]) -> None:
    with pytest.raises(ValueError):
        LidarSpec(**bad)


# ---- benchmark helper -----------------------------------------------------------------------


def test_the_benchmark_room_and_rate() -> None:
    obstacles = square_room(40, 4)
    assert obstacles.segments.shape == (40, 4) and obstacles.circles.shape == (4, 3)
    lidar = Lidar(EXACT, np.random.default_rng(0))
    assert np.isfinite(lidar.scan(0.0, 0.0, 0.0, obstacles)).all()
    assert scans_per_second(seconds=0.05) > 0.0


def test_a_scan_of_a_turning_robot_casts_each_beam_from_the_pose_at_its_instant() -> None:
    # a head turning clockwise from its zero mark measures beam i at the share
    # mod(-angle_i, 2 pi) / 2 pi of the turn: the start's pose for the first, the end's near
    # the last, a pose between them in between
    walls = square_room(4, 3)
    spec = EXACT
    lidar = Lidar(spec, np.random.default_rng(0))
    start, end = (0.4, -0.3, 0.2), (0.5, -0.25, 0.35)  # 10 cm and 0.15 rad in a turn
    ranges, ahead = lidar.scan_moving(start, end, walls)
    share = lidar.beam_fractions()
    assert share.min() >= 0.0 and share.max() < 1.0
    for i in (10, 300, 540, 800, 1070):
        f = (math.floor(share[i] * MOVING_CHUNKS) + 0.5) / MOVING_CHUNKS  # its piece's middle
        pose = tuple(a + f * (b - a) for a, b in zip(start, end, strict=True))
        at_instant = Lidar(spec, np.random.default_rng(0)).scan(*pose, walls)[i]
        assert ranges[i] == pytest.approx(at_instant, abs=1e-5)
        static_end = Lidar(spec, np.random.default_rng(0)).scan(*end, walls)[i]
        if share[i] < 0.2:  # what the next turn's first beams read just after the end
            assert ahead[i] == pytest.approx(static_end, abs=1e-6)
        else:
            assert ahead[i] == ranges[i]
    # the first beams of the turn were measured a whole turn before the last ones
    first, last = int(np.argmin(share)), int(np.argmax(share))
    assert share[last] - share[first] > 0.99
    # standing still, the scan is the one-pose scan, draw for draw
    a, _ = Lidar(LidarSpec(), np.random.default_rng(5)).scan_moving(end, end, walls)
    b = Lidar(LidarSpec(), np.random.default_rng(5)).scan(*end, walls)
    assert np.array_equal(a, b)


@pytest.mark.parametrize(
    ("start", "end", "mount_y_m"),
    [
        ((2.0, 1.3, 0.3), (2.04, 1.33, 0.42), 0.02),
        # every sensor origin on the line of the shelf at y = 0: cast piece by piece instead
        ((-1.0, 0.0, 0.0), (-0.96, 0.0, 0.1), 0.0),
    ],
)
def test_every_beam_of_a_moving_scan_is_its_pieces_one_pose_cast(
    start: tuple[float, float, float], end: tuple[float, float, float], mount_y_m: float
) -> None:
    # the turn is cast in one batched pass; each beam must read what a cast from its piece's
    # middle pose alone reads, cylinders, mount offset and mount yaw included
    walls = square_room(6, 4)
    walls.add_circle(-2.0, 2.5, 0.2)
    walls.add_segment(1.0, 0.0, 2.0, 0.0)
    spec = LidarSpec(noise_sigma_m=0.0, mount_x_m=0.0, mount_y_m=mount_y_m, mount_yaw_rad=0.1)
    lidar = Lidar(spec, np.random.default_rng(0))
    moving = lidar.true_ranges_moving(start, end, walls)
    piece = np.minimum((lidar.beam_fractions() * MOVING_CHUNKS).astype(int), MOVING_CHUNKS - 1)
    expected = np.empty_like(moving)
    for c in range(MOVING_CHUNKS):
        f = (c + 0.5) / MOVING_CHUNKS
        pose = tuple(a + f * (b - a) for a, b in zip(start, end, strict=True))
        expected[piece == c] = lidar.true_ranges(*pose, walls)[piece == c]
    assert np.array_equal(np.isfinite(moving), np.isfinite(expected))
    ok = np.isfinite(moving)
    assert ok.sum() > 1000
    np.testing.assert_allclose(moving[ok], expected[ok], rtol=0, atol=1e-9)
