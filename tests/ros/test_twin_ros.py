"""The twin's own ROS 2 publisher (``jackson sim --ros``): /twin/scan, /ground_truth/odom, /clock.

``jackson sim --ros --realtime`` runs in a subprocess with a private ROS domain; the minimal
test peer says HELLO (the twin's clock stands still until then) and drives forward, and
``twin_client.py`` in a third process subscribes with the documented QoS and reports.

On x86_64 ``make setup`` installs rclpy (the ``ros`` extra), so there a missing rclpy fails;
elsewhere the module is skipped unless a system ROS 2 is sourced.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import platform
import signal
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest

if platform.machine() != "x86_64":
    pytest.importorskip("rclpy")

from jackson.protocol import Telemetry
from jackson.sim.config import load_robot, load_world
from jackson.sim.lidar import LidarSpec
from jackson.sim.ros import ros_available
from jackson.sim.runner import TwinRunner
from jackson.sim.twin import Twin

from ..sim.wire_peer import WirePeer
from .conftest import private_ros_env

# lark (pulled in by rosidl's parser) imports the deprecated sre_parse
pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")

JACKSON = str(Path(sys.executable).parent / "jackson")
CLIENT = Path(__file__).with_name("twin_client.py")


@pytest.fixture
def ros_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> dict[str, str]:
    """A private ROS domain on the loopback interface, for this process and its children."""
    return private_ros_env(monkeypatch, tmp_path, 101, 100)


class HostThread:
    """The test peer in a thread: HELLO, then forward duties and a heartbeat per frame."""

    def __init__(self, serial: str, i2c: str, duty: float) -> None:
        self.host = WirePeer(serial, i2c)
        self.host.connect()
        self.duty = duty
        self.frames = 0
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                self.host.next_telemetry(timeout_s=2.0)
                self.host.set_wheels(self.duty, self.duty)
                self.host.heartbeat()
                self.frames += 1
        except BaseException as exc:  # reported by stop()
            self.error = exc

    def stop(self) -> None:
        self._stop.set()
        self.thread.join(timeout=5)
        self.host.close()


def test_rclpy_and_the_message_packages_are_available() -> None:
    assert ros_available() is None


def test_sim_ros_publishes_scan_ground_truth_and_clock(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    sim = subprocess.Popen(
        [JACKSON, "sim", "--ros", "--realtime", "--world", "square_room"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    host: HostThread | None = None
    try:
        assert sim.stdout is not None
        lines = [sim.stdout.readline().strip() for _ in range(5)]
        assert lines[0].startswith("serial: "), (lines, sim.stderr and sim.stderr.read())
        assert lines[2].startswith("lidar: /dev/pts/"), lines
        assert lines[3] == "ros: publishing /clock, /ground_truth/odom, /twin/scan on sim time"
        serial, i2c = lines[0].split(": ", 1)[1], lines[1].split(": ", 1)[1]
        host = HostThread(serial, i2c, duty=0.5)
        out = subprocess.run(
            [sys.executable, str(CLIENT), "--listen-s", "2.0"],
            capture_output=True,
            text=True,
            timeout=40,
            env=ros_env,
        )
    finally:
        if host is not None:
            host.stop()
        sim.send_signal(signal.SIGTERM)
        _, sim_err = sim.communicate(timeout=20)
    assert out.returncode == 0, out.stdout + out.stderr + sim_err
    assert sim.returncode == 0, sim_err
    assert host is not None and host.error is None, host and host.error
    report: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    counts = report["counts"]

    # rates over >= 2 s of real time: scans at 7.43 Hz, truth at 20 Hz, /clock at every frame
    assert counts["scan"] >= 10, report
    assert counts["ground_truth"] >= 30, report
    assert counts["clock"] >= 30, report

    spec = LidarSpec()
    scan = report["scan"]
    assert scan["frame_id"] == "laser"
    assert scan["beams"] == 1080
    assert scan["angle_increment"] == pytest.approx(0.005807, rel=1e-6)
    assert scan["angle_min"] == pytest.approx(-math.pi, rel=1e-6)
    assert scan["angle_max"] == pytest.approx(spec.angle_max_rad, rel=1e-6)
    assert scan["time_increment"] == pytest.approx(0.13465 / 1080, rel=1e-6)
    assert scan["scan_time"] == pytest.approx(0.13465, rel=1e-6)
    assert scan["range_min"] == pytest.approx(0.15, rel=1e-6)
    assert scan["range_max"] == pytest.approx(12.0, rel=1e-6)
    assert scan["finite"] > 900, scan  # the 4 m room is all around
    assert scan["finite_in_limits"], scan

    truth = report["ground_truth"]
    assert (truth["frame_id"], truth["child_frame_id"]) == ("odom", "base_footprint")
    assert report["max_v"] > 0.05, report  # the host drove the robot forward

    # /clock is sim time and advanced with the twin, about as fast as the wall clock
    assert report["clock_monotonic"], report
    assert report["scan_stamps_monotonic"], report
    assert report["clock_last"] - report["clock_first"] >= 1.5, report
    assert report["scan_stamp_last"] <= report["clock_last"] + 0.2, report


def test_sim_ros_without_rclpy_is_one_line_and_exit_2(tmp_path: Path) -> None:
    fake = tmp_path / "fake" / "rclpy"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError(\"No module named 'rclpy'\")\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path / "fake")}
    env.pop("ROS_DISTRO", None)
    out = subprocess.run(
        [JACKSON, "sim", "--ros", "--duration", "0.1"],
        capture_output=True,
        text=True,
        timeout=30,
        env=env,
    )
    assert out.returncode == 2, out.stdout + out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert lines[0].startswith("jackson sim: ROS 2 is missing (rclpy)"), lines
    assert out.stdout == ""


def _lockstep_run(tmp: Path, observed: list[int] | None) -> list[Telemetry]:
    twin = Twin(load_world("square_room"), load_robot("jackson"), seed=3, lidar=False)
    runner = TwinRunner(
        twin,
        i2c_path=tmp / "i2c.sock",
        observer=(lambda t: observed.append(t.t_us)) if observed is not None else None,
    )
    stop = threading.Event()
    thread = threading.Thread(target=runner.run, args=(None, stop), daemon=True)
    thread.start()
    host = WirePeer(runner.serial_path, f"unix:{tmp / 'i2c.sock'}")
    try:
        host.connect()
        return host.run(30, lambda t: (0.6, 0.3))
    finally:
        host.close()
        stop.set()
        thread.join(timeout=10)
        runner.close()


def test_the_observer_sees_every_advance_and_leaves_lockstep_alone(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    observed: list[int] = []
    with_observer = _lockstep_run(tmp_path / "a", observed)
    without = _lockstep_run(tmp_path / "b", None)
    assert with_observer == without  # the same frames, bit for bit
    assert all(b > a for a, b in itertools.pairwise(observed))
    assert observed[0] == 50_000  # after the first advance
    assert set(range(50_000, 30 * 50_000, 50_000)) <= set(observed)
