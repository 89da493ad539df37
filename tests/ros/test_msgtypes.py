"""jackson's own store of the ROS 2 types it writes gives what rosbags' Jazzy store gives: the
same fields, message definitions, type hashes (RIHS01) and CDR bytes, and its messages pickle
into a process that has not made the store yet."""

from __future__ import annotations

import pickle
import subprocess
import sys

import pytest
from rosbags.typesys import Stores, get_typestore

from jackson.host.ros import msgtypes
from jackson.host.ros.settings import TOPIC_TYPES

JAZZY = get_typestore(Stores.ROS2_JAZZY)


@pytest.mark.parametrize("name", sorted(msgtypes.DEFINITIONS))
def test_each_type_is_jazzys(name: str) -> None:
    ours = msgtypes.typestore()
    assert ours.fielddefs[name] == JAZZY.fielddefs[name]
    assert ours.generate_msgdef(name) == JAZZY.generate_msgdef(name)
    assert ours.hash_rihs01(name) == JAZZY.hash_rihs01(name)


def test_every_topic_type_and_what_it_holds_is_defined() -> None:
    ours = msgtypes.typestore()
    for msgtype, _, _ in TOPIC_TYPES.values():
        assert msgtype in ours.types
        ours.get_msgdef(msgtype)  # every type it names is there too


def test_a_message_serialises_to_jazzys_bytes() -> None:
    from jackson.host.ros.builder import DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time

    msg = DiagnosticArray(
        Header(Time(12, 345), "base_link"),
        [DiagnosticStatus(DiagnosticStatus.WARN, "imu", "drift", "mpu6050", [KeyValue("a", "b")])],
    )
    name = "diagnostic_msgs/msg/DiagnosticArray"
    ours = bytes(msgtypes.typestore().serialize_cdr(msg, name))
    assert ours == bytes(JAZZY.serialize_cdr(msg, name))
    back = JAZZY.deserialize_cdr(ours, name)
    assert back.status[0].values[0].value == "b" and back.header.stamp.nanosec == 345


def test_a_pickled_message_loads_in_a_fresh_process() -> None:
    from jackson.host.ros.builder import Header, Time

    blob = pickle.dumps(Header(Time(1, 2), "map"))
    code = (
        "import pickle, sys; m = pickle.loads(sys.stdin.buffer.read()); "
        "print(m.frame_id, m.stamp.nanosec)"
    )
    out = subprocess.run([sys.executable, "-c", code], input=blob, capture_output=True, check=True)
    assert out.stdout.decode().split() == ["map", "2"]
