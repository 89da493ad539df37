"""The motor interlock on the twin: a host that drives through the PCA9685 and then falls silent
(as a SIGKILLed daemon does) is stopped by the MCU's line, not by anything the host does.

docs/firmware.md, "Motor interlock": the MCU releases the PCA9685's OE (or the TB6612's STBY)
``failsafe_ms`` after the last HEARTBEAT; with the host's MODE2 (OUTDRV | OUTNE=01) every output
goes high and both bridges short-brake.
"""

from __future__ import annotations

import itertools
import math
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import pytest

from jackson.protocol import TelemetryFlags
from jackson.protocol.messages import FAILSAFE_MS_DEFAULT
from jackson.sim.config import ConfigError, RobotSpec, load_robot, load_world
from jackson.sim.fil import DEFAULT_BINARY
from jackson.sim.runner import TwinRunner
from jackson.sim.twin import Twin

from .wire_peer import WirePeer

FAILSAFE_S = FAILSAFE_MS_DEFAULT / 1000.0  # [s] the firmware's default failsafe_ms (the host's)
PERIOD_S = 0.05  # [s] one telemetry period at 20 Hz
DRIVE_FRAMES = 40  # 2 s of driving before the host falls silent
JACKSON = str(Path(sys.executable).parent / "jackson")

RecordProperty = Callable[[str, object], None]  # pytest's record_property fixture

needs_firmware = pytest.mark.skipif(
    not Path(os.environ.get("JACKSON_FIRMWARE_POSIX", DEFAULT_BINARY)).exists(),
    reason="the POSIX firmware is not built (make native)",
)


@dataclass(frozen=True)
class Sample:
    """The twin after one advance: MCU time, what the bridges apply, the ground truth."""

    t_s: float
    drive: tuple[float, float]
    connected: tuple[float, float]
    line: bool
    x: float
    y: float
    speed_m_s: float


class Watch:
    """Observer in the twin's thread: samples every advance and signals a condition."""

    def __init__(self, runner_ref: list[TwinRunner]) -> None:
        self.samples: list[Sample] = []
        self.runner_ref = runner_ref
        self.lock = threading.Lock()
        self.until_s: float | None = None
        self.reached = threading.Event()
        self.moving = threading.Event()

    def __call__(self, twin: Twin) -> None:
        left, right = twin._drive
        r = twin.robot
        s = Sample(
            twin.t_s,
            (left.drive, right.drive),
            (left.connected, right.connected),
            self.runner_ref[0].motor_enable(),
            r.x,
            r.y,
            math.hypot(r.vwx, r.vwy),
        )
        with self.lock:
            self.samples.append(s)
            until = self.until_s
        if s.speed_m_s > 0.08 and s.drive[0] > 0.0 and s.drive[1] > 0.0:
            self.moving.set()  # well into a straight leg
        if until is not None and s.t_s >= until:
            self.reached.set()

    def wait_until(self, t_s: float, timeout_s: float = 60.0) -> None:
        """Block until the twin's clock reaches ``t_s`` (MCU time)."""
        with self.lock:
            self.until_s = t_s
            done = bool(self.samples) and self.samples[-1].t_s >= t_s
        if not done:
            assert self.reached.wait(timeout_s), f"the twin never reached t = {t_s} s"

    def snapshot(self) -> list[Sample]:
        with self.lock:
            return list(self.samples)


@dataclass(frozen=True)
class Brake:
    """What the samples say about the stop after the host's last heartbeat."""

    last_heartbeat_s: float
    drive_off_s: float | None  # MCU time the bridges stopped driving (left CW/CCW), if they did
    distance_after_m: float  # path length from the last heartbeat to the end of the record
    final_speed_m_s: float
    line_dropped_s: float | None

    @property
    def delay_s(self) -> float:
        assert self.drive_off_s is not None, "the motors were still driven at the end"
        return self.drive_off_s - self.last_heartbeat_s


def analyse(samples: list[Sample], last_heartbeat_s: float) -> Brake:
    after = [s for s in samples if s.t_s >= last_heartbeat_s - 1e-9]
    # the drive observed at sample k was applied from sample k-1's instant: the drive stopped at
    # the instant of the last sample that still drove
    driving = [i for i, s in enumerate(samples) if s.drive != (0.0, 0.0)]
    assert driving, "the host never drove the motors"
    drive_off_s = samples[driving[-1]].t_s if driving[-1] + 1 < len(samples) else None
    distance = sum(math.dist((a.x, a.y), (b.x, b.y)) for a, b in itertools.pairwise(after))
    # the same for the line: it fell at the instant of the last sample that still had it
    first_off = next((i for i, s in enumerate(after) if i > 0 and not s.line), None)
    dropped = None if first_off is None else after[first_off - 1].t_s
    return Brake(last_heartbeat_s, drive_off_s, distance, samples[-1].speed_m_s, dropped)


def robot_with(interlock: str) -> RobotSpec:
    spec = load_robot("jackson")
    return replace(spec, wiring=replace(spec.wiring, interlock=interlock))


def run_silent_host(tmp_path: Path, *, firmware: bool, interlock: str = "pca9685_oe") -> Brake:
    """Drive forward at 60 % for DRIVE_FRAMES frames with a heartbeat each, then fall silent
    (the port stays open, as a hung host's does) and watch 2 s of MCU time."""
    twin = Twin(load_world("open_floor"), robot_with(interlock), lidar=False, seed=1)
    ref: list[TwinRunner] = []
    watch = Watch(ref)
    runner = TwinRunner(
        twin,
        i2c_path=tmp_path / "i2c.sock",
        firmware=firmware,
        heartbeat_timeout_s=0.3,
        observer=watch,
    )
    ref.append(runner)
    stop = threading.Event()
    thread = threading.Thread(target=runner.run, args=(None, stop), daemon=True)
    thread.start()
    host = WirePeer(runner.serial_path, f"unix:{tmp_path / 'i2c.sock'}")
    try:
        host.connect()
        last_t_us = 0
        for _ in range(DRIVE_FRAMES):
            t = host.next_telemetry()
            host.set_wheels(0.6, 0.6)
            host.heartbeat()
            last_t_us = t.t_us
            assert t.flags & TelemetryFlags.MOTOR_ENABLE or last_t_us <= 50_000
        # in lockstep the heartbeat for frame k reaches the MCU at frame k's instant
        last_heartbeat_s = last_t_us / 1e6
        watch.wait_until(last_heartbeat_s + FAILSAFE_S + 2.0)
        if runner.mcu is not None:
            assert runner.mcu.last_heartbeat_us == last_t_us
    finally:
        stop.set()
        thread.join(timeout=30)
        host.close()
        runner.close()
    return analyse(watch.snapshot(), last_heartbeat_s)


def report(name: str, b: Brake, record_property: RecordProperty) -> None:
    record_property(f"{name}_brake_delay_s", round(b.delay_s, 4))
    record_property(f"{name}_distance_after_last_heartbeat_m", round(b.distance_after_m, 4))
    print(
        f"\n{name}: drive off {b.delay_s * 1000:.1f} ms after the last heartbeat (MCU time), "
        f"line dropped at +{(b.line_dropped_s or float('nan')) - b.last_heartbeat_s:.3f} s, "
        f"{b.distance_after_m * 100:.1f} cm driven after it, final speed "
        f"{b.final_speed_m_s * 1000:.2f} mm/s"
    )


@pytest.mark.parametrize(
    "firmware",
    [False, pytest.param(True, marks=needs_firmware)],
    ids=["in_process", "firmware_process"],
)
def test_a_silent_host_is_braked_within_failsafe_plus_one_period(
    tmp_path: Path, firmware: bool, record_property: RecordProperty
) -> None:
    b = run_silent_host(tmp_path, firmware=firmware)
    report("firmware_process" if firmware else "in_process", b, record_property)
    assert b.line_dropped_s == pytest.approx(b.last_heartbeat_s + FAILSAFE_S, abs=PERIOD_S + 1e-6)
    # the bridges leave CW/CCW no sooner than failsafe_ms and within one period after it
    assert FAILSAFE_S - 1e-6 <= b.delay_s <= FAILSAFE_S + PERIOD_S + 1e-6
    if not firmware:  # the in-process MCU's next deadline is the drop itself
        assert b.delay_s == pytest.approx(FAILSAFE_S, abs=1e-6)
    assert b.final_speed_m_s < 0.002  # short brake: stopped well within 2 s
    # 60 % is about 0.21 m/s: failsafe_ms of it plus the braking distance, not the 0.4 m of 2 s more
    assert 0.1 * FAILSAFE_S < b.distance_after_m < 0.21 * FAILSAFE_S + 0.08


def test_without_the_interlock_a_silent_host_keeps_the_robot_driving(tmp_path: Path) -> None:
    b_none = run_silent_host(tmp_path, firmware=False, interlock="none")
    assert b_none.drive_off_s is None  # nothing drops the drive
    assert b_none.line_dropped_s is not None  # though the MCU released its (unwired) line
    assert b_none.final_speed_m_s > 0.15
    assert b_none.distance_after_m > 0.15 * (FAILSAFE_S + 2.0)  # failsafe_ms and 2 s at 60 %


def test_stby_wiring_puts_the_bridges_in_standby_and_the_robot_coasts_to_rest(
    tmp_path: Path, record_property: RecordProperty
) -> None:
    b = run_silent_host(tmp_path, firmware=False, interlock="tb6612_stby")
    report("stby", b, record_property)
    assert b.delay_s == pytest.approx(FAILSAFE_S, abs=1e-6)
    assert b.final_speed_m_s < 0.01


def test_stby_interlock_and_a_stby_channel_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text("wiring:\n  stby_channel: 6\n  interlock: tb6612_stby\n")
    with pytest.raises(ConfigError, match="interlock"):
        load_robot(path)
    path.write_text("wiring:\n  interlock: relay\n")
    with pytest.raises(ConfigError, match="pca9685_oe, tb6612_stby, none"):
        load_robot(path)


def test_shipped_robots_wire_the_interlock_to_oe() -> None:
    for name in ("jackson", "jackson_physical"):
        assert load_robot(name).wiring.interlock == "pca9685_oe"


def test_a_killed_daemon_is_braked_by_the_interlock(
    tmp_path: Path, record_property: RecordProperty
) -> None:
    """The real daemon drives the square through the PCA9685 (the twin's I2C socket); SIGKILL
    leaves the PCA9685 holding its last duty, and only the MCU's line stops the robot."""
    twin = Twin(load_world("square_room"), load_robot("jackson"), lidar=False, seed=2)
    ref: list[TwinRunner] = []
    watch = Watch(ref)
    sock, link = tmp_path / "i2c.sock", tmp_path / "serial"
    runner = TwinRunner(twin, i2c_path=sock, serial_link=str(link), observer=watch)
    ref.append(runner)
    stop = threading.Event()
    thread = threading.Thread(target=runner.run, args=(None, stop), daemon=True)
    thread.start()
    cmd = [JACKSON, "daemon", "--port", str(link), "--i2c", f"unix:{sock}", "--no-record"]
    daemon = subprocess.Popen(
        [*cmd, "--mission", "square"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    mcu = runner.mcu
    assert mcu is not None
    try:
        if not watch.moving.wait(60):
            daemon.kill()
            raise AssertionError(f"the daemon never drove: {daemon.communicate()[0]}")
        assert mcu.motor_enable
        daemon.send_signal(signal.SIGKILL)
        daemon.wait(timeout=10)
        killed_s = watch.snapshot()[-1].t_s
        watch.wait_until(killed_s + FAILSAFE_S + 2.0)
        last_heartbeat_s = mcu.last_heartbeat_us / 1e6  # no heartbeat after the kill
    finally:
        stop.set()
        thread.join(timeout=30)
        if daemon.poll() is None:
            daemon.kill()
            daemon.wait()
        runner.close()
    b = analyse(watch.snapshot(), last_heartbeat_s)
    report("daemon_sigkill", b, record_property)
    assert last_heartbeat_s <= killed_s + 1e-6
    assert b.delay_s == pytest.approx(FAILSAFE_S, abs=1e-6)
    assert b.drive_off_s is not None and b.drive_off_s - killed_s <= FAILSAFE_S + PERIOD_S
    assert not mcu.motor_enable
    flags = mcu.telemetry_flags(mcu.last_heartbeat_us + 1_000_000)
    assert flags & TelemetryFlags.HOST_LOST and not flags & TelemetryFlags.MOTOR_ENABLE
    assert b.final_speed_m_s < 0.002
