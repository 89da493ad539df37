"""One scripted scenario against the twin's MCU (the firmware core in the twin's process) and
against the POSIX firmware process: the host receives the same bytes from both."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from jackson.protocol import (
    FrameDecoder,
    RequestInfo,
    SetConfig,
    SetRate,
    Status,
    Telemetry,
    TelemetryFlags,
    ZeroCounters,
    decode_message,
)
from jackson.sim.config import ROBOTS_DIR

from .twin_process import TwinProcess


def duties(t: Telemetry) -> tuple[float, float]:
    s = t.t_us / 1e6
    if s < 1.0:
        return 0.6, 0.6
    if s < 2.0:
        return 0.3, 0.7
    return -0.4, 0.2


CORRUPT = b"\x00\xa5\x5a\x01\x82\x00\x02\x14\x00\xde\xad\xbe\xef"


def scenario(robot: str, *args: str) -> bytes:
    """120 frames of lockstep with commands; a host's commands go before its heartbeat, as the
    daemon sends them, so both MCUs see them at the same instant."""
    twin = TwinProcess("--no-lidar", "--seed", "3", "--boot-id", "0x5eed", "--robot", robot, *args)
    host = twin.host()
    try:
        host.connect()
        for k in range(120):
            t = host.next_telemetry()
            host.set_wheels(*duties(t))
            if k == 30:
                host.send(SetRate(rate_hz=50))
            elif k == 50:  # other IMU ranges: the twin scales the registers it feeds by them
                host.send(SetConfig(accel_fs=1, gyro_fs=2, failsafe_ms=600))
            elif k == 70:
                host.send(ZeroCounters(mask=3))
            elif k == 90:
                host.send(RequestInfo())
                host.port.write(CORRUPT)
            host.heartbeat()
        return bytes(host.received)
    finally:
        host.close()
        twin.stop()


@pytest.fixture(params=["jackson_physical", "no_imu"])
def robot(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """The physical robot, and the same robot without its MPU-6050: the driver's retries and
    I2C error counts must match too."""
    if request.param != "no_imu":
        return str(request.param)
    spec = yaml.safe_load((ROBOTS_DIR / "jackson_physical.yaml").read_text())
    spec.setdefault("imu", {})["present"] = False
    path = tmp_path / "no_imu.yaml"
    path.write_text(yaml.safe_dump(spec))
    return str(path)


def test_the_mcu_in_process_and_the_firmware_process_send_identical_bytes(robot: str) -> None:
    in_process = scenario(robot)
    process = scenario(robot, "--firmware")
    assert len(in_process) > 120 * 38
    if in_process != process:  # show where they part
        i = next(k for k, (a, b) in enumerate(zip(in_process, process, strict=False)) if a != b)
        raise AssertionError(
            f"first difference at byte {i}: in process {in_process[i - 8 : i + 30].hex()} vs "
            f"firmware process {process[i - 8 : i + 30].hex()}"
        )
    # and the scenario exercised what it is meant to: the IMU's health and error counts, the
    # ranges set at frame 50 (flag bits 8-11) and the registers scaled by them
    messages = [decode_message(f) for f in FrameDecoder().feed(process)]
    telemetry = [m for m in messages if isinstance(m, Telemetry)]
    statuses = [m for m in messages if isinstance(m, Status)]
    imu_missing = robot != "jackson_physical"
    assert statuses and all((s.i2c_errors > 0) == imu_missing for s in statuses)
    assert all(bool(t.flags & TelemetryFlags.IMU_OK) != imu_missing for t in telemetry)
    before, after = telemetry[45], telemetry[60]
    assert (before.flags >> 8) & 0xF == 0 and (after.flags >> 8) & 0xF == 1 | (2 << 2)
    if not imu_missing:  # gravity: 16384 LSB/g at +-2 g, 8192 at +-4 g
        assert before.accel[2] == pytest.approx(16384 * 0.9479, rel=0.02)
        assert after.accel[2] == pytest.approx(8192 * 0.9479, rel=0.02)
