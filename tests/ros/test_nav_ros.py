"""Stage 3 on ROS 2: ``jackson daemon --ros`` navigating the maze against the twin (its MCU and
its emulated RPLIDAR on ptys, real time), and an rclpy client in another process that hears
/map, /plan, /local_plan and /scan as RViz would."""

from __future__ import annotations

import json
import platform
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

if platform.machine() != "x86_64":
    pytest.importorskip("rclpy")

from jackson.host.nav.grid import OccupancyGrid
from jackson.sim.config import load_world
from jackson.sim.raster import raster

from ..sil.harness import TwinThread
from .test_bridge import ros_env as ros_env  # the private ROS domain fixture

pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
CLIENT = Path(__file__).with_name("nav_client.py")


def test_the_daemon_publishes_nav2s_topics_while_it_navigates(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    occ, ox, oy = raster(load_world("maze"), 0.05)  # the twin's truth as the known map
    OccupancyGrid(np.where(occ, 100, 0).astype(np.int8), 0.05, ox, oy).save(tmp_path / "m.yaml")
    client = subprocess.Popen(
        [sys.executable, str(CLIENT), "--listen-s", "60"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    assert client.stdout is not None
    assert client.stdout.readline().strip() == "ready"
    twin = TwinThread(tmp_path, world="maze", robot="jackson_physical", lidar=True, lockstep=False)
    assert twin.lidar is not None
    daemon = subprocess.Popen(
        [
            str(Path(sys.executable).parent / "jackson"),
            "daemon",
            "--ros",
            "--port",
            twin.serial,
            "--i2c",
            twin.i2c,
            "--lidar",
            twin.lidar,
            "--map",
            str(tmp_path / "m.yaml"),
            "--start=-0.6909,-0.0364,0",
            "--goal=1.2091,-0.0364",
            "--run-dir",
            str(tmp_path / "run"),
            "--max-seconds",
            "90",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    try:
        c_out, c_err = client.communicate(timeout=90)
    finally:
        daemon.send_signal(signal.SIGTERM)
        d_out, d_err = daemon.communicate(timeout=30)
        twin.stop()
    assert client.returncode == 0, c_out + c_err + d_err
    report: dict[str, Any] = json.loads(c_out.strip().splitlines()[-1])
    seen = (report, d_out[-2000:], d_err[-2000:])  # what the daemon said, should one fail
    assert report["map"] >= 1 and report["map_frame"] == "map", seen
    assert report["map_size"][2] == 0.05, seen
    assert report["plan"] >= 3 and report["plan_points"] > 10, seen  # 1 Hz and when blocked
    assert report["local_plan"] >= 10, seen
    # the densest mode of the twin's A1M8: Sensitivity, 1060 or 1061 samples a turn
    assert report["scan"] >= 10 and 1059 <= report["scan_beams"] <= 1061, seen
    assert "daemon:" in d_out, d_out + d_err
