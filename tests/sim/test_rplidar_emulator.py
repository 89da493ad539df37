"""The twin's RPLIDAR A1M8 on its own pty, read by the host's real driver in lockstep."""

from __future__ import annotations

import errno
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

from jackson.host.lidar.rplidar import LidarError, Revolution, RplidarDriver, open_error
from jackson.protocol.rplidar import (
    Command,
    DeviceHealth,
    HealthStatus,
    ResponseDecoder,
    encode_request,
)
from jackson.sim.config import load_robot, load_world
from jackson.sim.lidar import LidarSpec
from jackson.sim.rplidar import TWIN_INFO, RplidarEmulator
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
    emulator = RplidarEmulator(LidarSpec())
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
    emulator = RplidarEmulator(LidarSpec())
    fd = _slave(emulator)
    try:
        expected = {
            Command.GET_HEALTH: bytes.fromhex("a55a0300000006 000000"),
            Command.GET_INFO: bytes.fromhex("a55a1400000004 181d0107") + b"JACKSON TWIN A1\x00",
            Command.GET_SAMPLERATE: bytes.fromhex("a55a0400000015 7d007d00"),  # 125 us
            Command.SCAN: bytes.fromhex("a55a0500004081"),
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


def test_jackson_sim_without_lidar_prints_no_lidar_line() -> None:
    proc, lines = _sim("--no-lidar")
    try:
        assert lines[0].startswith("serial: ") and lines[1].startswith("i2c: ")
        assert lines[2].startswith("twin: "), lines
    finally:
        assert _stop(proc) == 0
