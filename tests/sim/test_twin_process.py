"""`jackson sim` as a user runs it: a real pty, a real I2C socket, a host in another process."""

from __future__ import annotations

import contextlib
import itertools
import os
import re
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest
import serial

from jackson.bench.lockstep import _TWIN_SUMMARY
from jackson.common.liveness import STALL_EXIT
from jackson.protocol import Heartbeat, HostState, MotorPwm, Telemetry, TelemetryFlags
from jackson.sim.fil import DEFAULT_BINARY

from .twin_process import JACKSON, TwinProcess


def test_nothing_is_sent_before_hello() -> None:
    twin = TwinProcess("--no-lidar")
    try:
        port = serial.Serial(twin.serial, timeout=0.3)
        assert port.read(100) == b""
        port.close()
    finally:
        twin.stop()


def test_host_drives_the_twin_through_the_pca9685() -> None:
    twin = TwinProcess("--no-lidar")
    host = twin.host()
    try:
        info = host.connect()
        assert info.telemetry_rate_hz == 20
        tel = host.run(40, lambda t: (0.6, 0.6))  # 2 s forward
        moved = tel[-1].enc_left - tel[0].enc_left
        assert 600 < moved < 1500  # about 0.27 m/s: 2.6 wheel turns of 621 ticks in 2 s
        assert abs(tel[-1].enc_left - tel[-1].enc_right) <= 2
        tel = host.run(40, lambda t: (0.0, 0.0))  # short brake
        assert tel[-1].enc_left - tel[-20].enc_left == 0
        assert [b.t_us - a.t_us for a, b in itertools.pairwise(tel)] == [50_000] * 39
    finally:
        host.close()
        code, out, _ = twin.stop()
    assert code == 0
    # the summary the lockstep bench reads: frames since the HELLO, CPU time, polling part
    summary = _TWIN_SUMMARY.search(out)
    assert summary is not None, out
    frames, cpu_s, spun_s = int(summary[1]), float(summary[2]), float(summary[3])
    assert frames >= 80
    assert 0.0 < cpu_s < 60.0
    assert 0.0 <= spun_s <= cpu_s


def test_client_can_close_and_reopen_the_port() -> None:
    twin = TwinProcess("--no-lidar", "--heartbeat-timeout", "0.2")
    host = twin.host()
    try:
        host.connect()
        host.run(5, lambda t: (0.5, 0.5))
        host.port.close()
        time.sleep(0.5)  # the twin carries on in real time without its host
        host.port.open()
        t1 = host.next_telemetry()
        t2 = host.next_telemetry()
        assert t2.t_us > t1.t_us
    finally:
        host.close()
        code, out, _ = twin.stop()
    assert code == 0
    assert "telemetry frames" in out


def test_mcu_failsafe_fires_after_heartbeats_stop() -> None:
    twin = TwinProcess("--no-lidar", "--mcu-motors", "--heartbeat-timeout", "0.2")
    host = twin.host()
    try:
        host.connect()
        t = host.next_telemetry()
        host.send(MotorPwm(left=5000, right=5000, timeout_ms=10_000))
        host.send(Heartbeat(ack_seq=host.last_telemetry_seq, host_state=HostState.ACTIVE))
        last_hb_us = t.t_us
        fired_at = None
        for _ in range(60):  # no more heartbeats
            t = host.next_telemetry()
            if t.flags & TelemetryFlags.FAILSAFE_ACTIVE:
                fired_at = t.t_us
                break
        assert fired_at is not None
        assert 200_000 <= fired_at - last_hb_us <= 250_000  # failsafe_ms (0.2 s) and a frame
    finally:
        host.close()
        twin.stop()


def test_sigterm_shuts_down_cleanly(tmp_path: Path) -> None:
    sock = tmp_path / "bus.sock"
    twin = TwinProcess("--no-lidar", "--i2c", str(sock))
    assert sock.exists()
    twin.proc.send_signal(signal.SIGTERM)
    code, out, err = twin.stop()
    assert code == 0, err
    assert "simulated" in out
    assert not sock.exists()


def test_bad_robot_file_is_one_line_naming_the_field(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nmotor:\n  stall_torque_nm: -1\n")
    out = subprocess.run([JACKSON, "sim", "--robot", str(bad)], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1
    assert "motor.stall_torque_nm" in out.stderr
    assert "Traceback" not in out.stderr


def test_unknown_field_and_bad_world_are_refused(tmp_path: Path) -> None:
    bad = tmp_path / "w.yaml"
    bad.write_text("name: w\nwals: []\n")
    out = subprocess.run([JACKSON, "sim", "--world", str(bad)], capture_output=True, text=True)
    assert out.returncode == 2
    assert "wals: unknown field" in out.stderr
    out = subprocess.run(
        [JACKSON, "sim", "--world", "no_such_world"], capture_output=True, text=True
    )
    assert out.returncode == 2
    assert "no_such_world" in out.stderr


TWIN_STALL = re.compile(
    r"jackson sim: lockstep stalled: the twin waited (\d+\.\d) s for the host's HEARTBEAT after "
    r"frame (\d+) \(sim time (\d+\.\d\d) s\): the host process is (gone|stopped)"
)


FIRMWARE_BUILT = Path(os.environ.get("JACKSON_FIRMWARE_POSIX", DEFAULT_BINARY)).exists()


@pytest.mark.parametrize(
    "mcu",
    [
        (),
        pytest.param(
            ("--firmware",),
            marks=pytest.mark.skipif(
                not FIRMWARE_BUILT, reason="the POSIX firmware is not built (make native)"
            ),
        ),
    ],
    ids=["in_process", "firmware_process"],
)
def test_a_host_answering_late_is_not_a_stall_and_a_silent_one_is(mcu: tuple[str, ...]) -> None:
    """A twin that waits without a heartbeat timeout (longer than --stall-timeout) is not cut by
    a host that answers each frame 0.3 s late, 3 s in all, at a 1 s limit; it gives up 1 s after
    the host is gone: its summary, one line on stderr, exit status 75. With either MCU."""
    twin = TwinProcess("--no-lidar", *mcu, "--heartbeat-timeout", "3600", "--stall-timeout", "1")
    host = twin.host()
    try:
        host.connect()

        def late(_: Telemetry) -> tuple[float, float]:
            threading.Event().wait(0.3)  # the host's slowness under test
            return 0.3, 0.3

        tel = host.run(10, late)
        assert [b.t_us - a.t_us for a, b in itertools.pairwise(tel)] == [50_000] * 9
        assert twin.proc.poll() is None  # 3 s of slow answers: still running
        host.close()  # the host goes away (alive but idle, it would be waited for 60 s)
        silent = time.monotonic()
        twin.proc.wait(timeout=60)  # no more heartbeats
        waited = time.monotonic() - silent
    finally:
        with contextlib.suppress(OSError):
            host.close()
        code, out, err = twin.stop()
    assert code == STALL_EXIT
    assert err.count("\n") == 1 and "Traceback" not in err
    said = TWIN_STALL.fullmatch(err.strip())
    assert said is not None, err
    assert 1.0 <= float(said[1]) < 2.0 and waited >= 1.0
    assert int(said[2]) == 11  # the frame after the last one answered
    assert _TWIN_SUMMARY.search(out) is not None  # the summary, as on any way out


def test_stall_timeout_default_is_the_runners() -> None:
    from jackson.sim.cli import STALL_TIMEOUT_S
    from jackson.sim.runner import STALL_S

    assert STALL_TIMEOUT_S == STALL_S


@pytest.mark.parametrize("value", ["0", "-2", "nan", "inf", "x"])
def test_a_bad_stall_timeout_is_one_line(value: str) -> None:
    out = subprocess.run(
        [JACKSON, "sim", "--stall-timeout", value], capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "--stall-timeout" in out.stderr
    assert "Traceback" not in out.stderr
