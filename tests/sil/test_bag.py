"""Every run folder holds a rosbag2 (MCAP) that ROS tools open; a killed run's bag still reads."""

from __future__ import annotations

import math
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest

from jackson.experiments import metrics
from jackson.experiments.run_csv import read_csv
from jackson.host.ros.bag import read_bag

from .harness import JACKSON, TwinThread, run_daemon_cli, wait_for


def _rows(run: Path) -> int:
    """Complete rows in the run's odometry.csv (the header excluded)."""
    return max(0, (run / "odometry.csv").read_bytes().count(b"\n") - 1)


TOPICS = (
    "/wheel/odom",
    "/imu/data",
    "/odometry/filtered",
    "/joint_states",
    "/diagnostics",
    "/tf",
    "/tf_static",
    "/jackson/telemetry",
)


def test_sigterm_mid_run_leaves_a_readable_bag(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path, world="open_floor")
    try:
        proc = subprocess.Popen(
            [
                JACKSON,
                "daemon",
                "--port",
                twin.serial,
                "--i2c",
                twin.i2c,
                "--mission",
                "figure8",
                "--run-dir",
                str(tmp_path / "run"),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        # mid-way through the figure-eight: 40 frames on disk (at any machine speed)
        wait_for(lambda: _rows(tmp_path / "run") >= 40, timeout_s=120, what="40 flushed frames")
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
    finally:
        twin.stop()
    assert proc.returncode in (0, 1), err  # 1: the mission did not finish
    bag = read_bag(tmp_path / "run" / "bag")
    assert set(TOPICS) <= set(bag)
    assert len(bag["/wheel/odom"]) > 20
    assert len(bag["/jackson/telemetry"]) >= len(bag["/wheel/odom"])
    _, imu = bag["/imu/data"][0]
    assert imu.orientation_covariance[0] == -1


def test_a_square_runs_bag_reproduces_its_metrics(tmp_path: Path) -> None:
    twin = TwinThread(tmp_path)
    try:
        out = run_daemon_cli(twin, "--mission", "square", "--run-dir", str(tmp_path / "run"))
    finally:
        twin.stop()
    assert out.returncode == 0, out.stderr
    bag = read_bag(tmp_path / "run" / "bag")

    def xy(topic: str) -> np.ndarray:
        return np.array([(m.pose.pose.position.x, m.pose.pose.position.y) for _, m in bag[topic]])

    ekf = read_csv(tmp_path / "run" / "ekf.csv")
    odo = read_csv(tmp_path / "run" / "odometry.csv")
    assert metrics.closure_error(xy("/odometry/filtered")) == metrics.closure_error(
        np.c_[ekf["x_m"], ekf["y_m"]]
    )
    assert metrics.closure_error(xy("/wheel/odom")) == metrics.closure_error(
        np.c_[odo["x_m"], odo["y_m"]]
    )
    path = metrics.square_path()
    assert math.isclose(
        metrics.cross_track_rmse(xy("/odometry/filtered"), path),
        metrics.cross_track_rmse(np.c_[ekf["x_m"], ekf["y_m"]], path),
    )


def test_a_killed_runs_bag_is_repaired_by_the_next_daemon(tmp_path: Path) -> None:
    """SIGKILL mid-mission leaves the bag without metadata.yaml; the next daemon started with
    the same recording folder repairs it and says so, and the bag then holds the run up to the
    last flushed chunk."""
    twin = TwinThread(tmp_path, world="open_floor")
    runs = tmp_path / "runs"
    cmd = [JACKSON, "daemon", "--port", twin.serial, "--i2c", twin.i2c]
    try:
        proc = subprocess.Popen(
            [*cmd, "--mission", "figure8", "--run-dir", str(runs / "killed")],
            stdout=subprocess.DEVNULL,
        )
        wait_for(lambda: _rows(runs / "killed") >= 200, timeout_s=120, what="200 frames")
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=20)
        assert not (runs / "killed" / "bag" / "metadata.yaml").exists()
        kept = _rows(runs / "killed")
        out = run_daemon_cli(twin, "--run-dir", str(runs / "next"), "--max-seconds", "1")
    finally:
        twin.stop()
    said = [line for line in out.stdout.splitlines() if "repaired the unfinished bag" in line]
    assert len(said) == 1, out.stdout + out.stderr
    bag = read_bag(runs / "killed" / "bag")
    assert said[0].endswith(f": {sum(len(m) for m in bag.values())} messages recovered")
    # chunks go to disk every second of MCU time: at most that much (20 frames) is lost
    assert len(bag["/wheel/odom"]) >= kept - 40
    assert set(TOPICS) <= set(bag)


def test_the_bag_is_finished_before_the_run_lets_go_of_its_lock(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A campaign's next daemon repairs the unfinished bags of runs whose lock is free: the
    ending daemon must finish its bag before it lets go of the lock, or the next one takes the
    closing bag for a killed run's."""
    from jackson.experiments.trial import TrialSpec, run_trial
    from jackson.host.recording import RunRecorder, run_in_progress

    seen: list[tuple[bool, bool]] = []
    close = RunRecorder.close

    def closing(self: RunRecorder) -> None:
        seen.append(
            ((self.folder / "bag" / "metadata.yaml").exists(), run_in_progress(self.folder))
        )
        close(self)

    monkeypatch.setattr(RunRecorder, "close", closing)
    run = tmp_path / "runs" / "R01"
    result = run_trial(TrialSpec("square", 0, 0, "jackson", "square_room", run))
    assert result["completed"]
    # the bag was complete while the recorder still held the run
    assert seen == [(True, True)]
    assert not run_in_progress(run)
