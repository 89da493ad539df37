"""The fault matrix's key rows on the twin with the real daemon (``jackson faults`` runs all)."""

from __future__ import annotations

from pathlib import Path

from jackson.experiments.fault_matrix import (
    BRAKE_LIMIT_S,
    FOREIGN_TOLD,
    LIDAR_TOLD,
    STALL_TOLD,
    Fault,
    matrix,
    plot_brakes,
    run_row,
)


def test_a_killed_host_on_the_pca9685_path_is_braked_by_the_interlock(tmp_path: Path) -> None:
    row = run_row(Fault("host SIGKILL", "pca9685", must_brake=True), tmp_path)
    assert row.braked and row.brake_delay_s is not None
    assert row.brake_delay_s <= BRAKE_LIMIT_S
    assert row.consistent, row.rows  # files flushed together: they end at the same frame
    # and the bag (flushed with them on MCU time) ends within a second and a frame of them
    assert row.rows["bag_end_ms"] > 0, row.rows
    before = [v for t, v in row.trace if t < 0]
    stopped = [v for t, v in row.trace if t > BRAKE_LIMIT_S + 0.5]
    assert before and max(before) > 0.05  # driving at the fault
    assert stopped and max(stopped) < 0.005  # and standing after the brake
    plot_brakes([row], tmp_path / "brakes.png")
    assert (tmp_path / "brakes.png").stat().st_size > 10_000


def test_an_imu_that_dies_mid_mission_is_excluded_and_the_square_goes_on(tmp_path: Path) -> None:
    row = run_row(Fault("IMU death", "pca9685"), tmp_path)
    assert any("health: imu ok -> excluded" in t and "dead" in t for t in row.told), row.told
    assert not any("aborted" in t for t in row.told), row.told
    assert row.distance_after_m > 0.2  # it drove on (wheel-only yaw)
    assert row.passed and row.consistent


def test_the_daemon_survives_an_i2c_server_restart(tmp_path: Path) -> None:
    row = run_row(Fault("I2C server restart", "pca9685", repeat=2), tmp_path)
    assert row.host_alive or row.exit_status in (0, 1)
    assert row.reconnected
    # the operator hears of each outage and of its end on stdout, not only in health.json
    failed = [t for t in row.told if t.startswith("daemon: I2C: PCA9685 write failed")]
    back = [t for t in row.told if t.startswith("daemon: I2C: PCA9685 back and re-initialised")]
    assert failed, row.told
    assert len(back) >= len(failed) - 1, row.told  # the last may still be on when the run ends


def test_a_mute_device_is_one_line_within_two_seconds_and_hello_is_retried(
    tmp_path: Path,
) -> None:
    row = run_row(Fault("mute device", "mcu"), tmp_path)
    assert row.passed, (row.note, row.told)
    assert row.brake_delay_s is not None and row.brake_delay_s <= 2.0  # from the first HELLO
    assert row.rows["hellos"] >= 3  # visible retries
    first = next(t for t in row.told if "no answer on" in t)
    assert "is the firmware flashed? (make flash)" in first


def _row(name: str) -> Fault:
    """The matrix's row ``name`` (with its cause and its wrong cause)."""
    return next(f for f in matrix(short=True) if f.name == name)


def test_a_stopped_daemon_navigating_is_told_as_its_own_stall_not_the_lidars(
    tmp_path: Path,
) -> None:
    row = run_row(_row("host SIGSTOP navigating"), tmp_path)
    assert row.passed, (row.note, row.told)
    stall = next(t for t in row.told if t.startswith(STALL_TOLD))
    assert 2.0 <= float(stall.removeprefix(STALL_TOLD).split()[0]) <= 4.0  # SIGSTOP for 2.5 s
    assert not [t for t in row.told if LIDAR_TOLD in t], row.told


def test_random_bytes_on_the_lidar_line_are_told_as_garbage_not_silence(tmp_path: Path) -> None:
    row = run_row(_row("LiDAR garbage bytes"), tmp_path)
    assert row.passed, (row.note, row.told)
    first = next(t for t in row.told if "health: lidar ok ->" in t)
    assert "garbage on the line" in first  # the first verdict names it
    assert any("mission aborted" in t and "garbage" in t for t in row.told), row.told


def test_a_foreign_write_on_the_motor_driver_is_told_and_aborts_the_mission(
    tmp_path: Path,
) -> None:
    row = run_row(_row("foreign MODE1 write"), tmp_path)
    assert row.passed, (row.note, row.told)
    assert row.exit_status == 1
    assert any(t.startswith("daemon: mission aborted: " + FOREIGN_TOLD) for t in row.told)
