"""The sensor health monitor on synthetic frames: gates, windowed tests, states and policy."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import replace

import numpy as np
import pytest

from jackson.host.estimation.ekf import Ekf
from jackson.host.estimation.health import (
    Health,
    HealthConfig,
    HealthInput,
    HealthMonitor,
    Verdict,
    wheel_yaw_prior,
)
from jackson.host.estimation.odometry import RobotGeometry

DT = 0.05
ROBOT = RobotGeometry()
GYRO_SIGMA = 0.005  # [rad/s] a quieter gyro than the EKF's R assumes, as the MPU-6050 is
ACCEL_SIGMA = 0.018  # [m/s^2] the twin's MPU-6050


class Robot:
    """A robot driving (v, w) with exact encoders (quantised) and a noisy gyro."""

    def __init__(self, seed: int = 0) -> None:
        self.rng = np.random.default_rng(seed)
        self.t = 0.0
        self.phi = [0.0, 0.0]  # wheel angles [rad]
        self.counts = [0, 0]
        self.raw_noise = 0
        self.v = 0.0  # the true forward speed at the last frame [m/s]

    def frame(
        self,
        v: float,
        w: float,
        *,
        gyro_extra: float = 0.0,
        imu_ok: bool = True,
        frozen: bool = False,
        stuck: tuple[bool, bool] = (False, False),
        slip: tuple[float, float] = (1.0, 1.0),
    ) -> HealthInput:
        """One frame; ``slip`` scales each wheel's turn over the floor's (1.3: spins 30 % more)."""
        self.t += DT
        b = ROBOT.wheel_separation_m
        om = [
            (v - w * b / 2) / ROBOT.wheel_radius_left_m,
            (v + w * b / 2) / ROBOT.wheel_radius_right_m,
        ]
        ticks = []
        speeds = []
        for i, tpr in enumerate((ROBOT.ticks_per_rev_left, ROBOT.ticks_per_rev_right)):
            self.phi[i] += om[i] * slip[i] * DT
            new = math.floor(self.phi[i] / (2 * math.pi) * tpr)
            if stuck[i]:
                new = self.counts[i]
            ticks.append(new - self.counts[i])
            self.counts[i] = new
            speeds.append(ticks[-1] * 2 * math.pi / tpr / DT)
        wz = w + self.rng.normal(0.0, GYRO_SIGMA) + gyro_extra
        a_x = (v - self.v) / DT + self.rng.normal(0.0, ACCEL_SIGMA)  # the true speed's change
        self.v = v
        if not frozen:
            self.raw_noise = int(self.rng.integers(-1000, 1000))
        return HealthInput(
            t_s=self.t,
            imu_ok=imu_ok,
            imu_raw=(self.raw_noise, 0, 16384, 0, 0, 0, 0),
            wz_rad_s=wz if imu_ok else None,
            wheel_rad_s=(speeds[0], speeds[1]),
            ticks=(ticks[0], ticks[1]),
            dt_s=DT,
            wheel_cmd_rad_s=(om[0], om[1]),
            commanded_still=v == 0.0 and w == 0.0,
            accel_y_m_s2=v * w + self.rng.normal(0.0, ACCEL_SIGMA) if imu_ok else None,
            accel_x_m_s2=a_x if imu_ok else None,
        )


def drive(
    mon: HealthMonitor, robot: Robot, seconds: float, v: float, w: float, **fault: object
) -> list[Verdict]:
    return [mon.update(robot.frame(v, w, **fault)) for _ in range(round(seconds / DT))]  # type: ignore[arg-type]


def monitor(**cfg: object) -> HealthMonitor:
    return HealthMonitor(replace(HealthConfig(), **cfg), ROBOT)  # type: ignore[arg-type]


def course(seconds: float) -> Iterator[tuple[float, float]]:
    """Straights, arcs both ways, pivots and stops, 20 s per lap."""
    laps = [
        (0.15, 0.0, 5.0),
        (0.08, 0.15, 4.0),
        (0.0, 0.6, 2.0),
        (0.08, -0.15, 4.0),
        (0.0, 0.0, 1.0),
        (0.0, -0.6, 2.0),
        (0.2, 0.0, 2.0),
    ]
    t = 0.0
    while t < seconds:
        for v, w, span in laps:
            for _ in range(round(span / DT)):
                yield v, w
            t += span


def test_a_healthy_robot_raises_no_alarm_in_an_hour_of_driving() -> None:
    mon, robot = monitor(), Robot(1)
    for v, w in course(3600.0):
        verdict = mon.update(robot.frame(v, w))
        assert verdict.lost is None
    assert mon.transitions == [], mon.transitions[:3]
    assert mon.counts["gated"] <= 2  # 1e-4 per sample of 72 000


def test_a_spike_is_not_fused_and_three_in_a_window_exclude_the_imu_until_it_recovers() -> None:
    mon, robot = monitor(), Robot(2)
    drive(mon, robot, 5.0, 0.1, 0.2)
    (one,) = drive(mon, robot, DT, 0.1, 0.2, gyro_extra=2.0)
    assert not one.use_gyro  # not fused; a spike once the next sample passes
    drive(mon, robot, DT, 0.1, 0.2)
    assert mon.state("imu") is Health.SUSPECT
    drive(mon, robot, 0.2, 0.1, 0.2)
    drive(mon, robot, DT, 0.1, 0.2, gyro_extra=-2.0)
    drive(mon, robot, 0.1, 0.1, 0.2)
    (third,) = drive(mon, robot, DT, 0.1, 0.2, gyro_extra=2.0)
    (after,) = drive(mon, robot, DT, 0.1, 0.2)
    assert not third.use_gyro and not after.use_gyro and after.lost is None
    assert mon.state("imu") is Health.EXCLUDED
    verdicts = drive(mon, robot, 2.5, 0.1, 0.2)
    assert mon.state("imu") is Health.RECOVERED and verdicts[-1].use_gyro
    drive(mon, robot, 10.0, 0.1, 0.2)
    assert mon.state("imu") is Health.OK
    assert [t.new for t in mon.transitions] == [
        Health.SUSPECT,
        Health.EXCLUDED,
        Health.RECOVERED,
        Health.OK,
    ]


def test_a_dead_imu_is_excluded_and_the_policy_decides() -> None:
    for policy, lost in (("continue", False), ("stop", True)):
        mon, robot = monitor(imu_lost=policy), Robot(3)
        drive(mon, robot, 3.0, 0.1, 0.0)
        verdicts = drive(mon, robot, 0.3, 0.1, 0.0, imu_ok=False)
        first = next(i for i, v in enumerate(verdicts) if mon.transitions)
        assert mon.state("imu") is Health.EXCLUDED
        assert (first + 1) * DT <= 0.25 + DT + 1e-9
        assert (verdicts[-1].lost is not None) == lost
        assert "dead" in mon.reason("imu")


def test_frozen_registers_exclude_the_imu() -> None:
    mon, robot = monitor(), Robot(4)
    drive(mon, robot, 3.0, 0.0, 0.3)
    drive(mon, robot, 0.6, 0.0, 0.3, frozen=True)
    assert mon.state("imu") is Health.EXCLUDED and "stuck" in mon.reason("imu")


@pytest.mark.parametrize("side", [0, 1])
def test_a_cut_encoder_wire_excludes_that_encoder_only(side: int) -> None:
    mon, robot = monitor(), Robot(5)
    drive(mon, robot, 3.0, 0.15, 0.0)
    stuck = (side == 0, side == 1)
    verdicts = drive(mon, robot, 1.0, 0.15, 0.0, stuck=stuck)
    names = ("encoder_left", "encoder_right")
    assert mon.state(names[side]) is Health.EXCLUDED, mon.transitions
    assert mon.state(names[1 - side]) is Health.OK and mon.state("imu") is Health.OK
    assert verdicts[-1].lost is None and verdicts[-1].use_gyro
    # with the IMU gone too, nothing is left to steer by: the policy brakes
    drive(mon, robot, 0.3, 0.15, 0.0, stuck=stuck, imu_ok=False)
    assert mon.update(robot.frame(0.15, 0.0, stuck=stuck, imu_ok=False)).lost is not None


@pytest.mark.parametrize("side", [0, 1])
def test_a_slipping_wheel_is_found_against_the_gyro_and_the_other_wheel(side: int) -> None:
    mon, robot = monitor(), Robot(6)
    drive(mon, robot, 3.0, 0.15, 0.0)
    slip = (1.3, 1.0) if side == 0 else (1.0, 1.3)
    verdicts = drive(mon, robot, 2.0, 0.15, 0.0, slip=slip)
    names = ("encoder_left", "encoder_right")
    assert mon.state(names[side]) is Health.EXCLUDED, mon.transitions
    assert "sides with the gyro" in mon.reason(names[side])
    assert verdicts[-1].use_gyro  # held only while the witness made up its mind
    assert mon.state(names[1 - side]) is Health.OK and mon.state("imu").usable
    drive(mon, robot, 4.0, 0.15, 0.0)  # off the patch
    assert mon.state(names[side]) is Health.RECOVERED and mon.state("imu") is Health.OK


@pytest.mark.parametrize("side", [0, 1])
def test_a_slow_slip_is_told_from_a_gyro_fault_by_the_forward_speed(side: int) -> None:
    """At 0.05 m/s the lateral force hardly tells a slipping wheel from a gyro that jumped;
    the wheels' forward speed running away from the accelerometer's does."""
    mon, robot = monitor(), Robot(16 + side)
    drive(mon, robot, 3.0, 0.05, 0.0)
    slip = (2.5, 1.0) if side == 0 else (1.0, 2.5)
    drive(mon, robot, 1.0, 0.05, 0.0, slip=slip)
    names = ("encoder_left", "encoder_right")
    assert mon.state(names[side]) is Health.EXCLUDED, mon.transitions
    assert "sides with the gyro" in mon.reason(names[side])
    assert mon.state("imu").usable
    # the speed witness alone: the gap is the slip's (its sign names the wheel), not zero
    gap = mon.speed_gap(3.1)
    assert gap is not None
    g, x, sigma = gap
    assert abs(x) > 3.0 * sigma and (x > 0) == (side == 1)  # + : the right wheel
    slip_gap = x if side == 1 else -x
    assert abs(g - slip_gap) < 0.5 * abs(x) < abs(g)


def test_a_slow_gyro_jump_is_not_blamed_on_a_wheel() -> None:
    """The same disagreement from the gyro's side: the wheels' speed agrees with the
    accelerometer's, so no wheel is excluded but the gyro is."""
    mon, robot = monitor(), Robot(18)
    drive(mon, robot, 3.0, 0.05, 0.0)
    drive(mon, robot, 1.5, 0.05, 0.0, gyro_extra=-0.4)
    assert mon.state("encoder_left").usable and mon.state("encoder_right").usable
    assert mon.state("imu") is Health.EXCLUDED, mon.transitions
    assert "sides with the wheels" in mon.reason("imu")
    gap = mon.speed_gap(3.1)
    assert gap is not None
    g, x, sigma = gap
    assert abs(x) > 3.0 * sigma and abs(g) < min(abs(g - x), abs(g + x))


def test_a_gyro_reading_non_zero_standing_still_is_a_bias_to_measure_again() -> None:
    mon, robot = monitor(), Robot(7)
    drive(mon, robot, 2.0, 0.1, 0.0)
    verdicts = drive(mon, robot, 2.0, 0.0, 0.0, gyro_extra=0.05)
    assert any(v.stationary for v in verdicts)
    assert mon.state("imu") is Health.EXCLUDED and "bias" in mon.reason("imu")
    assert any("bias" in t.reason for t in mon.transitions)


def test_standing_still_needs_a_still_command_and_no_count() -> None:
    mon, robot = monitor(), Robot(8)
    verdicts = drive(mon, robot, 1.0, 0.0, 0.0)
    first = next(i for i, v in enumerate(verdicts) if v.stationary)
    assert first * DT == pytest.approx(0.25, abs=DT + 1e-9)
    assert not any(v.stationary for v in drive(mon, robot, 1.0, 0.1, 0.0))
    assert not any(v.stationary for v in drive(monitor(zupt=False), Robot(), 1.0, 0.0, 0.0))


def test_zero_velocity_updates_keep_a_parked_robots_covariance_bounded() -> None:
    """The paper's filter predicts a parked robot's pose ever more uncertain (0.05 m^2/s);
    with zero-velocity updates its velocity settles at once and its pose variance stops."""

    def park(zupt: Callable[[Ekf, float], None] | None) -> tuple[float, float, float]:
        ekf = Ekf()
        t = 0.0
        for _ in range(100):  # driving at 0.2 m/s, then braking
            t += DT
            ekf.update_wheel(t, 0.2)
            ekf.update_gyro(t, 0.0)
        peak_vx = p_parked = 0.0
        for k in range(round(120.0 / DT)):
            t += DT
            if k == 5:
                p_parked = ekf.P[0, 0]
            if zupt is not None and k >= 5:
                zupt(ekf, t)
            else:
                ekf.update_wheel(t, 0.0)
                ekf.update_gyro(t, 0.0)
            if k * DT > 0.5:
                peak_vx = max(peak_vx, abs(ekf.vx_m_s))
        return p_parked, ekf.P[0, 0], peak_vx

    def zupt(ekf: Ekf, t: float) -> None:
        ekf.stationary = True
        ekf.update_zero_velocity(t, 1e-6)

    p0_paper, p_paper, vx_paper = park(None)
    p0_zupt, p_zupt, vx_zupt = park(zupt)
    assert p_paper - p0_paper > 5.0  # m^2 more after two minutes
    assert p_zupt - p0_zupt < 1e-9 and vx_zupt < 1e-4
    assert vx_paper > vx_zupt


def test_the_monitor_shows_each_sensors_health_from_the_frames_alone() -> None:
    from jackson.host.monitor import SensorWatch
    from jackson.protocol import Telemetry, TelemetryFlags

    watch = SensorWatch()
    rng = np.random.default_rng(9)
    for k in range(100):  # 5 s standing still, a live IMU, then 1 s without IMU_OK
        flags = TelemetryFlags.IMU_OK if k < 80 else 0
        noise = tuple(int(v) for v in rng.integers(-3, 4, size=3))
        watch.feed(Telemetry(t_us=50_000 * k, flags=flags, accel=(0, 0, 16384), gyro=noise))
        if k == 79:
            assert "imu ok" in watch.line() and "encoder_left ok" in watch.line()
    assert "imu excluded" in watch.line() and "dead" in watch.line()


def test_a_gyro_bias_step_while_driving_is_held_as_ambiguous_then_charged_to_the_gyro() -> None:
    """Over a short window a bias step and a slipping wheel look alike and the accelerometer
    cannot tell them apart at 0.1 m/s: the wheels' yaw stands in, and a disagreement that
    outlasts ``ambiguity_s`` is the gyro's; it stays out while the disagreement lasts."""
    mon, robot = monitor(), Robot(10)
    drive(mon, robot, 5.0, 0.1, 0.15)
    verdicts = drive(mon, robot, 6.0, 0.1, 0.15, gyro_extra=0.05)
    first = next(i for i, v in enumerate(verdicts) if not v.use_gyro)
    assert first * DT < 1.5  # the windowed test: about a window
    assert mon.state("imu") is Health.EXCLUDED and "longer than a slipping wheel" in mon.reason(
        "imu"
    )
    assert mon.state("encoder_left").usable and mon.state("encoder_right").usable
    assert not any(v.use_gyro for v in verdicts[first:])
    assert all(v.lost is None for v in verdicts)


def test_two_silent_wheels_judged_by_the_command_alone_are_not_two_cut_encoders() -> None:
    """Before the gyro's bias is known the command is the only witness: a robot whose motors do
    not move yet (the interlock, a stall) must not lose both encoders and brake for good."""
    mon, robot = monitor(), Robot(11)
    for _ in range(round(2.0 / DT)):
        h = robot.frame(0.0, 0.0)
        h = replace(h, wz_rad_s=None, wheel_cmd_rad_s=(4.5, 4.5), commanded_still=False)
        assert mon.update(h).lost is None
    assert mon.state("encoder_left") is Health.OK and mon.state("encoder_right") is Health.OK


# ---------------------------------------------------------------------------- the LiDAR

LIDAR_PERIOD = 1.0 / 7.43  # [s] the twin's A1M8
BEAMS = 1080


def room_scan(rng: np.random.Generator, sigma: float, x: float = 0.7, y: float = 0.4) -> np.ndarray:
    """Ranges from (x, y) in a 4 m x 3 m room centred on the origin, with N(0, sigma^2) noise,
    in the order a revolution measures them."""
    a = np.linspace(0.0, 2.0 * np.pi, BEAMS, endpoint=False)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (2.0 - x) / c, np.where(c < 0, (-2.0 - x) / c, np.inf))
        ty = np.where(s > 0, (1.5 - y) / s, np.where(s < 0, (-1.5 - y) / s, np.inf))
    r = np.minimum(tx, ty) + rng.normal(0.0, sigma, BEAMS)
    r[rng.random(BEAMS) < 0.05] = np.inf  # no return now and then
    return r


def scans(
    mon: HealthMonitor,
    rng: np.random.Generator,
    t0: float,
    seconds: float,
    sigma: float = 0.01,
    lost: float = 0.0,
) -> tuple[float, list[bool]]:
    """Revolutions every LIDAR_PERIOD for ``seconds``, stamped on 20 Hz frames as the core
    does, a fraction ``lost`` of them missing; (the time reached, each scan's use)."""
    used = []
    t = t0
    for _ in range(round(seconds / LIDAR_PERIOD)):
        t += LIDAR_PERIOD
        if rng.random() < lost:
            continue
        used.append(mon.scan(math.ceil(t / DT) * DT, room_scan(rng, sigma)))
    return t, used


def test_a_healthy_lidar_raises_no_alarm_and_its_noise_is_measured() -> None:
    mon, rng = monitor(), np.random.default_rng(30)
    _, used = scans(mon, rng, 0.0, 120.0)
    assert all(used) and mon.transitions == []
    assert mon.lidar_roughness_m == pytest.approx(0.01, rel=0.15)
    assert mon.lidar_missing < 0.05


def test_a_noisy_lidar_is_suspect_and_a_useless_one_excluded_and_stops_navigation() -> None:
    mon, rng = monitor(), np.random.default_rng(31)
    t, _ = scans(mon, rng, 0.0, 5.0)
    t, used = scans(mon, rng, t, 1.0, sigma=0.05)
    assert mon.state("lidar") is Health.SUSPECT and all(used)  # rough but usable
    assert mon.lidar_roughness_m == pytest.approx(0.05, rel=0.15)
    t, used = scans(mon, rng, t, 1.0, sigma=0.2)
    assert not any(used) and mon.state("lidar") is Health.EXCLUDED, mon.transitions
    robot = Robot(31)
    assert mon.update(robot.frame(0.1, 0.0)).lost is None  # nothing navigates by it
    mon.lidar_needed = True
    lost = mon.update(robot.frame(0.1, 0.0)).lost
    assert lost is not None and "LiDAR" in lost
    t, used = scans(mon, rng, t, 3.0)  # the noise goes: back in after recover_s
    assert mon.state("lidar") is Health.RECOVERED and used[-1] and not used[0]


def test_lost_revolutions_make_the_lidar_suspect_and_silence_excludes_it() -> None:
    mon, rng = monitor(), np.random.default_rng(32)
    t, _ = scans(mon, rng, 0.0, 10.0)
    t, _ = scans(mon, rng, t, 6.0, lost=0.3)
    assert mon.state("lidar") is Health.SUSPECT and "lost" in mon.reason("lidar")
    assert 0.15 < mon.lidar_missing < 0.45
    t, _ = scans(mon, rng, t, 12.0)
    assert mon.state("lidar") is Health.OK
    robot = Robot(32)
    robot.t = t
    drive(mon, robot, 1.2, 0.1, 0.0)  # frames but no scan
    assert mon.state("lidar") is Health.EXCLUDED and "no scan" in mon.reason("lidar")
    t, used = scans(mon, rng, robot.t, 3.0)
    assert mon.state("lidar") is Health.RECOVERED and used[-1]


def test_a_navigating_robot_is_held_sooner_the_faster_it_drives_when_the_lidar_falls_silent() -> (
    None
):
    """At 0.28 m/s the robot covers lidar_blind_m (6 cm) on its last scan in 0.21 s: it is held
    (lidar_blind, braked) then, and a scan that comes lets it go on; never sooner than 1.5
    revolution periods, the stream's own spacing. A silence of lidar_silence_s (1 s) excludes
    the LiDAR whatever the speed."""
    for v, limit in ((0.28, 0.06 / 0.28), (0.0, 1.0), (2.0, 1.5 * 0.13465)):
        mon, rng = monitor(), np.random.default_rng(33)
        mon.lidar_needed = True
        t, _ = scans(mon, rng, 0.0, 5.0)
        robot = Robot(33)
        robot.t = t
        drive(mon, robot, 0.1, v, 0.0)  # no scan from t on
        assert mon.lidar_silence_limit_s() == pytest.approx(limit, rel=0.05, abs=0.01)
        held_at = None
        for _ in range(round(1.5 / DT)):
            mon.update(robot.frame(v, 0.0))
            if mon.lidar_blind and held_at is None:
                held_at = robot.t
        if v > 0.0:  # standing, the 1 s silence excludes it first (and that brakes too)
            assert held_at is not None and held_at - t <= limit + 2 * DT, (v, held_at, t)
        assert mon.state("lidar") is Health.EXCLUDED and "no scan for 1.0" in mon.reason("lidar")
    mon, rng = monitor(), np.random.default_rng(37)
    mon.lidar_needed = True
    t, _ = scans(mon, rng, 0.0, 5.0)
    robot = Robot(37)
    robot.t = t
    drive(mon, robot, 0.4, 0.28, 0.0)
    assert mon.lidar_blind and mon.state("lidar") is Health.SUSPECT
    assert mon.scan(robot.t, room_scan(rng, 0.01))  # a scan again: the hold ends
    assert not mon.lidar_blind


def test_garbage_on_the_lidar_line_is_suspect_within_half_a_second_then_excluded() -> None:
    mon, rng = monitor(), np.random.default_rng(35)
    t, _ = scans(mon, rng, 0.0, 5.0)
    for k in range(40):  # clean bytes: 5 per node, 1080 nodes every 0.135 s, read per frame
        mon.lidar_bytes(t + k * DT, 2000, 0)
    t += 40 * DT
    assert mon.state("lidar") is Health.OK
    onset = t
    for k in range(30):  # half of every frame's bytes malformed
        mon.lidar_bytes(t + k * DT, 2000, 1000)
    t += 30 * DT
    first = [x for x in mon.transitions if x.sensor == "lidar"]
    assert first[0].new is Health.SUSPECT and first[0].t_s - onset <= 0.5
    assert "malformed" in first[0].reason
    assert mon.state("lidar") is Health.EXCLUDED  # it lasted
    assert not mon.scan(t, room_scan(rng, 0.01))  # a scan decoded meanwhile is not used


def test_a_revolution_that_is_not_a_turn_is_not_used() -> None:
    mon, rng = monitor(), np.random.default_rng(36)
    t, _ = scans(mon, rng, 0.0, 2.0)
    angles = np.linspace(0.0, 0.5, 40)  # a few random nodes decoded as a "revolution"
    assert not mon.scan(t + DT, np.full(40, 1.0), angles)
    assert mon.state("lidar") is Health.SUSPECT and "not a turn" in mon.reason("lidar")
    whole = np.linspace(0.0, 2.0 * np.pi, BEAMS, endpoint=False)
    assert mon.scan(t + 3 * DT, room_scan(rng, 0.01), whole)


def test_a_lidar_port_that_fails_is_excluded_at_once() -> None:
    mon = monitor()
    mon.lidar_needed = True
    mon.lidar_gone(4.2, "LiDAR port /dev/pts/9 went away (Input/output error)")
    assert mon.state("lidar") is Health.EXCLUDED
    assert mon.transitions[-1].t_s == 4.2


# ----------------------------------------------------------------- the wheel yaw model


def test_the_wheel_yaw_prior_follows_the_configured_uncertainties() -> None:
    """sigma_c0 = sqrt(2 (sigma_r^2 + sigma_C^2)) / B and sigma_s0^2 = sigma_B^2 + sigma_g^2 +
    (sigma_r^2 + sigma_C^2) / 2, the bounds n of them about s = 1, c = 0."""
    cfg = HealthConfig()
    prior = wheel_yaw_prior(cfg, ROBOT)
    var_e = 0.005**2 + 0.009**2
    assert prior.per_metre_sigma == pytest.approx(math.sqrt(2.0 * var_e) / 0.198)
    assert prior.scale_sigma == pytest.approx(math.sqrt(0.05**2 + 0.015**2 + var_e / 2.0))
    assert prior.per_metre_bounds == pytest.approx((-0.294, 0.294), abs=1e-3)
    assert prior.scale_bounds == pytest.approx((0.789, 1.211), abs=1e-3)
    wide = wheel_yaw_prior(replace(cfg, ticks_per_rev_uncertainty=0.02), ROBOT)
    assert wide.per_metre_sigma > prior.per_metre_sigma


def test_a_term_the_driving_does_not_excite_keeps_its_prior() -> None:
    """Pivots say nothing of c, straights nothing of s: each stays at its prior."""
    pivots, robot = monitor(), Robot(41)
    for _ in range(10):
        drive(pivots, robot, 3.0, 0.0, 0.6)
        drive(pivots, robot, 3.0, 0.0, -0.6)
    assert pivots.model.scale_learned and pivots.model.per_metre == 0.0
    straights, robot = monitor(), Robot(42)
    drive(straights, robot, 30.0, 0.2, 0.0)
    assert straights.model.identified == [False, True] and straights.model.scale == 1.0
    assert abs(straights.model.per_metre) < 0.02
    assert pivots.transitions == [] and straights.transitions == []


@pytest.mark.parametrize(("slip_s", "slip"), [(1.0, 1.08), (1.0, 1.05), (2.0, 1.04)])
def test_a_bad_first_seed_neither_locks_the_model_nor_excludes_a_healthy_gyro(
    slip_s: float, slip: float
) -> None:
    """The first straight samples come out of a turn with the right wheel spinning (0.1 rad/s
    of yaw the robot does not make: c = 0.4 rad/m if taken for its geometry). A model that
    takes them (gain 1/n) reads a yaw of c v on every straight after, which the monitor
    takes for a gyro bias step; this robot's true c is 0."""
    mon, robot = monitor(), Robot(40)
    bounds = wheel_yaw_prior(HealthConfig(), ROBOT).per_metre_bounds
    drive(mon, robot, 1.0, 0.0, 0.0)
    drive(mon, robot, 0.5, 0.12, 0.6)  # turning in
    drive(mon, robot, slip_s, 0.25, 0.0, slip=(1.0, slip))  # out of the turn, spinning
    seen = []
    for _ in range(6):
        for v, w, span in ((0.25, 0.0, 4.0), (0.15, 0.4, 2.0)):
            verdicts = drive(mon, robot, span, v, w)
            assert all(x.use_gyro and x.lost is None for x in verdicts)
            seen.append(mon.model.per_metre)
    assert all(bounds[0] <= c <= bounds[1] for c in seen)
    assert abs(seen[-1]) < 0.05 and mon.model.identified[1]  # learned from the healthy data
    assert mon.transitions == [], mon.transitions[:2]


def test_a_gyro_bias_step_is_still_found_once_the_model_is_learned() -> None:
    """The model learned over straights, arcs and pivots at navigation speeds; a +0.05 rad/s
    bias step on a straight at 0.25 m/s is the gyro's."""
    mon, robot = monitor(), Robot(43)
    for _ in range(3):
        for v, w, span in ((0.25, 0.0, 5.0), (0.15, 0.4, 3.0), (0.0, 0.8, 2.0)):
            drive(mon, robot, span, v, w)
    assert mon.model.identified == [True, True] and mon.transitions == []
    verdicts = drive(mon, robot, 6.0, 0.25, 0.0, gyro_extra=0.05)
    first = next(i for i, v in enumerate(verdicts) if not v.use_gyro)
    assert first * DT < 1.5
    assert mon.state("imu") is Health.EXCLUDED
    assert mon.state("encoder_left").usable and mon.state("encoder_right").usable
    assert abs(mon.model.per_metre) < 0.02  # the step was not learned as geometry


def _turn_in(mon: HealthMonitor, robot: Robot, creep: float) -> None:
    """Healthy driving, then turning in from 0.08 m/s to 0.24 m/s and 0.72 rad/s in 0.4 s
    (1.8 rad/s^2) with the outer wheel over-reading its floor speed by ``creep``."""
    drive(mon, robot, 1.0, 0.0, 0.0)
    for _ in range(3):
        for v, w, span in ((0.25, 0.0, 4.0), (0.15, 0.4, 3.0), (0.0, 0.8, 2.0)):
            drive(mon, robot, span, v, w)
    drive(mon, robot, 4.0, 0.08, 0.0)
    assert mon.transitions == []
    for k in range(1, 9):
        drive(mon, robot, DT, 0.08 + 0.02 * k, 0.09 * k, slip=(1.0, 1.0 + creep))
    drive(mon, robot, 3.0, 0.24, 0.72)


@pytest.mark.parametrize("seed", [50, 51, 52])
def test_the_tyres_creep_while_turning_in_at_speed_is_no_fault(seed: int) -> None:
    """Turning in at speed, the outer tyre creeps under the traction that turns the robot: its
    wheel reads 20 % more than the floor moved for 0.4 s (0.2 rad/s of yaw the robot does
    not make, as the twin's tyres do). The creep term (kappa_a v alpha) covers it."""
    mon, robot = monitor(), Robot(seed)
    _turn_in(mon, robot, 0.2)
    assert mon.transitions == [], mon.transitions[:2]


def test_a_wheel_spinning_while_turning_in_is_still_found() -> None:
    """The same turn-in with the outer wheel spinning 50 % faster than the floor: beyond any
    creep, the right wheel is excluded."""
    mon, robot = monitor(), Robot(50)
    _turn_in(mon, robot, 0.5)
    assert mon.transitions[0].sensor == "encoder_right"
    assert mon.transitions[0].new is Health.EXCLUDED
    assert mon.state("imu").usable
