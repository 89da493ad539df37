"""The mapper takes each revolution with the base's pose at the revolution's end, where the
LiDAR's timeline puts it between the frame before and the one it came with, not at that
frame: in a turn, a frame late is a heading off by the turn rate times up to 50 ms. And the
base's pose, not the EKF's, which trails it by a frame (robot_localization's order: the pose
is predicted with the twist from before the frame's measurements)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jackson.host.config import HostConfig
from jackson.host.control.base import NavState
from jackson.host.control.navigate import NavigateConfig, NavigateMission
from jackson.host.lidar.scan_timer import SCAN_PERIOD_S
from jackson.host.nav.ekf_lag import MAX_LAG_S, base_pose
from jackson.host.nav.slam.mapper import MappingConfig
from jackson.host.nav.types import Pose2D, Scan

W_RAD_S = 1.0  # turning on the spot
FRAME_S = 0.05


def test_a_revolution_is_mapped_with_the_pose_at_its_end_not_at_its_frame() -> None:
    nav = NavigateConfig(
        start=Pose2D(),
        goals=(Pose2D(1.0, 0.0),),
        localisation="slam",
        mapping=MappingConfig(scan_matching=False, loop_closure=False),
    )
    mission = NavigateMission(nav, HostConfig().limits)
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    ends = [k * SCAN_PERIOD_S for k in range(1, 60)]  # each revolution's end on MCU time
    mapped: list[tuple[float, float, float]] = []  # (the revolution's end, its heading, time)
    behind: list[float] = []  # the navigator's heading against the base's at the frame
    for k in range(1, 160):
        t = k * FRAME_S
        # the EKF's heading at a frame is the base's at the frame before
        s = NavState(t, 0.0, 0.0, W_RAD_S * (t - FRAME_S), 0.0, W_RAD_S)
        mission.track(s)
        for end in [e for e in ends if t - FRAME_S < e <= t]:  # came with this frame
            before = mission.mapper.scans_integrated if mission.mapper else 0
            mission.on_scan(Scan(t, angles, np.full(360, 2.0)), s)
            assert mission.mapper is not None
            if mission.mapper.scans_integrated > before:
                node = mission.mapper.nodes[-1]
                mapped.append((end, node.odom.yaw, node.scan.t_s))
                # and the navigator's pose is the base's now, not a frame behind as the EKF's
                behind.append(abs(math.remainder(mission.pose_map().yaw - W_RAD_S * t, math.tau)))
    late = [abs(math.remainder(yaw - W_RAD_S * end, math.tau)) for end, yaw, _ in mapped[-20:]]
    # once the timer has the phase: within 3 ms of the end (0.003 rad), where the frame's own
    # heading was up to 0.05 rad ahead and the EKF's trailed by 0.05 rad
    assert len(late) == 20 and max(late) < 0.004
    assert all(abs(t - end) < 0.004 for end, _, t in mapped[-20:])  # the node's time: the end
    assert max(behind[-20:]) < 1e-9  # 0.05 rad (a frame of the turn) with the EKF's own pose


def test_the_base_pose_carries_the_ekf_pose_on_by_its_twist_over_the_frame() -> None:
    ahead = base_pose(Pose2D(1.0, 2.0, 0.0), 0.2, 0.0, 0.05)
    assert ahead == Pose2D(1.01, 2.0, 0.0)
    arc = base_pose(Pose2D(0.0, 0.0, math.pi / 2), 0.2, 1.0, 0.05)  # along the chord of an arc
    assert arc.yaw == math.pi / 2 + 0.05
    assert math.hypot(arc.x, arc.y) == pytest.approx(0.01)
    assert math.atan2(arc.y, arc.x) == pytest.approx(math.pi / 2 + 0.025)
    # a long gap (frames lost) carries the twist over two frames at most
    assert base_pose(Pose2D(), 0.2, 0.0, 1.0) == base_pose(Pose2D(), 0.2, 0.0, MAX_LAG_S)
    assert base_pose(Pose2D(), 0.2, 0.0, -1.0) == Pose2D()


@pytest.mark.parametrize("deskewed", [True, False])
def test_a_revolution_measured_in_a_turn_is_mapped_deskewed(deskewed: bool) -> None:
    # the twin's A1M8 measures each beam from the pose at its instant of the turn; at 1 rad/s a
    # revolution's first and last beams are 0.13 rad apart, which the mission takes out before
    # the mapper writes it
    from jackson.sim.lidar import Lidar, LidarSpec, Obstacles

    room = Obstacles()
    room.add_polygon([(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)])
    spec = LidarSpec(noise_sigma_m=0.0)
    lidar = Lidar(spec, np.random.default_rng(0))
    nav = NavigateConfig(
        start=Pose2D(),
        goals=(Pose2D(1.0, 0.0),),
        localisation="slam",
        deskew=deskewed,
        mapping=MappingConfig(scan_matching=False, loop_closure=False),
    )
    mission = NavigateMission(nav, HostConfig().limits)
    ends = [k * SCAN_PERIOD_S for k in range(1, 60)]
    off: list[float] = []  # the mapped returns' distance from the walls, once timed
    for k in range(1, 160):
        t = k * FRAME_S
        s = NavState(t, 0.0, 0.0, W_RAD_S * (t - FRAME_S), 0.0, W_RAD_S)
        mission.track(s)
        for end in [e for e in ends if t - FRAME_S < e <= t]:
            ranges, _ = lidar.scan_moving(
                (0.0, 0.0, W_RAD_S * (end - SCAN_PERIOD_S)), (0.0, 0.0, W_RAD_S * end), room
            )
            before = mission.mapper.scans_integrated if mission.mapper else 0
            mission.on_scan(Scan(t, lidar.angles(), ranges.astype(np.float64)), s)
            assert mission.mapper is not None
            if mission.mapper.scans_integrated > before and k > 60:
                node = mission.mapper.nodes[-1]
                pts = node.scan.points(mission.mapper.graph.pose(len(mission.mapper.nodes) - 1))
                off.append(float(np.max(np.abs(3.0 - np.abs(pts).max(axis=1)))))
    assert len(off) >= 10
    if deskewed:  # within the twin's 3.7 ms pieces of a turn and the timer's 3 ms
        assert max(off) < 0.02
    else:  # bent by the turn: up to 0.13 rad at 3-4 m
        assert max(off) > 0.2
