"""Deskewing a revolution measured while the robot moved (:mod:`jackson.host.nav.deskew`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jackson.host.nav.deskew import beam_shares, deskew
from jackson.host.nav.types import Pose2D, Scan
from jackson.sim.lidar import MOVING_CHUNKS, Lidar, LidarSpec, Obstacles

HALF_M = 3.0  # a 6 m square room


def room() -> Obstacles:
    walls = Obstacles()
    h = HALF_M
    walls.add_polygon([(-h, -h), (h, -h), (h, h), (-h, h)])
    return walls


def off_wall_m(scan: Scan, base: Pose2D, mount: Pose2D) -> np.ndarray:
    """How far each return, placed from the sensor at ``base``, lies from the room's walls."""
    ok = scan.valid
    pts = scan.points(base, mount)
    d = HALF_M - np.maximum(np.abs(pts[:, 0]), np.abs(pts[:, 1]))
    assert len(d) == ok.sum()
    return np.abs(d)


@pytest.mark.parametrize(
    ("start", "end"),
    [
        ((0.3, -0.2, 0.4), (0.3 + 0.035 * math.cos(0.4), -0.2 + 0.035 * math.sin(0.4), 0.4)),
        ((0.3, -0.2, 0.4), (0.3, -0.2, 0.4 + 0.135)),  # a pivot at 1 rad/s
        ((-0.5, 0.6, -2.0), (-0.48, 0.62, -2.0 - 0.1)),  # an arc, turning right
    ],
)
def test_a_revolution_measured_on_the_move_lands_on_the_walls_once_deskewed(
    start: tuple[float, float, float], end: tuple[float, float, float]
) -> None:
    spec = LidarSpec(noise_sigma_m=0.0, mount_x_m=0.05, mount_y_m=-0.01, mount_yaw_rad=0.02)
    mount = Pose2D(spec.mount_x_m, spec.mount_y_m, spec.mount_yaw_rad)
    lidar = Lidar(spec, np.random.default_rng(0))
    ranges, _ = lidar.scan_moving(start, end, room())
    scan = Scan(1.0, lidar.angles(), ranges.astype(np.float64))
    s0, s1 = Pose2D(*start), Pose2D(*end)
    raw = off_wall_m(scan, s1, mount)
    fixed = deskew(scan, mount, s0.inverse().compose(s1))
    after = off_wall_m(fixed, s1, mount)
    # the twin casts a turn in pieces of 1/MOVING_CHUNKS: within half a piece of the motion
    piece_m = math.hypot(end[0] - start[0], end[1] - start[1]) + 4.3 * abs(end[2] - start[2])
    assert after.max() < piece_m / MOVING_CHUNKS
    assert raw.max() > 10 * after.max()
    # the same beams, no return left where it was; and taken at the start instead
    assert fixed.angles_rad.shape == scan.angles_rad.shape
    assert np.array_equal(np.isinf(fixed.ranges_m), np.isinf(scan.ranges_m))
    at_start = deskew(scan, mount, s0.inverse().compose(s1), at=0.0)
    assert off_wall_m(at_start, s0, mount).max() < piece_m / MOVING_CHUNKS


def test_a_revolution_of_a_robot_standing_still_is_left_as_it_is() -> None:
    scan = Scan(0.0, np.linspace(-math.pi, math.pi, 8, endpoint=False), np.full(8, 2.0))
    assert deskew(scan, Pose2D(), Pose2D()) is scan


def test_the_head_measures_clockwise_from_its_zero_mark() -> None:
    # heading h = -angle: straight ahead first, then the right side, the back, the left last
    shares = beam_shares(np.array([0.0, -math.pi / 2, -math.pi, math.pi / 2, 0.01]))
    assert shares[:4] == pytest.approx([0.0, 0.25, 0.5, 0.75])
    assert shares[4] == pytest.approx(1.0 - 0.01 / math.tau)
