"""The host's driver of the RPLIDAR A1M8 on its USB serial adapter (docs/lidar.md).

:class:`RplidarDriver` opens the port and :meth:`~RplidarDriver.start` starts a scan: STOP,
silence, GET_HEALTH, GET_INFO, GET_LIDAR_CONF for the device's scan modes (a device that does
not answer it, firmware before 1.24, has the standard scan only), motor on, then SCAN or
EXPRESS_SCAN in the mode chosen (docs/lidar.md, "How the host chooses the scan mode"). At
each :meth:`~RplidarDriver.poll` it reads whatever bytes have arrived without blocking and
returns the revolutions they completed. A revolution ends where the node with the S flag (or,
in a capsule stream, the sample with the sync flag of
:class:`~jackson.protocol.rplidar.CapsuleDecoder`) that starts the next one arrives, so it is
handed over as soon as the sensor has finished it.

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
from typing import Protocol

import numpy as np
import numpy.typing as npt
import serial

from jackson.common.errors import JacksonError, PortKind, port_open_message
from jackson.common.geometry import wrap_angles
from jackson.protocol import native as protocol_native
from jackson.protocol.rplidar import (
    A1M8_SCAN_PERIOD_S,
    CAPSULE_FORMATS,
    DESCRIPTOR_BYTES,
    Q8,
    CapsuleDecoder,
    Command,
    ConfType,
    DataType,
    Descriptor,
    DeviceHealth,
    DeviceInfo,
    ExpressScanRequest,
    HealthStatus,
    LidarConf,
    NodeBatch,
    ResponseDecoder,
    ResponseItem,
    ScanMode,
    SendMode,
    decode_descriptor,
    decode_health,
    decode_info,
    decode_lidar_conf,
    decode_samplerate,
    encode_express_scan,
    encode_lidar_conf_query,
    encode_request,
)

__all__ = [
    "DECODED_ANSWER_TYPES",
    "DENSEST",
    "STANDARD",
    "LidarError",
    "Revolution",
    "RevolutionAssembler",
    "RplidarDriver",
    "choose_mode",
    "start_mode",
]

FloatArray = npt.NDArray[np.float64]

RANGE_CAP_M = 12.0  # [m] the A1M8's range (REFERENCE); navigation caps it at 8 m (AMCL)
ANSWER_TIMEOUT_S = 1.0  # [s] for GET_HEALTH, GET_INFO and the SCAN descriptor
SILENCE_S = 0.02  # [s] no byte for this long after STOP: the device has stopped sending
SILENCE_TIMEOUT_S = 1.0  # [s] a device still sending after this long ignores STOP
READ_CHUNK = 65536
MAX_READ_BYTES = 1 << 20  # one poll reads at most this much (a flood cannot hold it)
Q6_TO_RAD = math.pi / (180.0 * 64.0)
MM_Q2_TO_M = 1.0 / 4000.0
SCAN_PERIOD_S = A1M8_SCAN_PERIOD_S  # [s] the A1M8's turn (protocol/rplidar.py)
A1M8_STANDARD_US = 508  # [us] the A1M8's standard sample time (docs/lidar.md, "Scan modes")
FIRST_CONF_FIRMWARE = (1, 24)  # the first firmware that answers GET_LIDAR_CONF
MAX_ANSWER_BYTES = 255  # a single answer longer than this is a damaged descriptor
SYNC = bytes((0xA5, 0x5A))  # the start of every response descriptor
STANDARD = "standard"
"""The ``mode`` of :meth:`RplidarDriver.start` that runs SCAN (standard nodes)."""
DENSEST = "densest"
"""``--lidar-mode``'s word for :meth:`RplidarDriver.start`'s None: the densest mode."""


def start_mode(option: str) -> str | None:
    """:meth:`RplidarDriver.start`'s ``mode`` for a ``--lidar-mode`` value (``densest``: None)."""
    return None if option.lower() == DENSEST else option


DECODED_ANSWER_TYPES = frozenset({int(DataType.MEASUREMENT), *CAPSULE_FORMATS})
"""The scan answer types :class:`RevolutionAssembler` decodes: 0x81 nodes and the capsules."""


class LidarError(JacksonError, RuntimeError):
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


LIDAR_PORT = PortKind(
    "LiDAR port", "the RPLIDAR", "/dev/ttyUSB* or /dev/jackson-lidar, docs/lidar.md"
)


def open_error(port: str, exc: BaseException) -> LidarError:
    """A one-line explanation of why the LiDAR's ``port`` cannot be opened."""
    return LidarError(port_open_message(LIDAR_PORT, port, exc))


class RevolutionAssembler:
    """Revolutions out of the device's byte stream, free of I/O: what :meth:`RplidarDriver.poll`
    and the daemon's core (which logs the raw bytes, so ``jackson replay`` rebuilds the same
    scans) both run.

    The stream is standard nodes (SCAN, answer type 0x81) unless ``answer_type`` names a
    capsule format (EXPRESS_SCAN: 0x82 legacy, 0x84 ultra, 0x85 dense); capsules are decoded
    by :class:`~jackson.protocol.rplidar.CapsuleDecoder`, whose angle spreading and parallax
    model are the protocol's, and a turn then begins at the sample with its sync flag.

    Parameters
    ----------
    range_cap_m : float
        Readings above this read ``inf`` [m].
    streaming : bool
        Whether the stream is already past the scan's descriptor (nodes come first), as the
        bytes a started driver hands out with :meth:`RplidarDriver.read` are. A capsule
        stream is always past its descriptor.
    answer_type : int
        The scan's answer type (:attr:`RplidarDriver.answer_type`): 0x81 nodes, or a key
        of :data:`~jackson.protocol.rplidar.CAPSULE_FORMATS`.

    Attributes
    ----------
    decoder : ResponseDecoder or CapsuleDecoder
        The protocol decoder; its ``malformed_bytes`` counts skipped bytes.
    answer_type : int
        The answer type being decoded.
    samples : int
        Nodes or capsule samples decoded.
    revolutions : int
        Revolutions completed.
    partial_nodes : int
        Nodes (samples) before the first turn flag (a turn begun before the scan), dropped.

    Raises
    ------
    ValueError
        A cap that is not positive, or an answer type that is neither 0x81 nor a capsule
        format.
    """

    def __init__(
        self,
        range_cap_m: float = RANGE_CAP_M,
        *,
        streaming: bool = False,
        answer_type: int = DataType.MEASUREMENT,
    ) -> None:
        if not range_cap_m > 0.0:
            raise ValueError(f"range_cap_m must be > 0, got {range_cap_m}")
        self.range_cap_m = range_cap_m
        self.decoder: ResponseDecoder | CapsuleDecoder = ResponseDecoder(streaming=streaming)
        self.answer_type = int(DataType.MEASUREMENT)
        self.samples = 0
        self.revolutions = 0
        self.partial_nodes = 0
        self.answers: list[ResponseItem] = []  # descriptors and single responses, in order
        self._in_turn = False  # a turn flag has begun the turn being collected
        self._angle_parts: list[npt.NDArray[np.integer]] = []
        self._distance_parts: list[npt.NDArray[np.integer]] = []
        if answer_type != DataType.MEASUREMENT:
            self.expect(answer_type)

    def expect(self, answer_type: int) -> None:
        """Decode what is fed from now on as the stream of a scan in ``answer_type``, past its
        descriptor (after a new SCAN or EXPRESS_SCAN; the decoder's counters start again).

        Raises
        ------
        ValueError
            An answer type that is neither 0x81 nor a capsule format.
        """
        if answer_type == DataType.MEASUREMENT:
            self.decoder = ResponseDecoder(streaming=True)
        elif answer_type in CAPSULE_FORMATS:
            self.decoder = CapsuleDecoder(answer_type)
        else:
            raise ValueError(f"the host decodes no scan of answer type {answer_type:#04x}")
        self.answer_type = int(answer_type)
        self.reset_turn()

    def reset_turn(self) -> None:
        """Drop the turn being collected (after STOP, or a new scan)."""
        self._in_turn = False
        self._angle_parts.clear()
        self._distance_parts.clear()

    def feed(self, data: bytes) -> list[Revolution]:
        """The revolutions ``data`` completes (other items go to :attr:`answers`)."""
        done: list[Revolution] = []
        if isinstance(self.decoder, CapsuleDecoder):
            batch = self.decoder.feed(data)
            if len(batch):
                self._collect(batch.start, batch.angle_q6, batch.distance_q2, done)
            return done
        for item in self.decoder.feed(data):
            if isinstance(item, NodeBatch):
                self._collect(item.start, item.angle_q6, item.distance_q2, done)
            else:
                self.answers.append(item)
        return done

    def _collect(
        self,
        start: npt.NDArray[np.bool_],
        angle_q6: npt.NDArray[np.integer],
        distance_q2: npt.NDArray[np.integer],
        done: list[Revolution],
    ) -> None:
        self.samples += len(start)
        starts = np.flatnonzero(start)
        bounds = [0, *starts.tolist(), len(start)]
        for k in range(len(bounds) - 1):
            lo, hi = bounds[k], bounds[k + 1]
            if k > 0:  # a turn flag at lo: the turn being collected is complete
                if self._in_turn:
                    done.append(self._finish_turn())
                self._in_turn = True
            if hi <= lo:
                continue
            if self._in_turn:
                self._angle_parts.append(angle_q6[lo:hi])
                self._distance_parts.append(distance_q2[lo:hi])
            else:
                self.partial_nodes += hi - lo

    def _finish_turn(self) -> Revolution:
        angle_q6 = np.concatenate(self._angle_parts)
        distance_q2 = np.concatenate(self._distance_parts)
        self._angle_parts.clear()
        self._distance_parts.clear()
        if protocol_native.LIB is not None:  # the same numbers, compiled
            angles, ranges = protocol_native.rplidar_turn(
                angle_q6, distance_q2, Q6_TO_RAD, MM_Q2_TO_M, self.range_cap_m
            )
            self.revolutions += 1
            return Revolution(angles, ranges, len(angles))
        # heading clockwise -> counter-clockwise, wrapped to [-pi, pi)
        angles = -angle_q6.astype(np.float64) * Q6_TO_RAD
        angles = wrap_angles(angles)
        ranges = distance_q2.astype(np.float64) * MM_Q2_TO_M
        ranges[(distance_q2 == 0) | (ranges > self.range_cap_m)] = np.inf
        order = np.argsort(angles, kind="stable")
        self.revolutions += 1
        return Revolution(angles[order], ranges[order], len(order))


def choose_mode(modes: tuple[ScanMode, ...], typical_id: int | None) -> ScanMode | None:
    """The densest mode the host decodes: the fewest us per sample among the answer types
    :class:`RevolutionAssembler` reads (0x81 and the capsule formats), the typical mode first
    on a tie, then the lower id; None when none is decodable."""
    usable = [m for m in modes if m.answer_type in DECODED_ANSWER_TYPES]
    if not usable:
        return None
    return min(usable, key=lambda m: (m.us_per_sample_q8, m.id != typical_id, m.id))


class LidarSource(Protocol):
    """What the daemon needs of a started LiDAR (:class:`RplidarDriver` is one): its raw bytes
    (the core decodes and logs them), the stream's answer type, and what a run folder's meta
    records of it."""

    info: DeviceInfo | None  # the device, when it told
    mode: ScanMode | None  # the scan mode started (None: not started)

    @property
    def answer_type(self) -> int:
        """The data answer type of the stream (what the core decodes the bytes as)."""
        ...

    def read(self) -> bytes:
        """The raw bytes available now (never blocks)."""
        ...


class RplidarDriver:
    """An RPLIDAR A1 on a serial port, in the scan mode :meth:`start` chooses.

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
    modes : tuple of ScanMode
        The scan modes GET_LIDAR_CONF listed at the last :meth:`start` (empty for a device
        that does not answer it).
    typical_mode : int or None
        The id of the device's typical mode, when it said.
    mode : ScanMode or None
        The mode running since :meth:`start` (name, us per sample, answer type); without
        GET_LIDAR_CONF, Standard at GET_SAMPLERATE's standard time.
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
        self.info: DeviceInfo | None = None
        self.health: DeviceHealth | None = None
        self.modes: tuple[ScanMode, ...] = ()
        self.typical_mode: int | None = None
        self.mode: ScanMode | None = None
        self.scanning = False
        self._raw = bytearray()  # answers during start(), not yet taken
        self._skipped = 0  # bytes start() found no answer in
        self._ready: list[Revolution] = []  # completed, not yet handed out
        self._tail = b""  # scan bytes read with the scan's descriptor, not yet handed out

    # ------------------------------------------------------------------ counters

    @property
    def decoder(self) -> ResponseDecoder | CapsuleDecoder:
        """The protocol decoder of the running scan's stream."""
        return self.assembler.decoder

    @property
    def malformed_bytes(self) -> int:
        """Bytes skipped since the last :meth:`start` (bad start flags or check bits, bad
        capsule checksums, unknown descriptors)."""
        return self._skipped + self.decoder.malformed_bytes

    @property
    def nodes(self) -> int:
        """Valid nodes (or capsule samples) decoded."""
        return self.assembler.samples

    @property
    def answer_type(self) -> int:
        """The answer type of the running scan's stream (what a :class:`RevolutionAssembler`
        fed with :meth:`read`'s bytes must :meth:`~RevolutionAssembler.expect`)."""
        return self.mode.answer_type if self.mode is not None else int(DataType.MEASUREMENT)

    @property
    def samples_per_revolution_expected(self) -> float | None:
        """Samples a turn the running mode gives at the A1M8's 7.43 Hz (None before
        :meth:`start`): 1060.2 in Sensitivity, 265.1 in the A1's Standard."""
        if self.mode is None:
            return None
        return SCAN_PERIOD_S * 1e6 / self.mode.us_per_sample

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

    def _ask(
        self,
        command: Command,
        what: str,
        data_type: int,
        payload: bytes = b"",
        *,
        conf_type: int | None = None,
        required: bool = True,
    ) -> tuple[Descriptor, bytes] | None:
        """Send ``command`` and wait for its answer of ``data_type``: a single response's
        descriptor and payload (of a GET_LIDAR_CONF answer: for ``conf_type``), or a scan's
        descriptor and the stream bytes that came with it. None when no answer came within
        ``answer_timeout_s`` and the answer is not ``required``.

        Raises
        ------
        LidarError
            No answer to a ``required`` request.
        """
        self._raw.clear()
        self._write(encode_request(command, payload))
        deadline = time.monotonic() + self.answer_timeout_s
        while True:
            answer = self._take_answer(data_type, conf_type)
            if answer is not None:
                return answer
            left = deadline - time.monotonic()
            if left <= 0:
                if not required:
                    return None
                raise LidarError(
                    f"no answer to {what} from {self.port_name} within "
                    f"{self.answer_timeout_s:g} s: is the RPLIDAR powered, and is this its port?"
                )
            if self._wait_readable(left):
                self._raw += self._read_available()

    def _take_answer(
        self, data_type: int, conf_type: int | None
    ) -> tuple[Descriptor, bytes] | None:
        """The wanted answer at the front of the bytes read so far, skipping what precedes it
        (other answers: a late one to an earlier request; bytes that start none)."""
        buf = self._raw
        while True:
            at = buf.find(SYNC)
            if at < 0:
                keep = 1 if buf.endswith(SYNC[:1]) else 0
                self._skipped += len(buf) - keep
                del buf[: len(buf) - keep]
                return None
            self._skipped += at
            del buf[:at]
            d = decode_descriptor(bytes(buf))
            if d is None:
                return None  # the rest of the descriptor is still to come
            if d.send_mode == SendMode.MULTIPLE:
                if d.data_type == data_type:
                    rest = bytes(buf[DESCRIPTOR_BYTES:])
                    buf.clear()
                    return d, rest
                self._skipped += 1
                del buf[:1]
                continue
            if d.length > MAX_ANSWER_BYTES:
                self._skipped += 1
                del buf[:1]
                continue
            end = DESCRIPTOR_BYTES + d.length
            if len(buf) < end:
                return None
            payload = bytes(buf[DESCRIPTOR_BYTES:end])
            del buf[:end]
            if d.data_type != data_type:
                continue
            if conf_type is not None and (
                len(payload) < 4 or decode_lidar_conf(payload).conf_type != conf_type
            ):
                continue
            return d, payload

    def _conf(self, conf_type: ConfType, mode_id: int | None = None) -> LidarConf | None:
        """A GET_LIDAR_CONF entry, or None when the device did not answer it."""
        answer = self._ask(
            Command.GET_LIDAR_CONF,
            "GET_LIDAR_CONF",
            DataType.LIDAR_CONF,
            encode_lidar_conf_query(conf_type, mode_id),
            conf_type=conf_type,
            required=False,
        )
        if answer is None:
            return None
        conf = decode_lidar_conf(answer[1])
        return conf if conf.value else None

    def _scan_modes(self) -> tuple[tuple[ScanMode, ...], int | None]:
        """The device's scan modes and typical mode (none: it does not answer
        GET_LIDAR_CONF, as firmware before 1.24)."""
        count = self._conf(ConfType.SCAN_MODE_COUNT)
        if count is None or len(count.value) < 2:
            return (), None
        typical = self._conf(ConfType.SCAN_MODE_TYPICAL)
        modes = []
        for i in range(count.u16):
            us = self._conf(ConfType.SCAN_MODE_US_PER_SAMPLE, i)
            answer_type = self._conf(ConfType.SCAN_MODE_ANS_TYPE, i)
            if us is None or answer_type is None or len(us.value) < 4:
                continue  # a mode the device does not describe cannot be chosen
            distance = self._conf(ConfType.SCAN_MODE_MAX_DISTANCE, i)
            name = self._conf(ConfType.SCAN_MODE_NAME, i)
            modes.append(
                ScanMode(
                    i,
                    name.text if name is not None else f"mode {i}",
                    us.u32,
                    distance.u32 if distance is not None and len(distance.value) >= 4 else 0,
                    answer_type.u8,
                )
            )
        typical_id = typical.u16 if typical is not None and len(typical.value) >= 2 else None
        return tuple(modes), typical_id

    def _standard_without_conf(self) -> ScanMode:
        """Standard as GET_SAMPLERATE times it (the A1M8's 508 us if it does not answer)."""
        answer = self._ask(
            Command.GET_SAMPLERATE, "GET_SAMPLERATE", DataType.SAMPLE_RATE, required=False
        )
        us = decode_samplerate(answer[1]).standard_us if answer is not None else A1M8_STANDARD_US
        return ScanMode(0, "Standard", us * Q8, 0, DataType.MEASUREMENT)

    def _pick(self, mode: str | None) -> ScanMode:
        """The mode :meth:`start` runs for its ``mode`` argument."""
        if mode is None:
            chosen = choose_mode(self.modes, self.typical_mode)
        elif mode.lower() == STANDARD:
            chosen = next((m for m in self.modes if m.answer_type == DataType.MEASUREMENT), None)
        else:
            chosen = next((m for m in self.modes if m.name.lower() == mode.lower()), None)
            if chosen is None or chosen.answer_type not in DECODED_ANSWER_TYPES:
                names = ", ".join(
                    m.name for m in self.modes if m.answer_type in DECODED_ANSWER_TYPES
                )
                raise LidarError(
                    f"the RPLIDAR on {self.port_name} has no scan mode {mode!r} the host "
                    f"decodes (it offers: {names or 'the standard scan only'})"
                )
        return chosen if chosen is not None else self._standard_without_conf()

    def start(self, mode: str | None = None) -> None:
        """Stop whatever the device was doing, check it, choose a scan mode and start it.

        Parameters
        ----------
        mode : str or None
            None (the default): the densest mode the host decodes (:func:`choose_mode`;
            Sensitivity on an A1M8 with firmware 1.29, SCAN on a device that does not answer
            GET_LIDAR_CONF). ``"standard"``: SCAN, standard nodes. A mode's name
            (``"Boost"``, ``"Express"``, any case): that mode. A caller that decodes the raw
            bytes itself (:meth:`read`) tells its assembler :attr:`answer_type`.

        Raises
        ------
        LidarError
            No answer to GET_HEALTH, GET_INFO, SCAN or EXPRESS_SCAN within
            ``answer_timeout_s``, a device that keeps sending after STOP, a health status of
            ERROR, or a named mode the device does not offer.
        """
        self.scanning = False
        self.mode = None
        self._write(encode_request(Command.STOP))
        self._wait_silence()
        self._raw.clear()
        self._skipped = 0
        self._reset_turn()
        health = self._ask(Command.GET_HEALTH, "GET_HEALTH", DataType.DEVICE_HEALTH)
        assert health is not None
        self.health = decode_health(health[1])
        if self.health.status == HealthStatus.ERROR:
            raise LidarError(
                f"the RPLIDAR on {self.port_name} reports health ERROR (code "
                f"{self.health.error_code:#06x}): power-cycle it (unplug its USB cable) and retry"
            )
        info = self._ask(Command.GET_INFO, "GET_INFO", DataType.DEVICE_INFO)
        assert info is not None
        self.info = decode_info(info[1])
        has_conf = (self.info.firmware_major, self.info.firmware_minor) >= FIRST_CONF_FIRMWARE
        self.modes, self.typical_mode = self._scan_modes() if has_conf else ((), None)
        chosen = self._pick(mode)
        self._set_motor(True)
        self._reset_turn()
        if chosen.answer_type == DataType.MEASUREMENT:
            scan = self._ask(Command.SCAN, "SCAN", DataType.MEASUREMENT)
        else:
            request = encode_express_scan(ExpressScanRequest(working_mode=chosen.id))
            scan = self._ask(
                Command.EXPRESS_SCAN, f"EXPRESS_SCAN ({chosen.name})", chosen.answer_type, request
            )
        assert scan is not None
        self.assembler.expect(chosen.answer_type)
        self.mode = chosen
        self.scanning = True
        self._tail = bytes(scan[1])  # the stream's first bytes: read() and poll() give them

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
        self._tail = b""
        self.assembler.reset_turn()
        self.assembler.answers.clear()

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
        data, self._tail = self._tail + self._read_available(), b""
        return data

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
        data, self._tail = self._tail + self._read_available(), b""
        if data:
            self._consume(data)
            self.assembler.answers.clear()  # answers outside start(): none asked, none kept
        revolutions, self._ready = self._ready, []
        return revolutions
