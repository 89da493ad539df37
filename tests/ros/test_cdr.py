"""The bag's own CDR encoders (host/ros/cdr.py) against rosbags': the same bytes for every
message type they pack, built by the daemon's message builder from varied values (odd string
lengths that shift the alignment, empty and long sequences, negative and extreme numbers)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.stores.ros2_jazzy import (
    std_msgs__msg__MultiArrayDimension as MultiArrayDimension,
)

from jackson.host.config import HostConfig
from jackson.host.estimation.odometry import OdometryState
from jackson.host.nav.types import Scan
from jackson.host.ros import cdr, msgtypes
from jackson.host.ros.messages import MessageBuilder, RosSettings, StampClock

STORE = get_typestore(Stores.ROS2_JAZZY)


def _builders() -> list[MessageBuilder]:
    cfg = HostConfig()
    out = []
    for frames in (("odom", "base_footprint", "imu_link"), ("o", "a_much_longer_frame", "im")):
        settings = RosSettings(odom_frame=frames[0], base_frame=frames[1], imu_frame=frames[2])
        out.append(MessageBuilder(settings, cfg.odometry, StampClock(sim_time=True)))
    return out


def _messages(rng: np.random.Generator) -> list[object]:
    msgs: list[object] = []
    for b in _builders():
        for t_s in (0.0, 1.25, 12345.678901):
            v = rng.normal(0.0, 3.0, 12)
            odo = OdometryState(t_s, *v[:11])
            msgs += [b.wheel_odom(t_s, odo), b.joint_states(t_s, odo), b.wheel_tf(t_s, odo)]
            msgs += [b.odom_tf(t_s, *v[:3]), b.static_tf(t_s), b.twist(t_s, v[0], -1e300)]
            msgs.append(b.imu_si(t_s, tuple(v[:3]), tuple(v[3:6])))
            for n in (0, 1, 7):
                msgs.append(b.raw_frame(rng.integers(0, 256, n, dtype=np.uint8).tobytes()))
                msgs.append(b.path(t_s, rng.normal(size=(n, 3)), "odom" if n else "map"))
            angles = np.linspace(-math.pi, math.pi, 1060, endpoint=False)
            ranges = np.where(rng.random(1060) < 0.1, np.inf, rng.uniform(0.15, 8.0, 1060))
            msgs.append(b.scan(Scan(t_s + 1.0, angles, ranges)))
    dims = b.raw_frame(b"\x01\x02\x03")
    dims.layout.dim = [MultiArrayDimension(label="abc", size=3, stride=1)]
    msgs.append(dims)
    return msgs


def test_every_encoder_writes_what_rosbags_writes() -> None:
    msgs = _messages(np.random.default_rng(7))
    seen = set()
    for msg in msgs:
        want = bytes(STORE.serialize_cdr(msg, msg.__msgtype__))
        got = cdr.serialize(STORE, msg)
        assert got == want, msg.__msgtype__
        seen.add(msg.__msgtype__)
    assert seen == set(cdr.ENCODERS)  # every encoder was checked


def test_other_types_go_through_rosbags() -> None:
    b = _builders()[0]
    goal = b.goal(1.0, 0.5, -0.5, 0.3)
    assert goal.__msgtype__ not in cdr.ENCODERS
    assert cdr.serialize(STORE, goal) == bytes(STORE.serialize_cdr(goal, goal.__msgtype__))


@pytest.mark.parametrize("msgtype", sorted(cdr.ENCODERS))
def test_each_encoder_reads_back_with_rosbags(msgtype: str) -> None:
    for msg in _messages(np.random.default_rng(3)):
        if msg.__msgtype__ == msgtype:
            data = cdr.serialize(STORE, msg)
            back = msgtypes.typestore().deserialize_cdr(data, msgtype)  # the daemon's classes
            assert type(back) is type(msg)
            assert bytes(STORE.serialize_cdr(back, msgtype)) == data
            assert repr(STORE.deserialize_cdr(data, msgtype)) == repr(back)  # Jazzy's reads it


@pytest.mark.parametrize("length", range(1, 10))
def test_encoders_pad_after_names_of_every_length(length: int) -> None:
    """The encoders that pack a message in a few pieces pad after its names from their
    lengths: every length of frame name, mod 8, gives rosbags' bytes."""
    name = "f" * length
    settings = RosSettings(
        odom_frame=name,
        base_frame=name[:-1] or "b",
        imu_frame=name + "i",
        base_link_frame=name + "bl",
        left_wheel_frame=name + "l",
    )
    b = MessageBuilder(settings, HostConfig().odometry, StampClock(sim_time=True))
    rng = np.random.default_rng(length)
    odo = OdometryState(1.5, *rng.normal(0.0, 1.0, 11))
    msgs = [
        b.wheel_odom(1.5, odo), b.wheel_tf(1.5, odo), b.odom_tf(1.5, 0.1, 0.2, 0.3),
        b.imu_si(1.5, (0.1, 0.2, 0.3), (1.0, 2.0, 3.0)), b.path(1.5, rng.normal(size=(3, 3)), name),
    ]  # fmt: skip
    for msg in msgs:
        assert cdr.serialize(STORE, msg) == bytes(STORE.serialize_cdr(msg, msg.__msgtype__))
