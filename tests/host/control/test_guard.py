"""A mission stops when its time is up or the estimate has lost a sensor."""

from __future__ import annotations

from jackson.host.control.guard import MissionGuard

DT = 0.05  # [s] 20 Hz frames


def run(
    guard: MissionGuard,
    frames: int,
    *,
    t0: float = 0.0,
    imu_ok: bool = True,
    counts=lambda k: (10 * k, 10 * k),
    cmd=(5.0, 5.0),
    bias: bool = True,
) -> str | None:
    for k in range(frames):
        reason = guard.check(t0 + k * DT, imu_ok, bias, counts(k), cmd)
        if reason is not None:
            return reason
    return None


def test_a_healthy_mission_runs_on() -> None:
    assert run(MissionGuard("square"), 1000) is None


def test_a_mission_times_out_on_mcu_time() -> None:
    g = MissionGuard("square", timeout_s=2.0)
    reason = run(g, 100)
    assert reason is not None and reason.startswith("timeout")


def test_an_imu_that_dies_stops_the_mission_within_its_silence_time() -> None:
    g = MissionGuard("square")
    assert run(g, 100) is None
    for k in range(100, 200):
        reason = g.check(k * DT, False, True, (10 * k, 10 * k), (5.0, 5.0))
        if reason is not None:
            break
    assert reason is not None and reason.startswith("IMU silent")
    assert (k - 99) * DT <= g.cfg.imu_silence_s + DT + 1e-9


def test_a_stuck_encoder_on_a_driven_wheel_stops_the_mission() -> None:
    g = MissionGuard("square")
    reason = run(g, 100, counts=lambda k: (10 * k, 500))
    assert reason is not None and reason.startswith("right encoder silent")


def test_a_wheel_standing_still_as_commanded_is_not_a_fault() -> None:
    g = MissionGuard("square")
    assert run(g, 400, counts=lambda k: (10 * k, 500), cmd=(5.0, 0.0)) is None


def test_no_gyro_bias_is_a_reason_after_the_wait() -> None:
    g = MissionGuard("square")
    reason = run(g, 400, imu_ok=False, bias=False)
    assert reason is not None and reason.startswith("no gyro bias")
