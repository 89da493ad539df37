"""The back-up recovery beside a wall: it backs away from the wall, never onto it, and with
nothing near it backs up straight as Nav2's does."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from jackson.common.robot import ENVELOPE_X_M, ENVELOPE_Y_M
from jackson.host.actuation.limiter import LimiterConfig, VelocityLimiter
from jackson.host.control.navigator_config import NavigatorConfig
from jackson.host.control.recovery import RECOVERIES, RecoveryBehaviours
from jackson.host.nav.costmap import Costmap
from jackson.host.nav.types import Pose2D
from jackson.sim.lidar import Obstacles

from ..stage3_course import DT_S, scan_points, unicycle

WALL_X = 1.813  # a wall along y, east of the robot, off the cells' edges
WEST_X = 0.013


def _corners(pose: Pose2D) -> np.ndarray:
    """The envelope's four corners in the map frame, shape (4, 2)."""
    lx = np.array([ENVELOPE_X_M[0], ENVELOPE_X_M[1], ENVELOPE_X_M[1], ENVELOPE_X_M[0]])
    ly = np.array([ENVELOPE_Y_M[0], ENVELOPE_Y_M[0], ENVELOPE_Y_M[1], ENVELOPE_Y_M[1]])
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return np.column_stack((pose.x + c * lx - s * ly, pose.y + s * lx + c * ly))


def _recover(
    pose: Pose2D, walls: tuple, names: tuple[str, ...] = ("backup",), seed: int = 0
) -> list[Pose2D]:
    """Recoveries ``names`` one after the other from ``pose`` in a corridor of ``walls``, the
    local costmap fed noisy A1M8 scans (sigma 0.01 m) as the robot goes; the poses it drove
    through."""
    cfg = NavigatorConfig()
    local_cfg = dataclasses.replace(cfg.costmap, track_unknown_space=False)
    local = Costmap.rolling_window(
        local_cfg, pose.x, pose.y, cfg.local_size_m, cfg.local_resolution_m
    )
    other = Costmap.rolling_window(
        local_cfg, pose.x, pose.y, cfg.local_size_m, cfg.local_resolution_m
    )
    world = Obstacles(segments=walls)
    rng = np.random.default_rng(seed)
    for _ in range(5):  # what the robot saw while it stood there
        local.update(scan_points(pose, world, rng, 0.01), (pose.x, pose.y))
    behaviours = RecoveryBehaviours(cfg, local, other)
    limits = LimiterConfig()
    limiter = VelocityLimiter(limits)
    t, poses, ticks = 0.0, [pose], 0
    for name in names:
        behaviours._next = RECOVERIES.index(name)
        assert behaviours.begin(t, pose)
        moving = True
        while moving:  # the recovery, then the braking after it
            out = behaviours.tick(t, pose, limits) if behaviours.current else None
            v, w = limiter.limit(*(out or (0.0, 0.0)), t)
            moving = out is not None or abs(v) > 1e-9 or abs(w) > 1e-9
            pose = unicycle(pose, v, w, DT_S)
            t += DT_S
            poses.append(pose)
            ticks += 1
            if ticks % 3 == 0:  # the A1M8's 7.43 Hz
                local.recentre(pose.x, pose.y)
                local.update(scan_points(pose, world, rng, 0.01), (pose.x, pose.y))
    return poses


CORRIDOR = ((WALL_X, 0.0, WALL_X, 8.0), (WEST_X, 0.0, WEST_X, 8.0))


def test_with_nothing_near_the_back_up_goes_straight_back() -> None:
    start = Pose2D(0.9, 4.0, math.pi / 2)  # mid-corridor, 0.9 m from each wall
    poses = _recover(start, CORRIDOR)
    end = poses[-1]
    assert end.yaw == pytest.approx(start.yaw, abs=1e-9)
    assert end.x == pytest.approx(start.x, abs=1e-9)
    assert start.y - end.y == pytest.approx(0.15, abs=0.01)


@pytest.mark.parametrize("turned_deg", [-9.0, 0.0, 9.0])
def test_beside_a_wall_too_near_to_turn_the_back_up_backs_away_from_it(
    turned_deg: float,
) -> None:
    """19.3 cm from a wall: the corners reach 19.1 cm, the noisy wall reads 3 cm nearer, so the
    robot cannot spin; straight back along the wall would leave it as near."""
    start = Pose2D(WALL_X - 0.193, 4.0, math.pi / 2 + math.radians(turned_deg))
    poses = _recover(start, CORRIDOR)
    gaps = [WALL_X - float(_corners(p)[:, 0].max()) for p in poses]
    assert min(gaps) > 0.0  # the body never reached the wall
    assert len(poses) > 20  # it drove, and did not stop at once
    end_centre_gap = WALL_X - poses[-1].x
    assert end_centre_gap > 0.193 + 0.005  # farther from the wall than it started


@pytest.mark.parametrize("turned_deg", [-9.0, 0.0])
def test_a_robot_too_near_a_wall_to_turn_turns_after_backing_away(turned_deg: float) -> None:
    """Facing along the wall or towards it: one back-up is enough (facing 9 degrees away from
    it, backing up nears the wall, and driving forward is the way out)."""
    start = Pose2D(WALL_X - 0.193, 4.0, math.pi / 2 + math.radians(turned_deg))
    stuck = _recover(start, CORRIDOR, ("spin",))
    assert len(stuck) == 2  # the corners would reach the wall: the spin does not start
    poses = _recover(start, CORRIDOR, ("backup", "spin"))
    assert min(WALL_X - float(_corners(p)[:, 0].max()) for p in poses) > 0.0
    turned = poses[-1].yaw - min(poses, key=lambda p: p.yaw).yaw
    assert turned > 1.5  # the spin's 1.57 rad, less its stop


def _wall_costmap(pose: Pose2D) -> Costmap:
    cfg = NavigatorConfig()
    local = Costmap.rolling_window(
        dataclasses.replace(cfg.costmap, track_unknown_space=False),
        pose.x, pose.y, cfg.local_size_m, cfg.local_resolution_m,
    )  # fmt: skip
    world, rng = Obstacles(segments=CORRIDOR), np.random.default_rng(3)
    for _ in range(5):
        local.update(scan_points(pose, world, rng, 0.01), (pose.x, pose.y))
    return local


def test_the_body_test_reads_a_noisy_wall_where_its_returns_mean_lies() -> None:
    pose = Pose2D(WALL_X - 0.193, 4.0, math.pi / 2)
    local = _wall_costmap(pose)
    depth, clearance = local.body_contacts(pose.x, pose.y, pose.yaw)
    assert depth[0] == -math.inf  # the body (side at 13.5 cm) is clear of the wall
    assert 0.178 < clearance[0] <= 0.193  # the wall within 1.5 cm of where it is
    # the footprint test's discs, as wide across the wall as the returns spread along it
    # and by noise, put it 3 cm nearer
    _, disc_clearance = local.checker.footprint_hits(
        np.array([pose.x]), np.array([pose.y]), np.array([pose.yaw]), True
    )
    assert disc_clearance[0] < 0.170
    # turned 45 degrees towards the wall, a corner (19.1 cm out) reaches into it
    depth, _ = local.body_contacts(pose.x, pose.y, pose.yaw - math.radians(45))
    assert depth[0] >= 0.0


def test_the_body_test_reads_only_what_is_still_in_the_window() -> None:
    pose = Pose2D(WALL_X - 0.193, 4.0, math.pi / 2)
    local = _wall_costmap(pose)
    local.recentre(pose.x - 1.2, pose.y - 1.2)  # the last scan's returns now partly outside
    depth, clearance = local.body_contacts(pose.x - 1.2, pose.y - 1.2, 0.0)
    assert depth[0] == -math.inf and clearance[0] > 0.5
