"""The twin's RPLIDAR A1M8 (firmware 1.29): Slamtec's serial protocol on a pty of its own.

The host opens the pty as it opens ``/dev/jackson-lidar`` on the robot and drives it with the
same requests (docs/lidar.md). :meth:`RplidarEmulator.serve` answers them as an A1M8 with
firmware 1.29 does: GET_HEALTH good, GET_INFO with the twin's identity (:data:`TWIN_INFO`),
GET_SAMPLERATE, GET_LIDAR_CONF for the scan-mode entries (:data:`A1M8_SCAN_MODES`, typical
mode Sensitivity), SCAN and FORCE_SCAN with their descriptor and nodes, EXPRESS_SCAN in the
capsule format of the mode asked for; STOP and RESET end a scan and send nothing (the real A1
prints a boot banner after RESET, the twin does not). As on the device, any request ends a
running scan first. A GET_LIDAR_CONF entry the A1 does not describe (the SDK asks for the
motor's desired speed, 0x01) gets no answer, and neither does a command the twin does not know.

Time is the caller's: the twin's runner advances a scan on the wall clock before the MCU's
session (the world standing still) and on the simulation's clock from the session's start,
where :meth:`RplidarEmulator.resume` takes the scan over to the new clock.

The motor needs no DTR: on the A1's USB adapter DTR switches MOTOCTL, but a pty has no modem
lines, so the twin's head always turns and a scan starts on its request alone.

While scanning, :meth:`RplidarEmulator.advance` writes one revolution per ``scan_period_s``
of simulation time (0.13465 s, 7.43 Hz), revolution ``k`` ending at ``k * scan_period_s``, the
head at heading 0 (clockwise) at each of these instants. The ranges come from the caller, one
array per revolution in the twin's beam order (:class:`~jackson.sim.lidar.LidarSpec`:
``angle_min + i * increment``, counter-clockwise, ``inf`` for no return); beam ``i`` has the
heading ``-angle_i`` wrapped to [0°, 360°) (docs/lidar.md, "Frames").

**SCAN and FORCE_SCAN** run Standard as the A1M8 does, at 508 us a sample (265 nodes a
revolution, about 2 k samples/s), sampled from the twin's beams as the express modes are (below).
With ``device_standard_scan=False`` they send the twin's own beams instead: ``spec.beams``
standard nodes per revolution (the paper's 1080, 8000 a second), in the order the head meets
them, quality 47 for a return and 0 with distance 0 for none, S on the first; GET_LIDAR_CONF
and GET_SAMPLERATE then report Standard's sample time as ``scan_period_s / beams`` (124.7 us),
so what the device says and sends agree. Each revolution goes out whole at the instant it
ends, together with the S node of the next one, which the head measures at that same instant;
so a host sees a revolution complete as soon as it has ended, before the telemetry frame the
twin writes next (lockstep stays deterministic).

**EXPRESS_SCAN** runs the mode named by its working mode (0: the legacy express scan, as
Express) at the mode's sample time: sample ``n`` is taken at ``t0 + n * us_per_sample`` with
the head at ``360° * frac(t / scan_period_s)``, its distance read off that revolution's ranges
at that heading (:func:`ranges_at`: the twin casts its 1080 beams, the emulator interpolates
between the two around each sample), so revolutions hold a non-integer number of samples and
their headings drift from one turn to the next, as on the device (Sensitivity, 127 us: 1060.2
a revolution). The samples are cut into the mode's capsules in stream order (32, 96 or 40 a
capsule), each stamped with its first sample's raw angle; a revolution's capsules go out at
its end (a capsule waits for the next revolution when it is not full, an ultra capsule also
for the next capsule's first sample, which its last prediction needs). The first capsule of a
stream, and the first after a gap, carries the S bit. Legacy capsules carry ``dtheta = 0``
(the twin's head has no parallax: the raw angle is the heading). Ultra capsules carry no
correction and every decoder (Slamtec's SDK, pyrplidar,
:class:`~jackson.protocol.rplidar.CapsuleDecoder`) subtracts the A-series' parallax model
(:func:`~jackson.protocol.rplidar.ultra_angle_offset_q16`, about 7.3° at 2 m) from the raw
angle; the emulator therefore ranges each ultra sample at ``raw - offset(distance)``, found by
a fixed-point iteration, so the decoded heading is where the distance was measured.

Writes never block the twin: a revolution that does not fit the pty's buffer (nobody reads)
is dropped whole and counted; in SCAN the next one then carries its own S node again, in
EXPRESS_SCAN the next capsule carries the S bit.

A revolution the twin lost (a ``lidar_dropout`` fault, :mod:`jackson.sim.faults`) puts nothing
on the line: in SCAN its nodes and the next turn's S node never come, so the S node already
sent (measured as the lost turn began) starts the next revolution the host sees, one period
later; in EXPRESS_SCAN its samples are never taken and the capsule after the gap carries the
S bit.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from jackson.protocol import native as protocol_native
from jackson.protocol.rplidar import (
    ANGLE_Q6_TURN,
    CAPSULE_DISTANCE_MM_MAX,
    CAPSULE_FORMATS,
    CAPSULED,
    NODE_BYTES,
    Q8,
    SCAN_DESCRIPTOR,
    ULTRA_CAPSULED,
    CapsuleFormat,
    Command,
    DataType,
    DeviceHealth,
    DeviceInfo,
    HealthStatus,
    Request,
    RequestDecoder,
    SampleRate,
    ScanMode,
    decode_express_scan,
    decode_lidar_conf_query,
    encode_capsule,
    encode_dense_capsule,
    encode_nodes,
    encode_ultra_cabins,
    lidar_conf_response,
    response,
    scan_mode_conf,
    ultra_capsule_of_cabins,
)
from jackson.sim.lidar import LidarSpec
from jackson.sim.link import PtyLink
from jackson.sim.rplidar_ranges import (
    millimetres,
    parallax_ranged,
    ranges_at,
)

__all__ = [
    "A1M8_SAMPLE_RATE",
    "A1M8_SCAN_MODES",
    "A1M8_TYPICAL_MODE",
    "QUALITY_RETURN",
    "TWIN_HEALTH",
    "TWIN_INFO",
    "DeviceAnswers",
    "RplidarEmulator",
    "ranges_at",
]

QUALITY_RETURN = 47
"""Quality of a node with a return (a typical A1 value; 0 for no return)."""

TWIN_INFO = DeviceInfo(
    model=0x18,  # A1M8
    firmware_minor=29,
    firmware_major=1,
    hardware=7,
    serial=b"JACKSON TWIN A1\x00",
)
"""What the twin's GET_INFO answers: an A1M8, firmware 1.29, hardware 7, serial number
``4A41434B534F4E205457494E20413100`` (ASCII ``JACKSON TWIN A1``)."""

TWIN_HEALTH = DeviceHealth(HealthStatus.GOOD, 0)
"""What the twin's GET_HEALTH answers: good, no error."""

A1M8_MAX_DISTANCE_Q8 = 12 * Q8  # 12 m, every mode
A1M8_SCAN_MODES = (
    ScanMode(0, "Standard", 508 * Q8, A1M8_MAX_DISTANCE_Q8, DataType.MEASUREMENT),
    ScanMode(1, "Express", 254 * Q8, A1M8_MAX_DISTANCE_Q8, DataType.MEASUREMENT_CAPSULED),
    ScanMode(2, "Boost", 127 * Q8, A1M8_MAX_DISTANCE_Q8, DataType.MEASUREMENT_ULTRA_CAPSULED),
    ScanMode(3, "Sensitivity", 127 * Q8, A1M8_MAX_DISTANCE_Q8, DataType.MEASUREMENT_ULTRA_CAPSULED),
    ScanMode(4, "Stability", 201 * Q8, A1M8_MAX_DISTANCE_Q8, DataType.MEASUREMENT_ULTRA_CAPSULED),
)
"""The scan modes an A1M8 with firmware 1.29 (hardware 7) reports through GET_LIDAR_CONF, as
dumped from real units (docs/lidar.md, "Scan modes"): 508, 254, 127, 127 and 201 us a sample,
12 m, answer types 0x81, 0x82, 0x84, 0x84, 0x84."""
A1M8_TYPICAL_MODE = 3
"""Its typical mode: Sensitivity."""
A1M8_SAMPLE_RATE = SampleRate(508, 254)
"""Its GET_SAMPLERATE answer [us]: Standard's and Express's sample times."""

KNOWN_COMMANDS = frozenset(int(c) for c in Command)
TIME_TOLERANCE_S = 1e-9  # a revolution ending this close after t_s counts as ended at t_s
RECENT_REQUESTS = 256

# a revolution's ranges, or (its ranges, what the next turn's first beams read just after it
# ended: the lookahead samples' ranges), or None for a revolution lost
RangesFn = Callable[[float], npt.ArrayLike | tuple[npt.ArrayLike, npt.ArrayLike] | None]
F64Array = npt.NDArray[np.float64]
I64Array = npt.NDArray[np.int64]
ScalarT = TypeVar("ScalarT", bound=np.generic)


class _SampleStream:
    """A running scan at a mode's own sample time: which samples each revolution holds, their
    distances, and the wire units (standard nodes or capsules) they fill."""

    def __init__(self, spec: LidarSpec, mode: ScanMode, t0_s: float) -> None:
        self.spec = spec
        self.format: CapsuleFormat | None = CAPSULE_FORMATS.get(mode.answer_type)
        self.dt_s = mode.us_per_sample * 1e-6
        self.t0_s = t0_s  # sample 0, at heading 0
        self.next_n = 0  # the next sample to take
        self.heading_deg: F64Array = np.zeros(0)  # raw angles of samples not yet in a capsule
        self.distance_mm: I64Array = np.zeros(0, dtype=np.int64)
        self.start_bit = True  # the next capsule starts a stream
        self.samples = 0
        self.edge_dropouts = 0  # ultra samples at an edge sent as no return

    def _sample_range(self, end_s: float) -> tuple[int, int]:
        """Samples ``[n0, n1)``: those of the revolution ending at ``end_s``."""
        n1 = max(self.next_n, math.ceil((end_s - self.t0_s) / self.dt_s - TIME_TOLERANCE_S))
        return self.next_n, n1

    def lose(self, end_s: float) -> None:
        """The revolution ending at ``end_s`` was lost: its samples are never taken."""
        self.next_n = self._sample_range(end_s)[1]
        self.heading_deg = np.zeros(0)
        self.distance_mm = np.zeros(0, dtype=np.int64)
        self.start_bit = True

    def restart(self) -> None:
        """What was sent did not reach the line: the next capsule starts a stream."""
        self.start_bit = True

    @property
    def lookahead(self) -> int:
        """Samples past a revolution's end sent with it: what a host needs to see the turn end
        as soon as a device streaming them would show it. Nodes: the next turn's first (its
        S flag ends the turn). Capsules: a decoder places a capsule's samples when the next
        capsule arrives, so the capsule holding the next turn's first sample and the one
        after it (an ultra capsule also the first sample of the capsule after that, which
        its last prediction needs): 24.5 ms of samples in Sensitivity, 16 ms in Express."""
        fmt = self.format
        if fmt is None:
            return 1
        return 2 * fmt.samples + (1 if fmt is ULTRA_CAPSULED else 0)

    def revolution(
        self, end_s: float, ranges_m: F64Array, ahead_m: F64Array | None = None
    ) -> bytes:
        """Take the samples of the revolution ending at ``end_s``, and the :attr:`lookahead`
        samples of the next one, ranged on ``ahead_m`` (what the beams of the next turn's
        beginning read just after this one ended; None: on ``ranges_m``, which a scan of a
        robot standing still is); the wire bytes they complete."""
        n0, n_end = self._sample_range(end_s)
        n1 = max(n0, n_end + self.lookahead)
        self.next_n = n1
        self.samples += n1 - n0
        period = self.spec.scan_period_s
        n = np.arange(n0, n1)
        t = self.t0_s + n * self.dt_s
        heading = 360.0 * np.mod((t - (end_s - period)) / period, 1.0)
        if self.format is None:
            # S on the first sample of each turn: the first at or after a turn boundary
            turn = np.floor((t - self.t0_s) / period + TIME_TOLERANCE_S)
            before = np.floor((t - self.dt_s - self.t0_s) / period + TIME_TOLERANCE_S)
            start = (turn > before) | (n == 0)
            ranges = self._split(n < n_end, heading, ranges_m, ahead_m, self._ranges_at)
            return self._nodes(heading, ranges, start)
        mm: I64Array
        if self.format is ULTRA_CAPSULED:
            mm = self._split(n < n_end, heading, ranges_m, ahead_m, self._parallax_ranged)
        else:
            top = CAPSULE_DISTANCE_MM_MAX if self.format is CAPSULED else 0xFFFF
            r = self._split(n < n_end, heading, ranges_m, ahead_m, self._ranges_at)
            mm = millimetres(r, top)
        self.heading_deg = np.concatenate((self.heading_deg, heading))
        self.distance_mm = np.concatenate((self.distance_mm, mm))
        return self._capsules()

    def _ranges_at(self, ranges_m: F64Array, heading: F64Array) -> F64Array:
        return ranges_at(self.spec, ranges_m, heading)

    @staticmethod
    def _split(
        own: npt.NDArray[np.bool_],
        heading: F64Array,
        ranges_m: F64Array,
        ahead_m: F64Array | None,
        ranged: Callable[[F64Array, F64Array], npt.NDArray[ScalarT]],
    ) -> npt.NDArray[ScalarT]:
        """``ranged(ranges, heading)`` of the samples, those not ``own`` (the next turn's
        first) ranged on ``ahead_m`` when given."""
        if ahead_m is None or own.all():
            return ranged(ranges_m, heading)
        return np.concatenate((ranged(ranges_m, heading[own]), ranged(ahead_m, heading[~own])))

    def _nodes(self, heading: F64Array, ranges: F64Array, start: npt.NDArray[np.bool_]) -> bytes:
        distance_q2 = 4 * millimetres(ranges, 0xFFFF // 4)
        angle_q6 = np.mod(np.rint(heading * 64.0).astype(np.int64), ANGLE_Q6_TURN)
        quality = np.where(distance_q2 > 0, QUALITY_RETURN, 0)
        return encode_nodes(start, quality, angle_q6, distance_q2)

    def _parallax_ranged(self, ranges_m: F64Array, raw_deg: F64Array) -> I64Array:
        """Distances [mm] of ultra samples, each ranged where a decoder will place it
        (:func:`~jackson.sim.rplidar_ranges.parallax_ranged`); the edge dropouts counted."""
        mm, dropouts = parallax_ranged(self.spec, ranges_m, raw_deg)
        self.edge_dropouts += dropouts
        return mm

    def _capsules(self) -> bytes:
        fmt = self.format
        assert fmt is not None
        n = fmt.samples
        need = n + 1 if fmt is ULTRA_CAPSULED else n
        count = max(0, (len(self.distance_mm) - need) // n + 1)
        if fmt is ULTRA_CAPSULED:
            return self._ultra_capsules(count)
        out = []
        for c in range(count):
            d = self.distance_mm[c * n : c * n + need]
            start_q6 = int(np.rint(self.heading_deg[c * n] * 64.0)) % ANGLE_Q6_TURN
            if fmt is CAPSULED:
                out.append(encode_capsule(start_q6, self.start_bit, d))
            else:
                out.append(encode_dense_capsule(start_q6, self.start_bit, d))
            self.start_bit = False
        self.heading_deg = self.heading_deg[count * n :]
        self.distance_mm = self.distance_mm[count * n :]
        return b"".join(out)

    def _ultra_capsules(self, count: int) -> bytes:
        """The ``count`` ultra capsules due, their cabins encoded at once (5 ms a revolution
        one capsule at a time, most of it numpy's per-call cost)."""
        n = ULTRA_CAPSULED.samples
        if count == 0:
            return b""
        rows = np.arange(count)[:, None] * n + np.arange(n + 1)[None, :]
        d = np.asarray(self.distance_mm, np.int64)[rows]
        if protocol_native.LIB is not None:  # the same bytes, compiled
            q6 = np.rint(np.asarray(self.heading_deg)[: count * n : n] * 64.0).astype(np.int64)
            data, dropouts = protocol_native.ultra_capsules(d, q6 % ANGLE_Q6_TURN, self.start_bit)
            self.edge_dropouts += dropouts
            self.start_bit = False
            self.heading_deg = self.heading_deg[count * n :]
            self.distance_mm = self.distance_mm[count * n :]
            return data
        words, decoded_mm = encode_ultra_cabins(d)
        self.edge_dropouts += int(np.count_nonzero((decoded_mm == 0) & (d[:, :n] > 0)))
        start_q6 = np.rint(np.asarray(self.heading_deg)[: count * n : n] * 64.0).astype(np.int64)
        out = []
        for c in range(count):
            out.append(
                ultra_capsule_of_cabins(int(start_q6[c]) % ANGLE_Q6_TURN, self.start_bit, words[c])
            )
            self.start_bit = False
        self.heading_deg = self.heading_deg[count * n :]
        self.distance_mm = self.distance_mm[count * n :]
        return b"".join(out)


class _BeamScan:
    """SCAN with the twin's own beams: ``spec.beams`` standard nodes a revolution in the order
    the head meets them, quality :data:`QUALITY_RETURN` for a return and 0 with distance 0
    for none, S on the first. A revolution goes out with the next one's S node (measured as
    the head passes 0 deg at its end), so the host sees it complete at once."""

    samples = 0  # no samples at a mode's own rate: a revolution is the beams
    edge_dropouts = 0

    def __init__(self, spec: LidarSpec) -> None:
        # node j of a turn is beam _order[j]: headings clockwise from 0 deg, ascending
        angles = spec.angle_min_rad + np.arange(spec.beams) * spec.angle_increment_rad
        heading_rad = np.mod(-angles, 2.0 * math.pi)
        self._order = np.argsort(heading_rad, kind="stable")
        q6 = np.rint(np.degrees(heading_rad[self._order]) * 64.0).astype(np.int64)
        self._angle_q6 = np.mod(q6, 360 * 64)
        self._start = np.zeros(spec.beams, dtype=bool)
        self._start[0] = True
        self._own_start_node = True  # the next revolution must carry its own S node

    def revolution(
        self, end_s: float, ranges_m: F64Array, ahead_m: F64Array | None = None
    ) -> bytes:
        """The wire bytes of the revolution ending at ``end_s``: its nodes (its S node went out
        with the previous turn, unless that was dropped), then the next turn's S node, ranged
        on ``ahead_m`` when given (what it read just after this turn ended)."""
        nodes = self._encode(ranges_m)
        body = nodes if self._own_start_node else nodes[NODE_BYTES:]
        self._own_start_node = False
        return body + (nodes if ahead_m is None else self._encode(ahead_m))[:NODE_BYTES]

    def _encode(self, ranges_m: F64Array) -> bytes:
        r = ranges_m[self._order]
        ok = np.isfinite(r) & (r > 0.0)
        distance_q2 = np.zeros(len(r), dtype=np.int64)
        distance_q2[ok] = np.clip(np.rint(r[ok] * 4000.0), 1, 0xFFFF)
        quality = np.where(distance_q2 > 0, QUALITY_RETURN, 0)
        return encode_nodes(self._start, quality, self._angle_q6, distance_q2)

    def lose(self, end_s: float) -> None:
        """The revolution ending at ``end_s`` was lost: nothing is sent, and the S node already
        sent starts the next revolution the host sees."""

    def restart(self) -> None:
        """What was sent did not reach the line: the next revolution carries its own S node."""
        self._own_start_node = True


@dataclass(frozen=True)
class DeviceAnswers:
    """What the emulated device says about itself.

    Attributes
    ----------
    info : DeviceInfo
        The GET_INFO answer.
    health : DeviceHealth
        The GET_HEALTH answer.
    modes : tuple of ScanMode
        The scan modes GET_LIDAR_CONF describes and EXPRESS_SCAN runs (ids 0, 1, ...; mode 0
        is SCAN's).
    typical_mode : int
        The id GET_LIDAR_CONF's SCAN_MODE_TYPICAL answers.
    """

    info: DeviceInfo
    health: DeviceHealth
    modes: tuple[ScanMode, ...]
    typical_mode: int

    def __post_init__(self) -> None:
        if not self.modes or any(m.id != i for i, m in enumerate(self.modes)):
            raise ValueError("scan modes need ids 0, 1, ... in order")
        if not 0 <= self.typical_mode < len(self.modes):
            raise ValueError(
                f"typical mode {self.typical_mode} is not one of the {len(self.modes)} modes"
            )

    def with_standard(self, us_per_sample_q8: int) -> DeviceAnswers:
        """The same answers with mode 0 (Standard, SCAN's) at another sample time [us * 256]."""
        m0 = self.modes[0]
        standard = ScanMode(0, m0.name, us_per_sample_q8, m0.max_distance_q8, m0.answer_type)
        return replace(self, modes=(standard, *self.modes[1:]))

    @property
    def legacy_express(self) -> ScanMode | None:
        """The mode EXPRESS_SCAN's working mode 0 (the legacy express scan) runs: the first
        with legacy capsules (Express on the A1M8)."""
        return next((m for m in self.modes if m.answer_type == DataType.MEASUREMENT_CAPSULED), None)

    @property
    def sample_rate(self) -> SampleRate:
        """The GET_SAMPLERATE answer: mode 0's and the legacy express scan's sample times
        [us]."""
        express = self.legacy_express
        return SampleRate(
            round(self.modes[0].us_per_sample), round((express or self.modes[0]).us_per_sample)
        )


class RplidarEmulator:
    """An RPLIDAR A1M8 (firmware 1.29) behind a pty, driven by the twin's loop in simulation time.

    Parameters
    ----------
    spec : LidarSpec
        Beams, increment, first angle and scan period of the revolutions.
    link : str or None
        Also make this symlink to the pty (only a symlink there is replaced).
    info : DeviceInfo
        The GET_INFO answer.
    health : DeviceHealth
        The GET_HEALTH answer.
    modes : tuple of ScanMode
        The scan modes GET_LIDAR_CONF describes and EXPRESS_SCAN runs (ids 0, 1, ...;
        mode 0 is SCAN's).
    typical_mode : int
        The id GET_LIDAR_CONF's SCAN_MODE_TYPICAL answers.
    device_standard_scan : bool
        SCAN at mode 0's own sample time (508 us on the A1M8; the default, as the robot's
        device) or, with False, the twin's ``spec.beams`` per revolution.

    Attributes
    ----------
    path : str
        The pty the host opens.
    device : DeviceAnswers
        What it answers about itself: ``info``, ``health``, ``modes`` (mode 0 at the twin's
        beam time unless ``device_standard_scan``), ``typical_mode`` and ``sample_rate``.
    modes : tuple of ScanMode
        The modes as answered (``device.modes``).
    sample_rate : SampleRate
        The GET_SAMPLERATE answer: mode 0's and the legacy express scan's sample times [us].
    scanning : bool
        Whether a scan is running.
    scan_mode : ScanMode or None
        The mode of the running (or last) scan.
    requests, ignored_requests : int
        Requests received, and those left unanswered: commands the twin does not know,
        GET_LIDAR_CONF entries it does not describe, EXPRESS_SCAN of a mode it does not have.
    recent_requests : deque of Request
        The last 256 requests, oldest first.
    revolutions_written, revolutions_dropped : int
        Revolutions sent, and those dropped because the pty was full.
    revolutions_lost : int
        Revolutions the twin lost (the ranges function gave None): nothing was sent.
    """

    def __init__(
        self,
        spec: LidarSpec | None = None,
        link: str | None = None,
        *,
        info: DeviceInfo = TWIN_INFO,
        health: DeviceHealth = TWIN_HEALTH,
        modes: tuple[ScanMode, ...] = A1M8_SCAN_MODES,
        typical_mode: int = A1M8_TYPICAL_MODE,
        device_standard_scan: bool = True,
    ) -> None:
        self.spec = spec = spec if spec is not None else LidarSpec()
        device = DeviceAnswers(info, health, modes, typical_mode)
        self.device_standard_scan = device_standard_scan
        if not device_standard_scan:  # Standard reported at the twin's beam time
            device = device.with_standard(round(spec.time_increment_s * 1e6 * Q8))
        self.device = device
        self.link = PtyLink(link)
        self._requests = RequestDecoder()
        self.scanning = False
        self.scan_mode: ScanMode | None = None
        self._stream: _SampleStream | _BeamScan | None = None
        self._next_turn = 0  # index k of the next revolution to end, at k * scan_period_s
        self._turns_scheduled = 0  # revolutions that ended since the scan (re)started
        self._inject: deque[bytes] = deque()
        self.requests = 0
        self.ignored_requests = 0
        self.recent_requests: deque[Request] = deque(maxlen=RECENT_REQUESTS)
        self.revolutions_written = 0
        self.revolutions_dropped = 0
        self.revolutions_lost = 0

    def fileno(self) -> int:
        """The pty's master descriptor (for a selector)."""
        return self.link.fileno()

    @property
    def path(self) -> str:
        """The pty the host opens."""
        return self.link.path

    @property
    def modes(self) -> tuple[ScanMode, ...]:
        """The scan modes as answered (``device.modes``)."""
        return self.device.modes

    @property
    def sample_rate(self) -> SampleRate:
        """The GET_SAMPLERATE answer (``device.sample_rate``)."""
        return self.device.sample_rate

    # ------------------------------------------------------------------ requests

    def serve(self, t_s: float) -> int:
        """Read the host's requests and answer them, without blocking.

        Parameters
        ----------
        t_s : float
            Simulation time now [s]: a scan starts with the first revolution that begins at
            or after it.

        Returns
        -------
        int
            Requests handled.
        """
        data = self.link.read()
        if not data:
            return 0
        requests = self._requests.feed(data)
        for req in requests:
            self.recent_requests.append(req)
            self._handle(req, t_s)
        self.requests += len(requests)
        return len(requests)

    def _handle(self, req: Request, t_s: float) -> None:
        command = req.command
        if command not in KNOWN_COMMANDS:
            self.ignored_requests += 1
            return
        self.scanning = False  # any request ends a scan (the device's request state)
        device = self.device
        if command == Command.GET_HEALTH:
            self.link.write(response(device.health))
        elif command == Command.GET_INFO:
            self.link.write(response(device.info))
        elif command == Command.GET_SAMPLERATE:
            self.link.write(response(device.sample_rate))
        elif command == Command.GET_LIDAR_CONF:
            query = decode_lidar_conf_query(req.payload)
            conf = (
                None if query is None else scan_mode_conf(query, device.modes, device.typical_mode)
            )
            if conf is None:
                self.ignored_requests += 1
            else:
                self.link.write(lidar_conf_response(conf))
        elif command in (Command.SCAN, Command.FORCE_SCAN):
            self._start_scan(device.modes[0], t_s)
        elif command == Command.EXPRESS_SCAN:
            working_mode = decode_express_scan(req.payload).working_mode
            mode = device.legacy_express if working_mode == 0 else None
            if 0 < working_mode < len(device.modes):
                mode = device.modes[working_mode]
            if mode is None or mode.answer_type not in CAPSULE_FORMATS:
                self.ignored_requests += 1
                return
            self._start_scan(mode, t_s)

    def _start_scan(self, mode: ScanMode, t_s: float) -> None:
        fmt = CAPSULE_FORMATS.get(mode.answer_type)
        # in scan state before the descriptor leaves: a host that has read it sees the mode
        self.scanning = True
        self.scan_mode = mode
        self._schedule(mode, t_s)
        self.link.write(SCAN_DESCRIPTOR if fmt is None else fmt.descriptor)

    def _schedule(self, mode: ScanMode, t_s: float) -> None:
        """The scan's revolutions from the first that begins at or after ``t_s``."""
        period = self.spec.scan_period_s
        self._next_turn = math.ceil(t_s / period - TIME_TOLERANCE_S) + 1
        self._turns_scheduled = 0
        device_rate = mode.answer_type in CAPSULE_FORMATS or self.device_standard_scan
        t0_s = (self._next_turn - 1) * period
        self._stream = _SampleStream(self.spec, mode, t0_s) if device_rate else _BeamScan(self.spec)

    def resume(self, t_s: float) -> None:
        """Go on with the running scan on another clock from ``t_s``, as if it had been asked
        for then (without a second descriptor): its next revolution is the first that begins
        at or after ``t_s``. Bytes of its earlier revolutions still on the line are dropped.

        The twin's runner calls it when the MCU's session starts: until then the scan ran on
        the wall clock over a world standing still, and a lockstep run is then the same however
        long the LiDAR ran before it, or whether anyone read it.
        """
        if not self.scanning or self.scan_mode is None:
            return
        if self._turns_scheduled:
            self.link.discard()
        self._schedule(self.scan_mode, t_s)

    @property
    def malformed_request_bytes(self) -> int:
        """Bytes from the host that were no request (skipped)."""
        return self._requests.malformed_bytes

    @property
    def samples(self) -> int:
        """Samples the running scan took at its mode's own rate (0 for SCAN with the twin's
        beams, which sends ``spec.beams`` nodes a revolution)."""
        return 0 if self._stream is None else self._stream.samples

    @property
    def edge_dropouts(self) -> int:
        """Samples of the running ultra-capsuled scan sent as no return at an edge: the
        parallax model gives them no consistent heading, or their jump in distance is past a
        prediction's reach (511 steps of the major's scale)."""
        return 0 if self._stream is None else self._stream.edge_dropouts

    # ------------------------------------------------------------------ revolutions

    def next_revolution_end_s(self) -> float | None:
        """When the next revolution ends [s of simulation time]; None when not scanning."""
        return self._next_turn * self.spec.scan_period_s if self.scanning else None

    def inject(self, data: bytes) -> None:
        """Test hook: put ``data`` on the line just before the next revolution's bytes (a
        glitch on the USB serial adapter). Safe to call from another thread."""
        self._inject.append(bytes(data))

    def advance(self, t_s: float, ranges_for_revolution: RangesFn) -> int:
        """Write every revolution that ended at or before ``t_s``.

        Parameters
        ----------
        t_s : float
            Simulation time now [s].
        ranges_for_revolution : callable
            Called with a revolution's end time [s]; returns its ``beams`` ranges [m] in the
            spec's beam order, ``inf`` (or NaN, or <= 0) for no return, or None for a
            revolution lost (nothing is written).

        Returns
        -------
        int
            Revolutions that ended (written, dropped or lost).
        """
        if not self.scanning:
            return 0
        stream = self._stream
        assert stream is not None  # scanning
        period = self.spec.scan_period_s
        ended = 0
        while self._next_turn * period <= t_s + TIME_TOLERANCE_S:
            end_s = self._next_turn * period
            ranges = ranges_for_revolution(end_s)
            if ranges is None:
                self.revolutions_lost += 1
                stream.lose(end_s)
            else:
                ahead = None
                if isinstance(ranges, tuple):
                    ranges, ahead = ranges
                r = np.asarray(ranges, dtype=np.float64)
                a = None if ahead is None else np.asarray(ahead, dtype=np.float64)
                for what in (r, a):
                    if what is not None and what.shape != (self.spec.beams,):
                        raise ValueError(
                            f"a revolution needs {self.spec.beams} ranges, got shape {what.shape}"
                        )
                self._write(stream.revolution(end_s, r, a))
            self._next_turn += 1
            self._turns_scheduled += 1
            ended += 1
        return ended

    def _write(self, data: bytes) -> None:
        """One revolution's bytes onto the line, after any injected ones; dropped whole (and
        counted) when the pty is full."""
        assert self._stream is not None
        while self._inject:
            self.link.write(self._inject.popleft())
        if self.link.write(data):
            self.revolutions_written += 1
        else:
            self.revolutions_dropped += 1
            self._stream.restart()

    def close(self) -> None:
        """Close the pty (and remove the link)."""
        self.link.close()
