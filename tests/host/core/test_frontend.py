"""The front end: a telemetry frame in, the frame's measurement out (time, lost frames,
counts, wheel speeds, the gyro less its bias, the accelerometer), and an MCU reset as a new
origin."""

from __future__ import annotations

import math

import pytest

from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.core.frontend import FrontEnd
from jackson.protocol import Info, Telemetry, TelemetryFlags
from jackson.protocol.units import GRAVITY_M_S2

CFG = load_config(DEFAULT_CONFIG)
TPR = CFG.robot.ticks_per_rev_left
LSB_PER_DPS = 131.0  # the MPU-6050's gyro at +-250 deg/s (the flags' full scale 0)


def frame(t_us: int, left: int = 0, right: int = 0, gyro_z: int = 0, imu: bool = True) -> Telemetry:
    flags = int(TelemetryFlags.IMU_OK) if imu else 0
    return Telemetry(
        t_us=t_us, enc_left=left, enc_right=right, flags=flags, accel=(0, 1638, 16384),
        gyro=(0, 0, gyro_z),
    )  # fmt: skip


def test_a_frame_measures_time_counts_wheel_speeds_and_the_accelerometer() -> None:
    fe = FrontEnd(CFG)
    first = fe.measure(frame(1_000_000, 100, 200))
    assert (first.t_s, first.ticks, first.dt_s, first.counts) == (1.0, (0, 0), 0.0, (100, 200))
    m = fe.measure(frame(1_050_000, 110, 212))
    assert m.t_s == 1.05 and m.ticks == (10, 12) and m.dt_s == pytest.approx(0.05)
    assert m.counts == (110, 212) and m.imu_ok and m.lost == 0
    assert m.wheel_rad_s == pytest.approx(
        (2 * math.pi * 10 / TPR / 0.05, 2 * math.pi * 12 / TPR / 0.05)
    )
    assert m.accel_m_s2 == pytest.approx((0.0, 0.1 * GRAVITY_M_S2, GRAVITY_M_S2), rel=1e-3)
    assert fe.frames == 2 and fe.t_s == 1.05


def test_the_gyro_is_measured_less_its_bias_once_the_robot_stood_still_long_enough() -> None:
    fe = FrontEnd(CFG)  # ekf.gyro_bias_window_s: 2 s
    t_us = 0
    for _ in range(60):  # 3 s standing still, the gyro reading 1 deg/s
        t_us += 50_000
        m = fe.measure(frame(t_us, gyro_z=131))
    assert m.raw_wz_rad_s == pytest.approx(math.radians(131 / LSB_PER_DPS))
    assert m.wz_rad_s == pytest.approx(0.0, abs=1e-12) and fe.bias_ever_known
    m = fe.measure(frame(t_us + 50_000, 5, 5, gyro_z=393))  # driving, 3 deg/s raw
    assert m.wz_rad_s == pytest.approx(math.radians(2.0), rel=1e-3)
    fe.remeasure_bias()  # the health monitor's verdict asks: measured again at the next rest
    m = fe.measure(frame(t_us + 100_000, 10, 10, gyro_z=393))
    assert m.wz_rad_s is None and fe.bias_ever_known  # unknown again, but it was known once
    m = fe.measure(frame(t_us + 150_000, 10, 10, imu=False))
    assert (m.imu_ok, m.raw_wz_rad_s, m.accel_m_s2) == (False, None, None)


def test_frames_missing_by_seq_are_lost_once_and_wrap_at_255() -> None:
    fe = FrontEnd(CFG)
    fe.frame_seq(250)
    fe.measure(frame(0))
    fe.frame_seq(251)
    fe.frame_seq(2)  # 252..255, 0, 1 missing
    assert fe.measure(frame(50_000)).lost == 6
    fe.frame_seq(3)
    assert fe.measure(frame(100_000)).lost == 0
    fe.link_up()  # a new session: the first frame's SEQ is not a gap
    fe.frame_seq(77)
    assert fe.measure(frame(150_000)).lost == 0


def test_an_mcu_reset_makes_the_next_frame_a_new_origin_and_the_counts_go_on() -> None:
    fe = FrontEnd(CFG)
    assert not fe.info(Info(boot_id=1))
    fe.measure(frame(5_000_000, 400, 400))
    fe.measure(frame(5_050_000, 410, 420))
    assert fe.info(Info(boot_id=2)) and fe.resets == 1
    m = fe.measure(frame(20_000, 0, 0))  # the new boot: its counts and clock restart
    assert (m.ticks, m.dt_s, m.counts) == ((0, 0), 0.0, (410, 420))
    m = fe.measure(frame(70_000, 7, 3))
    assert m.ticks == (7, 3) and m.counts == (417, 423) and m.dt_s == pytest.approx(0.05)


def test_the_health_input_is_the_frames_measurement_and_the_commands_two_facts() -> None:
    fe = FrontEnd(CFG)
    fe.measure(frame(0, gyro_z=0))
    m = fe.measure(frame(50_000, 3, 4, gyro_z=17))
    h = m.health_input((1.5, -1.5), commanded_still=False)
    assert h.t_s == m.t_s and h.ticks == (3, 4) and h.dt_s == m.dt_s
    assert h.wheel_rad_s == m.wheel_rad_s and h.wz_rad_s == m.wz_rad_s
    assert h.imu_raw == (0, 1638, 16384, 0, 0, 17, 0)  # accel, gyro, temperature registers
    assert h.accel_x_m_s2 == 0.0 and h.accel_y_m_s2 == pytest.approx(0.1 * GRAVITY_M_S2, rel=1e-3)
    assert h.wheel_cmd_rad_s == (1.5, -1.5) and not h.commanded_still
