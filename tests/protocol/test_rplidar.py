"""Slamtec's RPLIDAR protocol: golden bytes derived by hand from the documented layout, garbage,
resynchronisation and round trips."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jackson.protocol.errors import EncodeError
from jackson.protocol.rplidar import (
    HEALTH_DESCRIPTOR,
    INFO_DESCRIPTOR,
    SAMPLERATE_DESCRIPTOR,
    SCAN_DESCRIPTOR,
    Command,
    Descriptor,
    DeviceHealth,
    DeviceInfo,
    MeasurementNode,
    NodeBatch,
    Request,
    RequestDecoder,
    ResponseDecoder,
    SampleRate,
    SendMode,
    decode_descriptor,
    decode_health,
    decode_info,
    decode_node,
    decode_nodes,
    decode_samplerate,
    encode_descriptor,
    encode_health,
    encode_info,
    encode_node,
    encode_nodes,
    encode_request,
    encode_samplerate,
    response,
)

# ------------------------------------------------------------------ golden vectors

REQUESTS = [
    (Command.STOP, "a5 25"),
    (Command.RESET, "a5 40"),
    (Command.SCAN, "a5 20"),
    (Command.GET_INFO, "a5 50"),
    (Command.GET_HEALTH, "a5 52"),
    (Command.GET_SAMPLERATE, "a5 59"),
]


@pytest.mark.parametrize(("command", "golden"), REQUESTS)
def test_requests_without_payload_are_sync_and_command(command: Command, golden: str) -> None:
    assert encode_request(command) == bytes.fromhex(golden)
    assert RequestDecoder().feed(bytes.fromhex(golden)) == [Request(command)]


def test_a_request_with_payload_carries_size_and_xor_checksum() -> None:
    # EXPRESS_SCAN 0x82, 5 zero bytes: a5 ^ 82 ^ 05 = 0x22
    golden = bytes.fromhex("a5 82 05 00 00 00 00 00 22")
    assert encode_request(0x82, bytes(5)) == golden
    assert RequestDecoder().feed(golden) == [Request(0x82, bytes(5))]
    # a5 ^ f0 ^ 02 ^ 94 ^ 02 = 0xc1 (set motor PWM 660 = 0x0294)
    assert encode_request(0xF0, bytes.fromhex("9402")) == bytes.fromhex("a5 f0 02 94 02 c1")


def test_a_payload_needs_bit_7_of_the_command() -> None:
    with pytest.raises(EncodeError, match="no payload"):
        encode_request(Command.SCAN, b"\x01")
    with pytest.raises(EncodeError, match="a byte"):
        encode_request(0x100)


DESCRIPTORS = [
    (SCAN_DESCRIPTOR, "a5 5a 05 00 00 40 81", Descriptor(5, SendMode.MULTIPLE, 0x81)),
    (INFO_DESCRIPTOR, "a5 5a 14 00 00 00 04", Descriptor(20, SendMode.SINGLE, 0x04)),
    (HEALTH_DESCRIPTOR, "a5 5a 03 00 00 00 06", Descriptor(3, SendMode.SINGLE, 0x06)),
    (SAMPLERATE_DESCRIPTOR, "a5 5a 04 00 00 00 15", Descriptor(4, SendMode.SINGLE, 0x15)),
]


@pytest.mark.parametrize(("constant", "golden", "descriptor"), DESCRIPTORS)
def test_descriptors_pack_30_bit_length_and_2_bit_mode(
    constant: bytes, golden: str, descriptor: Descriptor
) -> None:
    assert constant == bytes.fromhex(golden)
    assert encode_descriptor(descriptor) == bytes.fromhex(golden)
    assert decode_descriptor(bytes.fromhex(golden)) == descriptor


def test_the_length_is_30_bits_and_the_mode_the_top_2() -> None:
    d = Descriptor(0x3FFFFFFF, 0b10, 0x42)
    assert encode_descriptor(d) == bytes.fromhex("a5 5a ff ff ff bf 42")
    assert decode_descriptor(encode_descriptor(d)) == d
    with pytest.raises(EncodeError, match="30 bits"):
        encode_descriptor(Descriptor(1 << 30, 0, 0x04))
    assert decode_descriptor(bytes.fromhex("a5 5b 05 00 00 40 81")) is None


def test_info_is_model_firmware_hardware_and_16_byte_serial() -> None:
    serial = bytes(range(0x10, 0x20))
    info = DeviceInfo(model=0x18, firmware_minor=29, firmware_major=1, hardware=7, serial=serial)
    golden = bytes.fromhex("18 1d 01 07") + serial
    assert encode_info(info) == golden
    assert decode_info(golden) == info
    assert response(info) == INFO_DESCRIPTOR + golden
    assert info.model_name == "A1M8"
    assert info.firmware == "1.29"
    assert info.serial_hex == "101112131415161718191A1B1C1D1E1F"
    with pytest.raises(EncodeError, match="16 bytes"):
        encode_info(DeviceInfo(0x18, 29, 1, 7, b"short"))


@pytest.mark.parametrize(
    ("health", "golden"),
    [
        (DeviceHealth(0, 0), "00 00 00"),
        (DeviceHealth(1, 0x0102), "01 02 01"),
        (DeviceHealth(2, 0x8001), "02 01 80"),
    ],
)
def test_health_is_status_and_little_endian_error_code(health: DeviceHealth, golden: str) -> None:
    assert encode_health(health) == bytes.fromhex(golden)
    assert decode_health(bytes.fromhex(golden)) == health
    assert response(health) == HEALTH_DESCRIPTOR + bytes.fromhex(golden)


def test_samplerate_is_two_little_endian_times_in_us() -> None:
    rate = SampleRate(standard_us=500, express_us=250)  # 2 kHz and 4 kHz
    golden = bytes.fromhex("f4 01 fa 00")
    assert encode_samplerate(rate) == golden
    assert decode_samplerate(golden) == rate
    assert response(rate) == SAMPLERATE_DESCRIPTOR + golden


NODES = [
    # quality 47, S: byte0 = 47 << 2 | 0b01 = 0xbd; 90 deg = 5760 q6 -> (5760 << 1) | 1 = 0x2d01;
    # 1000 mm = 4000 q2 = 0x0fa0
    (MeasurementNode(47, True, 5760, 4000), "bd 01 2d a0 0f"),
    # quality 47, not S: 0xbe; 0 deg -> 0x0001; 2.5 mm -> 10 = 0x000a
    (MeasurementNode(47, False, 0, 10), "be 01 00 0a 00"),
    # no return: quality 0, distance 0; 359.984 deg = 23039 q6 -> 0xb3ff
    (MeasurementNode(0, False, 23039, 0), "02 ff b3 00 00"),
    # the extremes of every field
    (MeasurementNode(63, True, 0x7FFF, 0xFFFF), "fd ff ff ff ff"),
]


@pytest.mark.parametrize(("node", "golden"), NODES)
def test_measurement_nodes(node: MeasurementNode, golden: str) -> None:
    assert encode_node(node) == bytes.fromhex(golden)
    assert decode_node(bytes.fromhex(golden)) == node
    assert decode_nodes(bytes.fromhex(golden)).nodes() == [node]
    assert encode_nodes([node.start], [node.quality], [node.angle_q6], [node.distance_q2]) == (
        bytes.fromhex(golden)
    )


def test_node_degrees_and_millimetres() -> None:
    node = MeasurementNode(47, True, 5760, 4001)
    assert node.angle_deg == 90.0
    assert node.distance_mm == 1000.25


@pytest.mark.parametrize(
    "bad",
    [
        "bf 01 2d a0 0f",  # S and !S both set
        "bc 01 2d a0 0f",  # neither
        "bd 00 2d a0 0f",  # check bit 0
    ],
)
def test_a_node_with_wrong_check_bits_is_refused(bad: str) -> None:
    assert decode_node(bytes.fromhex(bad)) is None


def test_fields_out_of_range_are_refused() -> None:
    with pytest.raises(EncodeError, match="quality"):
        encode_node(MeasurementNode(64, False, 0, 0))
    with pytest.raises(EncodeError, match="angle_q6"):
        encode_nodes([False], [0], [1 << 15], [0])
    with pytest.raises(EncodeError, match="distance_q2"):
        encode_nodes([False], [0], [0], [1 << 16])


# ------------------------------------------------------------------ the stream decoder


def _nodes(items: Sequence[object]) -> list[MeasurementNode]:
    return [n for item in items if isinstance(item, NodeBatch) for n in item.nodes()]


def test_a_session_decodes_in_stream_order() -> None:
    info = DeviceInfo(0x18, 29, 1, 7, bytes(16))
    nodes = [MeasurementNode(47, k == 0, k * 64, 4000 + k) for k in range(5)]
    stream = (
        response(DeviceHealth(0, 0))
        + response(info)
        + SCAN_DESCRIPTOR
        + b"".join(encode_node(n) for n in nodes)
    )
    items = ResponseDecoder().feed(stream)
    assert items[:5] == [
        Descriptor(3, SendMode.SINGLE, 0x06),
        DeviceHealth(0, 0),
        Descriptor(20, SendMode.SINGLE, 0x04),
        info,
        Descriptor(5, SendMode.MULTIPLE, 0x81),
    ]
    assert len(items) == 6 and _nodes(items) == nodes


def test_garbage_before_a_descriptor_is_counted() -> None:
    decoder = ResponseDecoder()
    items = decoder.feed(b"\x00\x01\xa5\x00\xa5" + response(DeviceHealth(1, 7)))
    assert items == [Descriptor(3, SendMode.SINGLE, 0x06), DeviceHealth(1, 7)]
    assert decoder.malformed_bytes == 5


def test_bad_nodes_are_skipped_byte_by_byte_and_the_stream_resynchronises() -> None:
    good = [MeasurementNode(47, False, 64 * k, 4000) for k in range(3)]
    decoder = ResponseDecoder()
    decoder.feed(SCAN_DESCRIPTOR)
    stream = (
        encode_node(good[0])
        + b"\x00\xff\x03"  # start flags 00, 11, 11: no node starts here
        + bytes.fromhex("bd 00 2d a0 0f")  # check bit 0: 5 bytes, each a bad start
        + encode_node(good[1])
        + bytes.fromhex("a5 5a 00 00 00 00 99")  # a descriptor of no known kind
        + b"\x00"
        + encode_node(good[2])
    )
    items = decoder.feed(stream)
    assert _nodes(items) == good
    assert decoder.malformed_bytes == 3 + 5 + 7 + 1
    assert decoder.nodes == 3


def test_a_descriptor_inside_the_node_stream_ends_it() -> None:
    decoder = ResponseDecoder()
    node = MeasurementNode(47, True, 0, 4000)
    items = decoder.feed(SCAN_DESCRIPTOR + encode_node(node) + response(SampleRate(125, 125)))
    assert items[-2:] == [Descriptor(4, 0, 0x15), SampleRate(125, 125)]
    assert not decoder.streaming
    assert decoder.malformed_bytes == 0


def test_a_request_with_a_bad_checksum_is_skipped() -> None:
    decoder = RequestDecoder()
    bad = bytes.fromhex("a5 82 05 00 00 00 00 00 23")
    assert decoder.feed(b"\x00" + bad + encode_request(Command.STOP)) == [Request(0x25)]
    assert decoder.malformed_bytes == 1 + len(bad)


# ------------------------------------------------------------------ properties

node_strategy = st.builds(
    MeasurementNode,
    quality=st.integers(0, 63),
    start=st.booleans(),
    angle_q6=st.integers(0, 0x7FFF),
    distance_q2=st.integers(0, 0xFFFF),
)


@given(node_strategy)
def test_every_node_round_trips(node: MeasurementNode) -> None:
    assert decode_node(encode_node(node)) == node


@given(
    st.builds(
        DeviceInfo,
        model=st.integers(0, 255),
        firmware_minor=st.integers(0, 255),
        firmware_major=st.integers(0, 255),
        hardware=st.integers(0, 255),
        serial=st.binary(min_size=16, max_size=16),
    ),
    st.builds(DeviceHealth, status=st.integers(0, 255), error_code=st.integers(0, 0xFFFF)),
    st.builds(SampleRate, standard_us=st.integers(0, 0xFFFF), express_us=st.integers(0, 0xFFFF)),
    st.lists(node_strategy, max_size=40),
    st.lists(st.integers(1, 50), max_size=30),
)
def test_any_session_decodes_the_same_in_any_chunks(
    info: DeviceInfo,
    health: DeviceHealth,
    rate: SampleRate,
    nodes: list[MeasurementNode],
    cuts: list[int],
) -> None:
    stream = (response(health) + response(info) + response(rate) + SCAN_DESCRIPTOR) + b"".join(
        encode_node(n) for n in nodes
    )
    decoder = ResponseDecoder()
    items: list[object] = []
    pos = 0
    for cut in cuts:
        items += decoder.feed(stream[pos : pos + cut])
        pos += cut
    items += decoder.feed(stream[pos:])
    singles = [i for i in items if not isinstance(i, NodeBatch | Descriptor)]
    assert singles == [health, info, rate]
    assert _nodes(items) == nodes
    assert decoder.malformed_bytes == 0


@given(st.binary(max_size=400), st.lists(node_strategy, min_size=1, max_size=20))
def test_garbage_never_raises_and_the_stream_recovers(
    garbage: bytes, nodes: list[MeasurementNode]
) -> None:
    """Whatever precedes them, the nodes after a fresh SCAN descriptor all come through."""
    decoder = ResponseDecoder()
    decoder.feed(SCAN_DESCRIPTOR)
    for k in range(0, len(garbage), 7):
        decoder.feed(garbage[k : k + 7])
    tail = SCAN_DESCRIPTOR + b"".join(encode_node(n) for n in nodes)
    # a gap on the line (longer than any single response) before the device restarts
    items = decoder.feed(b"\x00" * 32 + tail)
    assert decoder.malformed_bytes <= len(garbage) + 32
    decoded = _nodes(items)
    assert decoded[len(decoded) - len(nodes) :] == nodes


@given(st.binary(max_size=300))
def test_request_garbage_never_raises(garbage: bytes) -> None:
    decoder = RequestDecoder()
    requests = decoder.feed(garbage)
    assert decoder.malformed_bytes + sum(
        2 + (len(r.payload) + 2 if r.command & 0x80 else 0) for r in requests
    ) + len(decoder._buf) == len(garbage)


def test_a_revolution_of_1080_nodes_decodes_in_bulk() -> None:
    rng = np.random.default_rng(1)
    start = np.zeros(1080, dtype=bool)
    start[0] = True
    angle = np.arange(1080) * 21  # 0.33 deg steps in q6
    distance = rng.integers(0, 48000, 1080)
    data = SCAN_DESCRIPTOR + encode_nodes(start, 47, angle, distance)
    decoder = ResponseDecoder()
    items = decoder.feed(data)
    assert len(items) == 2
    batch = items[1]
    assert isinstance(batch, NodeBatch) and len(batch) == 1080
    np.testing.assert_array_equal(batch.start, start)
    np.testing.assert_array_equal(batch.angle_q6, angle)
    np.testing.assert_array_equal(batch.distance_q2, distance)
    assert (batch.quality == 47).all()


def test_the_assembler_rebuilds_revolutions_from_any_chunking() -> None:
    """The daemon's core decodes the logged raw bytes itself (streaming, no descriptor): the
    same revolutions whatever the read sizes were, and nodes before the first S flag dropped."""
    from jackson.host.lidar.rplidar import RevolutionAssembler

    n = 360
    angle_q6 = (np.arange(n) * 64).astype(np.int64)  # 0..359 degrees
    turns = []
    for k in range(3):
        start = np.zeros(n, dtype=bool)
        start[0] = True
        turns.append(encode_nodes(start, 47, angle_q6, 4000 * (k + 1)))  # 1, 2, 3 m
    lead = encode_nodes(False, 47, 64 * 200, 4000)  # the end of a turn begun earlier
    stream = lead + b"".join(turns) + encode_nodes(True, 47, 0, 4000)  # next turn's S node
    whole = RevolutionAssembler(streaming=True).feed(stream)
    rng = np.random.default_rng(3)
    chunked = RevolutionAssembler(streaming=True)
    got = []
    pos = 0
    while pos < len(stream):
        step = int(rng.integers(1, 700))
        got += chunked.feed(stream[pos : pos + step])
        pos += step
    assert [r.nodes for r in whole] == [n, n, n] == [r.nodes for r in got]
    for k, (a, b) in enumerate(zip(whole, got, strict=True)):
        assert np.array_equal(a.ranges_m, b.ranges_m)
        assert np.allclose(a.ranges_m, k + 1.0)
        assert a.angles_rad[0] >= -math.pi and a.angles_rad[-1] < math.pi
    assert chunked.partial_nodes == 1 and chunked.decoder.malformed_bytes == 0


@pytest.mark.parametrize("answer_type", [0x82, 0x84])
def test_a_capsule_that_starts_at_exactly_zero_degrees_still_ends_its_turn(
    answer_type: int,
) -> None:
    """The SDK's sync test adds a truncated increment to a capsule's last sample: a capsule
    starting at exactly 0 deg left the turn before it unflagged, and two turns merged (the
    twin's LiDAR did so every 207 s of MCU time; an A1M8's start angle lands on 0 as often)."""
    import itertools

    from jackson.protocol.rplidar import (
        CapsuleDecoder,
        encode_capsule,
        encode_ultra_capsule,
    )

    step_q6 = 2086  # about 32.6 deg a capsule, as the A1M8's Sensitivity mode
    starts = [(k * step_q6) % (360 * 64) for k in range(-30, 40)]
    starts = [(a - starts[30]) % (360 * 64) for a in starts]  # capsule 30 starts at 0 deg
    assert starts[30] == 0
    dec = CapsuleDecoder(answer_type)
    if answer_type == 0x84:
        stream = b"".join(
            encode_ultra_capsule(a, k == 0, [1000] * 97) for k, a in enumerate(starts)
        )
    else:
        stream = b"".join(encode_capsule(a, k == 0, [1000] * 32) for k, a in enumerate(starts))
    batch = dec.feed(stream)
    turns = sum(1 for a, b in itertools.pairwise(starts) if b < a)
    assert int(batch.start.sum()) == turns
