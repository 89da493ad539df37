"""Fusion: the EKF fed what the health monitor's verdict allows, the verdict's reason to brake
kept and told once, the monitor's transitions told."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.core.frontend import FrontEnd, Measurement
from jackson.host.core.fusion import ONE_WHEEL_VARIANCE_SCALE, Fusion
from jackson.host.health import Health, HealthInput, Transition, Verdict
from jackson.host.health.states import Recent
from jackson.protocol import Telemetry, TelemetryFlags

CFG = load_config(DEFAULT_CONFIG)
R = CFG.robot


class SpyEkf:
    """Records the updates it is given, in order."""

    def __init__(self) -> None:
        self.calls: list[tuple[Any, ...]] = []
        self.stationary = False

    def update_wheel(self, t_s: float, vx: float, vy: float, **kw: float) -> None:
        self.calls.append(("wheel", vx, kw.get("variance_scale", 1.0)))

    def update_gyro(self, t_s: float, wz: float) -> None:
        self.calls.append(("gyro", wz))

    def update_yaw_rate(self, t_s: float, wz: float, variance: float) -> None:
        self.calls.append(("yaw_rate", wz, variance))

    def update_zero_velocity(self, t_s: float, variance: float) -> None:
        self.calls.append(("zero", variance))


class FixedMonitor:
    """A monitor whose verdict is given: Fusion reads only the verdict."""

    def __init__(self, verdict: Verdict) -> None:
        self.verdict = verdict
        self.transitions: Recent[Transition] = Recent(10)
        self.seen: list[HealthInput] = []

    def link(self, t_s: float, lost: int) -> None:
        pass

    def update(self, h: HealthInput) -> Verdict:
        self.seen.append(h)
        return self.verdict


OK = Verdict(True, True, True, False, 4e-4, None, wheel_yaw_rate_rad_s=0.31)


def measurements(n: int, imu: bool = True) -> list[Measurement]:
    """n frames of a robot turning left (the right wheel 12 counts a frame, the left 8), the
    gyro agreeing (0.135 rad/s), after 2.5 s standing still (its bias known)."""
    fe = FrontEnd(CFG)
    flags = int(TelemetryFlags.IMU_OK)
    per_count = 2 * math.pi * R.wheel_radius_left_m / R.ticks_per_rev_left
    w = (12 - 8) * per_count / 0.05 / R.wheel_separation_m  # [rad/s] the wheels' yaw rate
    gyro_z = round(math.degrees(w) * 131.0)  # at +-250 deg/s
    out = []
    for k in range(50):
        fe.measure(Telemetry(t_us=50_000 * k, flags=flags, accel=(0, 0, 16384)))
    for k in range(50, 50 + n):
        left, right = 8 * (k - 49), 12 * (k - 49)
        t = Telemetry(
            t_us=50_000 * k, enc_left=left, enc_right=right, flags=flags if imu else 0,
            accel=(k % 3, 0, 16384), gyro=(0, 0, gyro_z),  # a live IMU's registers change
        )  # fmt: skip
        out.append(fe.measure(t))
    return out


def fusion_with(verdict: Verdict) -> tuple[Fusion, SpyEkf, list[str]]:
    told: list[str] = []
    fusion = Fusion(CFG, told.append, lambda tr: None)
    fusion.health = FixedMonitor(verdict)  # type: ignore[assignment]
    spy = SpyEkf()
    fusion.ekf = spy  # type: ignore[assignment]
    return fusion, spy, told


def test_a_healthy_frame_fuses_both_wheels_and_the_gyro() -> None:
    fusion, ekf, told = fusion_with(OK)
    m = measurements(2)[-1]
    assert fusion.fuse(m, (1.0, 1.0), False) is OK and fusion.verdict is OK
    assert ekf.calls == [("wheel", m.odometry.v_m_s, 1.0), ("gyro", m.wz_rad_s)]
    assert fusion.health.seen[-1].wheel_cmd_rad_s == (1.0, 1.0)  # type: ignore[union-attr]
    assert told == [] and fusion.sensors_lost is None


def test_an_excluded_gyro_is_not_fused_and_the_verdicts_wheel_yaw_rate_stands_in() -> None:
    fusion, ekf, _ = fusion_with(dataclasses.replace(OK, use_gyro=False))
    m = measurements(2)[-1]
    fusion.fuse(m, (1.0, 1.0), False)
    assert ekf.calls == [("wheel", m.odometry.v_m_s, 1.0), ("yaw_rate", 0.31, 4e-4)]


@pytest.mark.parametrize("side", [0, 1])
def test_an_excluded_encoder_gives_the_speed_from_the_other_wheel_and_the_gyro(side: int) -> None:
    verdict = dataclasses.replace(OK, use_left=side == 1, use_right=side == 0)
    fusion, ekf, _ = fusion_with(verdict)
    m = measurements(2)[-1]
    fusion.fuse(m, (1.0, 1.0), False)
    assert m.wz_rad_s is not None
    half = 0.5 * m.wz_rad_s * R.wheel_separation_m
    om = m.wheel_rad_s
    vx = (
        R.wheel_radius_right_m * om[1] - half if side == 0 else R.wheel_radius_left_m * om[0] + half
    )
    assert ekf.calls == [("wheel", vx, ONE_WHEEL_VARIANCE_SCALE), ("gyro", m.wz_rad_s)]
    assert vx == pytest.approx(m.odometry.v_m_s, rel=0.05)  # the gyro agrees with the wheels


def test_standing_still_is_a_zero_velocity_update_and_nothing_else() -> None:
    fusion, ekf, _ = fusion_with(dataclasses.replace(OK, stationary=True))
    fusion.fuse(measurements(1)[0], (0.0, 0.0), True)
    assert ekf.calls == [("zero", CFG.health.zupt_variance)] and ekf.stationary


def test_a_lost_verdict_is_kept_as_the_reason_to_brake_and_told_once() -> None:
    fusion, _, told = fusion_with(dataclasses.replace(OK, lost="both encoders excluded"))
    for m in measurements(3):
        fusion.fuse(m, (1.0, 1.0), False)
    assert fusion.sensors_lost == "both encoders excluded"
    assert told == ["health: braking: both encoders excluded"]


def test_without_the_monitor_every_measurement_is_fused() -> None:
    cfg = dataclasses.replace(CFG, health=dataclasses.replace(CFG.health, enabled=False))
    fusion = Fusion(cfg, print, lambda tr: None)
    assert fusion.health is None
    spy = SpyEkf()
    fusion.ekf = spy  # type: ignore[assignment]
    m = measurements(1, imu=True)[0]
    assert fusion.fuse(m, (0.0, 0.0), False) is None and fusion.verdict is None
    assert spy.calls == [("wheel", m.odometry.v_m_s, 1.0), ("gyro", m.wz_rad_s)]


def test_a_dead_imu_is_excluded_by_the_monitor_told_and_left_out_of_the_filter() -> None:
    told: list[str] = []
    transitions: list[Transition] = []
    fusion = Fusion(CFG, told.append, transitions.append)
    gyro_updates = []
    real = fusion.ekf.update_gyro

    def spy(t_s: float, wz: float) -> bool:
        gyro_updates.append(t_s)
        return real(t_s, wz)

    fusion.ekf.update_gyro = spy  # type: ignore[method-assign]
    verdicts = [fusion.fuse(m, (4.0, 6.0), False) for m in measurements(20)]
    assert all(v is not None and v.use_gyro for v in verdicts) and len(gyro_updates) == 20
    dead = [fusion.fuse(m, (4.0, 6.0), False) for m in measurements(30, imu=False)[20:]]
    assert [(t.sensor, t.new) for t in transitions] == [("imu", Health.EXCLUDED)]
    assert any(line.startswith("health: imu ok -> excluded") for line in told)
    assert len(gyro_updates) == 20 and not any(v is not None and v.use_gyro for v in dead)
    assert fusion.sensors_lost is None  # the wheels' yaw rate stands in: a degraded mode
    assert fusion.ekf.vyaw_rad_s == pytest.approx(0.135, rel=0.1)


def test_transitions_are_told_after_the_monitors_record_has_filled() -> None:
    told: list[str] = []
    fusion = Fusion(CFG, told.append, lambda tr: None)
    hm = fusion.health
    assert hm is not None
    record = hm.transitions
    for k in range(record.maxlen + 5):  # a long-running daemon: the record is trimmed
        record.append(Transition(0.05 * k, "lidar", Health.OK, Health.SUSPECT, f"test {k}"))
        fusion.report_health()
        assert told[-1].endswith(f"test {k}")
    assert len(told) == record.maxlen + 5
