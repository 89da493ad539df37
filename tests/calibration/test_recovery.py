"""Each calibration recovers the twin's hidden truth within 1 %, recorded through the host.

The twin (in a thread, lockstep, over a real pty and the I2C socket, as tests/sil does) runs a
robot whose true values differ from what the host believes: 617/626 ticks per revolution,
a 0.205 m track, a 0.01 rad/s gyro z bias, gravity read as 9.299 m/s^2, breakaway duties of
0.12 (left) and 0.15 (right). The runs are recorded by :mod:`jackson.calibration.runs` (the
daemon for velocity runs and, with a duty script as its command source, for raw duties), and the CLI
works from the run folders (or records them itself), as a user would.
"""

from __future__ import annotations

import argparse
import bisect
import csv
import dataclasses
import math
import shutil
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from jackson.calibration import cli, runs
from jackson.calibration import procedures as proc
from jackson.host.config import DEFAULT_CONFIG, HostConfig, load_config
from jackson.sim.config import RobotSpec, Sides, load_robot
from jackson.sim.twin import Truth

from ..sil.harness import TwinThread, host_config

_BASE = load_robot("jackson")
HIDDEN = dataclasses.replace(
    _BASE,
    ticks_per_rev=Sides(617.0, 626.0),
    wheel_separation_m=0.205,
    motor=dataclasses.replace(_BASE.motor, deadband_duty=Sides(0.12, 0.15)),
    imu=dataclasses.replace(
        _BASE.imu, gyro_bias_rad_s=(0.0, 0.0, 0.01), gravity_scale=9.299 / 9.81
    ),
)
TRUE_TPR = (617.0, 626.0)
# [s] of wall time without a HEARTBEAT before the twin moves on without the host: far beyond a
# busy host's time for one frame (a run's steps must not start late on the twin's clock), and
# paid once at the end of each run of a multi-run procedure
HOST_SILENT_S = 3.0


def twin_on(tmp: Path, robot: RobotSpec = HIDDEN) -> TwinThread:
    return TwinThread(tmp, world="open_floor", robot=robot, heartbeat_timeout_s=HOST_SILENT_S)


@pytest.fixture
def twin(tmp_path: Path) -> Iterator[TwinThread]:
    t = twin_on(tmp_path)
    yield t
    t.stop()


def calibrate(*argv: str) -> int:
    parser = argparse.ArgumentParser(prog="jackson")
    sub = parser.add_subparsers(dest="command", required=True)
    cli.add_parser(sub)
    args = parser.parse_args(["calibrate", *argv])
    rc: int = args.func(args)
    return rc


def config_copy(tmp: Path) -> Path:
    path = tmp / "jackson.yaml"
    shutil.copy(DEFAULT_CONFIG, path)
    return path


def with_tpr(cfg: HostConfig, left: float, right: float) -> HostConfig:
    robot = dataclasses.replace(cfg.robot, ticks_per_rev_left=left, ticks_per_rev_right=right)
    return dataclasses.replace(cfg, robot=robot)


def frame_times(folder: Path) -> tuple[float, float]:
    with (folder / "odometry.csv").open() as f:
        rows = list(csv.DictReader(f))
    return float(rows[0]["t_s"]), float(rows[-1]["t_s"])


def truth_at(twin: TwinThread, t_s: float) -> Truth:
    log = twin.twin.truth_log
    k = bisect.bisect_left([s.t_s for s in log], t_s - 1e-9)
    return log[k]


def rel(got: float, true: float) -> float:
    return abs(got - true) / abs(true)


def test_encoders_recover_617_left_and_626_right(
    twin: TwinThread, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Interactive CLI: after each straight run the 'tape' is the twin's ground truth."""
    out = tmp_path / "runs"
    config = config_copy(tmp_path)

    def tape(prompt: str) -> str:
        newest = max(out.glob("straight-*"), key=lambda p: p.stat().st_mtime)
        a, b = frame_times(newest)
        pa, pb = truth_at(twin, a), truth_at(twin, b)
        return f"{math.hypot(pb.x - pa.x, pb.y - pa.y):.4f}"

    monkeypatch.setattr("builtins.input", tape)
    rc = calibrate(
        "encoders",
        "--port",
        twin.serial,
        "--i2c",
        twin.i2c,
        "--out",
        str(out),
        "--count",
        "2",
        "--length",
        "0.5",
        "--speed",
        "0.2",
        "--write",
        str(config),
    )
    assert rc == 0
    robot = load_config(config).robot
    errors = (rel(robot.ticks_per_rev_left, 617.0), rel(robot.ticks_per_rev_right, 626.0))
    print(f"encoders: {robot.ticks_per_rev_left} / {robot.ticks_per_rev_right}, errors {errors}")
    assert max(errors) < 0.01
    text = config.read_text()
    assert "ticks_per_rev: {left: " in text
    assert "# [ticks/rev] C_e,run, Table 3" in text  # the comment stayed
    assert list(tmp_path.glob("jackson.yaml.bak-*"))


def test_track_recovers_0_205_m(twin: TwinThread, tmp_path: Path) -> None:
    link = runs.Link(twin.serial, with_tpr(host_config(twin.i2c), *TRUE_TPR))

    def true_rotation(folder: Path, index: int) -> float:
        a, b = frame_times(folder)
        return truth_at(twin, b).yaw - truth_at(twin, a).yaw

    folders = runs.record_rotation_runs(
        link, tmp_path / "runs", true_rotation, count=2, turns=1.0, w_rad_s=1.5
    )
    track = proc.calibrate_track(
        [proc.rotation_run(r, r.notes["true_rotation_rad"]) for r in map(runs.load_run, folders)],
        link.config.robot,
    )
    print(
        f"track: B = {track.wheel_separation_m:.5f} m, error {rel(track.wheel_separation_m, 0.205)}"
    )
    assert rel(track.wheel_separation_m, 0.205) < 0.01
    assert track.wheel_rotation_difference_rad[0] > 0 > track.wheel_rotation_difference_rad[1]


def test_imu_recovers_gyro_bias_and_gravity_scale(twin: TwinThread, tmp_path: Path) -> None:
    link = runs.Link(twin.serial, host_config(twin.i2c))
    folders = runs.record_imu_runs(link, tmp_path / "runs", still_s=10.0, spin_s=2.0)
    config = config_copy(tmp_path)
    assert calibrate("imu", "--runs", *map(str, folders), "--write", str(config)) == 0
    cal = load_config(config).imu.calibration
    assert cal is not None
    bias_error = rel(cal.gyro_bias_rad_s[2], 0.01)
    scale_error = rel(cal.accel_scale, 9.81 / 9.299)
    print(f"imu: bias z {cal.gyro_bias_rad_s[2]:.6f} ({bias_error}), scale {cal.accel_scale}")
    assert bias_error < 0.01 and scale_error < 0.01
    assert max(abs(cal.gyro_bias_rad_s[0]), abs(cal.gyro_bias_rad_s[1])) < 1e-4
    assert cal.rotation == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def test_yaw_sign_audit_catches_a_gyro_upside_down(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    flipped = dataclasses.replace(HIDDEN, imu=dataclasses.replace(HIDDEN.imu, yaw_scale=-1.0))
    twin = twin_on(tmp_path, flipped)
    try:
        link = runs.Link(twin.serial, host_config(twin.i2c))
        folders = runs.record_imu_runs(link, tmp_path / "runs", still_s=2.0, spin_s=2.0)
    finally:
        twin.stop()
    spin = runs.load_run(folders[1])
    audit = proc.yaw_sign_audit(
        spin.gyro_rad_s[:, 2], proc.odometry_yaw_rate(spin, link.config.robot)
    )
    assert not audit.ok and audit.correlation < -0.9
    config = config_copy(tmp_path)
    assert calibrate("imu", "--runs", *map(str, folders), "--write", str(config)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "upside down" in err[0]
    assert config.read_text() == DEFAULT_CONFIG.read_text()


def test_deadband_recovers_breakaway_duties_through_the_pca9685(
    twin: TwinThread, tmp_path: Path
) -> None:
    """Raw duties written to the PCA9685 over the I2C socket, recorded by the CLI itself."""
    config = config_copy(tmp_path)
    out = tmp_path / "runs"
    argv = ["--port", twin.serial, "--i2c", twin.i2c, "--out", str(out), "--write", str(config)]
    assert calibrate("deadband", *argv) == 0
    db = load_config(config).deadband
    got = {
        "forward_left": (db.forward_left, 0.12),
        "reverse_left": (db.reverse_left, 0.12),
        "forward_right": (db.forward_right, 0.15),
        "reverse_right": (db.reverse_right, 0.15),
    }
    errors = {k: rel(v, t) for k, (v, t) in got.items()}
    print(f"deadband: {[v for v, _ in got.values()]}, errors {errors}")
    assert max(errors.values()) < 0.01
    # the duties really bypassed the compensation: the ramps start below the believed 0.10
    run = runs.load_run(out / "deadband")
    nonzero = np.abs(run.duty_left[run.duty_left != 0])
    assert nonzero.min() < 0.05


def test_characterisation_matches_the_twins_ground_truth(twin: TwinThread, tmp_path: Path) -> None:
    cfg = with_tpr(host_config(twin.i2c), *TRUE_TPR)
    folder = runs.record_step_run(runs.Link(twin.serial, cfg), tmp_path / "runs")
    run = runs.load_run(folder)
    c = proc.characterise(run, cfg.robot)
    a = int(np.flatnonzero(run.duty_left)[0])
    b = a + int(np.flatnonzero(run.duty_left[a:] == 0)[0])
    t_a, t_b = run.t_s[a], run.t_s[b]
    log = [s for s in twin.twin.truth_log if t_a - 1e-9 <= s.t_s <= run.t_s[-1] + 1e-9]
    t = np.array([s.t_s for s in log])
    vx = np.array([s.vx for s in log])
    settled = (t >= t_a + 0.5 * (t_b - t_a)) & (t <= t_b + 1e-9)
    v_top = float(np.mean(vx[settled]))
    k = int(np.argmax(vx >= 0.9 * v_top))
    t90 = t[k - 1] + (0.9 * v_top - vx[k - 1]) / (vx[k] - vx[k - 1]) * (t[k] - t[k - 1]) - t_a
    # chassis travel from the brake to its first standstill (the speed's first zero)
    after = t >= t_b - 1e-9
    tb, vb = t[after], vx[after]
    z = int(np.argmax(vb <= 0.0))
    stop = float(np.sum(0.5 * (vb[1:z] + vb[: z - 1]) * np.diff(tb[:z])))
    stop += 0.5 * vb[z - 1] * (tb[z] - tb[z - 1]) * vb[z - 1] / (vb[z - 1] - vb[z])
    errors = (
        rel(c.top_speed_m_s, v_top),
        rel(c.time_to_90_s, t90),
        rel(c.stopping_distance_m, stop),
    )
    print(
        f"characterise: top {c.top_speed_m_s:.4f} m/s (truth {v_top:.4f}), t90 "
        f"{c.time_to_90_s:.4f} s ({t90:.4f}), stop {c.stopping_distance_m * 1000:.2f} mm "
        f"({stop * 1000:.2f}; wheels {c.wheel_stopping_distance_m * 1000:.2f}), errors {errors}"
    )
    assert max(errors) < 0.01
    assert c.wheel_stopping_distance_m < c.stopping_distance_m  # the short brake skids
    config = config_copy(tmp_path)  # --write: the wheel speed at full duty
    assert calibrate("characterise", "--runs", str(folder), "--write", str(config)) == 0
    top = 0.5 * (c.top_wheel_speed_left_rad_s + c.top_wheel_speed_right_rad_s)
    assert rel(load_config(config).deadband.max_wheel_rad_s, top) < 0.01


def test_twin_fit_recovers_effective_radius_track_and_yaw_scale(tmp_path: Path) -> None:
    """The paper's V16/V17 situation: the twin's effective wheel radius, track and gyro scale
    differ from the host's 0.033 / 0.198 / 1; the fit finds 0.0325 / 0.205 / 0.6953."""
    robot = dataclasses.replace(
        _BASE,
        wheel_radius_m=Sides(0.0325, 0.0325),
        wheel_separation_m=0.205,
        imu=dataclasses.replace(_BASE.imu, yaw_scale=1.0 / 0.6953),
    )
    twin = twin_on(tmp_path, robot)
    try:
        folder = runs.record_excitation_run(
            runs.Link(twin.serial, host_config(twin.i2c)), tmp_path / "runs"
        )
    finally:
        twin.stop()
    reference = tmp_path / "truth.csv"
    with reference.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "x_m", "y_m", "yaw_rad"])
        for s in twin.twin.truth_log:
            w.writerow([repr(s.t_s), repr(s.x), repr(s.y), repr(s.yaw)])
    config = config_copy(tmp_path)
    argv = ["--runs", str(folder), "--reference", str(reference), "--write", str(config)]
    # by default the radius is held (the encoders' distance per count) and the gap is named
    assert calibrate("twin-fit", *argv) == 0
    assert load_config(config).robot.wheel_radius_left_m == 0.033
    assert rel(load_config(config).robot.wheel_separation_m, 0.205 * 0.033 / 0.0325) < 0.02
    assert calibrate("twin-fit", *argv, "--fit-radius") == 0  # the paper's V16/V17 fit
    segment = proc.fit_segment(runs.load_run(folder), runs.load_reference(reference), (621, 621))
    fit = proc.fit_twin([segment])
    errors = (
        rel(fit.wheel_radius_m, 0.0325),
        rel(fit.wheel_separation_m, 0.205),
        rel(fit.yaw_scale, 0.6953),
    )
    print(f"twin fit: {fit.wheel_radius_m:.6f} {fit.wheel_separation_m:.6f} {fit.yaw_scale:.4f}")
    print(f"twin fit errors {errors}")
    assert max(errors) < 0.01
    robot_cfg = load_config(config).robot
    assert rel(robot_cfg.wheel_radius_left_m, 0.0325) < 0.01
    assert rel(robot_cfg.wheel_separation_m, 0.205) < 0.01
