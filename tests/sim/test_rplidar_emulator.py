"""The twin's RPLIDAR A1M8 on its own pty, read by the host's real driver in lockstep."""

from __future__ import annotations

import errno
import itertools
import math
import os
import select
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from jackson.host.lidar.rplidar import LidarError, Revolution, RplidarDriver, open_error
from jackson.protocol import native as protocol_native
from jackson.protocol.rplidar import (
    CapsuleDecoder,
    Command,
    ConfType,
    DataType,
    Descriptor,
    DeviceHealth,
    ExpressScanRequest,
    HealthStatus,
    LidarConf,
    LidarConfQuery,
    ResponseDecoder,
    decode_descriptor,
    decode_express_scan,
    decode_lidar_conf,
    decode_lidar_conf_query,
    decode_nodes,
    encode_capsule,
    encode_dense_capsule,
    encode_descriptor,
    encode_express_scan,
    encode_lidar_conf_query,
    encode_request,
    encode_ultra_cabins,
    encode_ultra_capsule,
    lidar_conf_response,
    scan_mode_conf,
    ultra_angle_offset_q16,
    varbitscale_decode,
    varbitscale_encode,
)
from jackson.sim.config import load_robot, load_world
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles, cast
from jackson.sim.rplidar import (
    A1M8_SAMPLE_RATE,
    A1M8_SCAN_MODES,
    A1M8_TYPICAL_MODE,
    TWIN_HEALTH,
    TWIN_INFO,
    DeviceAnswers,
    RplidarEmulator,
    _SampleStream,
)
from jackson.sim.runner import RunnerStats, TwinRunner
from jackson.sim.twin import Twin

from .twin_process import JACKSON
from .wire_peer import WirePeer

PERIOD_S = 0.13465  # REFERENCE: LiDAR scan period (7.43 Hz)
BEAMS = 1080
WALL_AHEAD_M = 2.0
SIGMA_M = 0.01  # REFERENCE: LiDAR sigma
GARBAGE = (
    b"\x00\xff\x03\xfc"  # start flags 00 and 11: never a node
    + bytes.fromhex("a55a0000000099")  # a descriptor of no known kind
    + b"\x00\xff" * 8
)

WORLD = f"""\
name: lidar_box
walls:
  - [{WALL_AHEAD_M}, -1.5, {WALL_AHEAD_M}, 1.5]
  - [-1.0, 1.5, {WALL_AHEAD_M}, 1.5]
  - [-1.0, -1.5, -1.0, 1.5]
  - [-1.0, -1.5, {WALL_AHEAD_M}, -1.5]
"""


@dataclass
class Session:
    twin: Twin
    runner: TwinRunner
    driver: RplidarDriver
    peer: WirePeer
    revolutions: list[tuple[float, Revolution]]  # (MCU time of the frame it came before, rev)


@pytest.fixture
def session(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[Session]:
    """The twin in a thread (its MCU the emulator, or the compiled POSIX firmware when the
    test asks with ``indirect`` parametrisation), the real driver and a lockstep peer."""
    world = tmp_path / "lidar_box.yaml"
    world.write_text(WORLD)
    twin = Twin(load_world(world), load_robot("jackson"), seed=5)
    sock = tmp_path / "i2c.sock"
    runner = TwinRunner(
        twin,
        i2c_path=sock,
        lidar_link=str(tmp_path / "lidar"),
        lidar_twin_beams=True,  # SCAN sends the twin's own beams: exact ranges, beam order
        heartbeat_timeout_s=30.0,
        firmware=getattr(request, "param", False),
    )
    stop = threading.Event()
    stats: list[RunnerStats] = []
    thread = threading.Thread(target=lambda: stats.append(runner.run(None, stop)), daemon=True)
    thread.start()
    driver = RplidarDriver(str(tmp_path / "lidar"))  # through the --lidar-link symlink
    peer = WirePeer(runner.serial_path, f"unix:{sock}")
    try:
        yield Session(twin, runner, driver, peer, [])
    finally:
        driver.close()
        stop.set()  # before the last heartbeat: a waiting firmware twin then sees the stop
        peer.close()
        thread.join(timeout=30)
        runner.close()
    assert not thread.is_alive()


def drive(s: Session, frames: int) -> float:
    """Acknowledge ``frames`` telemetry frames, polling the LiDAR after each; the MCU time
    [s] of the last frame (left unacknowledged, so the twin waits there)."""
    t_s = 0.0
    for k in range(frames):
        if k:
            s.peer.heartbeat()
        t_s = s.peer.next_telemetry().t_us / 1e6
        s.revolutions += [(t_s, r) for r in s.driver.poll()]
        # everything that ended by this frame was written before it: lockstep is exact
        assert len(s.revolutions) == math.floor(t_s / PERIOD_S + 1e-9), t_s
    return t_s


@pytest.mark.parametrize("session", [False, True], indirect=True, ids=["emulator", "firmware"])
def test_the_driver_starts_the_twins_a1m8_and_reads_its_revolutions(session: Session) -> None:
    s = session
    s.driver.start()
    assert s.driver.health == DeviceHealth(HealthStatus.GOOD, 0)
    assert s.driver.info == TWIN_INFO
    assert s.driver.info.model_name == "A1M8"
    s.peer.connect()

    t_s = drive(s, 60)  # 3 s of sim time: frames at 0.05 .. 3.00 s
    assert t_s == pytest.approx(3.0)
    assert len(s.revolutions) == 22  # floor(3.0 / 0.13465): 7.43 Hz of sim time
    assert [r.nodes for _, r in s.revolutions] == [BEAMS] * 22
    assert s.driver.revolutions == 22
    assert s.driver.malformed_bytes == 0
    assert s.driver.partial_nodes == 0
    assert s.runner.lidar is not None and s.runner.lidar.revolutions_dropped == 0
    assert s.runner.lidar_scans_missing == 0

    # the ranges are the twin's own scans, to the protocol's 0.25 mm, in its beam order
    lidar = s.twin._lidar
    assert lidar is not None
    scans = {round(sc.t_s / PERIOD_S): sc.ranges.astype(np.float64) for sc in s.twin.scans}
    first = int(np.argmin(np.mod(-lidar.angles(), 2 * math.pi)))  # the beam at heading 0
    for k, (_, rev) in enumerate(s.revolutions, start=1):
        np.testing.assert_allclose(rev.angles_rad, lidar.angles(), atol=math.radians(1 / 128))
        expected = scans[k].copy()
        expected[first] = scans[max(k - 1, 1)][first]  # its S node went out a turn earlier
        np.testing.assert_allclose(rev.ranges_m, expected, atol=1.3e-4, rtol=0)

    # ... which are the exact ray caster's distances plus the sensor's noise
    truth = s.twin.truth()
    exact = lidar.true_ranges(truth.x, truth.y, truth.yaw, s.twin._obstacles)
    ranges = np.array([r.ranges_m for _, r in s.revolutions])
    assert np.isfinite(ranges).all() and np.isfinite(exact).all()  # a closed box
    error = ranges - exact
    assert np.abs(error).max() < 6 * SIGMA_M
    assert error.std() == pytest.approx(SIGMA_M, rel=0.05)
    ahead = int(np.argmin(np.abs(lidar.angles())))
    assert ranges[:, ahead].mean() == pytest.approx(WALL_AHEAD_M, abs=0.01)


def test_each_revolution_is_whole_at_its_frame_on_a_busy_machine(session: Session) -> None:
    """A 1080-beam revolution (5405 bytes) is larger than a tty's buffer (4095): the kernel
    holds the rest back and moves it on asynchronously once the host has read, and a pty's
    bytes reach the reader through a kernel worker. A read that finds the buffer empty waits
    for that worker (``tty_buffer_flush_work`` in N_TTY's read), so a revolution written
    before a frame is whole at that frame on every run, even with two busy processes
    competing for the cores: a campaign's results do not depend on the machine's load."""
    s = session
    s.driver.start()
    s.peer.connect()
    burn = "while True: pass"
    hogs = [subprocess.Popen([sys.executable, "-c", burn]) for _ in range(2)]
    try:
        drive(s, 200)  # 10 s: 74 revolutions, each asserted at its own frame
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
    assert [r.nodes for _, r in s.revolutions] == [BEAMS] * 74
    assert s.driver.partial_nodes == 0
    assert s.runner.lidar is not None
    assert s.runner.lidar.revolutions_dropped == 0


def test_garbage_on_the_line_is_counted_and_skipped(session: Session) -> None:
    s = session
    s.driver.start()
    s.peer.connect()
    drive(s, 10)
    assert s.runner.lidar is not None
    s.runner.lidar.inject(GARBAGE)
    s.peer.heartbeat()
    drive(s, 30)
    assert s.driver.malformed_bytes == len(GARBAGE)
    assert [r.nodes for _, r in s.revolutions] == [BEAMS] * len(s.revolutions)


def test_restarting_the_scan_stops_and_starts_it_again(session: Session) -> None:
    s = session
    s.driver.start()
    s.peer.connect()
    drive(s, 8)  # to 0.40 s: two revolutions
    assert len(s.revolutions) == 2
    s.driver.start()  # STOP, silence, GET_HEALTH, GET_INFO, SCAN at t = 0.40 s
    s.peer.heartbeat()
    for _ in range(12):  # to 1.0 s: turns ending at 0.5386, 0.67325, 0.8079, 0.94255
        s.peer.next_telemetry()
        s.revolutions += [(0.0, r) for r in s.driver.poll()]
        s.peer.heartbeat()
    assert len(s.revolutions) == 2 + 4
    assert s.driver.partial_nodes == 0


# ------------------------------------------------------------------ the emulator alone


def _slave(emulator: RplidarEmulator) -> int:
    fd = os.open(emulator.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    return fd


def test_a_pty_nobody_reads_never_blocks_the_twin() -> None:
    emulator = RplidarEmulator(LidarSpec(), device_standard_scan=False)
    fd = _slave(emulator)
    try:
        os.write(fd, encode_request(Command.SCAN))
        select.select([emulator.fileno()], [], [], 5.0)
        assert emulator.serve(0.0) == 1 and emulator.scanning
        ranges = np.full(BEAMS, 3.0)
        ended = emulator.advance(60.0, lambda end_s: ranges)  # 445 turns, nobody reading
        assert ended == math.floor(60.0 / PERIOD_S)
        assert emulator.revolutions_dropped > 0
        assert emulator.revolutions_written + emulator.revolutions_dropped == ended
        # what did get through is whole turns, readable after the flood
        decoder = ResponseDecoder()
        while True:
            emulator.link.flush()  # what the twin still holds goes out as the pty drains
            try:
                data = os.read(fd, 65536)
            except BlockingIOError:
                break
            decoder.feed(data)
        assert decoder.malformed_bytes == 0
        assert decoder.nodes >= BEAMS * emulator.revolutions_written
    finally:
        os.close(fd)
        emulator.close()


def test_each_request_is_answered_byte_exactly() -> None:
    emulator = RplidarEmulator(LidarSpec(), device_standard_scan=False)
    fd = _slave(emulator)
    try:
        expected = {
            Command.GET_HEALTH: bytes.fromhex("a55a0300000006 000000"),
            Command.GET_INFO: bytes.fromhex("a55a1400000004 181d0107") + b"JACKSON TWIN A1\x00",
            # standard: the twin's beams, 0.13465 s / 1080 = 125 us; express: the A1's 254 us
            Command.GET_SAMPLERATE: bytes.fromhex("a55a0400000015 7d00fe00"),
            Command.SCAN: bytes.fromhex("a55a0500004081"),
            Command.FORCE_SCAN: bytes.fromhex("a55a0500004081"),
        }
        for command, answer in expected.items():
            os.write(fd, encode_request(command))
            select.select([emulator.fileno()], [], [], 5.0)
            assert emulator.serve(0.0) == 1
            got = b""
            while len(got) < len(answer) and select.select([fd], [], [], 5.0)[0]:
                got += os.read(fd, 256)
            assert got == answer, command.name
        os.write(fd, encode_request(Command.STOP))
        select.select([emulator.fileno()], [], [], 5.0)
        emulator.serve(0.0)
        assert not emulator.scanning
        assert emulator.advance(10.0, lambda end_s: np.zeros(BEAMS)) == 0
    finally:
        os.close(fd)
        emulator.close()


def _ask(emulator: RplidarEmulator, fd: int, packet: bytes, answer_bytes: int) -> bytes:
    """Write a request, let the emulator serve it, read ``answer_bytes`` back (or what came
    before the line went quiet)."""
    os.write(fd, packet)
    select.select([emulator.fileno()], [], [], 5.0)
    assert emulator.serve(0.0) >= 1
    got = b""
    while len(got) < answer_bytes and select.select([fd], [], [], 0.5)[0]:
        got += os.read(fd, 4096)
    return got


# GET_LIDAR_CONF as an A1M8 with firmware 1.29 answers it: request payload = entry type u32 LE
# (+ mode id u16 LE); answer = descriptor (single, type 0x20, length 4 + value) + type + value
CONF_ANSWERS = [
    # entry, mode, answer
    (ConfType.SCAN_MODE_COUNT, None, "a55a0600000020 70000000 0500"),  # 5 modes
    (ConfType.SCAN_MODE_TYPICAL, None, "a55a0600000020 7c000000 0300"),  # Sensitivity
    # Q8 [us]: Sensitivity 127 * 256 = 0x7f00, Express 254 * 256 = 0xfe00, Stability 0xc900
    (ConfType.SCAN_MODE_US_PER_SAMPLE, 3, "a55a0800000020 71000000 007f0000"),
    (ConfType.SCAN_MODE_US_PER_SAMPLE, 1, "a55a0800000020 71000000 00fe0000"),
    (ConfType.SCAN_MODE_US_PER_SAMPLE, 4, "a55a0800000020 71000000 00c90000"),
    # Standard at the twin's beams: 0.13465 s / 1080 * 256 = 31917 = 0x7cad
    (ConfType.SCAN_MODE_US_PER_SAMPLE, 0, "a55a0800000020 71000000 ad7c0000"),
    (ConfType.SCAN_MODE_MAX_DISTANCE, 3, "a55a0800000020 74000000 000c0000"),  # 12 m * 256
    (ConfType.SCAN_MODE_ANS_TYPE, 0, "a55a0500000020 75000000 81"),
    (ConfType.SCAN_MODE_ANS_TYPE, 1, "a55a0500000020 75000000 82"),
    (ConfType.SCAN_MODE_ANS_TYPE, 3, "a55a0500000020 75000000 84"),
    (ConfType.SCAN_MODE_NAME, 3, "a55a1000000020 7f000000" + b"Sensitivity\x00".hex()),
    (ConfType.SCAN_MODE_NAME, 2, "a55a0a00000020 7f000000" + b"Boost\x00".hex()),
]


@pytest.mark.parametrize(("entry", "mode", "golden"), CONF_ANSWERS)
def test_get_lidar_conf_describes_the_a1m8s_five_scan_modes(
    entry: ConfType, mode: int | None, golden: str
) -> None:
    emulator = RplidarEmulator(LidarSpec(), device_standard_scan=False)
    fd = _slave(emulator)
    try:
        answer = bytes.fromhex(golden)
        packet = encode_request(Command.GET_LIDAR_CONF, encode_lidar_conf_query(entry, mode))
        assert _ask(emulator, fd, packet, len(answer)) == answer
        assert decode_lidar_conf(answer[7:]) == scan_mode_conf(
            LidarConfQuery(entry, b"" if mode is None else mode.to_bytes(2, "little")),
            A1M8_SCAN_MODES if mode else emulator.modes,
            A1M8_TYPICAL_MODE,
        )
    finally:
        os.close(fd)
        emulator.close()


def test_with_device_standard_scan_standard_is_the_a1s_508_us() -> None:
    emulator = RplidarEmulator(LidarSpec(), device_standard_scan=True)
    fd = _slave(emulator)
    try:
        rate = _ask(emulator, fd, encode_request(Command.GET_SAMPLERATE), 11)
        assert rate == bytes.fromhex("a55a0400000015 fc01fe00")  # 508 us, 254 us
        query = encode_lidar_conf_query(ConfType.SCAN_MODE_US_PER_SAMPLE, 0)
        conf = _ask(emulator, fd, encode_request(Command.GET_LIDAR_CONF, query), 15)
        assert conf == bytes.fromhex("a55a0800000020 71000000 00fc0100")  # 508 * 256
        assert emulator.modes == A1M8_SCAN_MODES
    finally:
        os.close(fd)
        emulator.close()


def test_what_the_a1_does_not_describe_gets_no_answer() -> None:
    """The SDK asks for the motor's desired speed (entry 0x01) before every scan; the A1 has
    no such entry. Nor a mode 9, nor a per-mode entry without a mode, nor EXPRESS_SCAN of the
    standard mode or of a mode it lacks: all silent, counted, and the next request answered."""
    emulator = RplidarEmulator(LidarSpec(), device_standard_scan=False)
    fd = _slave(emulator)
    try:
        silent = [
            encode_request(Command.GET_LIDAR_CONF, encode_lidar_conf_query(0x01)),
            encode_request(Command.GET_LIDAR_CONF, encode_lidar_conf_query(0x71, 9)),
            encode_request(Command.GET_LIDAR_CONF, encode_lidar_conf_query(0x75)),
            encode_request(Command.EXPRESS_SCAN, encode_express_scan(ExpressScanRequest(5))),
            encode_request(0xF0, bytes.fromhex("9402")),  # SET_MOTOR_PWM: A2/A3 only
        ]
        health = bytes.fromhex("a55a0300000006 000000")
        got = _ask(emulator, fd, b"".join(silent) + encode_request(Command.GET_HEALTH), 20)
        assert got == health
        assert emulator.ignored_requests == 5 and not emulator.scanning
        assert [r.command for r in emulator.recent_requests] == [0x84, 0x84, 0x84, 0x82, 0xF0, 0x52]
    finally:
        os.close(fd)
        emulator.close()


# ------------------------------------------------------------------ each scan mode's stream

BOX = [
    [2.0, -1.5, 2.0, 1.5],
    [-1.0, 1.5, 2.0, 1.5],
    [-1.0, -1.5, -1.0, 1.5],
    [-1.0, -1.5, 2.0, -1.5],
]
PILLAR = (1.0, 0.5, 0.2)  # a cylinder in the box: two edges a turn


def _room() -> Obstacles:
    room = Obstacles(BOX)
    room.add_circle(*PILLAR)
    return room


def _exact(heading_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    return cast((0.0, 0.0), -np.radians(heading_deg), _room(), 12.0)


@dataclass
class Stream:
    descriptor: Descriptor
    start: NDArray[np.bool_]
    heading_deg: NDArray[np.float64]
    range_m: NDArray[np.float64]
    emulator: RplidarEmulator


def _stream(
    packet: bytes,
    turns: int,
    *,
    device_standard_scan: bool = False,
    lost: frozenset[int] = frozenset(),
    ahead_m: float | None = None,
) -> Stream:
    """Start a scan with ``packet``, advance ``turns`` revolutions of the pillar room (noise
    free), and decode what came as Slamtec's SDK does; turns in ``lost`` the twin lost; with
    ``ahead_m``, what the next turn's first beams read just after each turn is the room's
    ranges plus that much."""
    spec = LidarSpec(noise_sigma_m=0.0)
    ranges = Lidar(spec, np.random.default_rng(0)).true_ranges(0.0, 0.0, 0.0, _room())
    emulator = RplidarEmulator(spec, device_standard_scan=device_standard_scan)
    fd = _slave(emulator)
    data = b""
    try:
        data = _ask(emulator, fd, packet, 7)
        for k in range(1, turns + 1):
            turn: NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]] | None
            turn = None if k in lost else ranges
            if turn is not None and ahead_m is not None:
                turn = (ranges, ranges + ahead_m)
            emulator.advance(k * spec.scan_period_s, lambda end_s, turn=turn: turn)
            emulator.link.flush()
            while select.select([fd], [], [], 0.05)[0]:
                data += os.read(fd, 65536)
    finally:
        os.close(fd)
        emulator.close()
    descriptor = decode_descriptor(data)
    assert descriptor is not None
    body = data[7:]
    if descriptor.data_type == DataType.MEASUREMENT:
        nodes = decode_nodes(body[: len(body) // 5 * 5])
        return Stream(
            descriptor, nodes.start, nodes.angle_q6 / 64.0, nodes.distance_q2 / 4000.0, emulator
        )
    samples = CapsuleDecoder(descriptor.data_type).feed(body)
    return Stream(
        descriptor, samples.start, samples.angle_deg, samples.distance_mm / 1000.0, emulator
    )


MODE_STREAMS = [
    # request, device standard scan, descriptor, us a sample
    (encode_request(Command.SCAN), True, "a55a0500004081", 508.0),
    (encode_request(Command.FORCE_SCAN), True, "a55a0500004081", 508.0),
    (encode_request(Command.EXPRESS_SCAN, bytes(5)), False, "a55a5400004082", 254.0),
    (encode_request(Command.EXPRESS_SCAN, bytes((1, 0, 0, 0, 0))), False, "a55a5400004082", 254.0),
    (encode_request(Command.EXPRESS_SCAN, bytes((2, 0, 0, 0, 0))), False, "a55a8400004084", 127.0),
    (encode_request(Command.EXPRESS_SCAN, bytes((3, 0, 0, 0, 0))), False, "a55a8400004084", 127.0),
    (encode_request(Command.EXPRESS_SCAN, bytes((4, 0, 0, 0, 0))), False, "a55a8400004084", 201.0),
]


@pytest.mark.parametrize(
    ("packet", "device_standard_scan", "descriptor", "us"),
    MODE_STREAMS,
    ids=["scan", "force_scan", "legacy_express", "express", "boost", "sensitivity", "stability"],
)
def test_each_scan_mode_samples_at_its_own_rate_where_the_decoder_places_them(
    packet: bytes, device_standard_scan: bool, descriptor: str, us: float
) -> None:
    s = _stream(packet, 12, device_standard_scan=device_standard_scan)
    assert encode_descriptor(s.descriptor) == bytes.fromhex(descriptor)
    # whole turns between start flags: 0.13465 s / us samples, 7.43 turns a second
    per_turn = PERIOD_S / (us * 1e-6)
    turns = np.diff(np.flatnonzero(s.start))
    assert len(turns) >= 10
    assert set(turns.tolist()) <= {math.floor(per_turn), math.ceil(per_turn)}
    lookahead = 0 if s.emulator._stream is None else s.emulator._stream.lookahead
    assert s.emulator.samples == pytest.approx(12 * per_turn + lookahead, abs=1)
    assert s.emulator.revolutions_written == 12
    # every range is the room's at the heading the decoder gives it, to 1 cm, but for a
    # sample within a beam of an edge (the twin casts 1080 beams; between two beams across an
    # edge the sample takes the nearer one's range) and ultra predictions out of reach
    near = np.stack([_exact(s.heading_deg + d) for d in (-0.34, 0.0, 0.34)])
    edge = np.ptp(near, axis=0) > 0.1 * near.min(axis=0)
    sent = s.range_m > 0
    error = np.abs(s.range_m - near[1])
    assert error[sent & ~edge].max() < 0.01
    assert (sent & edge).sum() <= 4 * 12  # two edges a turn, both sides
    assert (~sent).sum() <= s.emulator.edge_dropouts <= 4 * 12  # (the last few not yet sent)


@pytest.mark.parametrize(
    ("packet", "device_standard_scan"),
    [(encode_request(Command.SCAN), True), (encode_request(Command.SCAN), False)]
    + [(encode_request(Command.EXPRESS_SCAN, bytes((m, 0, 0, 0, 0))), False) for m in (0, 3, 4)],
    ids=["scan", "beams", "legacy_express", "sensitivity", "stability"],
)
def test_the_next_turns_first_samples_read_what_the_head_saw_just_after_the_turn(
    packet: bytes, device_standard_scan: bool
) -> None:
    # they go out with the turn before (a host sees it end at once) and were measured just
    # after it ended: ranged on what the beams read then, not on the turn's own first beams,
    # measured a turn earlier
    s = _stream(packet, 8, device_standard_scan=device_standard_scan, ahead_m=0.5)
    near = np.stack([_exact(s.heading_deg + d) for d in (-0.34, 0.0, 0.34)])
    edge = np.ptp(near, axis=0) > 0.1 * near.min(axis=0)
    sent = (s.range_m > 0) & ~edge
    ahead = sent & (np.abs(s.range_m - near[1] - 0.5) < 0.01)
    own = sent & (np.abs(s.range_m - near[1]) < 0.01)
    assert (ahead | own)[sent].all()
    starts = np.flatnonzero(s.start)
    lookahead = getattr(s.emulator._stream, "lookahead", 1)  # nodes: the next turn's S node
    for a, b in itertools.pairwise(starts[1:]):  # whole turns after the first
        read_ahead = np.flatnonzero(ahead[a:b])
        # its beginning only (the decoders flag a turn's start a sample early or on time)
        assert len(read_ahead) > 0 and read_ahead.max() <= lookahead
        assert own[a + lookahead + 1 : b][sent[a + lookahead + 1 : b]].all()


def test_express_headings_drift_from_turn_to_turn_as_the_clock_runs() -> None:
    """Sensitivity's 127 us do not divide the turn: a turn holds 1060 or 1061 samples and the
    first sample after 0 deg falls elsewhere each turn."""
    s = _stream(encode_request(Command.EXPRESS_SCAN, bytes((3, 0, 0, 0, 0))), 8)
    firsts = s.heading_deg[np.flatnonzero(s.start)[1:] - 0]
    assert len(set(np.round(firsts, 2).tolist())) > 1


def test_a_lost_revolution_restarts_the_capsule_stream() -> None:
    s = _stream(
        encode_request(Command.EXPRESS_SCAN, bytes((3, 0, 0, 0, 0))), 10, lost=frozenset({4})
    )
    assert s.emulator.revolutions_lost == 1 and s.emulator.revolutions_written == 9
    # nothing spans the gap: every sample decoded is still where the room says
    near = np.stack([_exact(s.heading_deg + d) for d in (-0.34, 0.0, 0.34)])
    edge = np.ptp(near, axis=0) > 0.1 * near.min(axis=0)
    sent = s.range_m > 0
    assert np.abs(s.range_m - near[1])[sent & ~edge].max() < 0.01
    # nine turns, and the lookahead past the last before the gap and past the last one
    stream = s.emulator._stream
    assert stream is not None
    expected = 9 * PERIOD_S / 127e-6 + 2 * stream.lookahead
    assert s.emulator.samples == pytest.approx(expected, abs=2)


# ------------------------------------------------------------------ the codec's express answers


def test_requests_for_the_express_scan_and_the_configuration_golden_bytes() -> None:
    # a5 ^ 82 ^ 05 ^ 03 = 0x21: EXPRESS_SCAN, working mode 3 (Sensitivity), flags 0, param 0
    express = encode_request(Command.EXPRESS_SCAN, encode_express_scan(ExpressScanRequest(3)))
    assert express == bytes.fromhex("a5 82 05 03 00 00 00 00 21")
    assert decode_express_scan(bytes.fromhex("03 00 00 00 00")) == ExpressScanRequest(3)
    assert decode_express_scan(b"") == ExpressScanRequest(0)  # a short payload reads as zeros
    # a5 ^ 84 ^ 06 ^ 71 ^ 03 = 0x55: GET_LIDAR_CONF, us per sample of mode 3
    conf = encode_request(
        Command.GET_LIDAR_CONF, encode_lidar_conf_query(ConfType.SCAN_MODE_US_PER_SAMPLE, 3)
    )
    assert conf == bytes.fromhex("a5 84 06 71 00 00 00 03 00 55")
    query = decode_lidar_conf_query(bytes.fromhex("71 00 00 00 03 00") + bytes(30))  # SDK 2.0
    assert query == LidarConfQuery(0x71, bytes.fromhex("0300") + bytes(30))
    assert query.mode_id == 3
    assert decode_lidar_conf_query(b"\x71") is None


def test_a_lidar_conf_answer_is_its_type_then_its_value() -> None:
    conf = LidarConf(ConfType.SCAN_MODE_NAME, b"Boost\x00")
    golden = bytes.fromhex("a5 5a 0a 00 00 00 20 7f 00 00 00") + b"Boost\x00"
    assert lidar_conf_response(conf) == golden
    assert decode_lidar_conf(golden[7:]) == conf and conf.text == "Boost"
    assert LidarConf(0x71, bytes.fromhex("007f0000")).u32 == 127 * 256
    assert LidarConf(0x7C, bytes.fromhex("0300")).u16 == 3
    with pytest.raises(ValueError, match="at least 4 bytes"):
        decode_lidar_conf(b"\x7f\x00")


def test_a_legacy_capsule_is_sync_checksum_start_angle_and_16_cabins() -> None:
    # start 90 deg = 5760 = 0x1680, S set: 0x9680 -> 80 96. 1000 mm << 2 = 0x0fa0 -> a0 0f.
    # Checksum: XOR of bytes 2..83 = 80 ^ 96 (16 equal cabins cancel) = 0x16: a6 51.
    plain = encode_capsule(5760, True, 1000)
    assert plain == bytes.fromhex("a6 51 80 96") + bytes.fromhex("a0 0f a0 0f 00") * 16
    # cabin 0: sample 0 1000 mm, dtheta 0x25 (4.625 deg): word 0x0fa0 | 0x25 >> 4 = 0x0fa2;
    # sample 1 2000 mm, dtheta 3: word 0x1f40; byte 0x5 | 0x3 << 4 = 0x35.
    # Checksum 80 ^ 96 ^ a2 ^ 0f ^ 40 ^ 1f ^ 35 = 0xd1: a1 5d.
    distance = np.full(32, 1000)
    distance[1] = 2000
    dtheta = np.zeros(32, dtype=np.int64)
    dtheta[:2] = (0x25, 3)
    first = encode_capsule(5760, True, distance, dtheta)
    assert first[:9] == bytes.fromhex("a1 5d 80 96 a2 0f 40 1f 35")
    # the next capsule starts 16 deg on (0x1a80): sample k at 90 + k / 2 deg - dtheta / 8
    decoder = CapsuleDecoder(DataType.MEASUREMENT_CAPSULED)
    assert len(decoder.feed(first)) == 0  # held until the next one
    samples = decoder.feed(encode_capsule(6784, False, 1000))
    assert len(samples) == 32 and decoder.capsules == 2 and decoder.starts == 1
    assert samples.angle_q6[:3].tolist() == [5464, 5768, 5824]  # 85.375, 90.125, 91 deg
    assert samples.distance_mm[:3].tolist() == [1000.0, 2000.0, 1000.0]
    assert not samples.start.any()


def test_an_ultra_capsule_carries_a_major_and_two_predictions_a_cabin() -> None:
    # cabin 0 = 3000, 3012, 2992 mm; the rest, and the next capsule's first, 3020 mm.
    # Majors in the 4 mm step (codes 1280.. from 2048 mm): 3000 -> 1518 = 0x5ee, 3020 -> 0x5f3.
    # Predictions: (3012 - 3000) / 4 = 3; (2992 - 3020) / 4 = -7 = 0x3f9 (10 bits).
    # Word 0 = 0x5ee | 3 << 12 | 0x3f9 << 22 = 0xfe4035ee; the others 0x000005f3.
    # Start angle 0 with S: 00 80. Checksum 80 ^ ee ^ 35 ^ 40 ^ fe ^ f3 ^ 05 = 0x13: a3 51.
    distance = np.full(97, 3020)
    distance[:3] = (3000, 3012, 2992)
    capsule = encode_ultra_capsule(0, True, distance)
    assert capsule[:12] == bytes.fromhex("a3 51 00 80 ee 35 40 fe f3 05 00 00")
    assert capsule[8:] == bytes.fromhex("f3 05 00 00") * 31
    words, decoded = encode_ultra_cabins(distance)
    assert words[0] == 0xFE4035EE and decoded[:4].tolist() == [3000, 3012, 2992, 3020]
    # decoded: samples 32.5 deg / 96 apart from 0 deg, less the parallax model's offset
    decoder = CapsuleDecoder(DataType.MEASUREMENT_ULTRA_CAPSULED)
    decoder.feed(capsule)
    samples = decoder.feed(encode_ultra_capsule(2080, False, np.full(97, 3020)))
    assert samples.distance_mm[:4].tolist() == [3000.0, 3012.0, 2992.0, 3020.0]
    raw_q16 = (np.arange(96) * ((2080 * 4 << 3) // 3)).astype(np.int64)
    expected = np.mod((raw_q16 - ultra_angle_offset_q16(samples.distance_q2)) >> 10, 23040)
    assert samples.angle_q6.tolist() == expected.tolist()
    assert samples.angle_deg[0] == pytest.approx(360 - 7.55, abs=0.02)  # 3 m: 7.55 deg


def test_an_ultra_prediction_out_of_reach_is_sent_as_no_return() -> None:
    distance = np.full(97, 1000)
    distance[1] = 1000 + 2 * 511  # 511 steps of 2 mm from the major: past the reach (510)
    distance[4] = 0  # no return
    _, decoded = encode_ultra_cabins(distance)
    assert decoded[1] == 0 and decoded[4] == 0 and decoded[2] == 1000
    distance[1] = 1000 + 2 * 510
    assert encode_ultra_cabins(distance)[1][1] == 2020


def test_a_revolution_of_ultra_capsules_encodes_at_once_as_one_by_one() -> None:
    """The emulator encodes a revolution's capsules in one call: the same cabins, decoded
    distances and capsule bytes as each capsule alone, at every distance scale."""
    from jackson.protocol.rplidar import ultra_capsule_of_cabins

    rng = np.random.default_rng(11)
    d = rng.integers(0, 30000, (17, 97))
    d[rng.random(d.shape) < 0.1] = 0
    d[3] = rng.integers(990, 1010, 97)  # predictions in reach
    words, decoded = encode_ultra_cabins(d)
    assert words.shape == (17, 32) and decoded.shape == (17, 96)
    for c in range(17):
        one_words, one_decoded = encode_ultra_cabins(d[c])
        assert np.array_equal(words[c], one_words) and np.array_equal(decoded[c], one_decoded)
        assert ultra_capsule_of_cabins(64 * c, c == 0, words[c]) == encode_ultra_capsule(
            64 * c, c == 0, d[c]
        )
    with pytest.raises(ValueError, match="32 cabins"):
        ultra_capsule_of_cabins(0, True, words[:2])


def test_a_dense_capsule_is_forty_millimetre_distances() -> None:
    # 1000 mm = e8 03; 40 equal u16 cancel in the checksum: a0 50, start 0 without S
    capsule = encode_dense_capsule(0, False, 1000)
    assert capsule == bytes.fromhex("a0 50 00 00") + bytes.fromhex("e8 03") * 40
    decoder = CapsuleDecoder(DataType.MEASUREMENT_DENSE_CAPSULED)
    decoder.feed(capsule)
    samples = decoder.feed(encode_dense_capsule(640, False, 2000))  # 10 deg on
    assert samples.distance_mm.tolist() == [1000.0] * 40
    assert samples.angle_q6[:3].tolist() == [0, 16, 32]  # 0.25 deg apart, no correction


def test_the_variable_bit_scale_steps_1_2_4_8_16_mm() -> None:
    codes = [0, 511, 512, 1279, 1280, 1791, 1792, 3327, 3328, 4095]
    millimetres = [0, 511, 512, 2046, 2048, 4092, 4096, 16376, 16384, 28656]
    assert varbitscale_decode(codes)[0].tolist() == millimetres
    assert varbitscale_decode(codes)[1].tolist() == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4]
    assert varbitscale_encode(millimetres).tolist() == codes
    d = np.arange(0, 28657)
    error = varbitscale_decode(varbitscale_encode(d))[0] - d
    assert np.abs(error).max() == 8  # half of the 16 mm step


def test_the_parallax_model_of_ultra_capsules() -> None:
    # 2 m: k = 98361 // 8000 = 12; 9150 - 12 << 6 = 8382 rad / 2**16 -> 480253 deg / 2**16
    # below 50 mm: 7.5 deg = 8578 -> 491483
    assert ultra_angle_offset_q16([8000, 100]).tolist() == [480253, 491483]


@pytest.mark.parametrize("side", [1.0, -1.0], ids=["left", "right"])
@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "numpy"])
def test_ultra_samples_see_a_near_wall_up_to_its_end(
    side: float, compiled: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a thin wall 9.6 cm to one side whose end is 27 cm away (a door jamb beside the robot),
    # the room's walls 4 m away behind it: a raw angle whose laser line crosses both returns
    # the jamb (the nearer), so the decoded returns reach the wall's end on either side
    if compiled and protocol_native.LIB is None:
        pytest.skip(f"no compiled build: {protocol_native.REASON}")
    if not compiled:
        monkeypatch.setattr(protocol_native, "LIB", None)
    spec = LidarSpec(noise_sigma_m=0.0)
    room = Obstacles()
    room.add_polygon([(-4.0, -4.0), (4.0, -4.0), (4.0, 4.0), (-4.0, 4.0)])
    room.add_segment(0.25, side * 0.096, 3.0, side * 0.096)
    ranges = Lidar(spec, np.random.default_rng(0)).true_ranges(0.0, 0.0, 0.0, room)
    stream = _SampleStream(spec, A1M8_SCAN_MODES[3], 0.0)
    data = b"".join(stream.revolution(k * spec.scan_period_s, ranges, None) for k in range(1, 4))
    samples = CapsuleDecoder(DataType.MEASUREMENT_ULTRA_CAPSULED).feed(data)
    a, d = -np.radians(samples.angle_deg), samples.distance_mm / 1000.0
    x, y = d * np.cos(a), d * np.sin(a)
    on = (d > 0) & (np.abs(y - side * 0.096) < 0.005) & (x > 0.0) & (x < 1.0)
    assert on.sum() > 100
    # within two samples (0.34 deg, 7 mm along the wall seen this slantwise) of its end
    assert x[on].min() < 0.25 + 0.007
    assert stream.edge_dropouts < 150  # the far side's shadow, samples that fit no distance


def test_the_capsule_decoder_skips_garbage_and_bad_checksums() -> None:
    capsules = [encode_capsule(i * 1000, i == 0, 1500) for i in range(4)]
    bad = bytearray(capsules[2])
    bad[10] ^= 0x01
    decoder = CapsuleDecoder(DataType.MEASUREMENT_CAPSULED)
    samples = decoder.feed(b"\x00\xa5\x5a" + capsules[0] + capsules[1] + bytes(bad) + capsules[3])
    assert decoder.capsules == 3 and decoder.malformed_bytes == 3 + len(bad)
    assert len(samples) == 64 and (samples.distance_mm == 1500.0).all()  # 0 by 1, 1 by 3
    with pytest.raises(ValueError, match="no capsule format"):
        CapsuleDecoder(0x81)


# ------------------------------------------------------------------ the driver's errors


def test_a_missing_port_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(LidarError, match="does not exist") as info:
        RplidarDriver(str(tmp_path / "nothing"))
    assert "\n" not in str(info.value)


def test_permission_denied_is_one_line_naming_the_fix() -> None:
    error = open_error("/dev/jackson-lidar", OSError(errno.EACCES, "Permission denied"))
    assert "dialout" in str(error) and "\n" not in str(error)


def test_a_silent_device_is_one_line_naming_get_health() -> None:
    master, slave = os.openpty()  # a port nobody answers on
    try:
        driver = RplidarDriver(os.ttyname(slave), answer_timeout_s=0.2)
        t0 = time.monotonic()
        with pytest.raises(LidarError, match=r"no answer to GET_HEALTH .* within 0\.2 s"):
            driver.start()
        assert time.monotonic() - t0 < 2.0
        driver.close()
    finally:
        os.close(master)
        os.close(slave)


def test_a_device_in_protection_stop_is_refused() -> None:
    emulator = RplidarEmulator(LidarSpec(), health=DeviceHealth(HealthStatus.ERROR, 0x0123))
    done = threading.Event()

    def serve() -> None:
        while not done.is_set():
            if select.select([emulator.fileno()], [], [], 0.02)[0]:
                emulator.serve(0.0)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        driver = RplidarDriver(emulator.path)
        with pytest.raises(LidarError, match=r"health ERROR \(code 0x0123\)"):
            driver.start()
        assert not emulator.scanning
        driver.close()
    finally:
        done.set()
        thread.join(timeout=5)
        emulator.close()


# ------------------------------------------------------------------ jackson sim


def _sim(*args: str) -> tuple[subprocess.Popen[str], list[str]]:
    proc = subprocess.Popen(
        [JACKSON, "sim", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    lines = [proc.stdout.readline().strip() for _ in range(3)]
    return proc, lines


def _stop(proc: subprocess.Popen[str]) -> int:
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=20)
    return proc.returncode


def test_jackson_sim_prints_the_lidar_port_third(tmp_path: Path) -> None:
    link = tmp_path / "lidar"
    proc, lines = _sim("--lidar-link", str(link))
    try:
        assert lines[0].startswith("serial: /dev/pts/"), lines
        assert lines[1].startswith("i2c: unix:"), lines
        assert lines[2].startswith("lidar: /dev/pts/"), lines
        assert os.readlink(link) == lines[2].split(": ", 1)[1]
        with RplidarDriver(str(link)) as driver:  # the twin serves it before any HELLO
            driver.start()
            assert driver.info == TWIN_INFO
    finally:
        assert _stop(proc) == 0
    assert not link.is_symlink()


def test_jackson_sims_lidar_scans_on_its_own_before_any_host_opens_the_mcus_port() -> None:
    """A real A1M8 answers and scans on its own port whatever the MCU does: the host's driver
    alone on the LiDAR pty of a lockstep ``jackson sim`` nobody else talks to reads whole
    revolutions of the world standing still, one a turn of the wall clock, and the twin's
    clock does not move."""
    proc, lines = _sim("--world", "square_room")
    try:
        assert lines[2].startswith("lidar: "), lines
        revolutions: list[tuple[float, Revolution]] = []
        with RplidarDriver(lines[2].split(": ", 1)[1]) as driver:
            driver.start()  # the densest mode: Sensitivity
            assert driver.mode is not None and driver.mode.name == "Sensitivity"
            deadline = time.monotonic() + 60.0  # a hang guard only
            while len(revolutions) < 4:
                assert time.monotonic() < deadline, f"{len(revolutions)} revolutions in 60 s"
                now = time.monotonic()
                revolutions += [(now, r) for r in driver.poll()]
                threading.Event().wait(0.01)
        assert proc.poll() is None
    finally:
        code, out = _stop_output(proc)
    assert code == 0
    assert "0 telemetry frames" in out, out  # no HELLO: the world stood still
    rev = revolutions[-1][1]
    assert 1055 <= rev.nodes <= 1066  # 0.13465 s of 127 us samples
    assert abs(rev.angles_rad[0] + math.pi) < 0.02 and abs(rev.angles_rad[-1] - math.pi) < 0.02
    # the room's walls all round (a few edge samples without a return)
    assert np.isfinite(rev.ranges_m).mean() > 0.95 and np.nanmax(rev.ranges_m[:]) < 8.0
    # paced by the wall clock, not a flood of turns: three more turns took most of 3 x 0.135 s
    assert revolutions[-1][0] - revolutions[0][0] > 0.25


def _stop_output(proc: subprocess.Popen[str]) -> tuple[int, str]:
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=20)
    return proc.returncode, out


def test_a_scan_before_the_session_leaves_the_lockstep_run_as_it_was(tmp_path: Path) -> None:
    """The revolutions the LiDAR made on the wall clock before the HELLO are dropped from
    the line when the twin's clock starts: the session's revolutions are the ones of a scan
    started at the HELLO, at each frame as in lockstep, whoever read the line before."""
    world = tmp_path / "lidar_box.yaml"
    world.write_text(WORLD)
    twin = Twin(load_world(world), load_robot("jackson"), seed=5)
    sock = tmp_path / "i2c.sock"
    runner = TwinRunner(twin, i2c_path=sock, lidar_twin_beams=True, heartbeat_timeout_s=30.0)
    stop = threading.Event()
    thread = threading.Thread(target=lambda: runner.run(None, stop), daemon=True)
    thread.start()
    assert runner.lidar_path is not None
    driver = RplidarDriver(runner.lidar_path)
    peer = WirePeer(runner.serial_path, f"unix:{sock}")
    s = Session(twin, runner, driver, peer, [])
    try:
        driver.start()
        emulator = runner.lidar
        assert emulator is not None
        deadline = time.monotonic() + 30.0  # a hang guard only
        while emulator.revolutions_written < 3:  # three turns on the line, nobody reading
            assert time.monotonic() < deadline
            threading.Event().wait(0.01)
        assert twin.t_s == 0.0
        peer.connect()
        drive(s, 40)  # asserts, frame by frame, the turns that ended by it and no more
    finally:
        driver.close()
        stop.set()
        peer.close()
        thread.join(timeout=30)
        runner.close()
    assert [r.nodes for _, r in s.revolutions] == [BEAMS] * 14
    assert driver.partial_nodes == 0 and driver.malformed_bytes == 0
    # the twin's own scans, as in a run whose scan started at the HELLO
    lidar = twin._lidar
    assert lidar is not None
    scans = {round(sc.t_s / PERIOD_S): sc.ranges.astype(np.float64) for sc in twin.scans}
    first = int(np.argmin(np.mod(-lidar.angles(), 2 * math.pi)))  # the beam at heading 0
    for k, (_, rev) in enumerate(s.revolutions, start=1):
        expected = scans[k].copy()
        expected[first] = scans[max(k - 1, 1)][first]  # its S node went out a turn earlier
        np.testing.assert_allclose(rev.ranges_m, expected, atol=1.3e-4, rtol=0)


def test_jackson_sim_without_lidar_prints_no_lidar_line() -> None:
    proc, lines = _sim("--no-lidar")
    try:
        assert lines[0].startswith("serial: ") and lines[1].startswith("i2c: ")
        assert lines[2].startswith("twin: "), lines
    finally:
        assert _stop(proc) == 0


@pytest.mark.parametrize(
    "answer_type",
    [DataType.MEASUREMENT_CAPSULED, DataType.MEASUREMENT_ULTRA_CAPSULED,
     DataType.MEASUREMENT_DENSE_CAPSULED],
)  # fmt: skip
def test_capsules_decoded_together_are_the_capsules_decoded_one_by_one(answer_type: int) -> None:
    """A chunk of many capsules is decoded in one pass of arrays: the same samples, bit for
    bit, as capsule by capsule (random distances, corrections, a start bit and a wrap past
    360 deg within the stream)."""
    rng = np.random.default_rng(answer_type)
    capsules = []
    for i in range(60):
        angle_q6 = (i * 1400 + 20000) % (360 << 6)
        start = i == 0 or i == 31
        if answer_type == DataType.MEASUREMENT_CAPSULED:
            capsules.append(
                encode_capsule(angle_q6, start, rng.integers(0, 16000, 32), rng.integers(0, 64, 32))
            )
        elif answer_type == DataType.MEASUREMENT_ULTRA_CAPSULED:
            capsules.append(encode_ultra_capsule(angle_q6, start, rng.integers(0, 12000, 97)))
        else:
            capsules.append(encode_dense_capsule(angle_q6, start, rng.integers(0, 12000, 40)))
    together = CapsuleDecoder(answer_type).feed(b"".join(capsules))
    one = CapsuleDecoder(answer_type)
    parts = [one.feed(c) for c in capsules]
    assert len(together.angle_q6) == 58 * len(parts[1].angle_q6)  # two starts drop a capsule
    for field in ("start", "angle_q6", "distance_q2"):
        joined = np.concatenate([getattr(p, field) for p in parts])
        assert np.array_equal(getattr(together, field), joined), field


def test_the_device_answers_name_their_modes_in_order_and_one_of_them_typical() -> None:
    with pytest.raises(ValueError, match="ids 0, 1"):
        DeviceAnswers(TWIN_INFO, TWIN_HEALTH, A1M8_SCAN_MODES[1:], 0)
    with pytest.raises(ValueError, match="typical mode 5"):
        DeviceAnswers(TWIN_INFO, TWIN_HEALTH, A1M8_SCAN_MODES, 5)
    a1m8 = DeviceAnswers(TWIN_INFO, TWIN_HEALTH, A1M8_SCAN_MODES, A1M8_TYPICAL_MODE)
    assert a1m8.sample_rate == A1M8_SAMPLE_RATE  # Standard's 508 us, Express's 254 us
    assert a1m8.legacy_express is A1M8_SCAN_MODES[1]
    beams = a1m8.with_standard(round(124.7 * 256))  # SCAN at the twin's beam time
    assert beams.sample_rate.standard_us == 125 and beams.modes[1:] == A1M8_SCAN_MODES[1:]
