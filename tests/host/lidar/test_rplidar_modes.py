"""The host's RPLIDAR driver chooses the scan mode: the densest the host decodes (Sensitivity on
an A1M8 with firmware 1.29; the twin's own 1080-beam SCAN, at 124.7 us a sample, where the
twin reports it), the standard scan on request or on a device that does not answer
GET_LIDAR_CONF. The emulator runs on its pty in real time, in a closed box whose ranges are
known exactly."""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from jackson.host.lidar.rplidar import (
    LidarError,
    Revolution,
    RevolutionAssembler,
    RplidarDriver,
    choose_mode,
)
from jackson.protocol.rplidar import Command, DataType, Request, ScanMode
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles, cast
from jackson.sim.rplidar import A1M8_SCAN_MODES, RplidarEmulator

# a box round the sensor at the origin, 0 deg (x) facing the wall 2 m ahead
WALLS = [
    [2.0, -1.5, 2.0, 1.5],
    [-1.0, 1.5, 2.0, 1.5],
    [-1.0, -1.5, -1.0, 1.5],
    [-1.0, -1.5, 2.0, -1.5],
]
RANGE_MAX_M = 12.0
TOLERANCE_M = 0.01
RATE_HZ = 1.0 / 0.13465  # REFERENCE: LiDAR scan period (7.43 Hz)
BEAMS = 1080
SERVE_WAIT_S = 0.005  # [s] the emulator's loop waits at most this long for a request
WAIT_S = 10.0  # [s] the longest a test waits for revolutions
TURNS = 8
WRAP_GAP_RAD = np.radians(1.5)  # the twin's beams leave 1 deg between the last and the first


class OldFirmwareA1(RplidarEmulator):
    """An A1 that does not answer GET_LIDAR_CONF (as firmware before 1.24)."""

    def _handle(self, req: Request, t_s: float) -> None:
        if req.command == Command.GET_LIDAR_CONF:
            self.ignored_requests += 1
            return
        super()._handle(req, t_s)


def _run(emulator: RplidarEmulator) -> Iterator[RplidarEmulator]:
    """Serve ``emulator`` in real time in a thread, in the box, until the test ends."""
    spec = emulator.spec
    ranges = Lidar(spec, np.random.default_rng(0)).true_ranges(0.0, 0.0, 0.0, Obstacles(WALLS))
    stop = threading.Event()
    t0 = time.monotonic()

    def loop() -> None:
        while not stop.is_set():
            select.select([emulator.fileno()], [], [], SERVE_WAIT_S)
            now = time.monotonic() - t0
            emulator.serve(now)
            emulator.advance(now, lambda end_s: ranges)

    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    try:
        yield emulator
    finally:
        stop.set()
        thread.join(timeout=5)
        emulator.close()


@pytest.fixture
def twin() -> Iterator[RplidarEmulator]:
    """The twin's A1M8 (firmware 1.29) with ``device_standard_scan=False``: SCAN sends the
    twin's 1080 beams, and GET_LIDAR_CONF reports Standard at their 124.7 us a sample."""
    yield from _run(RplidarEmulator(LidarSpec(noise_sigma_m=0.0), device_standard_scan=False))


@pytest.fixture
def device() -> Iterator[RplidarEmulator]:
    """The twin's A1M8 as ``jackson sim`` runs it, SCAN at the A1's own 508 us a sample: the
    robot's unit."""
    yield from _run(RplidarEmulator(LidarSpec(noise_sigma_m=0.0), device_standard_scan=True))


@pytest.fixture
def old_twin() -> Iterator[RplidarEmulator]:
    yield from _run(OldFirmwareA1(LidarSpec(noise_sigma_m=0.0)))


def wait_for(read: Callable[[], list[Revolution]], count: int) -> list[tuple[float, Revolution]]:
    """``count`` revolutions, each with the time it was read [s], or fail after ``WAIT_S``."""
    got: list[tuple[float, Revolution]] = []
    deadline = time.monotonic() + WAIT_S
    while len(got) < count:
        assert time.monotonic() < deadline, f"{len(got)} of {count} revolutions"
        got += [(time.monotonic(), r) for r in read()]
    return got[:count]


def check_box(rev: Revolution) -> None:
    """Every return is the box's range at its angle, within 1 cm; a whole turn, no gap."""
    finite = np.isfinite(rev.ranges_m)
    assert finite.mean() > 0.99
    exact = cast((0.0, 0.0), rev.angles_rad, Obstacles(WALLS), RANGE_MAX_M)
    error = np.abs(rev.ranges_m[finite] - exact[finite])
    assert error.max() < TOLERANCE_M, error.max()
    step = 2 * np.pi / rev.nodes
    assert np.diff(rev.angles_rad).max() < 1.5 * step
    assert 2 * np.pi - (rev.angles_rad[-1] - rev.angles_rad[0]) < max(WRAP_GAP_RAD, 1.5 * step)


def test_the_driver_starts_sensitivity_on_an_a1m8_and_reads_1060_samples_a_turn(
    device: RplidarEmulator,
) -> None:
    twin = device
    with RplidarDriver(twin.path) as driver:
        driver.start(mode=None)
        assert len(driver.modes) == 5 and driver.typical_mode == 3
        assert driver.mode is not None and driver.mode.name == "Sensitivity"
        assert driver.mode.us_per_sample == 127.0
        assert driver.answer_type == DataType.MEASUREMENT_ULTRA_CAPSULED
        assert driver.samples_per_revolution_expected == pytest.approx(1060.2, abs=0.1)
        assert twin.scan_mode is not None and twin.scan_mode.id == 3
        revs = wait_for(driver.poll, TURNS)
        for _, rev in revs:
            assert 1059 <= rev.nodes <= 1061
            check_box(rev)
        rate_hz = (TURNS - 1) / (revs[-1][0] - revs[0][0])
        assert rate_hz == pytest.approx(RATE_HZ, rel=0.1)
        assert driver.malformed_bytes == 0


@pytest.mark.parametrize(
    ("name", "answer_type", "low", "high"),
    [
        ("Express", DataType.MEASUREMENT_CAPSULED, 529, 531),
        ("Boost", DataType.MEASUREMENT_ULTRA_CAPSULED, 1059, 1061),
        ("stability", DataType.MEASUREMENT_ULTRA_CAPSULED, 669, 671),
        ("standard", DataType.MEASUREMENT, 264, 266),  # the A1's own SCAN, 508 us
    ],
)
def test_each_mode_asked_by_name_reads_whole_revolutions(
    device: RplidarEmulator, name: str, answer_type: int, low: int, high: int
) -> None:
    with RplidarDriver(device.path) as driver:
        driver.start(mode=name)
        assert driver.mode is not None and driver.mode.name.lower() == name.lower()
        assert driver.answer_type == answer_type
        expected = driver.samples_per_revolution_expected
        assert expected is not None and low <= expected <= high
        for _, rev in wait_for(driver.poll, 3):
            assert low <= rev.nodes <= high
            check_box(rev)


@pytest.mark.parametrize("mode", [None, "standard", "Express"])
def test_the_raw_bytes_a_daemon_reads_decode_as_the_started_mode(
    device: RplidarEmulator, mode: str | None
) -> None:
    """The daemon's path: read() hands out every byte after the scan's descriptor (those that
    came with it too), and an assembler told the driver's answer type makes whole turns."""
    with RplidarDriver(device.path) as driver:
        driver.start(mode)
        assembler = RevolutionAssembler(streaming=True)
        assembler.expect(driver.answer_type)
        expected = driver.samples_per_revolution_expected
        assert expected is not None
        for _, rev in wait_for(lambda: assembler.feed(driver.read()), 3):
            assert abs(rev.nodes - expected) <= 1.5
            check_box(rev)
        assert assembler.decoder.malformed_bytes == 0


def test_standard_still_reads_the_twins_1080_beams(twin: RplidarEmulator) -> None:
    with RplidarDriver(twin.path) as driver:
        driver.start(mode="standard")
        assert driver.mode is not None and driver.mode.name == "Standard"
        assert driver.answer_type == DataType.MEASUREMENT
        assert driver.samples_per_revolution_expected == pytest.approx(BEAMS, abs=0.5)
        for _, rev in wait_for(driver.poll, 3):
            assert rev.nodes == BEAMS
            check_box(rev)
        # the emulator's thread has served the request once its revolutions arrive
        assert twin.scan_mode is not None and twin.scan_mode.id == 0
        driver.start(mode="Sensitivity")  # a restart changes the mode
        assert driver.answer_type == DataType.MEASUREMENT_ULTRA_CAPSULED
        for _, rev in wait_for(driver.poll, 2):
            assert 1059 <= rev.nodes <= 1061
            check_box(rev)


def test_the_densest_mode_on_the_twin_is_its_own_1080_beam_scan(twin: RplidarEmulator) -> None:
    """The twin reports Standard at 124.7 us a sample (what it sends), denser than
    Sensitivity's 127 us: the densest mode there is SCAN, the twin's own beams."""
    with RplidarDriver(twin.path) as driver:
        driver.start(mode=None)
        assert driver.mode is not None and driver.mode.name == "Standard"
        assert driver.mode.us_per_sample < A1M8_SCAN_MODES[3].us_per_sample
        for _, rev in wait_for(driver.poll, 2):
            assert rev.nodes == BEAMS


def test_a_device_without_get_lidar_conf_gets_the_standard_scan(old_twin: RplidarEmulator) -> None:
    with RplidarDriver(old_twin.path, answer_timeout_s=0.3) as driver:
        driver.start(mode=None)
        assert driver.modes == () and driver.typical_mode is None
        assert driver.mode is not None and driver.mode.name == "Standard"
        assert driver.answer_type == DataType.MEASUREMENT
        assert driver.mode.us_per_sample == 508.0  # GET_SAMPLERATE's standard time
        for _, rev in wait_for(driver.poll, 3):
            assert 264 <= rev.nodes <= 266
            check_box(rev)
        with pytest.raises(LidarError, match=r"no scan mode .Boost. .*standard scan only"):
            driver.start(mode="Boost")


def test_the_cores_assembler_rebuilds_the_revolutions_from_the_raw_bytes(
    device: RplidarEmulator,
) -> None:
    """The daemon hands :meth:`RplidarDriver.read`'s bytes to its core's assembler: told the
    stream's answer type, it rebuilds the same revolutions however the bytes are cut."""
    with RplidarDriver(device.path) as driver:
        driver.start(mode=None)
        whole = RevolutionAssembler(streaming=True, answer_type=driver.answer_type)
        stream = bytearray()

        def read() -> list[Revolution]:
            data = driver.read()
            stream.extend(data)
            return whole.feed(data)

        revs = [r for _, r in wait_for(read, 4)]
    chunked = RevolutionAssembler(streaming=True)
    chunked.expect(DataType.MEASUREMENT_ULTRA_CAPSULED)
    rng = np.random.default_rng(1)
    got: list[Revolution] = []
    pos = 0
    while pos < len(stream):
        step = int(rng.integers(1, 300))
        got += chunked.feed(bytes(stream[pos : pos + step]))
        pos += step
    assert len(got) >= 4
    for a, b in zip(revs, got, strict=False):
        np.testing.assert_array_equal(a.angles_rad, b.angles_rad)
        np.testing.assert_array_equal(a.ranges_m, b.ranges_m)
    assert chunked.decoder.malformed_bytes == 0


def test_the_densest_decodable_mode_wins_and_the_typical_one_breaks_a_tie() -> None:
    assert choose_mode(A1M8_SCAN_MODES, 3) == A1M8_SCAN_MODES[3]  # Boost and Sensitivity: 127
    assert choose_mode(A1M8_SCAN_MODES, 0) == A1M8_SCAN_MODES[2]  # the lower id then
    hq = ScanMode(5, "HQ", 64 * 256, 12 * 256, 0x83)  # a format the host does not decode
    assert choose_mode((*A1M8_SCAN_MODES, hq), 3) == A1M8_SCAN_MODES[3]
    assert choose_mode((hq,), 5) is None
    with pytest.raises(ValueError, match="no scan of answer type 0x83"):
        RevolutionAssembler(answer_type=0x83)
