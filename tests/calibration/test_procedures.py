"""The calibration maths on hand-computed cases, run folders, CLI errors and --write (the YAML
writer itself: test_yaml_update.py)."""

from __future__ import annotations

import math
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from jackson.calibration import procedures as proc
from jackson.calibration import runs
from jackson.host.config import DEFAULT_CONFIG, load_config
from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.recording import RunRecorder
from jackson.main import main
from jackson.protocol import SetImuCalibration, Telemetry, TelemetryFlags, encode_frame

GEOMETRY = RobotGeometry()  # r 0.033 m, B 0.198 m, 621 TPR per wheel
TWO_PI_R = 2.0 * math.pi * 0.033  # 0.20734511513692636 m per wheel revolution


# ------------------------------------------------------------------------- 1. encoders (Eq. A6)


def test_eq_a8_652_tpr_times_0_9525_gives_621() -> None:
    assert proc.encoder_resolution(652.0, 0.9525, 1.0) == pytest.approx(621.03)


def test_encoder_resolution_per_wheel_from_one_straight_run() -> None:
    # d_odom = 2 pi 0.033 x 3000 / 621 = 1.0016672 m for 1.000 m on the floor
    # C_cal = 621 x 1.0016672 = 2 pi 0.033 x 3000 = 622.0353 (left), x 3010 = 624.1088 (right)
    res = proc.calibrate_encoders([proc.StraightRun("a", 3000, 3010, 1.0)], GEOMETRY)
    assert res.ticks_per_rev_left == pytest.approx(622.0353454, rel=1e-9)
    assert res.ticks_per_rev_right == pytest.approx(624.1088, rel=1e-6)
    assert res.ratio_left == pytest.approx(1.0016672, rel=1e-6)
    assert res.spread_left == 0.0


def test_backward_runs_count_like_forward_ones_and_runs_are_averaged() -> None:
    runs_ = [
        proc.StraightRun("forward", 3000, 3000, 1.0),  # 622.0353
        proc.StraightRun("back", -1510, -1510, 0.5),  # 0.2073451 x 1510 / 0.5 = 626.1822
    ]
    res = proc.calibrate_encoders(runs_, GEOMETRY)
    assert res.per_run[1][0] == pytest.approx(626.18224, rel=1e-6)
    assert res.ticks_per_rev_left == pytest.approx((622.03535 + 626.18224) / 2, rel=1e-6)


def test_a_zero_measured_distance_is_refused() -> None:
    with pytest.raises(proc.CalibrationError, match="must be > 0 m, got 0"):
        proc.calibrate_encoders([proc.StraightRun("a", 3000, 3000, 0.0)], GEOMETRY)


def test_a_robot_that_did_not_drive_is_refused() -> None:
    with pytest.raises(proc.CalibrationError, match="the left wheel moved 3 ticks"):
        proc.calibrate_encoders([proc.StraightRun("a", 3, 2, 1.0)], GEOMETRY)


# ------------------------------------------------------------------------- 2. track (Eq. A12)


def test_eq_a15_the_papers_rotation_check_gives_0_198_m() -> None:
    # 0.033 x 37.70 / 2 pi = 1.2441 / 6.283185 = 0.198004
    assert proc.wheel_separation(0.033, 37.70, 0.0, 2 * math.pi) == pytest.approx(0.198004, 1e-5)


def test_track_from_counts_of_a_ccw_and_a_cw_rotation() -> None:
    # three wheel revolutions each way: dphi_R - dphi_L = 12 pi; one true turn: B = 0.033 x 6
    ccw = proc.RotationRun("ccw", -1863, 1863, 2 * math.pi)
    cw = proc.RotationRun("cw", 1863, -1863, 2 * math.pi)  # the user says "1 turn" for both
    res = proc.calibrate_track([ccw, cw], GEOMETRY)
    assert res.wheel_separation_m == pytest.approx(0.198, rel=1e-12)
    assert res.wheel_rotation_difference_rad[0] == pytest.approx(12 * math.pi)
    assert res.wheel_rotation_difference_rad[1] == pytest.approx(-12 * math.pi)


def test_a_straight_run_is_not_a_rotation() -> None:
    with pytest.raises(proc.CalibrationError, match="not an in-place rotation"):
        proc.calibrate_track([proc.RotationRun("a", 1863, 1863, 2 * math.pi)], GEOMETRY)


# ------------------------------------------------------------------------- 3. IMU


def test_datasheet_densities_at_21_hz_give_the_papers_sigmas() -> None:
    n = proc.datasheet_noise()
    # 0.005 deg/s/sqrt(Hz) x pi/180 x sqrt(21) = 3.99905e-4
    # 400e-6 g/sqrt(Hz) x 9.80665 m/s^2/g x sqrt(21) = 1.79759e-2
    assert f"{n.gyro_sigma_rad_s:.4g}" == "0.0003999"
    assert f"{n.accel_sigma_m_s2:.5g}" == "0.017976"
    one_pole = proc.datasheet_noise(21.0 * proc.FIRST_ORDER_NOISE_FACTOR)
    assert f"{one_pole.gyro_sigma_rad_s:.4g}" == "0.0005012"  # not what the paper printed
    assert proc.noise_sigma(400e-6 * 9.81, 21.0) == pytest.approx(1.7982e-2, abs=1e-6)  # nor this


def test_gravity_9_299_gives_scale_1_0549_which_the_paper_truncates_to_1_054() -> None:
    still = np.tile([0.0, 0.0, 9.299], (50, 1))
    prof = proc.imu_profile(np.zeros((50, 3)), still)
    assert prof.accel_scale == pytest.approx(1.0549521, rel=1e-7)
    assert round(prof.accel_scale, 3) == 1.055
    assert math.floor(prof.accel_scale * 1000) / 1000 == proc.PAPER_ACCEL_SCALE


def test_gyro_bias_is_the_mean_rate_at_rest_in_the_base_frame() -> None:
    rng = np.random.default_rng(3)
    gyro = np.array([0.001, -0.002, -0.01]) + 4e-4 * rng.standard_normal((400, 3))
    accel = np.array([0.0, 0.0, -9.81]) + 0.018 * rng.standard_normal((400, 3))
    upside_down = (1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0)  # turned about x
    prof = proc.imu_profile(gyro, accel, upside_down)
    assert prof.gyro_bias_rad_s == pytest.approx((0.001, 0.002, 0.01), abs=5e-5)
    assert prof.gravity_on_z
    assert not proc.imu_profile(gyro, accel).gravity_on_z  # identity: gravity points down


def test_yaw_sign_audit_wants_ccw_positive() -> None:
    w = np.concatenate([np.zeros(5), np.full(20, 1.0), np.full(20, -1.0)])
    assert proc.yaw_sign_audit(0.97 * w + 0.01, w).ok
    flipped = proc.yaw_sign_audit(-w, w)
    assert not flipped.ok and flipped.slope == pytest.approx(-1.0)
    with pytest.raises(proc.CalibrationError, match="did not turn"):
        proc.yaw_sign_audit(np.zeros(40), np.zeros(40))


# ------------------------------------------------------------------------- 4. deadband


def test_breakaway_lies_between_the_last_still_and_the_first_moving_level() -> None:
    duty = [0.10] * 4 + [0.11] * 4 + [0.12] * 4
    counts = [0] * 9 + [1, 2, 3, 4]  # frame 9 shows what duty[8] = 0.12 did
    assert proc.breakaway_bracket(duty, counts, 3) == proc.Bracket(0.11, 0.12)


def test_a_one_tick_jitter_is_not_breakaway() -> None:
    duty = [0.10] * 4 + [0.11] * 4 + [0.12] * 4
    counts = [0, 0, 1, 0, 0, 0, 0, 0, 0, 1, 2, 3, 3]
    assert proc.breakaway_bracket(duty, counts, 3) == proc.Bracket(0.11, 0.12)


def test_reverse_ramps_move_the_counts_down() -> None:
    duty = [-0.1] * 3 + [-0.2] * 3
    assert proc.breakaway_bracket(duty, [0, 0, 0, 0, -1, -2, -3], 3) == proc.Bracket(0.1, 0.2)
    # counts going up under a reverse duty are not a reverse breakaway
    assert proc.breakaway_bracket(duty, [0, 0, 0, 0, 1, 2, 3], 3) == proc.Bracket(0.2, math.inf)


def test_a_coarse_and_a_fine_ramp_combine_to_the_fine_step() -> None:
    coarse, fine = proc.Bracket(0.10, 0.12), proc.Bracket(0.118, 0.119)
    assert proc.combine_brackets([coarse, fine]) == fine
    assert proc.combine_brackets([coarse, proc.Bracket(0.13, 0.131)]).width == pytest.approx(0.001)


def _staircase(
    levels: Sequence[float], breakaway: float, frames: int = 4
) -> tuple[list[float], list[int]]:
    duty: list[float] = []
    counts = [0]
    for level in levels:
        for _ in range(frames):
            duty.append(level)
            step = int(math.copysign(1, level)) if abs(level) > breakaway else 0
            counts.append(counts[-1] + step)
    return duty, counts


def test_deadband_per_wheel_and_direction_from_one_run() -> None:
    levels = [0.10, 0.11, 0.12, 0.13, 0.14, 0.15, 0.16]
    t: list[float] = []
    d_l: list[float] = []
    d_r: list[float] = []
    c_l: list[int] = [0]
    c_r: list[int] = [0]
    for side, sign, breakaway in (
        ("l", 1, 0.115),
        ("l", -1, 0.125),
        ("r", 1, 0.145),
        ("r", -1, 0.155),
    ):
        duty, counts = _staircase([sign * x for x in levels], breakaway)
        for k, d in enumerate([*duty, 0.0, 0.0]):  # then brake two frames
            step = counts[k + 1] - counts[k] if k < len(duty) else 0
            d_l.append(d if side == "l" else 0.0)
            d_r.append(d if side == "r" else 0.0)
            c_l.append(c_l[-1] + (step if side == "l" else 0))
            c_r.append(c_r[-1] + (step if side == "r" else 0))
    d_l.append(0.0)
    d_r.append(0.0)
    t = [0.05 * k for k in range(len(c_l))]
    n = len(t)
    run = proc.RunData(
        "synthetic",
        np.array(t),
        np.array(c_l, dtype=np.int64),
        np.array(c_r, dtype=np.int64),
        np.full((n, 3), np.nan),
        np.full((n, 3), np.nan),
        np.array(d_l),
        np.array(d_r),
    )
    res = proc.calibrate_deadband([run])
    assert (res.forward_left, res.reverse_left) == pytest.approx((0.115, 0.125))
    assert (res.forward_right, res.reverse_right) == pytest.approx((0.145, 0.155))


def test_braking_at_constant_deceleration_stops_in_v_squared_over_2a() -> None:
    dt = np.full(20, 0.01)
    s, t = proc.braking_distance(0.3, np.full(20, -3.0), dt)  # 0.09 / 6 = 0.015 m in 0.1 s
    assert (s, t) == pytest.approx((0.015, 0.1))
    assert proc.braking_distance(-0.3, np.full(20, 3.0), dt) == pytest.approx((0.015, 0.1))
    assert math.isnan(proc.braking_distance(0.3, np.full(5, -1.0), dt[:5])[0])  # still moving


def _step_run(brake_lag_frames: int) -> proc.RunData:
    """A full-duty step at 200 Hz: 1 s at rest, 2 s at 10 counts a frame after a 10-frame
    ramp, then the brake written at 3 s that stops the wheels ``brake_lag_frames`` later."""
    n, a, b = 800, 200, 600
    speed = np.zeros(n, dtype=np.int64)
    speed[a : b + brake_lag_frames] = 10
    speed[a : a + 10] = np.arange(1, 11)
    speed[b + brake_lag_frames : b + brake_lag_frames + 5] = [8, 6, 4, 2, 1]
    counts = np.concatenate(([0], np.cumsum(speed[1:])))
    duty = np.where((np.arange(n) >= a) & (np.arange(n) < b), 1.0, 0.0)
    nan3 = np.full((n, 3), np.nan)
    t = np.arange(n) * 0.005
    return proc.RunData("step", t, counts, counts, nan3, nan3, duty, duty)


def test_a_brake_that_acted_late_on_the_mcu_clock_is_refused() -> None:
    """Stopping is measured from the brake's frame: a brake the motors got 0.3 s later (a
    twin that went on without its busy host) is refused, one a frame later is measured."""
    on_time = proc.characterise(_step_run(1), GEOMETRY)
    assert on_time.wheel_stopping_time_s == pytest.approx(0.025)
    with pytest.raises(proc.CalibrationError, match=r"brake acted 0\.30 s after"):
        proc.characterise(_step_run(61), GEOMETRY)


# ------------------------------------------------------------------------- 5. twin fit


def _segment(r: float, b: float, gyro_scale: float) -> proc.FitSegment:
    """Wheel angles of an S-curve, the reference integrated with (r, b), a gyro reading
    ``gyro_scale`` times the true yaw rate."""
    dt = 0.05
    v = np.concatenate([np.full(40, 0.15), np.full(80, 0.12), np.full(80, 0.12), np.zeros(40)])
    w = np.concatenate([np.zeros(40), np.full(80, 0.6), np.full(80, -0.6), np.full(40, 1.2)])
    dphi_r = (v + w * b / 2) * dt / r
    dphi_l = (v - w * b / 2) * dt / r
    yaw = np.concatenate(([0.0], np.cumsum(w * dt)))
    mid = yaw[:-1] + 0.5 * w * dt
    x = np.concatenate(([0.0], np.cumsum(v * dt * np.cos(mid))))
    y = np.concatenate(([0.0], np.cumsum(v * dt * np.sin(mid))))
    return proc.FitSegment(
        "s-curve",
        np.arange(len(yaw)) * dt,
        np.concatenate(([0.0], np.cumsum(dphi_l))),
        np.concatenate(([0.0], np.cumsum(dphi_r))),
        np.concatenate(([0.0], gyro_scale * w)),
        x,
        y,
        yaw,
    )


def test_dead_reckoning_of_a_straight_line() -> None:
    seg = _segment(0.033, 0.198, 1.0)
    straight = proc.dead_reckon(seg, 0.033, 0.198, 1.0)
    assert straight.x_m[40] == pytest.approx(0.15 * 40 * 0.05)
    assert straight.y_m[40] == pytest.approx(0.0, abs=1e-12)


def test_twin_fit_recovers_the_papers_effective_parameters() -> None:
    # the twin's motion follows r 0.031650, B 0.210481; its gyro needs x0.6953 to read true
    seg = _segment(0.031650, 0.210481, 1.0 / 0.6953)
    fit = proc.fit_twin([seg], 0.033, 0.198)
    assert fit.wheel_radius_m == pytest.approx(0.031650, rel=1e-6)
    assert fit.wheel_separation_m == pytest.approx(0.210481, rel=1e-6)
    assert fit.yaw_scale == pytest.approx(0.6953, rel=1e-6)
    assert fit.rms_position_m < 1e-6 < fit.initial_rms_position_m
    gyro_heading = proc.fit_twin([seg], 0.033, 0.198, heading="gyro")
    assert gyro_heading.wheel_radius_m == pytest.approx(0.031650, rel=1e-6)


def test_a_fit_needs_turning_runs() -> None:
    seg = _segment(0.033, 0.198, 1.0)
    no_turn = proc.FitSegment(
        "straight", seg.t_s[:41], seg.phi_left_rad[:41], seg.phi_right_rad[:41],
        seg.gyro_z_rad_s[:41], seg.ref_x_m[:41], seg.ref_y_m[:41], seg.ref_yaw_rad[:41],
    )  # fmt: skip
    with pytest.raises(proc.CalibrationError, match="turning runs"):
        proc.fit_twin([no_turn])


# ------------------------------------------------------------------------- run folders


def make_run(
    folder: Path,
    counts: Sequence[tuple[int, int]],
    *,
    flags: int = TelemetryFlags.IMU_OK,
    gyro: tuple[int, int, int] = (0, 0, 0),
    accel: tuple[int, int, int] = (0, 0, 16384),
    duties: Sequence[tuple[float, float]] | None = None,
    before: bytes | None = None,
) -> Path:
    """A run folder as the host writes it, from telemetry counts (20 Hz)."""
    rec = RunRecorder(folder, {"mission": None})
    if before is not None:
        rec.tx(0, before)
    for k, (left, right) in enumerate(counts):
        t = Telemetry(t_us=k * 50_000, enc_left=left, enc_right=right, flags=flags,
                      accel=accel, gyro=gyro)  # fmt: skip
        rec.rx(k, Telemetry.TYPE, k & 0xFF, t.pack())
        d = duties[k] if duties is not None else (0.0, 0.0)
        rec.row(rec.commands, (k * 0.05, 0.0, 0.0, d[0], d[1], int(d == (0.0, 0.0))))
    rec.close()
    return folder


def test_load_run_unwraps_counts_and_reads_duties(tmp_path: Path) -> None:
    top = 2**31 - 1
    run = runs.load_run(
        make_run(tmp_path / "r", [(top - 1, 0), (top, 5), (-(2**31), 9)], duties=[(0.1, 0.0)] * 3)
    )
    assert run.enc_left.tolist() == [top - 1, top, top + 1]  # the 32-bit wrap is gone
    assert run.t_s.tolist() == pytest.approx([0.0, 0.05, 0.1])
    assert run.duty_left.tolist() == [0.1, 0.1, 0.1]
    assert run.accel_m_s2[0] == pytest.approx([0.0, 0.0, 9.81])


def test_load_run_undoes_a_calibration_the_device_applied(tmp_path: Path) -> None:
    # the device applies omega = R omega_s - b, a = s R a_s; R turns about x (upside down)
    cal = SetImuCalibration(
        imu_rotation=(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0),
        gyro_bias=(0.0, 0.0, 0.02),
        accel_scale=1.25,
        persist=0,
    )
    lsb_per_rad_s = 131.0 * 180.0 / math.pi
    calibrated_gyro = (0, 0, round(0.03 * lsb_per_rad_s))  # R omega_s - b = 0.03
    run = runs.load_run(
        make_run(
            tmp_path / "r",
            [(0, 0)] * 5,
            flags=TelemetryFlags.IMU_OK | TelemetryFlags.IMU_CALIBRATED,
            gyro=calibrated_gyro,
            accel=(0, 0, 16384),
            before=encode_frame(cal, 0),
        )
    )
    assert np.isnan(run.gyro_rad_s[:2]).all()  # still in flight after the SET_IMU_CALIBRATION
    assert run.gyro_rad_s[4] == pytest.approx([0.0, 0.0, -0.05], abs=1e-4)  # R^T (0.03 + 0.02)
    assert run.accel_m_s2[4] == pytest.approx([0.0, 0.0, -9.81 / 1.25])


def test_a_reference_needs_its_columns(tmp_path: Path) -> None:
    path = tmp_path / "ref.csv"
    path.write_text("t,x,y\n0,0,0\n")
    with pytest.raises(proc.CalibrationError, match="t_s, x_m, y_m, yaw_rad"):
        runs.load_reference(path)


# ------------------------------------------------------------------------- the CLI's errors


def calibrate(*argv: str) -> int:
    """``jackson calibrate ARGV`` through the real entry point; its exit status."""
    try:
        return main(["calibrate", *argv])
    except SystemExit as exc:  # argparse refused an option
        return exc.code if isinstance(exc.code, int) else 2


def one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_a_missing_run_folder_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert calibrate("encoders", "--runs", "/nonexistent/run", "--distance", "1") == 2
    assert one_error_line(capsys) == (
        "jackson calibrate encoders: run folder /nonexistent/run does not exist"
    )


def test_a_zero_distance_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = make_run(tmp_path / "r", [(0, 0), (3000, 3000)])
    assert calibrate("encoders", "--runs", str(run), "--distance", "0") == 2
    assert "--distance: expected a number > 0, got '0'" in one_error_line(capsys)


def test_a_run_without_its_measurement_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = make_run(tmp_path / "r", [(0, 0), (3000, 3000)])
    assert calibrate("encoders", "--runs", str(run)) == 2
    assert one_error_line(capsys) == (
        "jackson calibrate encoders: run r: no measured distance: give --distance"
    )
    assert calibrate("track", "--runs", str(run)) == 2
    assert one_error_line(capsys) == (
        "jackson calibrate track: run r: no true rotation: give --true-turns"
    )


def test_a_robot_that_did_not_move_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = make_run(tmp_path / "r", [(0, 0)] * 10)
    assert calibrate("track", "--runs", str(run), "--true-turns", "1") == 2
    assert "not an in-place rotation" in one_error_line(capsys)
    assert calibrate("characterise", "--runs", str(run)) == 2
    assert "no duty step" in one_error_line(capsys)


def test_recording_or_recorded_runs_must_be_named(capsys: pytest.CaptureFixture[str]) -> None:
    assert calibrate("deadband") == 2
    assert "give --port PORT to record, or --runs DIR" in one_error_line(capsys)


def test_a_missing_serial_port_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert calibrate("imu", "--port", "/dev/nonexistent-jackson", "--i2c", "unix:/nonexistent") == 2
    assert "jackson calibrate imu: " in one_error_line(capsys)


# ------------------------------------------------------------------------- --write


def test_write_prints_the_changes_and_the_diff_and_keeps_a_backup(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = make_run(tmp_path / "r", [(0, 0), (3000, 3010)])
    config = tmp_path / "jackson.yaml"
    shutil.copy(DEFAULT_CONFIG, config)
    argv = ("encoders", "--runs", str(run), "--distance", "1", "--write", str(config))
    assert calibrate(*argv) == 0
    out = capsys.readouterr().out
    (backup,) = tmp_path.glob("jackson.yaml.bak-*")
    assert f"wrote {config} (backup {backup}):" in out
    assert "  robot.ticks_per_rev.left: 621 -> 622.0" in out
    assert f"--- {config} (before)\n+++ {config}\n" in out
    assert "-  ticks_per_rev: 621           # [ticks/rev]" in out
    assert "+  ticks_per_rev: {left: 622.0, right: 624.1} # [ticks/rev]" in out
    assert backup.read_text() == DEFAULT_CONFIG.read_text()
    assert load_config(config).robot.ticks_per_rev_right == 624.1
    text = config.read_text()
    assert calibrate(*argv) == 0  # the same result again: nothing to write
    assert f"{config} already holds these values: not written" in capsys.readouterr().out
    assert config.read_text() == text and len(list(tmp_path.glob("jackson.yaml.bak-*"))) == 1


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("robot: [wheel_radius_m\n", "not valid YAML"),
        ("robot: 0.033\n", "robot: expected a mapping"),
    ],
)
def test_write_into_a_file_that_is_not_a_host_yaml_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    run = make_run(tmp_path / "r", [(0, 0), (3000, 3010)])
    config = tmp_path / "c.yaml"
    config.write_text(text)
    argv = ("encoders", "--runs", str(run), "--distance", "1", "--config", str(DEFAULT_CONFIG))
    assert calibrate(*argv, "--write", str(config)) == 2
    line = one_error_line(capsys)
    assert line.startswith("jackson calibrate encoders: config c.yaml: ") and message in line
    assert config.read_text() == text and not list(tmp_path.glob("c.yaml.bak-*"))


def test_frames_lost_before_the_first_command_are_rest_and_not_refused() -> None:
    """A host slow to take its first frames (the twin dropped what its port could not queue)
    loses braked rest only; frames lost once the script drives are refused."""
    run = _step_run(1)
    for cut, refused in ((slice(100, 120), False), (slice(300, 320), True)):
        keep = np.ones(run.frames, bool)
        keep[cut] = False
        gap = proc.RunData(
            "step", run.t_s[keep], run.enc_left[keep], run.enc_right[keep],
            run.gyro_rad_s[keep], run.accel_m_s2[keep], run.duty_left[keep],
            run.duty_right[keep],
        )  # fmt: skip
        if refused:
            with pytest.raises(proc.CalibrationError, match=r"0\.10 s without a frame at 1\.50"):
                proc.check_frames(gap)
        else:
            proc.check_frames(gap)
