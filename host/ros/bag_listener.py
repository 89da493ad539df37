"""Feeds a run's rosbag2 from the daemon's core: every topic of the robot, and raw telemetry."""

from __future__ import annotations

import struct

from jackson.host.core import CoreListener, FrameResult, HostCore
from jackson.host.ekf import EkfState
from jackson.host.ros.bag import BagRecorder
from jackson.protocol import PROTOCOL_VERSION, Frame, TelemetryFlags, crc32c
from jackson.protocol.units import accel_m_s2, gyro_rad_s


def wire_bytes(frame: Frame) -> bytes:
    """The frame as it was on the wire (a delivered frame has this version and a valid CRC)."""
    body = bytes((PROTOCOL_VERSION, frame.type, frame.seq, len(frame.payload))) + frame.payload
    return b"\xa5\x5a" + body + struct.pack("<I", crc32c(body))


class BagListener(CoreListener):
    """Writes /wheel/odom, /imu/data, /joint_states, /odometry/filtered, /tf, /diagnostics (1 Hz)
    and every received frame (/jackson/telemetry) of a run, stamped with MCU time."""

    def __init__(self, bag: BagRecorder) -> None:
        self.bag = bag
        self._pending: list[bytes] = []
        self._t_s = 0.0
        self._next_diag_s = 0.0

    def on_frame(self, frame: Frame, host_time_ns: int) -> None:
        self._pending.append(wire_bytes(frame))

    def on_result(self, core: HostCore, result: FrameResult) -> None:
        t_s, telemetry, odo = result.t_s, result.telemetry, result.odometry
        self._t_s = t_s
        for raw in self._pending:
            self.bag.raw_frame(t_s, raw)
        self._pending.clear()
        if odo is not None:
            self.bag.wheel_odom(t_s, odo.x_m, odo.y_m, odo.yaw_rad, odo.v_m_s, odo.w_rad_s)
            self.bag.joint_states(
                t_s,
                odo.wheel_angle_left_rad,
                odo.wheel_angle_right_rad,
                odo.wheel_velocity_left_rad_s,
                odo.wheel_velocity_right_rad_s,
            )
        imu_ok = bool(telemetry.flags & TelemetryFlags.IMU_OK)
        if imu_ok:
            self.bag.imu(t_s, accel_m_s2(telemetry), gyro_rad_s(telemetry))
        if t_s >= self._next_diag_s:
            self._next_diag_s = t_s + 1.0
            rejected = sum(core.ekf.rejected.values())
            self.bag.diagnostics(
                t_s,
                {
                    "link": "up",
                    "imu": "ok" if imu_ok else "failing",
                    "host_lost_flag": str(bool(telemetry.flags & TelemetryFlags.HOST_LOST)),
                    "rejected_measurements": str(rejected),
                    "watchdog": "braked" if core.braked else "driving",
                },
                level=0 if imu_ok else 1,
            )

    def on_filtered(self, t_s: float, state: EkfState) -> None:
        self.bag.filtered(
            t_s,
            state.x_m,
            state.y_m,
            state.yaw_rad,
            state.vx_m_s,
            state.vy_m_s,
            state.vyaw_rad_s,
            state.covariance_diagonal,
        )
