"""The ROS 2 message types jackson writes, as one small rosbags typestore.

rosbags' Jazzy store holds every type of every ROS 2 release before it (each release's module
builds on the previous one): importing it took 90-230 ms of a daemon's start, for the 28 types
the daemon writes. :func:`typestore` registers only those, from their ``.msg`` definitions
below, and makes the same message classes, CDR bytes, message definitions and type hashes
(RIHS01) as Jazzy's store: ``tests/ros/test_msgtypes.py`` compares every one. Reading a bag
(other people's types too) still uses the full Jazzy store.

The classes live in this module under rosbags' names (``nav_msgs__msg__Odometry``), made at
the first use of one, so a pickled message loads in a process that has not built them yet.
"""

from __future__ import annotations

import functools
from typing import Any

from rosbags.typesys import get_types_from_msg
from rosbags.typesys.store import Typestore

DEFINITIONS: dict[str, str] = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id",
    "std_msgs/msg/MultiArrayDimension": "string label\nuint32 size\nuint32 stride",
    "std_msgs/msg/MultiArrayLayout": "MultiArrayDimension[] dim\nuint32 data_offset",
    "std_msgs/msg/UInt8MultiArray": "MultiArrayLayout layout\nuint8[] data",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/msg/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w",
    "geometry_msgs/msg/Pose": "Point position\nQuaternion orientation",
    "geometry_msgs/msg/PoseStamped": "std_msgs/Header header\nPose pose",
    "geometry_msgs/msg/PoseWithCovariance": "Pose pose\nfloat64[36] covariance",
    "geometry_msgs/msg/PoseWithCovarianceStamped": (
        "std_msgs/Header header\nPoseWithCovariance pose"
    ),
    "geometry_msgs/msg/Transform": "Vector3 translation\nQuaternion rotation",
    "geometry_msgs/msg/TransformStamped": (
        "std_msgs/Header header\nstring child_frame_id\nTransform transform"
    ),
    "geometry_msgs/msg/Twist": "Vector3 linear\nVector3 angular",
    "geometry_msgs/msg/TwistStamped": "std_msgs/Header header\nTwist twist",
    "geometry_msgs/msg/TwistWithCovariance": "Twist twist\nfloat64[36] covariance",
    "nav_msgs/msg/MapMetaData": (
        "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\n"
        "uint32 height\ngeometry_msgs/Pose origin"
    ),
    "nav_msgs/msg/OccupancyGrid": "std_msgs/Header header\nMapMetaData info\nint8[] data",
    "nav_msgs/msg/Odometry": (
        "std_msgs/Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist"
    ),
    "nav_msgs/msg/Path": "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses",
    "sensor_msgs/msg/Imu": (
        "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n"
        "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n"
        "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n"
        "float64[9] linear_acceleration_covariance"
    ),
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort"
    ),
    "sensor_msgs/msg/LaserScan": (
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\n"
        "float32 angle_increment\nfloat32 time_increment\nfloat32 scan_time\n"
        "float32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities"
    ),
    "diagnostic_msgs/msg/KeyValue": "string key\nstring value",
    "diagnostic_msgs/msg/DiagnosticStatus": (
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\n"
        "string message\nstring hardware_id\nKeyValue[] values"
    ),
    "diagnostic_msgs/msg/DiagnosticArray": ("std_msgs/Header header\nDiagnosticStatus[] status"),
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms",
    "rosgraph_msgs/msg/Clock": "builtin_interfaces/Time clock",
}
"""Each type's fields (and constants) in ROS 2 ``.msg`` syntax, Jazzy's."""


@functools.cache
def typestore() -> Typestore:
    """The store of :data:`DEFINITIONS` (made once per process; read-only by its users)."""
    store = Typestore()
    types = {}
    for name, text in DEFINITIONS.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    for name, cls in store.types.items():
        attr = name.replace("/", "__")
        cls.__module__ = __name__  # pickled by this module's name, not rosbags' scratch one
        cls.__qualname__ = attr
        globals()[attr] = cls
    return store


def __getattr__(attr: str) -> Any:
    """A message class by rosbags' name (``sensor_msgs__msg__Imu``), the store made first."""
    name = attr.replace("__", "/")
    if name in DEFINITIONS:
        return typestore().types[name]
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")
