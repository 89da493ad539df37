"""The messages of every telemetry frame packed straight into CDR, their objects made only if read.

Each frame the daemon sends about a dozen messages (/wheel/odom, /imu/data, /joint_states, the
transforms, the raw frame, the EKF's estimate at 30 Hz, /cmd_vel) to the bag and the live
node, and both only want their CDR bytes. Built as ``rosbags`` objects (ten dataclasses for an
Odometry) and then serialised, each cost about 25 us; :class:`FramePacker` packs the same bytes
from the values directly (:mod:`jackson.host.ros.cdr`'s encoders, which the object path uses
too) and hands on a :class:`Packed`: the bytes, the message type, and the object, made by the
:class:`~jackson.host.ros.builder.MessageBuilder` with the same stamp the first time a field
is read. ``tests/ros/test_packed.py`` checks bytes and objects against the builder's.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from jackson.host.ros import cdr
from jackson.host.ros.builder import MessageBuilder, planar_covariance
from jackson.host.ros.stamp_clock import NS_PER_S
from jackson.protocol import Telemetry
from jackson.protocol.units import accel_m_s2, gyro_rad_s

if TYPE_CHECKING:
    from jackson.host.estimation.ekf import EkfState
    from jackson.host.estimation.odometry import OdometryState

ODOMETRY = "nav_msgs/msg/Odometry"
IMU = "sensor_msgs/msg/Imu"
JOINT_STATE = "sensor_msgs/msg/JointState"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
TWIST = "geometry_msgs/msg/Twist"
UINT8_ARRAY = "std_msgs/msg/UInt8MultiArray"
_NO_EFFORT = np.zeros(0, dtype=np.float64)


class Packed:
    """A message as the sinks take it: its CDR bytes (:attr:`cdr`) and type
    (``__msgtype__``); any other attribute is the ``rosbags`` object's, made on first use.

    Parameters
    ----------
    msgtype : str
        The ROS type name (``nav_msgs/msg/Odometry``).
    data : bytes
        The serialised message, encapsulation header first.
    make : callable
        Makes the object (the same message).
    """

    __slots__ = ("__msgtype__", "_make", "_message", "cdr")

    def __init__(self, msgtype: str, data: bytes, make: Callable[[], Any]) -> None:
        self.__msgtype__ = msgtype
        self.cdr = data
        self._make = make
        self._message: Any = None

    @property
    def message(self) -> Any:
        """The ``rosbags`` object (made once)."""
        if self._message is None:
            self._message = self._make()
        return self._message

    def __getattr__(self, name: str) -> Any:
        return getattr(self.message, name)


class _At:
    """A stamp clock stopped at one stamp: the object of a packed message gets the stamp its
    bytes have, whenever it is made."""

    def __init__(self, ns: int) -> None:
        self._ns = ns

    def ns(self, t_s: float) -> int:
        return self._ns


class FramePacker:
    """Packs each frame's messages (module docstring) with a builder's names and clock.

    Parameters
    ----------
    builder : MessageBuilder
        The names, the fixed covariances and the stamp clock; it makes the objects.
    """

    def __init__(self, builder: MessageBuilder) -> None:
        self.builder = builder
        b = builder
        self._odom_pose_cov = cdr.f64_bytes(b.odom_pose_cov)
        self._odom_twist_cov = cdr.f64_bytes(b.odom_twist_cov)
        self._imu_covs = tuple(
            cdr.f64_bytes(c)
            for c in (
                b.imu_orientation_cov, b.imu_angular_velocity_cov, b.imu_linear_acceleration_cov
            )
        )  # fmt: skip

    def _made(self, ns: int, method: str, *args: Any) -> Callable[[], Any]:
        """The builder's ``method(*args)`` at the stamp ``ns``, to call later."""

        def make() -> Any:
            stopped = copy.copy(self.builder)
            stopped.clock = _At(ns)  # type: ignore[assignment]  # only its ns() is read
            return getattr(stopped, method)(*args)

        return make

    def _stamp(self, t_s: float) -> tuple[int, tuple[int, int]]:
        ns = self.builder.clock.ns(t_s)
        sec, nanosec = divmod(ns, NS_PER_S)
        return ns, (sec, nanosec)

    def _odometry(
        self, stamp: tuple[int, int], pose: tuple[float, float, float],
        twist: tuple[float, float, float], covariances: tuple[bytes, bytes],
    ) -> bytes:  # fmt: skip
        s = self.builder.settings
        x, y, yaw = pose
        return cdr.odometry(
            cdr.stamped_head(*stamp, s.odom_frame, s.base_frame),
            (x, y, 0.0, 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)), covariances[0],
            (twist[0], twist[1], 0.0, 0.0, 0.0, twist[2]), covariances[1],
        )  # fmt: skip

    def wheel_odom(self, t_s: float, odo: OdometryState) -> Packed:
        """/wheel/odom (:meth:`MessageBuilder.wheel_odom`)."""
        ns, stamp = self._stamp(t_s)
        data = self._odometry(
            stamp, (float(odo.x_m), float(odo.y_m), float(odo.yaw_rad)),
            (float(odo.v_m_s), 0.0, float(odo.w_rad_s)),
            (self._odom_pose_cov, self._odom_twist_cov),
        )  # fmt: skip
        return Packed(ODOMETRY, data, self._made(ns, "wheel_odom", t_s, odo))

    def filtered(self, t_s: float, state: EkfState) -> Packed:
        """/odometry/filtered (:meth:`MessageBuilder.filtered`)."""
        ns, stamp = self._stamp(t_s)
        d = state.covariance_diagonal
        covariances = (
            cdr.f64_bytes(planar_covariance(d[0], d[1], 0.0, 0.0, 0.0, d[2])),
            cdr.f64_bytes(planar_covariance(d[3], d[4], 0.0, 0.0, 0.0, d[5])),
        )
        data = self._odometry(
            stamp, (float(state.x_m), float(state.y_m), float(state.yaw_rad)),
            (float(state.vx_m_s), float(state.vy_m_s), float(state.vyaw_rad_s)), covariances,
        )  # fmt: skip
        return Packed(ODOMETRY, data, self._made(ns, "filtered", t_s, state))

    def imu(self, t_s: float, telemetry: Telemetry) -> Packed:
        """/imu/data (:meth:`MessageBuilder.imu`)."""
        ns, stamp = self._stamp(t_s)
        gyro, accel = gyro_rad_s(telemetry), accel_m_s2(telemetry)
        o_cov, a_cov, f_cov = self._imu_covs
        data = cdr.imu(
            cdr.stamped_head(*stamp, self.builder.settings.imu_frame), (0.0, 0.0, 0.0, 1.0),
            o_cov, tuple(float(v) for v in gyro), a_cov, tuple(float(v) for v in accel), f_cov,
        )  # fmt: skip
        return Packed(IMU, data, self._made(ns, "imu", t_s, telemetry))

    def joint_states(self, t_s: float, odo: OdometryState) -> Packed:
        """/joint_states (:meth:`MessageBuilder.joint_states`)."""
        ns, stamp = self._stamp(t_s)
        s = self.builder.settings
        data = cdr.joint_state(
            stamp, "", (s.left_wheel_joint, s.right_wheel_joint),
            np.array([float(odo.wheel_angle_left_rad), float(odo.wheel_angle_right_rad)]),
            np.array([float(odo.wheel_velocity_left_rad_s), float(odo.wheel_velocity_right_rad_s)]),
            _NO_EFFORT,
        )  # fmt: skip
        return Packed(JOINT_STATE, data, self._made(ns, "joint_states", t_s, odo))

    def transform(
        self, t_s: float, parent: str, child: str, xyz: tuple[float, float, float], yaw: float
    ) -> Packed:
        """/tf with one transform (:meth:`MessageBuilder.transform` in a TFMessage)."""
        ns, stamp = self._stamp(t_s)
        yaw = float(yaw)
        pose = (float(xyz[0]), float(xyz[1]), float(xyz[2]), 0.0, 0.0,
                math.sin(yaw / 2.0), math.cos(yaw / 2.0))  # fmt: skip
        data = cdr.tf_message([(stamp, parent, child, pose)])
        return Packed(TF_MESSAGE, data, self._made(ns, "tf", t_s, parent, child, xyz, yaw))

    def odom_tf(self, t_s: float, x: float, y: float, yaw: float) -> Packed:
        """/tf: odom -> base_footprint (:meth:`MessageBuilder.odom_tf`)."""
        s = self.builder.settings
        return self.transform(t_s, s.odom_frame, s.base_frame, (x, y, 0.0), yaw)

    def wheel_tf(self, t_s: float, odo: OdometryState) -> Packed:
        """/tf: base_link -> each wheel's link (:meth:`MessageBuilder.wheel_tf`)."""
        ns, stamp = self._stamp(t_s)
        s = self.builder.settings
        items = []
        for child, y, angle in (
            (s.left_wheel_frame, 0.5 * s.wheel_separation_m, odo.wheel_angle_left_rad),
            (s.right_wheel_frame, -0.5 * s.wheel_separation_m, odo.wheel_angle_right_rad),
        ):
            half = 0.5 * float(angle)
            pose = (0.0, y, 0.0, 0.0, math.sin(half), 0.0, math.cos(half))
            items.append((stamp, s.base_link_frame, child, pose))
        return Packed(TF_MESSAGE, cdr.tf_message(items), self._made(ns, "wheel_tf", t_s, odo))

    def twist(self, t_s: float, v: float, w: float) -> Any:
        """/cmd_vel (:meth:`MessageBuilder.twist`): packed unless it is stamped."""
        if self.builder.settings.cmd_vel_stamped:
            return self.builder.twist(t_s, v, w)
        ns = self.builder.clock.ns(t_s)
        data = cdr.twist(float(v), 0.0, 0.0, 0.0, 0.0, float(w))
        return Packed(TWIST, data, self._made(ns, "twist", t_s, v, w))

    def raw_frame(self, data: bytes) -> Packed:
        """/jackson/telemetry (:meth:`MessageBuilder.raw_frame`)."""
        raw = bytes(data)
        return Packed(UINT8_ARRAY, cdr.uint8_array(raw), self._made(0, "raw_frame", raw))
