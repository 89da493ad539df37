"""Firmware in the loop: the compiled POSIX firmware as the twin's MCU.

``build/native/firmware/jackson-firmware-posix`` runs the real firmware core on Linux; it makes
its own pty for the host and reads sensor records on stdin (docs/firmware.md, "Running the
firmware on Linux"). This module starts it and speaks that feed.
"""

from __future__ import annotations

import os
import selectors
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from jackson.common.errors import JacksonError
from jackson.sim.mcu import SensorSample, imu_register_bytes

REPO = Path(__file__).resolve().parents[1]
DEFAULT_BINARY = REPO / "build" / "native" / "firmware" / "jackson-firmware-posix"


class FirmwareError(JacksonError, RuntimeError):
    """The POSIX firmware is missing, failed to start, or stopped answering."""


@dataclass(frozen=True)
class FeedStatus:
    """The firmware's status line after a record."""

    t_us: int
    telemetry_seq: int
    frames_sent: int
    heartbeat_ack: int
    motor_left: int
    motor_right: int
    braked: bool
    failsafe: bool
    session: bool
    tx_dropped: int
    rx_crc_errors: int
    next_telemetry_us: int
    accel_fs: int  # the MPU-6050's ranges as the firmware set them (0-3)
    gyro_fs: int
    motor_enable: bool  # the interlock line, 1 asserted (docs/firmware.md, "Motor interlock")


def parse_status(line: bytes | str) -> FeedStatus:
    """One status line of the POSIX firmware (docs/firmware.md)."""
    parts = line.split()
    if not parts or parts[0] not in (b"s", "s") or len(parts) != 16:
        raise FirmwareError(f"unexpected status line from the firmware: {parts!r}")
    v = [int(x) for x in parts[1:]]
    braked, failsafe, session = (bool(x) for x in v[6:9])
    return FeedStatus(
        v[0],
        v[1],
        v[2],
        v[3],
        v[4],
        v[5],
        braked,
        failsafe,
        session,
        v[9],
        v[10],
        v[11],
        v[12],
        v[13],
        bool(v[14]),
    )


class FirmwareProcess:
    """One running POSIX firmware, driven through its sensor feed."""

    def __init__(
        self,
        binary: Path | None = None,
        *,
        motors: bool = False,
        imu_present: bool = True,
        boot_id: int | None = None,
    ) -> None:
        exe = Path(os.environ.get("JACKSON_FIRMWARE_POSIX", binary or DEFAULT_BINARY))
        if not exe.exists():
            raise FirmwareError(f"{exe} is missing: build it with `make native`")
        args = [str(exe)] + (["--motors"] if motors else []) + ([] if imu_present else ["--no-imu"])
        if boot_id:
            args += ["--boot-id", str(boot_id)]
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0)
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self._out = self.proc.stdout
        self._in = self.proc.stdin
        os.set_blocking(self._out.fileno(), False)
        self._buf = b""
        first = self._line(timeout_s=10.0).split()
        if len(first) != 2 or first[0] != b"serial":
            raise FirmwareError(f"unexpected first line from the firmware: {first!r}")
        self.serial_path = first[1].decode()
        self.last_status: FeedStatus | None = None  # the answer to the latest record

    def fileno(self) -> int:
        return self._out.fileno()

    def _line(self, timeout_s: float, on_wait: object = None) -> bytes:
        deadline = time.monotonic() + timeout_s
        sel = selectors.DefaultSelector()
        sel.register(self._out, selectors.EVENT_READ)
        try:
            while b"\n" not in self._buf:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise FirmwareError("the POSIX firmware stopped answering its feed")
                if callable(on_wait):
                    on_wait()
                if sel.select(min(left, 0.001 if callable(on_wait) else left)):
                    chunk = self._out.read()
                    if chunk == b"":
                        raise FirmwareError("the POSIX firmware exited")
                    if chunk:
                        self._buf += chunk
        finally:
            sel.close()
        line, _, self._buf = self._buf.partition(b"\n")
        return line

    def _command(self, text: str, timeout_s: float = 10.0, on_wait: object = None) -> FeedStatus:
        self._in.write(text.encode() + b"\n")
        self.last_status = parse_status(self._line(timeout_s, on_wait))
        return self.last_status

    def step(self, t_us: int, s: SensorSample) -> FeedStatus:
        """Sensors read ``s`` at ``t_us``; the firmware runs everything due up to then."""
        regs = imu_register_bytes(s.accel, s.temp, s.gyro).hex()
        return self._command(f"t {t_us} {s.enc_left} {s.enc_right} {int(s.imu_ok)} {regs}")

    def wait_heartbeat(self, seq: int, timeout_ms: int, on_wait: object = None) -> FeedStatus:
        """Serve the host link until it acknowledges telemetry ``seq`` (or the timeout);
        ``on_wait`` is called while waiting (the twin serves its I2C bus there)."""
        return self._command(f"w {seq} {timeout_ms}", timeout_ms / 1000 + 10.0, on_wait)

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self._in.write(b"q\n")
                self.proc.wait(timeout=5)
            except (BrokenPipeError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()
        self._in.close()
        self._out.close()
