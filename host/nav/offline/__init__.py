"""Mapping from a recording: a run folder's bag (/scan and odometry) fed to the mapper offline.

A run with scans (a teleop drive of the robot, a daemon run, a twin trial) holds everything the
survey's mapper is given live: each LiDAR revolution on /scan, the base's odometry pose on
/odometry/filtered (the EKF, preferred: what the survey maps with) or /wheel/odom, and where
the LiDAR sits on the base on /tf_static. :func:`map_recording` reads them back in time order
and feeds :class:`~jackson.host.nav.slam.mapper.Mapper` exactly as
:meth:`jackson.host.control.navigate.NavigateMission.on_scan` does, then writes the map the
survey writes (``built_map.yaml`` + ``.pgm``) and the corrected pose of every integrated scan.

Pairing a scan with a pose. A LaserScan is stamped with its first measurement and lasts
``scan_time``; the project's :class:`~jackson.host.nav.types.Scan` is stamped with its last
(``stamp + scan_time``), and the live survey pairs a revolution with the EKF's state of the
frame it completed in. The offline pose is the odometry linearly interpolated (the yaw along
the shorter arc) at ``stamp + pose_fraction * scan_time``: 1, the revolution's end, by default,
which reproduces the live pairing; 0.5, its middle, halves the largest skew of an undeskewed
revolution's returns but pairs differently from the map the robot built live (on three twin
surveys the two differ by under 0.01 of SSIM; the first measurement's time lost 0.05 on
one). A revolution
outside the odometry's span (before its first message, after its last) is not mapped.

Frames. The map frame is the odometry frame at the first scan, unless the run's ``meta.json``
names the start pose of a navigation (``navigate.start``): then the odometry is anchored there
as the survey anchors it (``start ⊕ odom``), so the map lands in the same (world) frame as the
live one and the goals. The mount is the chain base frame -> laser frame on /tf_static, else the
navigation's ``lidar_mount`` in ``meta.json``, else the base origin.

Reading streams: messages come one at a time from rosbags' reader over the run's bag folders
(:func:`~jackson.host.ros.bag.bag_folders`) in order, and only the odometry since the oldest
revolution not yet mapped is kept, so an hours-long run needs memory for the map only.
"""

from jackson.host.nav.offline.build import (
    MAP_NAME,
    OfflineMapSummary,
    map_recording,
    write_trajectory,
)
from jackson.host.nav.offline.errors import (
    DamagedBagError,
    NoBagError,
    NoOdometryError,
    NoOverlapError,
    NoScanError,
    RecordingMapError,
)
from jackson.host.nav.offline.pairing import OdometryTrack, OdomSample, interpolate, laser_scan
from jackson.host.nav.offline.recording import RecordingPlan, plan_recording, tf_chain

__all__ = [
    "MAP_NAME",
    "DamagedBagError",
    "NoBagError",
    "NoOdometryError",
    "NoOverlapError",
    "NoScanError",
    "OdomSample",
    "OdometryTrack",
    "OfflineMapSummary",
    "RecordingMapError",
    "RecordingPlan",
    "interpolate",
    "laser_scan",
    "map_recording",
    "plan_recording",
    "tf_chain",
    "write_trajectory",
]
