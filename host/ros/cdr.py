"""CDR for the topics a run records every frame, byte for byte what ``rosbags`` writes, faster.

The bag takes about a dozen messages per telemetry frame (odometry, IMU, joint states, the
transforms, the raw frame, the EKF's estimate, the local plan). ``rosbags``' serializer is
general: for each message it walks the type's definition to size the buffer, then again to
fill it, about 20-40 us per message on a 2-core machine, a third of a square run's frame. The
messages here have few, fixed layouts, so each is packed by one function with ``struct``:
little-endian CDR (XCDR1, the encapsulation header ``00 01 00 00``), every primitive aligned
to its size from the end of that header, strings as a u32 length (the NUL counted) and their
bytes, sequences as a u32 count and their elements. :data:`ENCODERS` maps a type name to its
function; :func:`serialize` falls back to ``rosbags`` for any other type.
``tests/ros/test_cdr.py`` checks every encoder against ``rosbags`` on messages the builder
makes, byte for byte.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable
from typing import Any

import numpy as np

HEADER = b"\x00\x01\x00\x00"

_U32 = struct.Struct("<I")
_I32_U32 = struct.Struct("<iI")
_F64x3 = struct.Struct("<3d")
_F64x4 = struct.Struct("<4d")
_F64x6 = struct.Struct("<6d")
_F64x7 = struct.Struct("<7d")
_F32x7 = struct.Struct("<7f")
_U32x3 = struct.Struct("<3I")


class _Writer:
    """A CDR buffer: alignment counted from the end of the encapsulation header."""

    __slots__ = ("buf",)

    def __init__(self) -> None:
        self.buf = bytearray(HEADER)

    def align(self, n: int) -> None:
        pad = -(len(self.buf) - 4) % n
        if pad:
            self.buf += b"\x00" * pad

    def u32(self, value: int) -> None:
        self.align(4)
        self.buf += _U32.pack(value)

    def string(self, text: str) -> None:
        self.align(4)
        self.buf += _string(text)

    def header(self, h: Any) -> None:
        self.stamped(h.stamp.sec, h.stamp.nanosec, h.frame_id)

    def stamped(self, sec: int, nanosec: int, frame_id: str) -> None:
        """A std_msgs/Header from its stamp and frame."""
        self.align(4)
        self.buf += _I32_U32.pack(sec, nanosec)
        self.buf += _string(frame_id)

    def f64s(self, packer: struct.Struct, *values: float) -> None:
        self.align(8)
        self.buf += packer.pack(*values)

    def f64_sequence(self, values: Any) -> None:
        data = np.ascontiguousarray(values, dtype="<f8")
        self.u32(data.size)
        if data.size:
            self.align(8)
            self.buf += data.tobytes()

    def pose(self, p: Any) -> None:
        q = p.orientation
        self.f64s(_F64x7, p.position.x, p.position.y, p.position.z, q.x, q.y, q.z, q.w)


@functools.lru_cache(maxsize=256)
def _string(text: str) -> bytes:
    """A CDR string: u32 length (the NUL counted), the UTF-8 bytes, the NUL (a run has few
    frame and joint names: each is encoded once)."""
    data = text.encode()
    return _U32.pack(len(data) + 1) + data + b"\x00"


@functools.lru_cache(maxsize=256)
def _names(texts: tuple[str, ...], at: int) -> bytes:
    """Strings that start at an offset ``at`` (mod 8, a multiple of 4) and are followed by
    float64s: each aligned to 4, the last padded to 8 (this depends on the names alone)."""
    buf = b""
    for text in texts:
        buf += bytes(-len(buf) % 4) + _string(text)
    return buf + bytes(-(at + len(buf)) % 8)


def _stamped(header: Any, *texts: str) -> bytes:
    """The start of a message whose header comes first, then ``texts``, then float64s: the
    encapsulation header, the stamp, the names, aligned for the float64s."""
    stamp = header.stamp
    return stamped_head(stamp.sec, stamp.nanosec, header.frame_id, *texts)


def stamped_head(sec: int, nanosec: int, frame_id: str, *texts: str) -> bytes:
    """:func:`_stamped` from the stamp and the names themselves."""
    return HEADER + _I32_U32.pack(sec, nanosec) + _names((frame_id, *texts), 0)


def f64_bytes(values: Any) -> bytes:
    """A fixed-size float64 array at an offset aligned to 8 (no count)."""
    return np.ascontiguousarray(values, dtype="<f8").tobytes()


def _odometry(m: Any) -> bytes:
    pose, tw = m.pose, m.twist
    p, q = pose.pose.position, pose.pose.orientation
    v, w = tw.twist.linear, tw.twist.angular
    return odometry(
        _stamped(m.header, m.child_frame_id), (p.x, p.y, p.z, q.x, q.y, q.z, q.w),
        f64_bytes(pose.covariance), (v.x, v.y, v.z, w.x, w.y, w.z), f64_bytes(tw.covariance),
    )  # fmt: skip


def odometry(
    head: bytes, pose: Any, pose_covariance: bytes, velocity: Any, twist_covariance: bytes
) -> bytes:
    """A nav_msgs/Odometry from its head (:func:`stamped_head` with the child frame), pose
    (x, y, z, qx, qy, qz, qw), velocity (vx, vy, vz, wx, wy, wz) and covariances' bytes
    (:func:`f64_bytes`)."""
    return b"".join(
        (head, _F64x7.pack(*pose), pose_covariance, _F64x6.pack(*velocity), twist_covariance)
    )


def _imu(m: Any) -> bytes:
    q, a, f = m.orientation, m.angular_velocity, m.linear_acceleration
    return imu(
        _stamped(m.header), (q.x, q.y, q.z, q.w), f64_bytes(m.orientation_covariance),
        (a.x, a.y, a.z), f64_bytes(m.angular_velocity_covariance), (f.x, f.y, f.z),
        f64_bytes(m.linear_acceleration_covariance),
    )  # fmt: skip


def imu(
    head: bytes,
    orientation: Any,
    orientation_covariance: bytes,
    angular_velocity: Any,
    angular_velocity_covariance: bytes,
    linear_acceleration: Any,
    linear_acceleration_covariance: bytes,
) -> bytes:
    """A sensor_msgs/Imu from its head (:func:`stamped_head`), vectors and covariances' bytes."""
    return b"".join(
        (
            head, _F64x4.pack(*orientation), orientation_covariance,
            _F64x3.pack(*angular_velocity), angular_velocity_covariance,
            _F64x3.pack(*linear_acceleration), linear_acceleration_covariance,
        )
    )  # fmt: skip


def _joint_state(m: Any) -> bytes:
    h = m.header
    return joint_state(
        (h.stamp.sec, h.stamp.nanosec), h.frame_id, m.name, m.position, m.velocity, m.effort
    )


def joint_state(
    stamp: tuple[int, int], frame_id: str, names: Any, position: Any, velocity: Any, effort: Any
) -> bytes:
    """A sensor_msgs/JointState from its stamp (sec, nanosec), frame, names and sequences."""
    w = _Writer()
    w.stamped(*stamp, frame_id)
    w.u32(len(names))
    for name in names:
        w.string(name)
    w.f64_sequence(position)
    w.f64_sequence(velocity)
    w.f64_sequence(effort)
    return bytes(w.buf)


def _tf_message(m: Any) -> bytes:
    items = []
    for t in m.transforms:
        h, v, q = t.header, t.transform.translation, t.transform.rotation
        pose = (v.x, v.y, v.z, q.x, q.y, q.z, q.w)
        items.append(((h.stamp.sec, h.stamp.nanosec), h.frame_id, t.child_frame_id, pose))
    return tf_message(items)


def tf_message(transforms: Any) -> bytes:
    """A tf2_msgs/TFMessage from its transforms, each ((sec, nanosec), parent, child, (x, y, z,
    qx, qy, qz, qw))."""
    parts = [HEADER, _U32.pack(len(transforms))]
    at = 4  # each transform's offset mod 8: after the count, then after float64s
    for stamp, parent, child, pose in transforms:
        parts += (_I32_U32.pack(*stamp), _names((parent, child), at), _F64x7.pack(*pose))
        at = 0
    return b"".join(parts)


def _uint8_multi_array(m: Any) -> bytes:
    w = _Writer()
    w.u32(len(m.layout.dim))
    for d in m.layout.dim:
        w.string(d.label)
        w.u32(d.size)
        w.u32(d.stride)
    w.u32(m.layout.data_offset)
    data = np.ascontiguousarray(m.data, dtype=np.uint8)
    w.u32(data.size)
    w.buf += data.tobytes()
    return bytes(w.buf)


def uint8_array(data: bytes) -> bytes:
    """A std_msgs/UInt8MultiArray of ``data`` with an empty layout (what
    :func:`_uint8_multi_array` writes for one)."""
    return HEADER + _U32x3.pack(0, 0, len(data)) + data


def _twist(m: Any) -> bytes:
    v, w = m.linear, m.angular
    return twist(v.x, v.y, v.z, w.x, w.y, w.z)


def twist(*values: float) -> bytes:
    """A geometry_msgs/Twist from (vx, vy, vz, wx, wy, wz)."""
    return HEADER + _F64x6.pack(*values)


def _path(m: Any) -> bytes:
    h = m.header
    head = _I32_U32.pack(h.stamp.sec, h.stamp.nanosec) + _string(h.frame_id)
    head += bytes(-len(head) % 4) + _U32.pack(len(m.poses))
    parts = [HEADER, head]
    at = len(head) % 8  # each pose's offset mod 8: after the count, then after float64s
    for stamped in m.poses:
        h, p, q = stamped.header, stamped.pose.position, stamped.pose.orientation
        parts += (
            _I32_U32.pack(h.stamp.sec, h.stamp.nanosec),
            _names((h.frame_id,), at),
            _F64x7.pack(p.x, p.y, p.z, q.x, q.y, q.z, q.w),
        )
        at = 0
    return b"".join(parts)


def _laser_scan(m: Any) -> bytes:
    w = _Writer()
    w.header(m.header)
    w.align(4)
    w.buf += _F32x7.pack(
        m.angle_min, m.angle_max, m.angle_increment, m.time_increment, m.scan_time,
        m.range_min, m.range_max,
    )  # fmt: skip
    for values in (m.ranges, m.intensities):
        data = np.ascontiguousarray(values, dtype="<f4")
        w.u32(data.size)
        w.buf += data.tobytes()
    return bytes(w.buf)


ENCODERS: dict[str, Callable[[Any], bytes]] = {
    "nav_msgs/msg/Odometry": _odometry,
    "sensor_msgs/msg/Imu": _imu,
    "sensor_msgs/msg/JointState": _joint_state,
    "tf2_msgs/msg/TFMessage": _tf_message,
    "std_msgs/msg/UInt8MultiArray": _uint8_multi_array,
    "geometry_msgs/msg/Twist": _twist,
    "nav_msgs/msg/Path": _path,
    "sensor_msgs/msg/LaserScan": _laser_scan,
}
"""The types packed here, by ``rosbags`` type name."""


def serialize(store: Any, msg: Any) -> bytes:
    """``msg`` in CDR: by :data:`ENCODERS` where its type is there, else by ``rosbags``.

    Parameters
    ----------
    store : rosbags.typesys.store.Typestore
        The type store for the other types.
    msg : object
        A ``rosbags`` message.

    Returns
    -------
    bytes
        The serialized message, encapsulation header first.
    """
    data = getattr(msg, "cdr", None)  # a message packed already (jackson.host.ros.packed)
    if type(data) is bytes:
        return data
    encode = ENCODERS.get(msg.__msgtype__)
    if encode is not None:
        return encode(msg)
    return bytes(store.serialize_cdr(msg, msg.__msgtype__))
