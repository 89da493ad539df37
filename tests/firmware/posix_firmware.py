"""Drives the POSIX build of the firmware (the real compiled core) as the digital twin will."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import serial  # type: ignore[import-untyped]

from jackson.protocol import FrameDecoder, Message, decode_message, encode_frame
from jackson.sim.fil import FeedStatus, parse_status

ROOT = Path(__file__).resolve().parents[2]
BINARY = Path(
    os.environ.get(
        "JACKSON_FIRMWARE_POSIX", ROOT / "build" / "native" / "firmware" / "jackson-firmware-posix"
    )
)


FeedReply = FeedStatus


def imu_registers(accel: tuple[int, int, int], temp: int, gyro: tuple[int, int, int]) -> str:
    """The 14 bytes at 0x3B..0x48 (big-endian, register order) as 28 hex digits."""
    values = (*accel, temp, *gyro)
    return b"".join(v.to_bytes(2, "big", signed=True) for v in values).hex()


class PosixFirmware:
    """The firmware process, its sensor feed (stdin/stdout) and a pyserial client on its pty."""

    def __init__(self, *args: str) -> None:
        if not BINARY.exists():
            raise FileNotFoundError(f"{BINARY} is missing: run `make native` first")
        self.proc = subprocess.Popen(
            [str(BINARY), *args],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            bufsize=1,
        )
        assert self.proc.stdout is not None and self.proc.stdin is not None
        first = self.proc.stdout.readline().split()
        assert first[0] == "serial", first
        self.path = first[1]
        self.port = serial.Serial(self.path, baudrate=921600, timeout=0)
        self.decoder = FrameDecoder()
        self.host_seq = 0
        self.last_crc = 0

    def close(self) -> None:
        self.port.close()
        if self.proc.poll() is None:
            assert self.proc.stdin is not None
            self.proc.stdin.write("q\n")
            self.proc.stdin.flush()
            self.proc.wait(timeout=5)

    def _command(self, line: str) -> FeedReply:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return parse_status(self.proc.stdout.readline())

    def step(
        self,
        t_us: int,
        left: int = 0,
        right: int = 0,
        imu_ok: bool = True,
        regs: str = imu_registers((0, 0, 16384), 0, (0, 0, 0)),
    ) -> FeedReply:
        """Sensors at t_us; the firmware runs up to t_us."""
        return self._command(f"t {t_us} {left} {right} {int(imu_ok)} {regs}")

    def wait_heartbeat(self, seq: int, timeout_ms: int = 2000) -> FeedReply:
        return self._command(f"w {seq} {timeout_ms}")

    def send(self, msg: Message) -> int:
        """Send ``msg``; its SEQ (the frame's CRC, which ACK/NACK echo, is in ``last_crc``)."""
        seq = self.host_seq
        frame = encode_frame(msg, seq)
        self.port.write(frame)
        self.port.flush()
        self.host_seq = (seq + 1) & 0xFF
        self.last_crc = int.from_bytes(frame[-4:], "little")
        return seq

    def receive(self, settle_s: float = 0.05) -> list[Message]:
        """Everything that arrived on the pty, decoded."""
        out: list[Message] = []
        deadline = time.monotonic() + settle_s
        while time.monotonic() < deadline:
            data = self.port.read(4096)
            if data:
                out += [decode_message(f) for f in self.decoder.feed(data)]
                deadline = time.monotonic() + settle_s
            else:
                time.sleep(0.002)
        return out
