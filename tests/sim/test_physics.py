"""The twin's physics: straight lines, circles, slip, deadband, encoders, IMU noise, walls."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from jackson.sim.config import MotorSpec, RobotSpec, Sides, WorldSpec, load_robot, load_world
from jackson.sim.robot import WheelDrive
from jackson.sim.twin import Twin

FLOOR = WorldSpec(name="test_floor", mu_static=0.8, mu_dynamic=0.7)


def robot(**changes: object) -> RobotSpec:
    base = dataclasses.replace(load_robot("jackson"), name="test")
    return dataclasses.replace(base, **changes)  # type: ignore[arg-type]


def drive(d: float) -> WheelDrive:
    return WheelDrive(d, 1.0)


def run_wheel_speed_pi(tw: Twin, w_left: float, w_right: float, seconds: float) -> None:
    """A wheel-speed PI on the true wheel speeds, 100 Hz, for tests of the physics only."""
    il = ir = 0.0
    kp, ki = 0.15, 1.5
    for _ in range(round(seconds * 100)):
        el, er = w_left - tw.robot.omega_l, w_right - tw.robot.omega_r
        il, ir = il + el * 0.01, ir + er * 0.01
        dl = max(-1.0, min(1.0, kp * el + ki * il))
        dr = max(-1.0, min(1.0, kp * er + ki * ir))
        tw.command(drive(dl), drive(dr))
        tw.advance(0.01)


def test_equal_pwm_drives_straight_without_asymmetry() -> None:
    tw = Twin(FLOOR, robot(), lidar=False)
    tw.command(drive(0.6), drive(0.6))
    tw.advance(5.0)
    t = tw.truth()
    assert t.x > 0.8
    assert abs(t.y) < 1e-9 and abs(t.yaw) < 1e-9


def test_equal_pwm_curves_by_the_configured_asymmetry() -> None:
    weak_right = robot(motor=dataclasses.replace(MotorSpec(), gain=Sides(1.0, 0.96)))
    tw = Twin(FLOOR, weak_right, lidar=False)
    tw.command(drive(0.6), drive(0.6))
    tw.advance(5.0)
    t = tw.truth()
    assert t.yaw < -0.05  # turns clockwise, towards the weak side
    # wheel speed ratio at steady state follows the gain once deadband is accounted for
    ratio = tw.robot.omega_r / tw.robot.omega_l
    assert 0.93 < ratio < 0.97


def test_v_0_08_w_0_16_traces_a_half_metre_circle() -> None:
    spec = robot()
    tw = Twin(FLOOR, spec, lidar=False)
    v, w, b, r = 0.08, 0.16, spec.wheel_separation_m, spec.wheel_radius_m.left
    run_wheel_speed_pi(tw, (v - w * b / 2) / r, (v + w * b / 2) / r, 3.0)  # settle
    start = len(tw.truth_log)
    run_wheel_speed_pi(tw, (v - w * b / 2) / r, (v + w * b / 2) / r, 2 * math.pi / w)
    xy = np.array([(s.x, s.y) for s in tw.truth_log[start:]])
    # least-squares circle fit (Kasa)
    a = np.c_[2 * xy, np.ones(len(xy))]
    cx, cy, c = np.linalg.lstsq(a, (xy**2).sum(axis=1), rcond=None)[0]
    radius = math.sqrt(c + cx**2 + cy**2)
    assert radius == pytest.approx(0.5, rel=0.01)
    assert not tw.robot.slipping


def test_low_friction_floor_slips_under_hard_acceleration() -> None:
    def peak_slip(world: WorldSpec) -> float:
        tw = Twin(world, robot(), lidar=False)
        tw.command(drive(0.7), drive(0.7))  # a hard step from rest
        worst = 0.0
        for _ in range(200):
            tw.advance(0.005)
            t = tw.truth()
            worst = max(worst, abs(t.omega_left * 0.033 - t.vx))
        return worst

    grippy = peak_slip(FLOOR)
    slippery = peak_slip(load_world("low_friction"))
    assert grippy < 0.001  # m/s: rolls without slipping
    assert slippery > 0.05  # the wheels spin up faster than the robot moves


def test_low_friction_world_file_is_the_papers_g03() -> None:
    w = load_world("low_friction")
    assert (w.mu_static, w.mu_dynamic) == (0.30, 0.25)


def test_deadband_holds_the_robot_below_breakaway_duty() -> None:
    tw = Twin(FLOOR, robot(), lidar=False)
    tw.command(drive(0.09), drive(0.09))  # below the 0.10 breakaway duty
    tw.advance(2.0)
    assert tw.truth().x == 0.0
    tw.command(drive(0.13), drive(0.13))
    tw.advance(2.0)
    assert tw.truth().x > 0.005


def test_counts_equal_wheel_rotation_times_true_ticks_per_rev() -> None:
    spec = robot(ticks_per_rev=Sides(617.0, 626.0))
    tw = Twin(FLOOR, spec, lidar=False)
    tw.command(drive(0.5), drive(-0.4))
    tw.advance(3.0)
    s = tw.sensors()
    rl, rr = tw.robot.angle_l / (2 * math.pi), tw.robot.angle_r / (2 * math.pi)
    assert s.enc_left == math.floor(rl * 617)
    assert s.enc_right == math.floor(rr * 626)
    assert rl > 1.5 and rr < -1.2


def test_imu_noise_matches_the_configured_sigma() -> None:
    tw = Twin(FLOOR, robot(), lidar=False, seed=7)
    gyro_z, accel_x = [], []
    for _ in range(4000):
        tw.advance(0.05)
        s = tw.sensors()
        gyro_z.append(s.gyro[2])
        accel_x.append(s.accel[0])
    gyro_sigma = np.std(np.array(gyro_z) / 131.0 * math.pi / 180.0)
    accel_sigma = np.std(np.array(accel_x) / 16384.0 * 9.81)
    # sampling error of a std over 4000 samples is about 1.1 %; quantisation adds < 1 %
    assert gyro_sigma == pytest.approx(3.999e-4, rel=0.05)
    assert accel_sigma == pytest.approx(1.7976e-2, rel=0.05)


def test_gravity_and_bias_appear_in_the_imu() -> None:
    spec = robot()
    biased = dataclasses.replace(
        spec,
        imu=dataclasses.replace(
            spec.imu,
            gravity_scale=9.299 / 9.81,
            gyro_bias_rad_s=(0.0, 0.0, 0.01),
            gyro_noise_sigma_rad_s=0.0,
            accel_noise_sigma_m_s2=0.0,
        ),
    )
    tw = Twin(FLOOR, biased, lidar=False)
    tw.advance(0.05)
    s = tw.sensors()
    assert s.accel[2] == round(9.299 / 9.81 * 16384)
    assert s.gyro[2] == round(0.01 * 180 / math.pi * 131)


def test_driving_into_a_wall_collides_and_never_tunnels() -> None:
    room = load_world("square_room")  # wall at x = 2.5
    tw = Twin(room, robot(), lidar=False)
    tw.robot.yaw = 4.0 * math.pi  # two turns on the spot behind it: the same heading, unwrapped
    tw.command(drive(1.0), drive(1.0))
    tw.advance(20.0)
    assert tw.collisions >= 1
    # each contact kept with its time, the robot's pose and what it touched
    first = tw.world.contacts[0]
    assert len(tw.world.contacts) == tw.collisions
    assert 0.0 < first.t_s <= tw.truth().t_s
    assert first.obstacle == "wall (2.50, -1.50)-(2.50, 2.50)"
    assert 2.5 - 0.2 < first.x_m < 2.5 and abs(first.y_m) < 0.1
    assert first.line().startswith(f"contact at {first.t_s:.2f} s: the robot at (")
    assert -math.pi < first.yaw_rad <= math.pi  # wrapped, as the log prints it
    front = tw.truth().x + 0.135177
    assert front <= 2.5 + 0.01  # pressed against the wall, not through it
    assert max(s.x for s in tw.truth_log) + 0.135177 <= 2.5 + 0.01


def test_triggered_cylinder_appears_after_the_robot_moves() -> None:
    w = load_world("stage3_corridor")
    tw = Twin(w, robot(), lidar=False)
    tw.command(drive(0.5), drive(0.5))
    tw.advance(0.2)
    assert tw.world.inserted == []
    tw.advance(1.0)
    assert len(tw.world.inserted) == 1
    t_ins, cyl = tw.world.inserted[0]
    assert cyl.radius == 0.125
    assert t_ins > 0.2


def test_actuation_latency_delays_the_command() -> None:
    tw = Twin(FLOOR, robot(actuation_latency_s=0.05), lidar=False)
    tw.command(drive(1.0), drive(1.0))
    tw.advance(0.045)
    assert tw.robot.omega_l == 0.0
    tw.advance(0.02)
    assert tw.robot.omega_l > 0.0


def test_free_space_shortcut_matches_pymunk_step_for_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """Away from obstacles the twin integrates as pymunk would; forcing pymunk changes nothing."""

    def trajectory() -> list[tuple[float, float, float]]:
        tw = Twin(FLOOR, robot(), lidar=False)
        tw.command(drive(0.5), drive(0.8))
        tw.advance(3.0)
        tw.command(drive(-0.6), drive(0.4))
        tw.advance(2.0)
        return [(s.x, s.y, s.yaw) for s in tw.truth_log]

    fast = trajectory()
    import jackson.sim.twin as twin_module

    monkeypatch.setattr(
        twin_module.Twin,
        "_step_near_obstacles",
        lambda self, space, dt: self.robot.step_space(space, dt),
    )
    monkeypatch.setattr(twin_module, "CONTACT_MARGIN_M", 1e9)
    slow = []
    tw = Twin(FLOOR, robot(), lidar=False)
    tw._free_budget = -1e9
    tw.command(drive(0.5), drive(0.8))
    tw.advance(3.0)
    tw.command(drive(-0.6), drive(0.4))
    tw.advance(2.0)
    slow = [(s.x, s.y, s.yaw) for s in tw.truth_log]
    assert len(fast) == len(slow) == 1001
    assert (
        max(abs(a - b) for p, q in zip(fast, slow, strict=True) for a, b in zip(p, q, strict=True))
        < 1e-9
    )


def test_scan_history_keeps_the_newest_scans_and_counts_all() -> None:
    everything = Twin(FLOOR, robot(), lidar=True)
    bounded = Twin(FLOOR, robot(), lidar=True, scan_history=5)
    for tw in (everything, bounded):
        tw.command(WheelDrive(0.5, 1.0), WheelDrive(0.6, 1.0))
        tw.advance(3.0)  # 7.43 Hz: 23 scans
    assert everything.scans_taken == bounded.scans_taken == len(everything.scans) >= 22
    assert len(bounded.scans) == 5
    newest = list(everything.scans)[-5:]
    assert [s.t_s for s in bounded.scans] == [s.t_s for s in newest]
    pairs = zip(bounded.scans, newest, strict=True)
    assert all(np.array_equal(a.ranges, b.ranges) for a, b in pairs)


def test_the_models_wheel_attributes_are_its_wheel_states() -> None:
    tw = Twin(FLOOR, robot(), seed=0)
    model = tw.robot.model
    tw.command(drive(0.6), drive(0.4))
    tw.advance(0.5)
    left, right = model.left, model.right
    assert (left.drive, left.connected, right.drive, right.connected) == (0.6, 1.0, 0.4, 1.0)
    assert (tw.robot.omega_l, tw.robot.angle_l, tw.robot.tau_l) == (
        left.omega,
        left.angle,
        left.tau,
    )
    assert (tw.robot.omega_r, tw.robot.angle_r, tw.robot.tau_r) == (
        right.omega,
        right.angle,
        right.tau,
    )
    assert left.omega > right.omega > 0.0
