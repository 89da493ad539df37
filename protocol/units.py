"""Telemetry's raw IMU counts in SI units, at the full-scale ranges its flags name.

The ranges (bits ACCEL_FS and GYRO_FS of ``flags``), the LSB tables and the nominal gravity come
from ``protocol/schema.yaml`` through the generated :mod:`jackson.protocol.messages`; this is the
one place the host and the twin convert them.
"""

from __future__ import annotations

import math

from jackson.protocol.messages import (
    ACCEL_LSB_PER_G,
    GRAVITY_M_S2,
    GYRO_LSB_PER_DPS,
    TEMP_LSB_PER_C,
    TEMP_OFFSET_C,
    Telemetry,
    accel_fs,
    gyro_fs,
)

Vec3 = tuple[float, float, float]


def gyro_lsb_per_rad_s(flags: int) -> float:
    """Gyro counts per rad/s at the range ``flags`` names."""
    return GYRO_LSB_PER_DPS[gyro_fs(flags)] * 180.0 / math.pi


def accel_lsb_per_m_s2(flags: int) -> float:
    """Accelerometer counts per m/s^2 at the range ``flags`` names (nominal gravity)."""
    return ACCEL_LSB_PER_G[accel_fs(flags)] / GRAVITY_M_S2


def gyro_rad_s(t: Telemetry) -> Vec3:
    """Angular velocity [rad/s], x y z."""
    lsb = GYRO_LSB_PER_DPS[gyro_fs(t.flags)]
    x, y, z = (math.radians(c / lsb) for c in t.gyro)
    return x, y, z


def yaw_rate_rad_s(t: Telemetry) -> float:
    """Angular velocity about z [rad/s] (the same value as ``gyro_rad_s(t)[2]``)."""
    return math.radians(t.gyro[2] / GYRO_LSB_PER_DPS[gyro_fs(t.flags)])


def accel_m_s2(t: Telemetry) -> Vec3:
    """Specific force [m/s^2], x y z."""
    lsb = ACCEL_LSB_PER_G[accel_fs(t.flags)]
    x, y, z = (c / lsb * GRAVITY_M_S2 for c in t.accel)
    return x, y, z


def temperature_c(t: Telemetry) -> float:
    """The MPU-6050's die temperature [deg C]."""
    return t.temp / TEMP_LSB_PER_C + TEMP_OFFSET_C
