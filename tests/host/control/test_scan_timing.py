"""The mapper takes each revolution with the odometry pose at the revolution's end, where the
LiDAR's timeline puts it between the frame before and the one it came with, not at that
frame: in a turn, a frame late is a heading off by the turn rate times up to 50 ms."""

from __future__ import annotations

import math

import numpy as np

from jackson.host.config import HostConfig
from jackson.host.control.base import NavState
from jackson.host.control.navigate import NavigateConfig, NavigateMission
from jackson.host.lidar.scan_timer import SCAN_PERIOD_S
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
    mapped: list[tuple[float, float]] = []  # (the revolution's end, the heading it got)
    for k in range(1, 160):
        t = k * FRAME_S
        s = NavState(t, 0.0, 0.0, W_RAD_S * t, 0.0, W_RAD_S)
        mission.track(s)
        for end in [e for e in ends if t - FRAME_S < e <= t]:  # came with this frame
            before = mission.mapper.scans_integrated if mission.mapper else 0
            mission.on_scan(Scan(t, angles, np.full(360, 2.0)), s)
            assert mission.mapper is not None
            if mission.mapper.scans_integrated > before:
                mapped.append((end, mission.mapper.nodes[-1].odom.yaw))
    late = [abs(math.remainder(yaw - W_RAD_S * end, math.tau)) for end, yaw in mapped[-20:]]
    # once the timer has the phase: within 3 ms of the end (0.003 rad), where the frame's own
    # heading was up to 0.05 rad ahead
    assert len(late) == 20 and max(late) < 0.004
