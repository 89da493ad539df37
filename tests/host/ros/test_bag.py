"""rosbag2 recording (host/ros/bag/): every topic round-trips through AnyReader."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap.records import Channel as McapChannel
from mcap.records import Chunk
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader, breakup_chunk
from rosbags.highlevel import AnyReader

from jackson.host.estimation.odometry import OdometryCovariance
from jackson.host.ros.bag import (
    BagError,
    BagRecorder,
    bag_info,
    needs_repair,
    read_bag,
    repair_bag,
    stamp_ns,
)
from jackson.host.ros.messages import TOPIC_TYPES, RosSettings
from jackson.main import main

WRITTEN = {
    "/wheel/odom": "nav_msgs/msg/Odometry",
    "/imu/data": "sensor_msgs/msg/Imu",
    "/odometry/filtered": "nav_msgs/msg/Odometry",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/jackson/telemetry": "std_msgs/msg/UInt8MultiArray",
}
ALL_TOPICS = {RosSettings().topic(k): RosSettings().topic_type(k) for k in TOPIC_TYPES}
FRAME = bytes([0xA5, 0x5A, 0x01, 0x10, 0x00, 0xFF, 0x00, 0x7E])


def write_one_of_each(path: Path) -> None:
    with BagRecorder(path) as bag:
        bag.raw_frame(1.25, FRAME)
        bag.wheel_odom(1.25, 0.5, -0.25, math.pi / 2, 0.2, 0.1)
        bag.imu(1.25, (0.1, -0.2, 9.81), (0.001, -0.002, 0.3))
        bag.joint_states(1.25, 3.0, -1.5, 6.0, -2.0)
        bag.filtered(1.25, 0.5, -0.25, math.pi / 2, 0.2, 0.01, 0.1, (1, 2, 3, 4, 5, 6, 7))
        bag.diagnostics(1.25, {"link": "up", "crc_errors": "0"}, level=1)


@pytest.fixture
def bag_messages(tmp_path: Path) -> dict[str, list[tuple[int, Any]]]:
    write_one_of_each(tmp_path / "bag")
    return read_bag(tmp_path / "bag")


def test_every_topic_is_written_with_its_type(tmp_path: Path) -> None:
    write_one_of_each(tmp_path / "bag")
    with AnyReader([tmp_path / "bag"]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        assert types == ALL_TOPICS  # every topic the node publishes or receives
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts == {t: int(t in WRITTEN) for t in ALL_TOPICS}
    assert (tmp_path / "bag" / "metadata.yaml").exists()
    assert (tmp_path / "bag" / "bag_0.mcap").exists()  # rosbag2 names: <folder>_<k>.mcap


def test_stamp_and_bag_time_come_from_t_s(bag_messages: dict[str, list[tuple[int, Any]]]) -> None:
    for topic, msgs in bag_messages.items():
        if topic not in WRITTEN:
            assert msgs == [], topic
            continue
        ns, msg = msgs[0]
        assert ns == 1_250_000_000, topic
        if hasattr(msg, "header"):
            assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1, 250_000_000)


def test_wheel_odom_pose_quaternion_and_covariances(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    _, odom = bag_messages["/wheel/odom"][0]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    p = odom.pose.pose
    assert (p.position.x, p.position.y, p.position.z) == (0.5, -0.25, 0.0)
    q = p.orientation
    half = math.sqrt(0.5)
    assert (q.x, q.y) == (0.0, 0.0)
    assert q.z == pytest.approx(half) and q.w == pytest.approx(half)  # yaw 90 deg
    t = odom.twist.twist
    assert (t.linear.x, t.linear.y, t.angular.z) == (0.2, 0.0, 0.1)
    cfg = OdometryCovariance()
    twist = odom.twist.covariance.reshape(6, 6)
    assert np.array_equal(np.diag(twist), [0.01, 0.001, 0, 0, 0, 0.02])
    assert np.count_nonzero(twist - np.diag(np.diag(twist))) == 0
    pose = np.diag(odom.pose.covariance.reshape(6, 6))
    assert np.array_equal(
        pose,
        [cfg.pose_xy, cfg.pose_xy, 0, 0, 0, cfg.pose_yaw],
    )


def test_imu_has_si_values_noise_covariances_and_no_orientation(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    _, imu = bag_messages["/imu/data"][0]
    assert imu.header.frame_id == "imu_link"
    assert imu.orientation_covariance[0] == -1.0
    a, w = imu.linear_acceleration, imu.angular_velocity
    assert (a.x, a.y, a.z) == (0.1, -0.2, 9.81)
    assert (w.x, w.y, w.z) == (0.001, -0.002, 0.3)
    # Table 2's R_wz and R_a, as the live /imu/data carries them
    assert np.array_equal(imu.angular_velocity_covariance.reshape(3, 3), np.eye(3) * 4e-4)
    assert np.array_equal(imu.linear_acceleration_covariance.reshape(3, 3), np.eye(3) * 0.01)


def test_filtered_takes_the_ekf_p_diagonal(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    _, est = bag_messages["/odometry/filtered"][0]
    assert (est.header.frame_id, est.child_frame_id) == ("odom", "base_footprint")
    assert est.pose.pose.orientation.z == pytest.approx(math.sqrt(0.5))
    t = est.twist.twist
    assert (t.linear.x, t.linear.y, t.angular.z) == (0.2, 0.01, 0.1)
    pose = est.pose.covariance.reshape(6, 6)
    twist = est.twist.covariance.reshape(6, 6)
    assert (pose[0, 0], pose[1, 1], pose[5, 5]) == (1, 2, 3)
    assert (twist[0, 0], twist[1, 1], twist[5, 5]) == (4, 5, 6)
    assert pose.sum() == 6 and twist.sum() == 15  # nothing else, ax's variance not published


def test_filtered_also_writes_odom_to_base_footprint_on_tf(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    _, tf = bag_messages["/tf"][0]
    (t,) = tf.transforms
    assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_footprint")
    assert (t.transform.translation.x, t.transform.translation.y) == (0.5, -0.25)
    assert t.transform.rotation.w == pytest.approx(math.sqrt(0.5))


def test_filtered_without_p_diag_or_with_pose_only(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag") as bag:
        bag.filtered(0.0, 0, 0, 0, 0, 0, 0, None)
        bag.filtered(0.1, 0, 0, 0, 0, 0, 0, (0.1, 0.2, 0.3))
        with pytest.raises(ValueError, match="p_diag"):
            bag.filtered(0.2, 0, 0, 0, 0, 0, 0, (0.1, 0.2, 0.3, 0.4))
    (_, none), (_, pose_only) = read_bag(tmp_path / "bag")["/odometry/filtered"]
    assert not none.pose.covariance.any() and not none.twist.covariance.any()
    assert pose_only.pose.covariance[35] == 0.3 and not pose_only.twist.covariance.any()


def test_joint_states_names_angles_and_speeds(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    _, js = bag_messages["/joint_states"][0]
    assert js.name == ["left_wheel_joint", "right_wheel_joint"]
    assert list(js.position) == [3.0, -1.5]
    assert list(js.velocity) == [6.0, -2.0]
    assert len(js.effort) == 0


def test_diagnostics_key_values_and_level(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    _, arr = bag_messages["/diagnostics"][0]
    (status,) = arr.status
    assert status.level == 1 and status.message == "WARN"
    assert {kv.key: kv.value for kv in status.values} == {"link": "up", "crc_errors": "0"}


def test_raw_frame_bytes_are_kept_exactly(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    _, raw = bag_messages["/jackson/telemetry"][0]
    assert bytes(raw.data) == FRAME


def test_tf_static_is_written_once_with_the_mounting(
    bag_messages: dict[str, list[tuple[int, Any]]],
) -> None:
    ((ns, tf),) = bag_messages["/tf_static"]
    assert ns == 1_250_000_000
    pairs = [(t.header.frame_id, t.child_frame_id) for t in tf.transforms]
    assert pairs == [
        ("base_footprint", "base_link"),
        ("base_link", "imu_link"),
        ("base_link", "laser"),
    ]
    heights = [t.transform.translation.z for t in tf.transforms]
    assert heights == [0.033, 0.0, 0.0]  # base_link at the axle's height, the wheel radius
    for t in tf.transforms:
        assert t.transform.rotation.w == 1.0 and t.transform.translation.x == 0.0


def test_names_and_mounting_follow_the_nodes_parameters(tmp_path: Path) -> None:
    settings = RosSettings(
        wheel_odom_topic="/jackson/odom",
        odom_frame="world",
        base_frame="base",
        imu_frame="imu",
        laser_offset_m=(0.1, 0.0, 0.2),
    )
    with BagRecorder(tmp_path / "bag", settings) as bag:
        bag.wheel_odom(0.0, 0, 0, 0, 0, 0)
        bag.raw_frame(0.0, b"\x00")
    msgs = read_bag(tmp_path / "bag")
    assert "/jackson/odom" in msgs and "/wheel/odom" not in msgs
    _, odom = msgs["/jackson/odom"][0]
    assert (odom.header.frame_id, odom.child_frame_id) == ("world", "base")
    laser = [t for t in msgs["/tf_static"][0][1].transforms if t.child_frame_id == "laser"]
    assert (laser[0].transform.translation.x, laser[0].transform.translation.z) == (0.1, 0.2)
    assert msgs["/tf_static"][0][1].transforms[0].header.frame_id == "base"


def test_bag_time_never_decreases_within_a_topic(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag") as bag:
        bag.wheel_odom(2.0, 0, 0, 0, 0, 0)
        bag.wheel_odom(1.5, 0, 0, 0, 0, 0)
        bag.imu(1.0, (0, 0, 0), (0, 0, 0))
    msgs = read_bag(tmp_path / "bag")
    (ns0, _), (ns1, late) = msgs["/wheel/odom"]
    assert ns0 == ns1 == 2_000_000_000
    assert late.header.stamp.sec == 1 and late.header.stamp.nanosec == 500_000_000
    assert msgs["/imu/data"][0][0] == 1_000_000_000


def test_a_thinned_topic_is_filed_at_its_rate_and_the_others_whole(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag", topic_hz={"wheel_odom": 5.0}) as bag:
        for k in range(20):  # 1 s of 20 Hz frames
            bag.wheel_odom(0.05 * k, 0, 0, 0, 0, 0)
            bag.imu(0.05 * k, (0, 0, 0), (0, 0, 0))
    msgs = read_bag(tmp_path / "bag")
    assert [ns for ns, _ in msgs["/wheel/odom"]] == [k * 200_000_000 for k in range(5)]
    assert len(msgs["/imu/data"]) == 20


def test_the_bag_says_which_messages_it_would_keep(tmp_path: Path) -> None:
    bag = BagRecorder(tmp_path / "bag", topic_hz={"local_plan": 5.0})
    assert bag.wants("local_plan", 1.0) and bag.wants("scan", 1.0)
    bag.wheel_odom(1.0, 0, 0, 0, 0, 0)
    bag.write("local_plan", 1.0, bag.builder.path(1.0, np.zeros((2, 3))))
    assert not bag.wants("local_plan", 1.15) and bag.wants("local_plan", 1.2)
    assert bag.wants("scan", 1.05)
    bag.close()
    assert not bag.wants("scan", 2.0)


def test_close_is_idempotent_and_later_writes_are_ignored(tmp_path: Path) -> None:
    bag = BagRecorder(tmp_path / "bag")
    bag.wheel_odom(0.1, 0, 0, 0, 0, 0)
    bag.close()
    bag.close()
    assert bag.closed
    bag.wheel_odom(0.2, 0, 0, 0, 0, 0)
    bag.close()
    assert len(read_bag(tmp_path / "bag")["/wheel/odom"]) == 1


def test_an_empty_bag_closes_with_every_topic(tmp_path: Path) -> None:
    BagRecorder(tmp_path / "bag").close()
    msgs = read_bag(tmp_path / "bag")
    assert msgs.keys() == ALL_TOPICS.keys()
    assert len(msgs["/tf_static"]) == 1 and not msgs["/wheel/odom"]


def test_an_existing_folder_is_not_overwritten(tmp_path: Path) -> None:
    (tmp_path / "bag").mkdir()
    with pytest.raises(BagError, match="cannot create"):
        BagRecorder(tmp_path / "bag")


def test_negative_time_is_refused(tmp_path: Path) -> None:
    with BagRecorder(tmp_path / "bag") as bag, pytest.raises(BagError, match=">= 0"):
        bag.imu(-0.1, (0, 0, 0), (0, 0, 0))


def test_an_unclosed_bag_is_not_readable_until_repaired(tmp_path: Path) -> None:
    bag = BagRecorder(tmp_path / "bag", flush_interval_s=0.5)
    for k in range(40):  # 2 s at 20 Hz: chunks flushed every 0.5 s
        t = k * 0.05
        bag.wheel_odom(t, k * 0.01, 0, 0, 0.2, 0)
        bag.raw_frame(t, FRAME)
    # the process dies here: no close(), no metadata.yaml
    assert not (tmp_path / "bag" / "metadata.yaml").exists()
    with pytest.raises(BagError, match="not a readable bag"):
        read_bag(tmp_path / "bag")
    count = repair_bag(tmp_path / "bag")
    msgs = read_bag(tmp_path / "bag")
    assert count == sum(len(v) for v in msgs.values())
    odom = msgs["/wheel/odom"]
    assert len(odom) >= 30  # all but the last unflushed half second
    assert [m.pose.pose.position.x for _, m in odom] == pytest.approx(
        [k * 0.01 for k in range(len(odom))]
    )
    assert all(bytes(m.data) == FRAME for _, m in msgs["/jackson/telemetry"])
    assert repair_bag(tmp_path / "bag") == count  # a complete bag is left alone


CHILD = textwrap.dedent(
    """
    import math, signal, sys, threading
    from pathlib import Path
    from jackson.host.ros.bag import BagRecorder

    stop = threading.Event()
    bag = BagRecorder(Path(sys.argv[1]))
    if sys.argv[2] == "stop-loop":  # as the daemon: the handler stops the loop
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
    else:  # the handler closes the bag itself, possibly in the middle of a write
        signal.signal(signal.SIGTERM, lambda *_: bag.close())
    k = 0
    try:
        while not stop.is_set() and not bag.closed:
            t = k * 0.05
            bag.raw_frame(t, bytes([k % 256]) * 16)
            bag.wheel_odom(t, 0.01 * k, 0.0, 0.0, 0.2, 0.0)
            bag.imu(t, (0.0, 0.0, 9.81), (0.0, 0.0, 0.1))
            bag.joint_states(t, 0.1 * k, 0.1 * k, 2.0, 2.0)
            if k % 2 == 0:
                bag.filtered(t, 0.01 * k, 0.0, 0.0, 0.2, 0.0, 0.0, [1e-3] * 7)
            if k % 20 == 0:
                bag.diagnostics(t, {"link": "up"})
            if k == 50:
                print("ready", flush=True)
            k += 1
    finally:
        bag.close()
    print("closed", k, flush=True)
    """
)


@pytest.mark.parametrize("handler", ["stop-loop", "close-in-handler"])
def test_sigterm_leaves_a_complete_bag(tmp_path: Path, handler: str) -> None:
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    bag_path = tmp_path / "bag"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, str(script), str(bag_path), handler],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"  # 50 steps written, the loop writing on
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    written = int(out.split()[-1])
    msgs = read_bag(bag_path)
    assert msgs.keys() == ALL_TOPICS.keys()
    assert all(msgs[topic] for topic in WRITTEN), {t: len(v) for t, v in msgs.items()}
    assert written - 1 <= len(msgs["/jackson/telemetry"]) <= written
    assert len(msgs["/wheel/odom"]) >= written - 1


_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def _close_at_opcode(bag: BagRecorder, n: int) -> Any:
    """A tracer that calls ``bag.close()`` at the ``n``-th opcode of the recorder's write path.

    This is what a signal handler does: Python runs it between two bytecodes of the main
    thread, at any of them. Message building is left out (it holds no state).
    """
    count = 0
    bag_file = sys.modules[BagRecorder.__module__].__file__
    # the functions that take, test and give back the write claim; opcodes elsewhere in a
    # write (message building, serialising) lie inside the claimed stretch like _write's own
    traced = {"_write", "_claim", "_release", "close"}

    def local(frame: Any, event: str, arg: Any) -> Any:
        nonlocal count
        if event == "opcode":
            count += 1
            if count == n:
                bag.close()
        return local

    def tracer(frame: Any, event: str, arg: Any) -> Any:
        if frame.f_code.co_filename != bag_file or frame.f_code.co_name not in traced:
            return None
        frame.f_trace_opcodes = True
        return local

    return tracer


def test_a_close_between_any_two_bytecodes_of_a_write_leaves_a_complete_bag(
    tmp_path: Path,
) -> None:
    # Every opcode of a write (claim, serialise, put, release) in turn: the close that a
    # SIGTERM handler runs there must neither fail the write nor lose the bag.
    n = 1
    while True:
        bag = BagRecorder(tmp_path / f"bag{n}")
        bag.wheel_odom(0.0, 0.0, 0, 0, 0, 0)
        sys.settrace(_close_at_opcode(bag, n))
        try:
            bag.wheel_odom(0.05, 0.01, 0, 0, 0.2, 0)
            bag.wheel_odom(0.10, 0.02, 0, 0, 0.2, 0)
        finally:
            sys.settrace(None)
        closed_inside = bag.closed
        bag.close()
        # metadata.yaml is written last by a clean close; reading every bag back is slow
        meta = yaml.load((tmp_path / f"bag{n}" / "metadata.yaml").read_text(), Loader=_YAML_LOADER)
        counts = {
            t["topic_metadata"]["name"]: t["message_count"]
            for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]
        }
        assert 1 <= counts["/wheel/odom"] <= 3
        if n % 40 == 0 or not closed_inside:
            assert len(read_bag(tmp_path / f"bag{n}")["/wheel/odom"]) == counts["/wheel/odom"]
        if not closed_inside:  # n is past the last opcode of both writes
            assert counts["/wheel/odom"] == 3
            break
        n += 1
    assert n > 60  # the writes were really traced opcode by opcode


def _raw_messages(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, timestamp, serialised bytes) of every message, in file order per topic."""
    out = []
    with AnyReader([path]) as reader:
        for conn, ns, raw in reader.messages():
            out.append((conn.topic, ns, bytes(raw)))
    return sorted(out)


def _recorded_bag(path: Path, seconds: float = 6.0) -> None:
    with BagRecorder(path, flush_interval_s=0.25) as bag:
        for k in range(int(seconds * 20)):
            t = k * 0.05
            bag.raw_frame(t, FRAME)
            bag.wheel_odom(t, k * 0.01, 0, 0, 0.2, 0)
            bag.imu(t, (0.1, -0.2, 9.81), (0.001, -0.002, 0.3))


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_the_bags_chunks_are_compressed_as_configured_and_read_back(
    tmp_path: Path, compression: str
) -> None:
    with BagRecorder(tmp_path / "bag", flush_interval_s=0.25, compression=compression) as bag:
        for k in range(100):
            bag.wheel_odom(k * 0.05, k * 0.01, 0, 0, 0.2, 0)
    file = next((tmp_path / "bag").glob("*.mcap"))
    with file.open("rb") as f:
        chunks = [r for r in StreamReader(f, emit_chunks=True).records if isinstance(r, Chunk)]
    assert chunks and {c.compression for c in chunks} == {
        "" if compression == "none" else compression
    }
    odom = [m for m in _raw_messages(tmp_path / "bag") if m[0] == "/wheel/odom"]
    assert len(odom) == 100  # rosbags decompresses them
    with pytest.raises(ValueError, match="bag compression 'gzip'"):
        BagRecorder(tmp_path / "other", compression="gzip")


def _chunk_ends(file: Path) -> list[tuple[int, list[tuple[str, int, bytes]]]]:
    """(end offset, messages) of every chunk of a finished file, read with mcap's reader."""
    out = []
    topics: dict[int, str] = {}
    with file.open("rb") as f:
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Chunk):
                msgs = []
                for r in breakup_chunk(record):
                    if isinstance(r, McapChannel):
                        topics[r.id] = r.topic
                    elif isinstance(r, McapMessage):
                        msgs.append((topics[r.channel_id], r.log_time, bytes(r.data)))
                out.append((f.tell(), msgs))
    return out


def test_a_bag_cut_anywhere_repairs_to_every_whole_chunk_before_the_cut(tmp_path: Path) -> None:
    """A kill leaves the file cut at any byte: inside the header, a chunk, a record. The
    repaired bag holds exactly the messages of the chunks that were whole before the cut:
    none lost, none damaged or invented."""
    _recorded_bag(tmp_path / "full")
    full = _raw_messages(tmp_path / "full")
    file = next((tmp_path / "full").glob("*.mcap"))
    data = file.read_bytes()
    chunks = _chunk_ends(file)
    assert len(chunks) >= 20  # one per 0.25 s flush
    step = max(997, len(data) // 60)  # about 60 cuts over the file, an odd stride
    offsets = sorted({*range(0, len(data), step | 1), 1, 7, 8, 9, 30, len(data)})
    offsets += [end + d for end, _ in chunks[:5] for d in (-1, 0, 1)]  # at chunk edges
    for cut in offsets:
        bag = tmp_path / f"cut{cut}"
        bag.mkdir()
        (bag / "cut.mcap").write_bytes(data[:cut])
        n = repair_bag(bag)
        got = _raw_messages(bag)
        whole = sorted(m for end, msgs in chunks if end <= cut for m in msgs)
        if cut < len(data):
            assert got == whole, f"cut at {cut}"
        assert n == len(got)
        assert _mcap_count(bag / "cut.mcap") == n  # the mcap library reads it too
    assert _raw_messages(tmp_path / f"cut{len(data)}") == full


def _mcap_count(file: Path) -> int:
    with file.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    return summary.statistics.message_count


def test_zeros_where_the_tail_should_be_are_a_cut(tmp_path: Path) -> None:
    """A power loss can leave the file at its full length with zeros where the last writes
    should be (the size was on disk, the data was not): repaired like a cut there."""
    _recorded_bag(tmp_path / "full")
    full = _raw_messages(tmp_path / "full")
    file = next((tmp_path / "full").glob("*.mcap"))
    data = bytearray(file.read_bytes())
    bag = tmp_path / "zeros"
    bag.mkdir()
    chunks = _chunk_ends(file)
    start = chunks[len(chunks) * 2 // 3][0] - 10  # inside a chunk two thirds of the way
    data[start:] = bytes(len(data) - start)
    (bag / "zeros.mcap").write_bytes(bytes(data))
    n = repair_bag(bag)
    got = _raw_messages(bag)
    assert 0.4 * len(full) < n < len(full)
    assert set(got) <= set(full)


def _killed(bag: BagRecorder) -> None:
    """What SIGKILL leaves of an open recorder: the bytes written so far, nothing more."""
    file = bag._files.file
    assert file is not None
    file.flush()  # Python's buffer is in the process, but the flushed chunks are written
    file.close()
    bag._state.closed = True


def _long_run(bag: BagRecorder, seconds: float) -> int:
    n = int(seconds * 20)
    for k in range(n):
        t = k * 0.05
        bag.raw_frame(t, FRAME)
        bag.wheel_odom(t, k * 0.01, 0, 0, 0.2, 0)
    return n


def test_a_long_recording_is_split_into_numbered_files_of_one_bag(tmp_path: Path) -> None:
    bag = BagRecorder(tmp_path / "bag", flush_interval_s=0.25, max_bytes=30_000)
    n = _long_run(bag, 60.0)
    bag.close()
    names = [f.name for f in bag.files]
    assert names == [f"bag_{k}.mcap" for k in range(len(names))] and len(names) >= 4
    meta = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    assert info["relative_file_paths"] == names
    assert [f["path"] for f in info["files"]] == names
    assert sum(f["message_count"] for f in info["files"]) == info["message_count"]
    for f, entry in zip(bag.files, info["files"], strict=True):
        assert f.stat().st_size < 30_000 * 2
        assert _mcap_count(f) == entry["message_count"]  # each file is a finished MCAP
    msgs = read_bag(tmp_path / "bag")  # rosbags reads the files as one bag
    assert len(msgs["/wheel/odom"]) == len(msgs["/jackson/telemetry"]) == n
    assert len(msgs["/tf_static"]) == 1
    stamps = [ns for ns, _ in msgs["/wheel/odom"]]
    assert stamps == sorted(stamps)
    got = bag_info(tmp_path / "bag")
    assert got.counts["/wheel/odom"] == n and got.files == tuple(bag.files)
    assert (got.start_ns, got.end_ns) == (0, stamp_ns((n - 1) * 0.05))


def test_a_killed_split_recording_repairs_to_every_flushed_message(tmp_path: Path) -> None:
    bag = BagRecorder(tmp_path / "bag", flush_interval_s=0.25, max_bytes=30_000)
    n = _long_run(bag, 30.0)
    _killed(bag)
    assert len(bag.files) >= 3 and needs_repair(tmp_path / "bag")
    finished = {f: f.read_bytes() for f in bag.files[:-1]}
    count = repair_bag(tmp_path / "bag")
    msgs = read_bag(tmp_path / "bag")
    assert count == sum(len(v) for v in msgs.values())
    odom = [m.pose.pose.position.x for _, m in msgs["/wheel/odom"]]
    assert n - 10 <= len(odom) < n  # the last quarter second was still in memory
    assert odom == pytest.approx([k * 0.01 for k in range(len(odom))])
    assert all(f.read_bytes() == b for f, b in finished.items())  # finished files untouched
    meta = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())
    assert meta["rosbag2_bagfile_information"]["relative_file_paths"] == [f.name for f in bag.files]


def test_repair_is_idempotent(tmp_path: Path) -> None:
    bag = BagRecorder(tmp_path / "bag", flush_interval_s=0.25, max_bytes=30_000)
    _long_run(bag, 20.0)
    _killed(bag)
    count = repair_bag(tmp_path / "bag")
    files = {f: f.read_bytes() for f in (tmp_path / "bag").iterdir()}
    assert repair_bag(tmp_path / "bag") == count  # a bag with metadata.yaml is left alone
    assert {f: f.read_bytes() for f in (tmp_path / "bag").iterdir()} == files
    # killed while repairing, after the files and before metadata.yaml: the same again
    (tmp_path / "bag" / "metadata.yaml").unlink()
    assert repair_bag(tmp_path / "bag") == count
    assert {f: f.read_bytes() for f in (tmp_path / "bag").iterdir()} == files


def test_a_failed_repair_keeps_the_original_bytes(tmp_path: Path) -> None:
    bag = BagRecorder(tmp_path / "bag", flush_interval_s=0.25)
    _long_run(bag, 5.0)
    _killed(bag)
    file = bag.files[0]
    before = file.read_bytes()
    (file.parent / f"{file.name}.repair").mkdir()  # where the rewrite goes: cannot be written
    with pytest.raises(BagError, match="cannot repair"):
        repair_bag(tmp_path / "bag")
    assert file.read_bytes() == before
    assert not (tmp_path / "bag" / "metadata.yaml").exists()


def test_a_file_that_is_not_mcap_is_refused(tmp_path: Path) -> None:
    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "bag_0.mcap").write_bytes(b"PK\x03\x04 not a bag at all")
    with pytest.raises(BagError, match="not an MCAP file"):
        repair_bag(tmp_path / "bag")


def bag_command(*argv: str) -> int:
    """``jackson bag ARGV`` through the real entry point; its exit status."""
    return main(["bag", *argv])


def test_jackson_bag_repair_and_info(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "run"
    bag = BagRecorder(run / "bag", flush_interval_s=0.5)
    for k in range(40):
        bag.wheel_odom(k * 0.05, k * 0.01, 0, 0, 0.2, 0)
    _killed(bag)
    assert bag_command("info", str(run)) == 2
    assert "jackson bag repair" in capsys.readouterr().err
    assert bag_command("repair", str(run)) == 0
    out = capsys.readouterr().out
    # flushed with the message at 1.5 s: 31 odometry messages, and /tf_static
    assert "repaired, 32 messages recovered" in out
    assert "  /wheel/odom: 31" in out and "0.000 s to 1.500 s" in out
    assert bag_command("repair", str(run)) == 0
    assert "nothing to repair" in capsys.readouterr().out
    assert bag_command("info", str(run / "bag")) == 0
    assert "bag_0.mcap" in capsys.readouterr().out


@pytest.mark.parametrize("what", ["missing", "file", "no bag"])
def test_jackson_bag_repair_refuses_in_one_line(tmp_path: Path, what: str) -> None:
    (tmp_path / "a_file").write_text("x")
    (tmp_path / "empty").mkdir()
    path = tmp_path / {"missing": "nowhere", "file": "a_file", "no bag": "empty"}[what]
    jackson = Path(sys.executable).parent / "jackson"
    out = subprocess.run([jackson, "bag", "repair", path], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and str(path) in out.stderr, out.stderr


LIVE_RECORDER = textwrap.dedent(
    """
    import sys
    from pathlib import Path
    from jackson.host.recording import RunRecorder
    from jackson.host.ros.bag import BagRecorder

    run = Path(sys.argv[1])
    rec = RunRecorder(run, {"mission": None})
    bag = BagRecorder(run / "bag", flush_interval_s=0.1)
    for k in range(20):
        bag.wheel_odom(k * 0.05, 0.0, 0, 0, 0, 0)
    print("recording", flush=True)
    sys.stdin.read()  # live until the test closes stdin, or kills it
    """
)


def test_a_run_being_recorded_is_never_repaired(tmp_path: Path) -> None:
    """A campaign's trials record side by side in one folder: the bag of a run whose recorder
    is alive (it holds the lock on log.jrec) is not touched; once that process is killed, the
    same bag is repaired."""
    from jackson.host.recording import run_in_progress

    run = tmp_path / "runs" / "live"
    child = subprocess.Popen(
        [sys.executable, "-c", LIVE_RECORDER, str(run)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout is not None and child.stdout.readline().strip() == "recording"
        assert run_in_progress(run)
        before = sorted((p.name, p.stat().st_size) for p in (run / "bag").iterdir())
        jackson = str(Path(sys.executable).parent / "jackson")
        out = subprocess.run([jackson, "bag", "repair", str(run)], capture_output=True, text=True)
        assert out.returncode == 2 and "being recorded" in out.stderr
        assert sorted((p.name, p.stat().st_size) for p in (run / "bag").iterdir()) == before
    finally:
        child.kill()
        child.wait()
    assert not run_in_progress(run)  # the kernel dropped the dead process's lock
    assert main(["bag", "repair", str(run)]) == 0
    assert len(read_bag(run / "bag")["/wheel/odom"]) >= 1


def test_chunk_indexes_wait_on_disk_and_the_summary_indexes_every_chunk(tmp_path: Path) -> None:
    """A chunk a flush: the writer's chunk indexes are kept in a file, not in memory, and the
    summary still holds one per chunk, each pointing at its chunk (mcap's indexed reader)."""
    from mcap.reader import make_reader

    from jackson.host.ros.bag.chunk_index import ChunkIndexFile

    with BagRecorder(tmp_path / "bag", flush_interval_s=0.05) as bag:
        assert isinstance(bag._files.writer._Writer__chunk_indices, ChunkIndexFile)  # type: ignore[attr-defined]
        for k in range(400):
            bag.wheel_odom(k * 0.05, k * 0.01, 0, 0, 0.2, 0)
    assert sorted(p.name for p in (tmp_path / "bag").iterdir()) == [
        "bag_0.mcap",
        "metadata.yaml",
    ]  # the index file had no name
    file = tmp_path / "bag" / "bag_0.mcap"
    chunks = _chunk_ends(file)
    assert len(chunks) > 300
    with file.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and len(summary.chunk_indexes) == len(chunks)
        odom = [m for _, _, m in reader.iter_messages(topics=["/wheel/odom"])]
    assert [m.log_time for m in odom] == [round(k * 0.05 * 1e9) for k in range(400)]
