"""The twin and the daemon both on ROS, as a user runs them: ``jackson sim --ros --world maze``
and ``jackson daemon --ros --lidar ... --goal ...`` in two processes (lockstep, the twin's
default), and a third process (``stamp_client.py``) that hears the clock and the stamps.

The daemon finds the twin's /clock and follows it; every stamp it publishes is MCU time, which
is the twin's sim time: never 0, never going back on a topic, within the /clock's span; each
scan is stamped at its own revolution's start, one LiDAR period (0.13465 s) after the one before
within 5 ms from the first (not at the telemetry frame it arrived with, which alternated 0.10
and 0.15 s); /local_plan is in odom (Nav2's controller frame); /tf_static has one publisher."""

from __future__ import annotations

import json
import os
import platform
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

if platform.machine() != "x86_64":
    pytest.importorskip("rclpy")

from .conftest import private_ros_env

pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
JACKSON = str(Path(sys.executable).parent / "jackson")
CLIENT = Path(__file__).with_name("stamp_client.py")
LIDAR_PERIOD_S = 0.13465  # the A1M8's revolution (REFERENCE: LiDAR)


@pytest.fixture
def ros_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> dict[str, str]:
    return private_ros_env(monkeypatch, tmp_path, 201, 14)


class Sim:
    """``jackson sim --ros --world maze`` in its own process; its ports from its first lines."""

    def __init__(self, env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(
            [JACKSON, "sim", "--ros", "--world", "maze"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        assert self.proc.stdout is not None
        self.ports: dict[str, str] = {}
        for line in self.proc.stdout:  # waits for each line; ends with the "twin:" line
            key, _, value = line.strip().partition(": ")
            self.ports[key] = value
            if key == "twin":
                break
        assert {"serial", "i2c", "lidar"} <= set(self.ports), self.ports

    def stop(self) -> str:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        _, err = self.proc.communicate(timeout=30)
        return err


@pytest.fixture
def sim(ros_env: dict[str, str]) -> Iterator[Sim]:
    s = Sim(ros_env)
    yield s
    s.stop()


def test_sim_and_daemon_on_ros_navigate_on_one_clock(
    sim: Sim, tmp_path: Path, ros_env: dict[str, str]
) -> None:
    done = tmp_path / "daemon-done"
    client = subprocess.Popen(
        [sys.executable, str(CLIENT), "--until", str(done), "--listen-s", "240"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    assert client.stdout is not None
    assert client.stdout.readline().strip() == "ready"
    daemon = subprocess.run(
        [
            JACKSON,
            "daemon",
            "--ros",
            "--port",
            sim.ports["serial"],
            "--i2c",
            sim.ports["i2c"],
            "--lidar",
            sim.ports["lidar"],
            "--start=-0.6909,-0.0364,0",
            "--goal=1.2091,-0.0364",
            "--run-dir",
            str(tmp_path / "run"),
            "--max-seconds",
            "180",
        ],
        capture_output=True,
        text=True,
        env=ros_env,
        timeout=240,
    )
    done.touch()
    c_out, c_err = client.communicate(timeout=60)
    said = daemon.stdout + daemon.stderr
    assert daemon.returncode == 0, said
    assert "navigation reached the goal" in said, said
    assert "ROS: /clock is published (a simulator): stamping with it" in said, said
    # the daemon's own CPU, said at the end and kept in health.json (docs/host.md, CPU)
    assert "daemon: CPU " in said and "% of a core" in said, said
    cpu = json.loads((tmp_path / "run" / "health.json").read_text())["cpu"]
    assert cpu["frames"] > 100 and cpu["robot_s"] > 5.0
    assert 0.0 < cpu["share_of_core"] < 4.0 and cpu["frame_us"]["median"] > 0.0
    assert client.returncode == 0, c_err
    report: dict[str, Any] = json.loads(c_out.strip().splitlines()[-1])
    clock = np.array(report["clock"], np.int64)
    # at least a second of /clock (20 Hz; how much of the run the client hears depends on when
    # discovery matches it to the twin on a busy machine), never going back
    assert len(clock) > 20 and np.all(np.diff(clock) >= 0)
    stamps = {k: np.array(v, np.int64) for k, v in report["stamps"].items()}
    for topic in ("/scan", "/odometry/filtered", "/wheel/odom", "/imu/data", "/local_plan"):
        s = stamps[topic]
        assert len(s) >= 10, (topic, len(s))
        assert s.min() > 0, topic  # never 0 (1970)
        assert np.all(np.diff(s) > 0), (topic, np.diff(s)[np.diff(s) <= 0][:5])
        # on the twin's clock (sim time from 0), not the system clock: never ahead of /clock
        assert s.max() <= clock.max() + 100_000_000, topic
    tf = stamps["/tf"]
    assert tf.min() > 0
    # each revolution one period after the one before (a lost one: two periods)
    gaps = np.diff(stamps["/scan"]) / 1e9
    periods = np.round(gaps / LIDAR_PERIOD_S)
    assert np.all(periods >= 1)
    error = np.abs(gaps - periods * LIDAR_PERIOD_S)
    # from the first: the timer moves its phase by at most 3 ms a revolution (ScanTimer)
    assert np.max(error) < 0.005, gaps
    timing = np.array(report["scan_timing"])
    assert np.allclose(timing[:, 1], LIDAR_PERIOD_S, rtol=0.02)  # scan_time
    assert np.allclose(timing[:, 0] * timing[:, 2], timing[:, 1])  # time_increment x beams
    assert report["frames"]["/local_plan"] == ["odom"]
    assert report["frames"]["/scan"] == ["laser"]
    assert len(report["static_publishers"]) == 1, report["static_publishers"]  # one: the daemon
    assert os.path.isdir(tmp_path / "run")
