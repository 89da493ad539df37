"""The twin's A1M8 driven by other people's hosts: Slamtec's own SDK (rplidar_sdk 2.1, through
the ``pyrplidarsdk`` binding) and the pure-Python ``pyrplidar``, each against the emulator on
its pty, in real time, in a closed box whose ranges are known exactly.

The emulator runs in a process of its own (this file run as a script): the SDK's binding
holds the GIL while it waits for an answer, so a thread beside it would never answer.
"""

from __future__ import annotations

import argparse
import math
import os
import select
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from jackson.protocol.rplidar import Command, ConfType, Request, decode_express_scan
from jackson.sim.lidar import Lidar, LidarSpec, Obstacles, cast
from jackson.sim.rplidar import A1M8_TYPICAL_MODE, TWIN_INFO, RplidarEmulator

# a box round the sensor at the origin, 0 deg (x) facing the wall 2 m ahead
WALLS = [
    [2.0, -1.5, 2.0, 1.5],
    [-1.0, 1.5, 2.0, 1.5],
    [-1.0, -1.5, -1.0, 1.5],
    [-1.0, -1.5, 2.0, -1.5],
]
RANGE_MAX_M = 12.0
TOLERANCE_M = 0.01
PERIOD_S = 0.13465  # REFERENCE: LiDAR scan period (7.43 Hz)
SENSITIVITY_US = 127.0  # A1M8 firmware 1.29: Boost and Sensitivity
EXPRESS_US = 254.0
STANDARD_US = 508.0
SERVE_WAIT_S = 0.005
STOP_WAIT_S = 10.0
QUIET_S = 0.2  # pyrplidar: the line is drained once it has been silent this long
HQ_QUALITY_RETURN = 47 << 2  # the SDK's 8-bit quality of a capsuled sample with a return


def _obstacles() -> Obstacles:
    return Obstacles(WALLS)


def expected_ranges(heading_deg: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The box's exact ranges [m] at clockwise headings [deg] (the sensor frame's angle is
    minus the heading, docs/lidar.md "Frames")."""
    angles = -np.radians(np.asarray(heading_deg, dtype=np.float64))
    return cast((0.0, 0.0), angles, _obstacles(), RANGE_MAX_M)


# ------------------------------------------------------------------ the device process


def serve(device_standard_scan: bool) -> None:
    """Run the emulator in real time until stdin closes; print its pty, then each request."""
    spec = LidarSpec(noise_sigma_m=0.0)
    ranges = Lidar(spec, np.random.default_rng(0)).true_ranges(0.0, 0.0, 0.0, _obstacles())
    emulator = RplidarEmulator(spec, device_standard_scan=device_standard_scan)
    print(f"pty: {emulator.path}", flush=True)
    t0 = time.monotonic()
    try:
        while True:
            readable = select.select([emulator.fileno(), sys.stdin], [], [], SERVE_WAIT_S)[0]
            if sys.stdin in readable and not os.read(sys.stdin.fileno(), 1024):
                break
            now = time.monotonic() - t0
            handled = emulator.serve(now)
            for req in list(emulator.recent_requests)[len(emulator.recent_requests) - handled :]:
                print(f"request {req.command:02x} {req.payload.hex()}", flush=True)
            emulator.advance(now, lambda end_s: ranges)
    finally:
        emulator.close()


@dataclass
class Device:
    """The emulator's process: ``path`` to open, :meth:`finish` for the requests it got."""

    proc: subprocess.Popen[str]
    path: str

    def finish(self) -> list[Request]:
        """Stop the process (end of file on its stdin) and read back the requests it handled."""
        out, _ = self.proc.communicate(input="", timeout=STOP_WAIT_S)
        requests = []
        for line in out.splitlines():
            if line.startswith("request "):
                _, command, payload = line.split(" ")
                requests.append(Request(int(command, 16), bytes.fromhex(payload)))
        return requests


def _start(*args: str) -> Iterator[Device]:
    proc = subprocess.Popen(
        [sys.executable, __file__, *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline().strip()
    try:
        assert line.startswith("pty: "), line
        yield Device(proc, line.split(": ", 1)[1])
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=STOP_WAIT_S)


@pytest.fixture
def device() -> Iterator[Device]:
    """The twin's A1M8 with SCAN sending the twin's 1080 beams (``device_standard_scan=False``)."""
    yield from _start()


@pytest.fixture
def device_standard() -> Iterator[Device]:
    """The twin's A1M8 as `jackson sim` runs it: SCAN at the A1's own 508 us a sample."""
    yield from _start("--device-standard-scan")


def check_revolution(heading_deg: npt.ArrayLike, range_m: npt.ArrayLike, us: float) -> None:
    """A whole turn at ``us`` a sample (7.43 turns a second), each range the box's own."""
    h = np.sort(np.asarray(heading_deg, dtype=np.float64))
    r = np.asarray(range_m, dtype=np.float64)
    per_turn = PERIOD_S / (us * 1e-6)
    assert math.floor(per_turn) - 1 <= len(h) <= math.ceil(per_turn)
    step = 360.0 / per_turn
    assert h[0] < 1.5 * step and h[-1] > 360.0 - 1.5 * step  # the whole turn ...
    assert np.diff(h).max() < 1.5 * step  # ... with no gap
    error = r - expected_ranges(heading_deg)
    assert np.abs(error).max() < TOLERANCE_M, np.abs(error).max()


# ------------------------------------------------------------------ Slamtec's SDK


def test_slamtecs_sdk_starts_the_typical_mode_and_reads_whole_revolutions(device: Device) -> None:
    sdk: Any = pytest.importorskip("pyrplidarsdk")
    driver = sdk.RplidarDriver(port=device.path, baudrate=115200)
    try:
        assert driver.connect()  # GET_INFO (motor control check), GET_HEALTH
        info = driver.get_device_info()
        assert (info.model, info.firmware_version, info.hardware_version) == (0x18, 0x011D, 7)
        assert info.serial_number == TWIN_INFO.serial.hex()
        health = driver.get_health()
        assert (health.status, health.error_code) == (0, 0)
        assert driver.start_scan()  # the typical mode: Sensitivity, ultra capsules
        revolutions = [driver.get_scan_data() for _ in range(3)]  # each a new turn
    finally:
        driver.stop_scan()
        driver.disconnect()
        del driver
    for revolution in revolutions:
        assert revolution is not None
        angles_rad, ranges_m, qualities = revolution
        check_revolution(np.degrees(angles_rad), ranges_m, SENSITIVITY_US)
        assert set(qualities) == {HQ_QUALITY_RETURN}

    # what the SDK asked: the typical mode, that mode's four entries, then its express scan
    requests = device.finish()
    conf = [
        (int.from_bytes(r.payload[:4], "little"), r.payload[4:6])
        for r in requests
        if r.command == Command.GET_LIDAR_CONF
    ]
    mode = A1M8_TYPICAL_MODE.to_bytes(2, "little")
    assert (ConfType.SCAN_MODE_TYPICAL, b"") in conf
    for entry in (
        ConfType.SCAN_MODE_US_PER_SAMPLE,
        ConfType.SCAN_MODE_MAX_DISTANCE,
        ConfType.SCAN_MODE_ANS_TYPE,
        ConfType.SCAN_MODE_NAME,
    ):
        assert (entry, mode) in conf
    express = [decode_express_scan(r.payload) for r in requests if r.command == 0x82]
    assert [e.working_mode for e in express] == [A1M8_TYPICAL_MODE]


# ------------------------------------------------------------------ pyrplidar


def revolutions_of(
    measurements: Iterable[Any], count: int
) -> list[tuple[list[float], list[float]]]:
    """The first ``count`` whole turns (heading [deg], range [m]) of a pyrplidar scan: each
    runs from a measurement with the start flag to the next."""
    turns: list[tuple[list[float], list[float]]] = []
    current: tuple[list[float], list[float]] | None = None
    for m in measurements:
        if m.start_flag:
            if current is not None:
                turns.append(current)
                if len(turns) == count:
                    return turns
            current = ([], [])
        if current is not None:
            current[0].append(m.angle)
            current[1].append(m.distance / 1000.0)
    return turns


def _drain(lidar: Any) -> None:
    """After STOP: read until the line has been quiet for QUIET_S (what was on its way)."""
    port = lidar.lidar_serial._serial
    timeout = port.timeout
    port.timeout = QUIET_S
    while port.read(65536):
        pass
    port.timeout = timeout


def test_pyrplidar_lists_the_five_scan_modes_and_reads_each_format(
    device_standard: Device,
) -> None:
    pyrplidar: Any = pytest.importorskip("pyrplidar")
    lidar = pyrplidar.PyRPlidar()
    lidar.connect(port=device_standard.path, baudrate=115200, timeout=3)
    try:
        info = lidar.get_info()
        assert (info.model, info.firmware_major, info.firmware_minor, info.hardware) == (
            0x18,
            1,
            29,
            7,
        )
        assert lidar.get_health().status == 0
        rate = lidar.get_samplerate()
        assert (rate.t_standard, rate.t_express) == (508, 254)
        modes = [
            (m.name, m.us_per_sample / 256, m.max_distance / 256, m.ans_type)
            for m in lidar.get_scan_modes()
        ]
        assert modes == [
            ("Standard", 508.0, 12.0, 0x81),
            ("Express", 254.0, 12.0, 0x82),
            ("Boost", 127.0, 12.0, 0x84),
            ("Sensitivity", 127.0, 12.0, 0x84),
            ("Stability", 201.0, 12.0, 0x84),
        ]
        assert lidar.get_scan_mode_typical() == A1M8_TYPICAL_MODE

        starts: list[tuple[Callable[[], Any], float]] = [
            (lambda: lidar.start_scan_express(A1M8_TYPICAL_MODE), SENSITIVITY_US),  # 0x84
            (lambda: lidar.start_scan_express(0), EXPRESS_US),  # legacy express, 0x82
            (lidar.start_scan, STANDARD_US),  # standard nodes, 0x81
        ]
        for start, us in starts:
            for heading_deg, range_m in revolutions_of(start()(), 3):
                check_revolution(heading_deg, range_m, us)
            lidar.stop()
            _drain(lidar)
    finally:
        lidar.disconnect()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="the twin's A1M8 on a pty, in real time")
    parser.add_argument("--device-standard-scan", action="store_true")
    serve(parser.parse_args().device_standard_scan)
