"""The map of a recording: scans and their poses fed to the mapper in time order, the map and
the corrected trajectory written (the package docstring)."""

from __future__ import annotations

import csv
import math
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jackson.host.nav.deskew import deskew
from jackson.host.nav.ekf_lag import FRAME_PERIOD_S, base_pose
from jackson.host.nav.offline.errors import NoOverlapError
from jackson.host.nav.offline.pairing import (
    POSE_FRACTION,
    STAMP_SLACK_S,
    OdometryTrack,
    OdomSample,
    laser_scan,
    stamp_s,
)
from jackson.host.nav.offline.recording import (
    EKF_TOPIC,
    SCAN_TOPIC,
    RecordingPlan,
    find_mount,
    messages,
    navigate_meta,
    plan_recording,
    pose_of,
)
from jackson.host.nav.slam.mapper import Mapper, MappingConfig
from jackson.host.nav.slam.store import graph_path, save_graph
from jackson.host.nav.types import Pose2D, Scan
from jackson.host.ros.builder import planar_pose

KEEP_ODOMETRY_S = 2.0  # [s] odometry kept behind the newest while no revolution waits
MAP_NAME = "built_map"
TRAJECTORY_NAME = "trajectory.csv"

ProgressFn = Callable[[int, float], None]  # (scans read, robot seconds so far)


@dataclass(frozen=True)
class OfflineMapSummary:
    """What :func:`map_recording` did.

    Attributes
    ----------
    map_yaml, trajectory_csv : Path
        The map_server YAML (its PGM beside it) and the corrected poses written.
    scans_read : int
        /scan messages read.
    scans_integrated : int
        Scans written into the map (the mapper skips those taken before the robot moved
        ``min_travel_m`` or turned ``min_heading_rad``).
    scans_paired : int
        Scans given to the mapper (those inside the odometry's span).
    odometry_topic : str
        The odometry mapped with.
    mount : Pose2D
        The LiDAR's pose on the base.
    mount_source : str
        Where the mount came from: ``/tf_static``, ``meta.json`` or ``default``.
    robot_s : float
        Robot time from the first to the last scan paired [s].
    cpu_s : float
        CPU time of the process while mapping [s].
    """

    map_yaml: Path
    trajectory_csv: Path
    scans_read: int
    scans_integrated: int
    scans_paired: int
    odometry_topic: str
    mount: Pose2D
    mount_source: str
    robot_s: float
    cpu_s: float

    @property
    def robot_s_per_cpu_s(self) -> float:
        """Robot-seconds mapped per CPU-second (inf when no CPU time was measured)."""
        return self.robot_s / self.cpu_s if self.cpu_s > 0 else math.inf


def map_recording(
    run: Path,
    out: Path,
    config: MappingConfig | None = None,
    pose_fraction: float = POSE_FRACTION,
    progress: ProgressFn | None = None,
    plan: RecordingPlan | None = None,
    deskewed: bool = True,
) -> OfflineMapSummary:
    """Build a map from a recorded run (module docstring) and write it into ``out``.

    Parameters
    ----------
    run : Path
        The run folder (with ``bag/``).
    out : Path
        Where ``built_map.yaml`` + ``.pgm`` and ``trajectory.csv`` go (created).
    config : MappingConfig or None
        The mapper's parameters (None: the survey's defaults).
    pose_fraction : float
        Where in a revolution its pose is taken (:func:`laser_scan`).
    progress : callable or None
        Called after every scan with the scans read and the robot seconds mapped so far.
    plan : RecordingPlan or None
        The checked inputs (default: :func:`plan_recording`).
    deskewed : bool
        Take each revolution as seen from the base's pose at its pose time, from the
        odometry's motion over it (:mod:`jackson.host.nav.deskew`), as the survey does.

    Raises
    ------
    RecordingMapError
        The folder cannot be mapped (a subclass names why; :class:`NoOverlapError`: no scan
        within the odometry's span, nothing written).
    """
    cpu0 = time.process_time()
    plan = plan or plan_recording(run)
    mount, mount_source = find_mount(run, plan.bags, plan.odometry_topic)
    nav = navigate_meta(run)
    anchor = pose_of(nav["start"], run, "start") if "start" in nav else Pose2D()
    mapper = Mapper(config or MappingConfig())
    track = OdometryTrack()
    waiting: deque[tuple[float, Scan, float]] = deque()  # pose time, scan, its first one's
    rows: list[tuple[float, Pose2D]] = []
    read = paired = 0
    span = [math.inf, -math.inf]

    def feed() -> None:
        nonlocal paired
        while waiting and waiting[0][1].t_s <= track.last_s + STAMP_SLACK_S:
            t_s, scan, first_s = waiting.popleft()
            at_first = track.pose_at(first_s)  # (asked in time order: the track drops the past)
            odom = track.pose_at(t_s)
            at_last = track.pose_at(scan.t_s)
            if odom is None:  # before the odometry began
                continue
            if deskewed and at_first is not None and at_last is not None:
                at = (t_s - first_s) / (scan.t_s - first_s) if scan.t_s > first_s else 1.0
                scan = deskew(scan, mount, at_first.inverse().compose(at_last), at)
            before = mapper.scans_integrated
            corrected = mapper.update(scan, anchor.compose(odom), mount)
            paired += 1
            span[0], span[1] = min(span[0], t_s), max(span[1], t_s)
            if mapper.scans_integrated > before:
                rows.append((t_s, corrected))
        if not waiting:  # keep a little odometry for a revolution stamped behind it
            track.trim(track.last_s - KEEP_ODOMETRY_S)

    topics = (SCAN_TOPIC, plan.odometry_topic)
    ekf = plan.odometry_topic == EKF_TOPIC
    for topic, msg in messages(plan.bags, topics):
        if topic == SCAN_TOPIC:
            read += 1
            if len(msg.ranges) >= 2:
                waiting.append((*laser_scan(msg, pose_fraction), stamp_s(msg.header)))
        else:
            track.add(OdomSample(stamp_s(msg.header), _odom_pose(msg, ekf)))
        feed()
        if progress is not None and topic == SCAN_TOPIC:
            progress(read, max(span[1] - span[0], 0.0))
    if mapper.scans_integrated == 0:
        raise NoOverlapError(
            f"{run}: none of its {read} scans falls within the time span of its "
            f"{plan.odometry_topic} messages: nothing to map"
        )
    mapper.finish()  # the last look for a loop closure
    out.mkdir(parents=True, exist_ok=True)
    yaml_path, _ = mapper.grid().save(out / f"{MAP_NAME}.yaml")
    save_graph(mapper, graph_path(yaml_path))
    trajectory = out / TRAJECTORY_NAME
    # node i is the i-th integrated scan: its pose in the optimised graph
    write_trajectory(trajectory, [(t, mapper.graph.pose(i)) for i, (t, _) in enumerate(rows)])
    return OfflineMapSummary(
        map_yaml=yaml_path,
        trajectory_csv=trajectory,
        scans_read=read,
        scans_integrated=mapper.scans_integrated,
        scans_paired=paired,
        odometry_topic=plan.odometry_topic,
        mount=mount,
        mount_source=mount_source,
        robot_s=max(span[1] - span[0], 0.0),
        cpu_s=time.process_time() - cpu0,
    )


def _odom_pose(msg: Any, ekf: bool) -> Pose2D:
    """A nav_msgs/Odometry message's planar pose; the EKF's carried on to the base's pose at
    its stamp (:mod:`jackson.host.nav.ekf_lag`)."""
    pose = planar_pose(msg.pose.pose)
    if not ekf:
        return pose
    twist = msg.twist.twist
    return base_pose(pose, float(twist.linear.x), float(twist.angular.z), FRAME_PERIOD_S)


def write_trajectory(path: Path, rows: Sequence[tuple[float, Pose2D]]) -> None:
    """``trajectory.csv``: t_s (the bag's clock), x_m, y_m, yaw_rad of each integrated scan's
    base pose in the map frame, as the optimised pose graph has it."""
    with path.open("w", newline="", encoding="utf8") as f:
        w = csv.writer(f)
        w.writerow(("t_s", "x_m", "y_m", "yaw_rad"))
        for t_s, p in rows:
            w.writerow((f"{t_s:.6f}", f"{p.x:.5f}", f"{p.y:.5f}", f"{p.yaw:.6f}"))
