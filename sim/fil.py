"""Firmware in the loop: the compiled POSIX firmware as the twin's MCU.

``build/native/firmware/jackson-firmware-posix`` runs the real firmware core on Linux; it makes
its own pty for the host and reads sensor records on stdin (docs/firmware.md, "Running the
firmware on Linux"). This module starts it and speaks that feed
(:class:`FirmwareProcess`), and makes it the twin's MCU behind the runner's interface
(:class:`FirmwarePort`, a :class:`~jackson.sim.port.McuPort`).
"""

from __future__ import annotations

import os
import selectors
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from jackson.common.errors import JacksonError
from jackson.sim.mcu import SensorSample, imu_register_bytes
from jackson.sim.port import Selectable, Tick

NO_FRAME = 256  # a SEQ no telemetry frame carries (SEQ is 8-bit): wait without an acknowledgement
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


class FirmwarePort:
    """The POSIX firmware process as the twin's MCU (:class:`~jackson.sim.port.McuPort`).

    The process serves its own pty; it learns the twin's time and sensors from records
    (:meth:`FirmwareProcess.step`) and serves the host's link while the runner waits for a
    HEARTBEAT (:meth:`FirmwareProcess.wait_heartbeat`). Everything the runner reads is the
    process's latest status line; its next deadline is the next telemetry frame (the instant
    the interlock line drops shows in the status line at the next frame, at most one period
    later).

    Parameters
    ----------
    sensors : callable
        The twin's sensors at the current instant.
    motors : bool
        The firmware drives the TB6612 itself (``--motors``).
    imu_present : bool
        An MPU-6050 is on the bus.
    boot_id : int or None
        INFO's boot_id (None: the process draws one).
    binary : Path or None
        The POSIX firmware (default: the build's, or ``$JACKSON_FIRMWARE_POSIX``).

    Raises
    ------
    FirmwareError
        The firmware is missing or does not start.
    """

    def __init__(
        self,
        sensors: Callable[[], SensorSample],
        *,
        motors: bool = False,
        imu_present: bool = True,
        boot_id: int | None = None,
        binary: Path | None = None,
    ) -> None:
        self.process = FirmwareProcess(
            binary, motors=motors, imu_present=imu_present, boot_id=boot_id
        )
        self._sensors = sensors

    @property
    def serial_path(self) -> str:
        return self.process.serial_path

    @property
    def host_link(self) -> Selectable | None:
        """None: the process serves its own pty."""
        return None

    def receive(self, now_us: int) -> None:
        """Nothing to hand over: the process reads its own pty."""

    def unplug(self) -> None:
        raise FirmwareError("the firmware process owns its pty: it cannot be unplugged")

    def plug(self) -> None:
        raise FirmwareError("the firmware process owns its pty: it cannot be plugged back")

    def tick(self, now_us: int) -> Tick:
        """Feed the sensors at ``now_us``: the process runs everything due up to then. At the
        instant it already stands at (the HELLO's, which its wait served) there is nothing
        to feed."""
        before = self.process.last_status
        if before is not None and before.t_us == now_us:
            return Tick(False)
        status = self.process.step(now_us, self._sensors())
        return Tick(status.telemetry_seq != (-1 if before is None else before.telemetry_seq))

    def next_deadline(self, now_us: int) -> int | None:
        """The next telemetry instant of the status line; None before a session (or should
        it not lie ahead of ``now_us``)."""
        status = self.process.last_status
        if status is None or status.next_telemetry_us < 0:
            return None
        step_us = (status.next_telemetry_us - now_us) & 0xFFFFFFFF
        return None if step_us == 0 or step_us >= 0x80000000 else status.next_telemetry_us

    @property
    def session(self) -> bool:
        status = self.process.last_status
        return status is not None and status.session

    @property
    def last_telemetry_seq(self) -> int:
        status = self.process.last_status
        return -1 if status is None else status.telemetry_seq

    def acknowledged(self, seq: int) -> bool:
        status = self.process.last_status
        # a new session (no telemetry sent in it) no longer awaits an older one's frame
        return status is not None and (status.heartbeat_ack == seq or status.telemetry_seq == -1)

    def heartbeat_mark(self) -> int:
        """The newest HEARTBEAT's ack_seq (-1 before one)."""
        status = self.process.last_status
        return -1 if status is None else status.heartbeat_ack

    def await_heartbeat(
        self, seq: int | None, timeout_s: float, serve: Callable[[float], bool]
    ) -> bool:
        """The process serves its link on the wall clock (``w``) while ``serve`` polls the
        twin's other links."""
        self.process.wait_heartbeat(
            NO_FRAME if seq is None else seq, round(timeout_s * 1000), on_wait=lambda: serve(0.0)
        )
        return False

    @property
    def motor_enable(self) -> bool:
        status = self.process.last_status
        return status is not None and status.motor_enable

    def wheel_duty(self) -> tuple[float, float, bool]:
        status = self.process.last_status
        if status is None:
            return 0.0, 0.0, False
        return status.motor_left / 1e4, status.motor_right / 1e4, status.braked

    def imu_ranges(self) -> tuple[int, int] | None:
        status = self.process.last_status
        return None if status is None else (status.accel_fs, status.gyro_fs)

    def close(self) -> None:
        self.process.close()
