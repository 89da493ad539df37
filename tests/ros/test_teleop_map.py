"""Mapping from a teleop recording of the twin, end to end, as a user does it: ``jackson sim
--realtime --truth``, ``jackson daemon --ros --lidar`` recording, a ROS 2 node publishing
/cmd_vel at 10 Hz along the survey route of the world, the twin's truth attached to the run
folder, and ``jackson map --from`` judging the map against the world
(``python -m jackson.experiments.teleop_twin drive``, in its own process)."""

from __future__ import annotations

import json
import platform
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

if platform.machine() != "x86_64":
    pytest.importorskip("rclpy")

from .conftest import private_ros_env

TELEOP = (sys.executable, "-m", "jackson.experiments.teleop_twin")
pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
LAST_LINE = re.compile(
    r"map: \S+/built_map\.yaml \(\+ \.pgm\) from (?P<scans>\d+) scans over [\d.]+ s of robot "
    r"time \(odometry: /odometry/filtered\); [\d.]+ robot-seconds mapped per CPU-second"
)


@pytest.fixture
def ros_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> dict[str, str]:
    return private_ros_env(monkeypatch, tmp_path, 1, 100)


@pytest.mark.timeout(900)  # a far backstop: about 40 s idle, the drive in real time
def test_a_teleop_drive_of_the_twin_is_recorded_mapped_and_judged(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    out = tmp_path / "teleop"
    done = subprocess.run(
        [*TELEOP, "drive", "--world", "square_room", "--out", str(out)],
        capture_output=True,
        text=True,
        env=ros_env,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    lines = done.stdout.strip().splitlines()
    m = LAST_LINE.fullmatch(lines[-1])
    assert m is not None and int(m["scans"]) > 50, lines[-1]
    report = json.loads((out / "teleop.json").read_text())
    drive = report["drive"]
    # the survey route of square_room: out to the Stage 3 goal and back, 2.4 m
    assert drive["collisions"] == 0 and drive["daemon_status"] == 0
    assert drive["route_m"] > 2.0 and drive["driven_m"] > 0.9 * drive["route_m"]
    assert drive["commands"] > 10 * drive["robot_s"] * 0.5  # 10 Hz of wall time
    # the run folder: a twin run, its map in the world's frame
    run = out / "run"
    meta = json.loads((run / "meta.json").read_text())
    assert meta["world"] == "square_room" and meta["robot"] == "jackson_physical"
    assert np.allclose(meta["navigate"]["start"], [0.0, 0.0, 0.0], atol=1e-6)
    truth = np.loadtxt(run / "ground_truth.csv", delimiter=",", skiprows=1)
    assert truth.shape[1] == 4 and truth[-1, 0] > drive["robot_s"]
    # judged against the world, as a survey's map is
    figures = report["map"]
    assert figures == json.loads((out / "map" / "map_quality.json").read_text())
    assert figures["world"] == "square_room" and figures["segments_judged"] == 4
    assert figures["segments_covered_fraction"] >= 0.75
    assert figures["precision"] > 0.9 and figures["ssim"] > 0.8
    assert figures["misplacement_p99_m"] < 0.15
    png = out / "map" / "built_map.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert re.search(r"^  precision +\d+\.\d% of \d+ occupied cells$", done.stdout, re.M)

    # the truth of another twin session (its MCU's boot_id) is refused in one line
    text = (out / "truth.csv").read_text()
    boot = re.search(r"boot_id (0x[0-9a-f]{8})", text)
    assert boot is not None
    other = tmp_path / "other-truth.csv"
    other.write_text(text.replace(boot[1], "0x00000001", 1))
    refused = subprocess.run(
        [*TELEOP, "attach", str(run), "--truth", str(other)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert refused.returncode == 2
    assert refused.stderr.strip() == (
        f"teleop_twin: {run}: recorded on a twin with boot_id {boot[1]}, {other} is the truth "
        "of boot_id 0x00000001: give the truth file of that twin session"
    )
    assert json.loads((run / "meta.json").read_text()) == meta  # untouched
