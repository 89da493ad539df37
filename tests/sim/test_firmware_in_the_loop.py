"""One scripted scenario against the MCU emulator and against the compiled firmware: the host
receives the same bytes from both."""

from __future__ import annotations

from jackson.protocol import RequestInfo, SetRate, Telemetry, ZeroCounters

from .twin_process import TwinProcess


def duties(t: Telemetry) -> tuple[float, float]:
    s = t.t_us / 1e6
    if s < 1.0:
        return 0.6, 0.6
    if s < 2.0:
        return 0.3, 0.7
    return -0.4, 0.2


CORRUPT = b"\x00\xa5\x5a\x01\x82\x00\x02\x14\x00\xde\xad\xbe\xef"


def scenario(*args: str) -> bytes:
    """120 frames of lockstep with commands; a host's commands go before its heartbeat, as the
    daemon sends them, so both MCUs see them at the same instant."""
    twin = TwinProcess("--no-lidar", "--seed", "3", "--robot", "jackson_physical", *args)
    host = twin.host()
    try:
        host.connect()
        for k in range(120):
            t = host.next_telemetry()
            host.set_wheels(*duties(t))
            if k == 30:
                host.send(SetRate(rate_hz=50))
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


def test_firmware_and_emulator_send_identical_bytes() -> None:
    emulated = scenario()
    compiled = scenario("--firmware")
    assert len(emulated) > 120 * 38
    if emulated != compiled:  # show where they part
        i = next(k for k, (a, b) in enumerate(zip(emulated, compiled, strict=False)) if a != b)
        raise AssertionError(
            f"first difference at byte {i}: emulator {emulated[i - 8 : i + 30].hex()} vs "
            f"firmware {compiled[i - 8 : i + 30].hex()}"
        )
