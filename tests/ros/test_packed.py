"""The frame messages packed straight into CDR (host/ros/packed.py) against the builder's
objects serialised by rosbags: the same bytes, and the same objects when read, stamped as
packed even after the clock moved on."""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from jackson.host.config import HostConfig
from jackson.host.estimation.ekf import EkfState
from jackson.host.estimation.odometry import OdometryState
from jackson.host.ros import cdr
from jackson.host.ros.messages import MessageBuilder, RosSettings, StampClock
from jackson.host.ros.packed import FramePacker, Packed
from jackson.protocol import Telemetry

STORE = get_typestore(Stores.ROS2_JAZZY)


def _builder(names: int, sim_time: bool) -> MessageBuilder:
    frames = [("odom", "base_footprint", "imu_link", "base_link", "left_wheel"),
              ("o", "a_much_longer_frame", "im", "bl", "lw_")][names]  # fmt: skip
    settings = RosSettings(
        odom_frame=frames[0], base_frame=frames[1], imu_frame=frames[2],
        base_link_frame=frames[3], left_wheel_frame=frames[4],
    )  # fmt: skip
    clock = StampClock(sim_time=sim_time)
    clock.observe(0.0, 1_700_000_000_123_456_789)
    return MessageBuilder(settings, HostConfig().odometry, clock)


def _telemetry(rng: np.random.Generator) -> Telemetry:
    a, g = rng.integers(-30000, 30000, (2, 3)).tolist()
    return Telemetry(accel=tuple(a), gyro=tuple(g), flags=1)  # type: ignore[arg-type]


def _ekf(rng: np.random.Generator) -> EkfState:
    x = tuple(rng.normal(0.0, 2.0, 7).tolist())
    return EkfState(1.0, x, tuple(rng.uniform(1e-6, 3.0, 7).tolist()), True)


@pytest.mark.parametrize("names", [0, 1])
@pytest.mark.parametrize("sim_time", [True, False])
def test_packed_messages_are_the_builders_bytes_and_objects(names: int, sim_time: bool) -> None:
    rng = np.random.default_rng(5 + names + 2 * sim_time)
    b = _builder(names, sim_time)
    pack = FramePacker(b)
    for t_s in (0.0, 1.25, 12345.678901):
        v = rng.normal(0.0, 3.0, 12)
        odo = OdometryState(t_s, *v[:11])
        tel = _telemetry(rng)
        state = _ekf(rng)
        raw = rng.integers(0, 256, int(rng.integers(0, 40)), dtype=np.uint8).tobytes()
        pairs = [
            (pack.wheel_odom(t_s, odo), b.wheel_odom(t_s, odo)),
            (pack.filtered(t_s, state), b.filtered(t_s, state)),
            (pack.imu(t_s, tel), b.imu(t_s, tel)),
            (pack.joint_states(t_s, odo), b.joint_states(t_s, odo)),
            (pack.odom_tf(t_s, *v[:3]), b.odom_tf(t_s, *v[:3])),
            (pack.wheel_tf(t_s, odo), b.wheel_tf(t_s, odo)),
            (pack.transform(t_s, "map", "odom", (v[0], v[1], 0.0), v[2]),
             b.tf(t_s, "map", "odom", (v[0], v[1], 0.0), v[2])),
            (pack.twist(t_s, v[3], -1e300), b.twist(t_s, v[3], -1e300)),
            (pack.raw_frame(raw), b.raw_frame(raw)),
        ]  # fmt: skip
        b.clock.observe(t_s + 0.5, 1_800_000_000_000_000_000)  # the clock moves on
        for packed, built in pairs:
            assert isinstance(packed, Packed) and packed.__msgtype__ == built.__msgtype__
            want = bytes(STORE.serialize_cdr(built, built.__msgtype__))
            assert packed.cdr == want == cdr.serialize(STORE, packed), built.__msgtype__
            # the object, made now, is the one built then (its stamp too)
            assert repr(packed.message) == repr(built)
            assert bytes(STORE.serialize_cdr(packed.message, built.__msgtype__)) == want
        b.clock.observe(0.0, 1_700_000_000_123_456_789)
    packed = pack.wheel_odom(2.0, OdometryState(2.0, *rng.normal(size=11)))
    assert packed.header.frame_id == b.settings.odom_frame  # fields read through


def test_a_stamped_cmd_vel_is_the_builders_object() -> None:
    b = MessageBuilder(
        RosSettings(cmd_vel_stamped=True), HostConfig().odometry, StampClock(sim_time=True)
    )
    msg = FramePacker(b).twist(1.0, 0.2, -0.3)
    assert not isinstance(msg, Packed)
    assert msg.__msgtype__ == "geometry_msgs/msg/TwistStamped"
