"""`jackson daemon` and `jackson monitor` as users meet them: one-line errors, real ptys."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import threading
import tty
from pathlib import Path

from jackson.host.transport import open_error
from jackson.protocol import FrameDecoder, Info, encode_frame

JACKSON = str(Path(sys.executable).parent / "jackson")


def run(*args: str, timeout: float = 30) -> subprocess.CompletedProcess[str]:
    return subprocess.run([JACKSON, *args], capture_output=True, text=True, timeout=timeout)


def mcu_config(tmp_path: Path) -> Path:
    cfg = tmp_path / "mcu.yaml"
    cfg.write_text("actuator: mcu\n")
    return cfg


def test_missing_port_is_one_line(tmp_path: Path) -> None:
    out = run(
        "daemon", "--config", str(mcu_config(tmp_path)), "--port", "/dev/ttyNOPE0", "--no-record"
    )
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1
    assert "/dev/ttyNOPE0 does not exist" in out.stderr


def test_permission_denied_names_the_dialout_group() -> None:
    err = open_error("/dev/ttyACM0", OSError(errno.EACCES, "Permission denied"))
    assert "dialout" in str(err)
    assert "\n" not in str(err)


def test_bad_config_is_one_line_naming_the_field(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("deadband:\n  left: {forward: 1.2, reverse: 0.1}\n")
    out = run("daemon", "--config", str(bad), "--port", "/dev/null")
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1
    assert "deadband.left.forward" in out.stderr


def test_firmware_with_another_protocol_is_refused_naming_both(tmp_path: Path) -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)

    def fake_device() -> None:  # answers HELLO with an INFO of another schema
        dec = FrameDecoder()
        while True:
            data = os.read(master, 256)
            if any(f.type == 0x80 for f in dec.feed(data)):
                info = Info(protocol_version=1, schema_hash=0x12345678)
                os.write(master, encode_frame(info, 0))
                return

    threading.Thread(target=fake_device, daemon=True).start()
    out = run("daemon", "--config", str(mcu_config(tmp_path)), "--port", path, "--no-record")
    os.close(master)
    os.close(slave)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1
    assert "0x12345678" in out.stderr and "v1" in out.stderr


def test_monitor_shows_the_twin(tmp_path: Path) -> None:
    twin = subprocess.Popen(
        [JACKSON, "sim", "--no-lidar", "--realtime"], stdout=subprocess.PIPE, text=True
    )
    assert twin.stdout is not None
    serial = twin.stdout.readline().split(": ", 1)[1].strip()
    try:
        out = run("monitor", "--port", serial, "--duration", "1.5")
    finally:
        twin.terminate()
        twin.wait(timeout=10)
    assert out.returncode == 0, out.stderr
    assert "firmware 0.1.0" in out.stdout
    assert "telemetry frames" in out.stdout
    assert "IMU_OK" in out.stdout
