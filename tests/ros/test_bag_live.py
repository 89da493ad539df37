"""The run's bag against the live topics of the same run, and the time policy on the twin.

`jackson sim --ros` (the twin: /twin/scan and /clock on sim time) and `jackson daemon --ros` with
``use_sim_time`` drive the square; ``record_client.py`` in a third process keeps every message
of the daemon's topics and the twin's /twin/scan as delivered. Every live message is in the run's
bag, byte for byte once both are serialised alike, and the twin's scans and the daemon's
odometry carry stamps of one clock (within one scan period).
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

from rosbags.typesys import Stores, get_typestore

from jackson.host.ros.bag import read_bag
from jackson.host.ros.messages import SCAN_PERIOD_S, TOPIC_TYPES, RosSettings

from .conftest import private_ros_env

pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")

JACKSON = str(Path(sys.executable).parent / "jackson")
CLIENT = Path(__file__).with_name("record_client.py")
OURS = ("wheel_odom", "imu", "joint_states", "filtered", "diagnostics", "tf", "tf_static")


@pytest.fixture
def ros_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> dict[str, str]:
    """A private ROS domain on the loopback interface, for this process and its children."""
    return private_ros_env(monkeypatch, tmp_path, 101, 100)


def _stamp(msg: object) -> float:
    header = getattr(msg, "header", None)
    if header is None:  # a TFMessage
        header = msg.transforms[0].header  # type: ignore[attr-defined]
    return float(header.stamp.sec) + 1e-9 * float(header.stamp.nanosec)


def test_the_bag_holds_every_live_message_and_the_twins_scans_line_up(
    tmp_path: Path, ros_env: dict[str, str]
) -> None:
    settings = RosSettings()
    sim = subprocess.Popen(
        [JACKSON, "sim", "--ros", "--realtime", "--world", "square_room"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ros_env,
    )
    daemon: subprocess.Popen[str] | None = None
    run = tmp_path / "run"
    try:
        assert sim.stdout is not None
        lines = [sim.stdout.readline().strip() for _ in range(5)]
        assert lines[0].startswith("serial: "), lines
        serial, i2c = lines[0].split(": ", 1)[1], lines[1].split(": ", 1)[1]
        daemon = subprocess.Popen(
            [
                JACKSON,
                "daemon",
                "--port",
                serial,
                "--i2c",
                i2c if i2c.startswith("unix:") else f"unix:{i2c}",
                "--mission",
                "square",
                "--run-dir",
                str(run),
                "--max-seconds",
                "40",
                "--ros",
                "--ros-args",
                "-p",
                "use_sim_time:=true",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=ros_env,
        )
        topics = [
            f"{settings.topic(k)}={settings.topic_type(k)}:{TOPIC_TYPES[k][1]}" for k in OURS
        ] + ["/twin/scan=sensor_msgs/msg/LaserScan:sensor"]
        live_file = tmp_path / "live.jsonl"
        out = subprocess.run(
            [sys.executable, str(CLIENT), "--listen-s", "4", "--out", str(live_file)]
            + [f"--topic={t}" for t in topics],
            capture_output=True,
            text=True,
            timeout=90,
            env=ros_env,
        )
    finally:
        if daemon is not None:
            daemon.send_signal(signal.SIGTERM)
            _, d_err = daemon.communicate(timeout=30)
        sim.send_signal(signal.SIGTERM)
        sim.communicate(timeout=30)
    assert out.returncode == 0, out.stderr + (d_err if daemon else "")

    store = get_typestore(Stores.ROS2_JAZZY)
    types = {settings.topic(k): settings.topic_type(k) for k in OURS}
    types["/twin/scan"] = "sensor_msgs/msg/LaserScan"

    def canonical(ros_type: str, data: bytes) -> bytes:
        return bytes(store.serialize_cdr(store.deserialize_cdr(data, ros_type), ros_type))

    live: dict[str, list[tuple[float, object, bytes]]] = {t: [] for t in types}
    for line in live_file.read_text().splitlines():
        row = json.loads(line)
        msg = store.deserialize_cdr(bytes.fromhex(row["data"]), types[row["topic"]])
        live[row["topic"]].append(
            (row["t"], msg, canonical(types[row["topic"]], bytes.fromhex(row["data"])))
        )
    bag = read_bag(run / "bag")
    for key in OURS:
        topic = settings.topic(key)
        ros_type = types[topic]
        recorded = Counter(bytes(store.serialize_cdr(msg, ros_type)) for _, msg in bag[topic])
        heard = Counter(data for _, _, data in live[topic])
        assert heard, topic
        missing = heard - recorded
        assert not missing, f"{topic}: {sum(missing.values())} live messages not in the bag"
        # and the bag is not a sample: over the span heard, it has what was published
        first, last = (
            min(_stamp(m) for _, m, _ in live[topic]),
            max(_stamp(m) for _, m, _ in live[topic]),
        )
        span = [m for _, m in bag[topic] if first <= _stamp(m) <= last]
        assert sum(heard.values()) >= 0.8 * len(span), (topic, sum(heard.values()), len(span))

    # one clock: each of the twin's scans has odometry within one scan period of its stamp
    odom = sorted(_stamp(m) for _, m, _ in live[settings.filtered_topic])
    scans = [_stamp(m) for _, m, _ in live["/twin/scan"] if odom[0] <= _stamp(m) <= odom[-1]]
    assert len(scans) >= 10
    for s in scans:
        assert min(abs(s - o) for o in odom) <= SCAN_PERIOD_S, s
