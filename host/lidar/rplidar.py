"""The host's driver of the RPLIDAR A1M8 on its USB serial adapter (docs/lidar.md).

:class:`RplidarDriver` opens the port, starts the standard scan (STOP, silence, GET_HEALTH,
GET_INFO, motor on, SCAN) and then, at each :meth:`~RplidarDriver.poll`, reads whatever bytes
have arrived without blocking and returns the revolutions they completed. A revolution ends
where the node with the S flag that starts the next one arrives, so it is handed over as soon
as the sensor has finished it.

Frame convention. The A1 measures its heading clockwise seen from above, from its 0° mark.
A :class:`Revolution` is in the ROS ``LaserScan`` convention of the ``laser`` frame (REP 103):
x along the sensor's 0° mark, angles counter-clockwise, ``angle = -heading`` wrapped to
[-pi, pi), sorted ascending. (Slamtec's ``rplidar_ros`` node instead reports
``pi - heading``: its x axis points along the 180° mark.) Ranges are metres; a node with
distance 0 (no return) and any reading above the software cap (8 m, REFERENCE: LiDAR) read
``inf``. A revolution carries no time stamp: the daemon stamps it on MCU time when it turns
it into a :class:`jackson.host.nav.types.Scan`.

The motor of the A1 is switched by the adapter board's MOTOCTL line, which follows the
serial port's DTR inverted: DTR asserted (as pyserial opens a port) stops it, DTR cleared
runs it. A pseudo-terminal (the twin) has no modem lines; setting DTR on one is skipped.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import select
import time
from dataclasses import dataclass
from types import TracebackType

import numpy as np
import numpy.typing as npt
import serial

from jackson.protocol.rplidar import (
    Command,
    DataType,
    Descriptor,
    DeviceHealth,
    DeviceInfo,
    HealthStatus,
    NodeBatch,
    ResponseDecoder,
    ResponseItem,
    encode_request,
)

__all__ = ["LidarError", "Revolution", "RevolutionAssembler", "RplidarDriver"]

FloatArray = npt.NDArray[np.float64]

RANGE_CAP_M = 8.0  # [m] REFERENCE: "software cap 8 m"
ANSWER_TIMEOUT_S = 1.0  # [s] for GET_HEALTH, GET_INFO and the SCAN descriptor
SILENCE_S = 0.02  # [s] no byte for this long after STOP: the device has stopped sending
SILENCE_TIMEOUT_S = 1.0  # [s] a device still sending after this long ignores STOP
READ_CHUNK = 65536
MAX_READ_BYTES = 1 << 20  # one poll reads at most this much (a flood cannot hold it)
Q6_TO_RAD = math.pi / (180.0 * 64.0)
MM_Q2_TO_M = 1.0 / 4000.0


class LidarError(RuntimeError):
    """The LiDAR cannot be used (missing port, no permission, no answer): one line."""


@dataclass(frozen=True)
class Revolution:
    """One turn of the sensor head, in the ``laser`` frame (see the module docstring).

    Attributes
    ----------
    angles_rad : ndarray of float
        Angle of each measurement [rad], counter-clockwise from x, in [-pi, pi), ascending.
    ranges_m : ndarray of float
        Range of each measurement [m]; ``inf`` for no return or beyond the cap.
    nodes : int
        Measurements in the turn (``len(angles_rad)``).
    """

    angles_rad: FloatArray
    ranges_m: FloatArray
    nodes: int


def open_error(port: str, exc: BaseException) -> LidarError:
    """A one-line explanation of why the LiDAR's ``port`` cannot be opened."""
    text = str(exc)
    code = getattr(exc, "errno", None)
    if code == errno.EACCES or "Permission denied" in text:
        return LidarError(
            f"permission denied on the LiDAR port {port}: add yourself to the dialout group "
            "(sudo usermod -aG dialout $USER) and log in again"
        )
    if code in (errno.EAGAIN, errno.EWOULDBLOCK) or "exclusively lock" in text:
        return LidarError(
            f"LiDAR port {port} is in use by another program: stop it first, or look with: "
            f"fuser -v {port}"
        )
    if code == errno.ENOENT or "No such file" in text:
        return LidarError(
            f"LiDAR port {port} does not exist: is the RPLIDAR plugged in? "
            "(look for /dev/ttyUSB* or /dev/jackson-lidar, docs/lidar.md)"
        )
    return LidarError(f"cannot open LiDAR port {port}: {text}")


class RevolutionAssembler:
    """Revolutions out of the device's byte stream, free of I/O: what :meth:`RplidarDriver.poll`
    and the daemon's core (which logs the raw bytes, so ``jackson replay`` rebuilds the same
    scans) both run.

    Parameters
    ----------
    range_cap_m : float
        Readings above this read ``inf`` [m].
    streaming : bool
        Whether the stream is already past the SCAN descriptor (nodes come first), as the
        bytes a started driver hands out with :meth:`RplidarDriver.read` are.

    Attributes
    ----------
    decoder : ResponseDecoder
        The protocol decoder; its counters count skipped bytes and nodes.
    revolutions : int
        Revolutions completed.
    partial_nodes : int
        Nodes before the first S flag (a turn begun before the scan), dropped.
    """

    def __init__(self, range_cap_m: float = RANGE_CAP_M, *, streaming: bool = False) -> None:
        if not range_cap_m > 0.0:
            raise ValueError(f"range_cap_m must be > 0, got {range_cap_m}")
        self.range_cap_m = range_cap_m
        self.decoder = ResponseDecoder(streaming=streaming)
        self.revolutions = 0
        self.partial_nodes = 0
        self.answers: list[ResponseItem] = []  # descriptors and single responses, in order
        self._in_turn = False  # an S flag has begun the turn being collected
        self._angle_parts: list[npt.NDArray[np.uint16]] = []
        self._distance_parts: list[npt.NDArray[np.uint16]] = []

    def reset_turn(self) -> None:
        """Drop the turn being collected (after STOP, or a new SCAN)."""
        self._in_turn = False
        self._angle_parts.clear()
        self._distance_parts.clear()

    def feed(self, data: bytes) -> list[Revolution]:
        """The revolutions ``data`` completes (other items go to :attr:`answers`)."""
        done: list[Revolution] = []
        for item in self.decoder.feed(data):
            if isinstance(item, NodeBatch):
                self._collect(item, done)
            else:
                self.answers.append(item)
        return done

    def _collect(self, batch: NodeBatch, done: list[Revolution]) -> None:
        starts = np.flatnonzero(batch.start)
        bounds = [0, *starts.tolist(), len(batch)]
        for k in range(len(bounds) - 1):
            lo, hi = bounds[k], bounds[k + 1]
            if k > 0:  # an S flag at lo: the turn being collected is complete
                if self._in_turn:
                    done.append(self._finish_turn())
                self._in_turn = True
            if hi <= lo:
                continue
            if self._in_turn:
                self._angle_parts.append(batch.angle_q6[lo:hi])
                self._distance_parts.append(batch.distance_q2[lo:hi])
            else:
                self.partial_nodes += hi - lo

    def _finish_turn(self) -> Revolution:
        angle_q6 = np.concatenate(self._angle_parts)
        distance_q2 = np.concatenate(self._distance_parts)
        self._angle_parts.clear()
        self._distance_parts.clear()
        # heading clockwise -> counter-clockwise, wrapped to [-pi, pi)
        angles = -angle_q6.astype(np.float64) * Q6_TO_RAD
        angles = np.mod(angles + math.pi, 2.0 * math.pi) - math.pi
        ranges = distance_q2.astype(np.float64) * MM_Q2_TO_M
        ranges[(distance_q2 == 0) | (ranges > self.range_cap_m)] = np.inf
        order = np.argsort(angles, kind="stable")
        self.revolutions += 1
        return Revolution(angles[order], ranges[order], len(order))


class RplidarDriver:
    """An RPLIDAR A1 in standard scan mode on a serial port.

    Parameters
    ----------
    port : str
        The serial device (``/dev/jackson-lidar``, or the twin's pty).
    baudrate : int
        The A1's fixed 115200 baud.
    range_cap_m : float
        Readings above this read ``inf`` [m] (the robot's software cap).
    answer_timeout_s : float
        How long to wait for each answer during :meth:`start` [s].

    Attributes
    ----------
    info : DeviceInfo or None
        The device's GET_INFO answer, once started.
    health : DeviceHealth or None
        The device's GET_HEALTH answer, once started (a warning is kept here; an error
        refuses to start).
    revolutions : int
        Revolutions handed out by :meth:`poll`.
    partial_nodes : int
        Nodes before the first S flag of a scan (a turn begun before the scan), dropped.

    Raises
    ------
    LidarError
        The port is missing, not permitted or in use.
    ValueError
        A cap or timeout that is not positive.
    """

    def __init__(
        self,
        port: str,
        baudrate: int = 115200,
        *,
        range_cap_m: float = RANGE_CAP_M,
        answer_timeout_s: float = ANSWER_TIMEOUT_S,
    ) -> None:
        if not answer_timeout_s > 0.0:
            raise ValueError(f"answer_timeout_s must be > 0, got {answer_timeout_s}")
        self.port_name = port
        self.range_cap_m = range_cap_m
        self.answer_timeout_s = answer_timeout_s
        try:
            self._port = serial.Serial(port, baudrate, timeout=0, write_timeout=0, exclusive=True)
        except (serial.SerialException, OSError) as exc:
            raise open_error(port, exc) from exc
        self._fd = self._port.fileno()
        os.set_blocking(self._fd, False)
        self.assembler = RevolutionAssembler(range_cap_m)
        self.decoder = self.assembler.decoder
        self.info: DeviceInfo | None = None
        self.health: DeviceHealth | None = None
        self.scanning = False
        self._answers = self.assembler.answers
        self._ready: list[Revolution] = []  # completed, not yet handed out

    # ------------------------------------------------------------------ counters

    @property
    def malformed_bytes(self) -> int:
        """Bytes the decoder skipped (bad start flags, bad check bit, unknown descriptors)."""
        return self.decoder.malformed_bytes

    @property
    def nodes(self) -> int:
        """Valid nodes decoded."""
        return self.decoder.nodes

    # ------------------------------------------------------------------ I/O

    def _write(self, packet: bytes) -> None:
        view = memoryview(packet)
        deadline = time.monotonic() + self.answer_timeout_s
        while view:
            try:
                view = view[os.write(self._fd, view) :]
            except BlockingIOError:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise LidarError(
                        f"cannot write to the LiDAR port {self.port_name}: output is stuck"
                    ) from None
                select.select([], [self._fd], [], left)
            except OSError as exc:
                raise LidarError(f"LiDAR port {self.port_name} failed: {exc.strerror}") from exc

    def _read_available(self) -> bytes:
        """Everything the port holds now: reads until it would block (a tty hands out at
        most its line discipline's buffer per read), at most ``MAX_READ_BYTES``."""
        chunks: list[bytes] = []
        total = 0
        while total < MAX_READ_BYTES:
            try:
                data = os.read(self._fd, READ_CHUNK)
            except BlockingIOError:
                break
            except OSError as exc:
                raise LidarError(
                    f"LiDAR port {self.port_name} went away ({exc.strerror}): is it unplugged?"
                ) from exc
            if not data:  # nothing now (the port reads with VMIN 0), or the other end hung up
                if not chunks and self._hung_up():
                    raise LidarError(
                        f"LiDAR port {self.port_name} went away (hung up): is it unplugged?"
                    )
                break
            chunks.append(data)
            total += len(data)
        return b"".join(chunks)

    def _hung_up(self) -> bool:
        """Whether the port reports a hang-up (a pty whose other end closed, a USB adapter
        gone): a read then returns nothing rather than failing."""
        poller = select.poll()
        poller.register(self._fd, select.POLLIN)
        return any(ev & (select.POLLHUP | select.POLLERR) for _, ev in poller.poll(0))

    def _wait_readable(self, timeout_s: float) -> bool:
        return bool(select.select([self._fd], [], [], max(0.0, timeout_s))[0])

    def _set_motor(self, on: bool) -> None:
        """MOTOCTL follows DTR inverted on the A1's adapter board; a pty has no DTR."""
        try:
            self._port.dtr = not on
        except (serial.SerialException, OSError) as exc:
            if getattr(exc, "errno", None) not in (errno.ENOTTY, errno.EINVAL):
                raise LidarError(
                    f"cannot switch the LiDAR motor on {self.port_name}: {exc}"
                ) from exc

    # ------------------------------------------------------------------ start and stop

    def _wait_silence(self) -> None:
        deadline = time.monotonic() + SILENCE_TIMEOUT_S
        while self._wait_readable(SILENCE_S):
            self._read_available()
            if time.monotonic() > deadline:
                raise LidarError(
                    f"the device on {self.port_name} keeps sending after STOP: "
                    "is it an RPLIDAR, at 115200 baud?"
                )

    def _ask(self, command: Command, wanted: type, what: str) -> ResponseItem:
        """Send ``command`` and return its answer of type ``wanted`` (a SCAN: the descriptor)."""
        self._answers.clear()
        self._write(encode_request(command))
        deadline = time.monotonic() + self.answer_timeout_s
        while True:
            for item in self._answers:
                if isinstance(item, wanted):
                    self._answers.clear()
                    return item
            self._answers.clear()
            left = deadline - time.monotonic()
            if left <= 0:
                raise LidarError(
                    f"no answer to {what} from {self.port_name} within "
                    f"{self.answer_timeout_s:g} s: is the RPLIDAR powered, and is this its port?"
                )
            if self._wait_readable(left):
                self._consume(self._read_available())

    def start(self) -> None:
        """Stop whatever the device was doing, check it, and start the standard scan.

        Raises
        ------
        LidarError
            No answer to GET_HEALTH, GET_INFO or SCAN within ``answer_timeout_s``, a device
            that keeps sending after STOP, or a health status of ERROR.
        """
        self.scanning = False
        self._write(encode_request(Command.STOP))
        self._wait_silence()
        self.decoder.reset()
        self._reset_turn()
        health = self._ask(Command.GET_HEALTH, DeviceHealth, "GET_HEALTH")
        assert isinstance(health, DeviceHealth)
        self.health = health
        if health.status == HealthStatus.ERROR:
            raise LidarError(
                f"the RPLIDAR on {self.port_name} reports health ERROR (code "
                f"{health.error_code:#06x}): power-cycle it (unplug its USB cable) and retry"
            )
        info = self._ask(Command.GET_INFO, DeviceInfo, "GET_INFO")
        assert isinstance(info, DeviceInfo)
        self.info = info
        self._set_motor(True)
        self._reset_turn()
        descriptor = self._ask(Command.SCAN, Descriptor, "SCAN")
        assert isinstance(descriptor, Descriptor)
        if descriptor.data_type != DataType.MEASUREMENT:
            raise LidarError(f"the device on {self.port_name} answered SCAN with {descriptor}")
        self.scanning = True

    def stop(self) -> None:
        """STOP the scan and the motor (the port stays open; :meth:`start` scans again)."""
        self.scanning = False
        self._write(encode_request(Command.STOP))
        self._set_motor(False)
        self._reset_turn()

    def close(self) -> None:
        """Stop (best effort) and close the port."""
        if self._port.is_open:
            with contextlib.suppress(LidarError, OSError):
                self.stop()
            self._port.close()

    def __enter__(self) -> RplidarDriver:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ------------------------------------------------------------------ revolutions

    @property
    def revolutions(self) -> int:
        """Revolutions completed."""
        return self.assembler.revolutions

    @property
    def partial_nodes(self) -> int:
        """Nodes before the first S flag of a scan (a turn begun before the scan), dropped."""
        return self.assembler.partial_nodes

    def _reset_turn(self) -> None:
        self._ready.clear()
        self.assembler.reset_turn()

    def _consume(self, data: bytes) -> None:
        self._ready.extend(self.assembler.feed(data))

    def read(self) -> bytes:
        """The raw bytes available now, without decoding them (never blocks).

        For a caller that decodes and logs the stream itself (the daemon feeds them to its
        core's :class:`RevolutionAssembler` made with ``streaming=True``); do not mix with
        :meth:`poll`.

        Raises
        ------
        LidarError
            The port went away (the USB cable was pulled).
        """
        return self._read_available()

    def poll(self) -> list[Revolution]:
        """The revolutions completed since the last call, from the bytes available now.

        Never blocks: it reads what the port holds and returns (an empty list when no turn
        ended).

        Returns
        -------
        list of Revolution
            In the order the sensor finished them.

        Raises
        ------
        LidarError
            The port went away (the USB cable was pulled).
        """
        data = self._read_available()
        if data:
            self._consume(data)
            self._answers.clear()  # answers outside start() (none are asked for) are not kept
        revolutions, self._ready = self._ready, []
        return revolutions
