"""Mapping from a recording (host/nav/offline_map.py): small bags written with the daemon's own
recorder, read back and mapped."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from jackson.host.nav.grid import OccupancyGrid
from jackson.host.nav.offline import (
    DamagedBagError,
    NoBagError,
    NoOdometryError,
    NoOverlapError,
    NoScanError,
    OdometryTrack,
    OdomSample,
    interpolate,
    laser_scan,
    map_recording,
    plan_recording,
    tf_chain,
)
from jackson.host.nav.slam.mapper import MappingConfig
from jackson.host.nav.types import Pose2D, Scan
from jackson.host.ros.bag import BagRecorder
from jackson.host.ros.messages import RosSettings

PERIOD_S = 0.1  # [s] one revolution
N_BEAMS = 360
ROOM_HALF_M = 1.5  # a square room 3 m wide, centred on the start


def room_scan(pose: Pose2D, t_end_s: float) -> Scan:
    """The scan a LiDAR at ``pose`` sees in the square room (exact ranges)."""
    angles = np.linspace(-math.pi, math.pi, N_BEAMS, endpoint=False)
    world = angles + pose.yaw
    c, s = np.cos(world), np.sin(world)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (ROOM_HALF_M - pose.x) / c, (-ROOM_HALF_M - pose.x) / c)
        ty = np.where(s > 0, (ROOM_HALF_M - pose.y) / s, (-ROOM_HALF_M - pose.y) / s)
    return Scan(t_end_s, angles, np.minimum(np.abs(tx), np.abs(ty)))


def record(
    run: Path,
    poses: list[tuple[float, Pose2D]],
    *,
    scans: bool = True,
    odometry: str | None = "filtered",
    settings: RosSettings | None = None,
    scan_offset_s: float = 0.0,
    ekf_lag: tuple[float, float] | None = None,
) -> None:
    """A run folder whose bag holds the odometry of ``poses`` and a scan every 0.1 s, seen
    from the laser frame of ``settings``; with ``ekf_lag`` (the twist: v [m/s], w [rad/s]),
    /odometry/filtered carries that twist and the pose of the frame before, as the EKF does."""
    ros = settings or RosSettings()
    mount = Pose2D(
        ros.base_link_offset_m[0] + ros.laser_offset_m[0],
        ros.base_link_offset_m[1] + ros.laser_offset_m[1],
    )
    with BagRecorder(run / "bag", settings) as bag:
        for k, (t_s, p) in enumerate(poses):
            if odometry == "filtered" and ekf_lag is not None:
                q = poses[max(k - 1, 0)][1]  # where the base was a frame before
                bag.filtered(t_s, q.x, q.y, q.yaw, ekf_lag[0], 0.0, ekf_lag[1], None)
            elif odometry == "filtered":
                bag.filtered(t_s, p.x, p.y, p.yaw, 0.0, 0.0, 0.0, None)
            elif odometry == "wheel":
                bag.wheel_odom(t_s, p.x, p.y, p.yaw, 0.0, 0.0)
            else:
                bag.raw_frame(t_s, b"\x00")
            if scans and round(t_s * 20) % 2 == 0 and t_s >= PERIOD_S:
                end = t_s + scan_offset_s
                msg = bag.builder.scan(room_scan(p.compose(mount), end), end - PERIOD_S, PERIOD_S)
                bag.write("scan", end, msg)


def drive(
    seconds: float = 3.0, v_m_s: float = 0.2, w_rad_s: float = 0.3
) -> list[tuple[float, Pose2D]]:
    """Odometry at 20 Hz along an arc from the origin."""
    out = []
    for k in range(int(seconds * 20) + 1):
        t = k / 20
        yaw = w_rad_s * t
        r = v_m_s / w_rad_s
        out.append((t, Pose2D(r * math.sin(yaw), r * (1 - math.cos(yaw)), yaw)))
    return out


# ---- pairing --------------------------------------------------------------------------------


def test_interpolation_is_linear_in_position_and_takes_the_shorter_arc() -> None:
    a = OdomSample(1.0, Pose2D(0.0, 0.0, math.pi - 0.1))
    b = OdomSample(2.0, Pose2D(1.0, -2.0, -math.pi + 0.1))
    p = interpolate(a, b, 1.25)
    assert (p.x, p.y) == pytest.approx((0.25, -0.5))
    assert abs(math.remainder(p.yaw - (math.pi - 0.05), math.tau)) < 1e-12


def test_track_answers_inside_its_span_only_and_forgets_what_it_passed() -> None:
    track = OdometryTrack()
    for t in (0.0, 0.05, 0.10, 0.15):
        track.add(OdomSample(t, Pose2D(10 * t, 0.0, 0.0)))
    track.add(OdomSample(0.12, Pose2D(99.0, 0.0, 0.0)))  # behind the last: dropped
    assert track.pose_at(-0.01) is None
    assert track.pose_at(0.16) is None
    p = track.pose_at(0.075)
    assert p is not None and p.x == pytest.approx(0.75)
    assert track.first_s == 0.05  # the pair around 0.075 stays, what came before goes
    p = track.pose_at(0.15)
    assert p is not None and p.x == pytest.approx(1.5)


def test_a_laser_scan_is_stamped_at_its_end_and_posed_where_asked() -> None:
    with_ranges = room_scan(Pose2D(), 5.0)
    from jackson.host.estimation.odometry import OdometryCovariance
    from jackson.host.ros.messages import MessageBuilder, StampClock

    b = MessageBuilder(RosSettings(), OdometryCovariance(), StampClock(sim_time=True))
    msg = b.scan(with_ranges, 4.9, PERIOD_S)
    t_end, scan = laser_scan(msg)
    assert t_end == pytest.approx(5.0) and scan.t_s == pytest.approx(5.0)
    t_mid, _ = laser_scan(msg, 0.5)
    assert t_mid == pytest.approx(4.95)
    np.testing.assert_allclose(scan.angles_rad, with_ranges.angles_rad, atol=1e-9)
    np.testing.assert_allclose(scan.ranges_m, with_ranges.ranges_m, rtol=1e-6)


def test_mount_is_the_chain_of_static_transforms(tmp_path: Path) -> None:
    settings = RosSettings(base_link_offset_m=(0.02, 0.0, 0.03), laser_offset_m=(0.1, -0.01, 0.2))
    record(tmp_path, drive(0.5), settings=settings)
    from jackson.host.ros.bag import read_bag

    (_, msg), *_ = read_bag(tmp_path / "bag")["/tf_static"]
    mount = tf_chain(msg.transforms, "base_footprint", "laser")
    assert mount is not None
    assert (mount.x, mount.y, mount.yaw) == pytest.approx((0.12, -0.01, 0.0))
    assert tf_chain(msg.transforms, "base_footprint", "camera") is None


# ---- a whole recording ----------------------------------------------------------------------


def test_a_drive_maps_the_room_and_writes_its_trajectory(tmp_path: Path) -> None:
    poses = drive()
    settings = RosSettings(laser_offset_m=(0.05, 0.0, 0.1))
    record(tmp_path / "run", poses, settings=settings)
    progress: list[tuple[int, float]] = []
    s = map_recording(
        tmp_path / "run", tmp_path / "out", progress=lambda n, t: progress.append((n, t))
    )
    assert s.odometry_topic == "/odometry/filtered"
    assert s.mount_source == "/tf_static" and s.mount.x == pytest.approx(0.05)
    assert s.scans_read == 30 and s.scans_paired == 30  # every revolution within the odometry
    assert 1 < s.scans_integrated <= 30
    assert s.robot_s == pytest.approx(2.9)
    assert progress[-1][0] == 30
    grid = OccupancyGrid.load(s.map_yaml)
    occupied = np.argwhere(grid.data >= 65)
    xs = grid.origin_x_m + (occupied[:, 1] + 0.5) * grid.resolution_m
    ys = grid.origin_y_m + (occupied[:, 0] + 0.5) * grid.resolution_m
    off_wall = np.minimum(np.abs(np.abs(xs) - ROOM_HALF_M), np.abs(np.abs(ys) - ROOM_HALF_M))
    assert len(occupied) > 100
    assert np.mean(off_wall <= grid.resolution_m) >= 0.9, np.unique(off_wall, return_counts=True)
    with (tmp_path / "out" / "trajectory.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == s.scans_integrated
    last = rows[-1]
    t = float(last["t_s"])
    truth = poses[round(t * 20)][1]
    assert math.hypot(float(last["x_m"]) - truth.x, float(last["y_m"]) - truth.y) < 0.03


def test_the_ekf_pose_a_frame_behind_is_carried_on_to_the_base_by_its_twist(
    tmp_path: Path,
) -> None:
    poses = drive(v_m_s=0.2, w_rad_s=1.0)  # turning at 1 rad/s: a frame is 0.05 rad
    record(tmp_path / "run", poses, ekf_lag=(0.2, 1.0))
    odometry_only = MappingConfig(scan_matching=False, loop_closure=False)
    map_recording(tmp_path / "run", tmp_path / "out", config=odometry_only)
    with (tmp_path / "out" / "trajectory.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) > 10
    for row in rows:
        truth = poses[round(float(row["t_s"]) * 20)][1]
        assert abs(math.remainder(float(row["yaw_rad"]) - truth.yaw, math.tau)) < 1e-5
        assert math.hypot(float(row["x_m"]) - truth.x, float(row["y_m"]) - truth.y) < 1e-5


def test_wheel_odometry_is_the_fallback_and_the_start_anchors_the_map(tmp_path: Path) -> None:
    record(tmp_path / "run", drive(1.0), odometry="wheel")
    meta = {"navigate": {"start": [2.0, 1.0, math.pi / 2], "lidar_mount": [0.3, 0.0, 0.0]}}
    (tmp_path / "run" / "meta.json").write_text(json.dumps(meta))
    s = map_recording(tmp_path / "run", tmp_path / "out")
    assert s.odometry_topic == "/wheel/odom"
    assert s.mount_source == "/tf_static"  # the bag's transforms win over meta.json
    with (tmp_path / "out" / "trajectory.csv").open() as f:
        first = next(csv.DictReader(f))
    # the first scan, 0.1 s in at 0.2 m/s: 0.02 m along the start's heading (+y)
    assert float(first["t_s"]) == pytest.approx(0.1)
    assert (float(first["x_m"]), float(first["y_m"])) == pytest.approx((2.0, 1.02), abs=1e-3)


def test_scans_outside_the_odometry_are_not_mapped(tmp_path: Path) -> None:
    record(tmp_path / "run", drive(1.0), scan_offset_s=0.5)  # the last scans run past it
    s = map_recording(tmp_path / "run", tmp_path / "out")
    assert s.scans_read == 10 and s.scans_paired < s.scans_read


# ---- refusals -------------------------------------------------------------------------------


def test_a_missing_folder_or_bag_is_refused(tmp_path: Path) -> None:
    with pytest.raises(NoBagError, match="no such run folder"):
        plan_recording(tmp_path / "nowhere")
    with pytest.raises(NoBagError, match="no bag"):
        plan_recording(tmp_path)


def test_a_bag_folder_given_for_its_run_is_mapped_as_one(tmp_path: Path) -> None:
    record(tmp_path, drive(0.5))
    plan = plan_recording(tmp_path / "bag")
    assert plan.bags == (tmp_path / "bag",) and plan.scan_count == 5


def test_a_bag_without_scans_says_to_record_with_the_lidar(tmp_path: Path) -> None:
    record(tmp_path, drive(0.5), scans=False)
    with pytest.raises(
        NoScanError, match=r"has no /scan: record with the LiDAR on \(jackson daemon --lidar"
    ):
        plan_recording(tmp_path)


def test_a_bag_without_odometry_is_refused(tmp_path: Path) -> None:
    record(tmp_path, drive(0.5), odometry=None)
    with pytest.raises(NoOdometryError, match="/odometry/filtered or /wheel/odom"):
        plan_recording(tmp_path)


def test_an_unclosed_bag_points_at_bag_repair(tmp_path: Path) -> None:
    record(tmp_path, drive(0.5))
    (tmp_path / "bag" / "metadata.yaml").unlink()
    with pytest.raises(DamagedBagError, match="jackson bag repair"):
        plan_recording(tmp_path)


def test_scans_that_never_meet_the_odometry_write_nothing(tmp_path: Path) -> None:
    record(tmp_path / "run", drive(0.5), scan_offset_s=100.0)
    with pytest.raises(NoOverlapError, match="none of its 5 scans"):
        map_recording(tmp_path / "run", tmp_path / "out")
    assert not (tmp_path / "out").exists()
