"""The twin's RPLIDAR A1M8: Slamtec's serial protocol on a pty of its own, byte for byte.

The host opens the pty as it opens ``/dev/jackson-lidar`` on the robot and drives it with the
same requests (docs/lidar.md). :meth:`RplidarEmulator.serve` answers them: GET_HEALTH good,
GET_INFO with the twin's identity (:data:`TWIN_INFO`), GET_SAMPLERATE, SCAN with its
descriptor; STOP and RESET end a scan and send nothing (the real A1 prints a boot banner after
RESET, the twin does not). As on the device, any request ends a running scan first.

While scanning, :meth:`RplidarEmulator.advance` writes one revolution per
``scan_period_s`` of simulation time (0.13465 s, 7.43 Hz), revolution ``k`` ending at
``k * scan_period_s``: 1080 standard measurement nodes in the order the head meets them
(heading clockwise from 0°, S flag on the first), quality 47 for a return and 0 with distance
0 for none. Each revolution goes out whole at the instant it ends, together with the S node
of the next one, which the head measures at that same instant; so a host sees a revolution
complete as soon as it has ended, before the telemetry frame the twin writes next (lockstep
stays deterministic). The ranges come from the caller, one array per revolution in the
twin's beam order (:class:`~jackson.sim.lidar.LidarSpec`: ``angle_min + i * increment``,
counter-clockwise, ``inf`` for no return); the node for beam ``i`` has the heading
``-angle_i`` wrapped to [0°, 360°) (docs/lidar.md, "Frames").

The real A1M8 delivers about 2000 standard nodes a second at 115200 baud (a pty has no baud
rate): the twin's 8000 a second are the paper's 1080-beam scans, which the device reaches in
its Boost mode.

Writes never block the twin: a revolution that does not fit the pty's buffer (nobody reads)
is dropped whole and counted, and the next one then carries its own S node again.

A revolution the twin lost (a ``lidar_dropout`` fault, :mod:`jackson.sim.faults`) puts nothing
on the line: its nodes and the next turn's S node never come, so the S node already sent
(measured as the lost turn began) starts the next revolution the host sees, one period later.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from jackson.protocol.rplidar import (
    NODE_BYTES,
    SCAN_DESCRIPTOR,
    Command,
    DeviceHealth,
    DeviceInfo,
    HealthStatus,
    RequestDecoder,
    SampleRate,
    encode_nodes,
    response,
)
from jackson.sim.lidar import LidarSpec
from jackson.sim.link import PtyLink

__all__ = ["QUALITY_RETURN", "TWIN_HEALTH", "TWIN_INFO", "RplidarEmulator"]

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

KNOWN_COMMANDS = frozenset(int(c) for c in Command)
TIME_TOLERANCE_S = 1e-9  # a revolution ending this close after t_s counts as ended at t_s

RangesFn = Callable[[float], npt.ArrayLike | None]


class RplidarEmulator:
    """An RPLIDAR A1M8 behind a pty, driven by the twin's loop in simulation time.

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

    Attributes
    ----------
    path : str
        The pty the host opens.
    scanning : bool
        Whether a SCAN is running.
    requests, ignored_requests : int
        Requests received, and those of commands it does not know (ignored).
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
    ) -> None:
        self.spec = spec if spec is not None else LidarSpec()
        self.info = info
        self.health = health
        self.link = PtyLink(link)
        self.path = self.link.path
        self._requests = RequestDecoder()
        # node j of a turn is beam _order[j]: headings clockwise from 0 deg, ascending
        spec = self.spec
        angles = spec.angle_min_rad + np.arange(spec.beams) * spec.angle_increment_rad
        heading_rad = np.mod(-angles, 2.0 * math.pi)
        self._order = np.argsort(heading_rad, kind="stable")
        q6 = np.rint(np.degrees(heading_rad[self._order]) * 64.0).astype(np.int64)
        self._angle_q6 = np.mod(q6, 360 * 64)
        self._start = np.zeros(spec.beams, dtype=bool)
        self._start[0] = True
        self.sample_rate = SampleRate(
            round(spec.time_increment_s * 1e6), round(spec.time_increment_s * 1e6)
        )
        self.scanning = False
        self._next_turn = 0  # index k of the next revolution to end, at k * scan_period_s
        self._own_start_node = True  # the next revolution must carry its own S node
        self._inject: deque[bytes] = deque()
        self.requests = 0
        self.ignored_requests = 0
        self.revolutions_written = 0
        self.revolutions_dropped = 0
        self.revolutions_lost = 0

    def fileno(self) -> int:
        """The pty's master descriptor (for a selector)."""
        return self.link.fileno()

    # ------------------------------------------------------------------ requests

    def serve(self, t_s: float) -> int:
        """Read the host's requests and answer them, without blocking.

        Parameters
        ----------
        t_s : float
            Simulation time now [s]: a SCAN starts with the first revolution that begins at
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
            self._handle(req.command, t_s)
        self.requests += len(requests)
        return len(requests)

    def _handle(self, command: int, t_s: float) -> None:
        if command not in KNOWN_COMMANDS:
            self.ignored_requests += 1
            return
        self.scanning = False  # any request ends a scan (the device's request state)
        if command == Command.GET_HEALTH:
            self.link.write(response(self.health))
        elif command == Command.GET_INFO:
            self.link.write(response(self.info))
        elif command == Command.GET_SAMPLERATE:
            self.link.write(response(self.sample_rate))
        elif command == Command.SCAN:
            self.link.write(SCAN_DESCRIPTOR)
            self.scanning = True
            period = self.spec.scan_period_s
            self._next_turn = math.ceil(t_s / period - TIME_TOLERANCE_S) + 1
            self._own_start_node = True

    @property
    def malformed_request_bytes(self) -> int:
        """Bytes from the host that were no request (skipped)."""
        return self._requests.malformed_bytes

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
        period = self.spec.scan_period_s
        ended = 0
        while self._next_turn * period <= t_s + TIME_TOLERANCE_S:
            end_s = self._next_turn * period
            ranges = ranges_for_revolution(end_s)
            if ranges is None:
                self.revolutions_lost += 1
            else:
                self._write_turn(np.asarray(ranges, dtype=np.float64))
            self._next_turn += 1
            ended += 1
        return ended

    def _write_turn(self, ranges_m: npt.NDArray[np.float64]) -> None:
        if ranges_m.shape != (self.spec.beams,):
            raise ValueError(
                f"a revolution needs {self.spec.beams} ranges, got shape {ranges_m.shape}"
            )
        r = ranges_m[self._order]
        ok = np.isfinite(r) & (r > 0.0)
        distance_q2 = np.zeros(len(r), dtype=np.int64)
        distance_q2[ok] = np.clip(np.rint(r[ok] * 4000.0), 1, 0xFFFF)
        quality = np.where(distance_q2 > 0, QUALITY_RETURN, 0)
        nodes = encode_nodes(self._start, quality, self._angle_q6, distance_q2)
        # this turn's nodes (its S node went out with the previous turn, unless that was
        # dropped), then the next turn's S node, measured now as the head passes 0 deg
        body = nodes if self._own_start_node else nodes[NODE_BYTES:]
        while self._inject:
            self.link.write(self._inject.popleft())
        if self.link.write(body + nodes[:NODE_BYTES]):
            self.revolutions_written += 1
            self._own_start_node = False
        else:
            self.revolutions_dropped += 1
            self._own_start_node = True

    def close(self) -> None:
        """Close the pty (and remove the link)."""
        self.link.close()
