"""The twin's scans on the emulated RPLIDAR A1M8's pty, on the twin's clock.

An emulated RPLIDAR A1M8 (:mod:`jackson.sim.rplidar`) answers on a pty of its own, served with
the serial link and the I2C bus in every wait of the runner. Its revolutions are the twin's own
scans (same noise, same dropout), written before the MCU acts at each instant: a revolution
that ended at or before a telemetry frame reaches the host ahead of that frame. Before the
MCU's session the LiDAR does not wait for it, as a real A1M8 does not: it answers, and a scan
streams revolutions of the world standing still on the wall clock (its own noise stream, so the
twin's are not drawn from); at the HELLO the scan goes on with the twin's clock
(:meth:`~jackson.sim.rplidar.RplidarEmulator.resume`), and the session's revolutions are the
ones a scan asked for at that instant would give.
"""

from __future__ import annotations

import selectors
import time

import numpy as np
from numpy.typing import NDArray

from jackson.sim.lidar import Lidar, LidarSpec
from jackson.sim.rplidar import RplidarEmulator
from jackson.sim.twin import Twin

STILL_WAIT_S = 0.05  # [s] longest wait for the host before the session, between revolutions


class LidarFeed:
    """The emulated RPLIDAR of one twin, registered in the runner's selector as ``"lidar"``.

    Parameters
    ----------
    twin : Twin
        The twin whose scans are sent.
    spec : LidarSpec
        Its LiDAR.
    selector : selectors.BaseSelector
        The runner's selector (the pty is registered there, and removed when it closes).
    link : str or None
        A symlink to make at the pty.
    twin_beams : bool
        Send the twin's exact beams instead of an A1M8's SCAN at 508 us a sample
        (RplidarEmulator's ``device_standard_scan=False``).
    seed : int
        The still LiDAR's noise stream (the MCU's boot_id).

    Raises
    ------
    OSError
        The pty or its link cannot be made.
    """

    def __init__(
        self,
        twin: Twin,
        spec: LidarSpec,
        selector: selectors.BaseSelector,
        *,
        link: str | None,
        twin_beams: bool,
        seed: int,
    ) -> None:
        self.twin = twin
        self._selector = selector
        self._still_since: float | None = time.monotonic()  # None once the session started
        self.emulator: RplidarEmulator | None = RplidarEmulator(
            spec, link, device_standard_scan=not twin_beams
        )
        self.path = self.emulator.path
        self.scans_missing = 0  # revolutions with no scan of the twin's (sent empty)
        selector.register(self.emulator, selectors.EVENT_READ, "lidar")
        self._still = Lidar(spec, np.random.default_rng(seed))

    def clock_s(self) -> float:
        """The LiDAR's clock [s]: the twin's once the MCU's session started; before, the
        twin's standing time plus the wall time since the twin started (its head turns)."""
        if self._still_since is None:
            return self.twin.t_s
        return self.twin.t_s + (time.monotonic() - self._still_since)

    def serve(self) -> None:
        """Answer the host's requests (without blocking)."""
        if self.emulator is not None:
            self.emulator.serve(self.clock_s())

    def _scan_for(
        self, end_s: float
    ) -> NDArray[np.float32] | tuple[NDArray[np.float32], NDArray[np.float32]] | None:
        """The twin's scan for the revolution ending at ``end_s``: the one it took at the
        first physics step at or after that instant (the two share one schedule), with what
        the next turn's first beams read (:class:`~jackson.sim.twin_scans.Scan`); None when a
        ``lidar_dropout`` fault lost it (nothing goes on the line)."""
        twin = self.twin
        dt = twin.dt
        for scan in reversed(twin.scans):
            if end_s - 1e-6 <= scan.t_s < end_s + dt - 1e-9:
                return scan.ranges if scan.ahead is None else (scan.ranges, scan.ahead)
            if scan.t_s < end_s - 1e-6:
                break
        if any(end_s - 1e-6 <= t < end_s + dt - 1e-9 for t in twin.lost_scans):
            return None
        assert self.emulator is not None
        self.scans_missing += 1
        return np.full(self.emulator.spec.beams, np.inf, dtype=np.float32)

    def advance(self) -> None:
        """Write the revolutions that ended by now (before the MCU acts at this instant, so
        they reach the host ahead of this instant's telemetry frame). A ``lidar_garbage``
        fault puts random bytes before each; ``lidar_closed`` closes the LiDAR's port for good
        (its pty gone, as a pulled USB cable)."""
        lidar = self.emulator
        if lidar is None:
            return
        twin = self.twin
        faults = twin.faults
        if faults is not None and faults.lidar_line_faults:
            due = lidar.next_revolution_end_s()
            if due is not None and due <= twin.t_s + 1e-9:
                garbage, closed = faults.lidar_line(twin.t_s, 5 * lidar.spec.beams)
                if closed:
                    self._selector.unregister(lidar)
                    lidar.close()
                    self.emulator = None
                    return
                if garbage:
                    lidar.inject(garbage)
        lidar.advance(twin.t_s, self._scan_for)

    def _still_ranges(self, end_s: float) -> NDArray[np.float32]:
        """Before the session: a revolution of the world standing still, from where the robot
        stands (its own noise stream: the twin's scans are not drawn from)."""
        s = self.twin.truth()
        return self._still.scan(s.x, s.y, s.yaw, self.twin.world.obstacles)

    def advance_still(self) -> float:
        """Before the session: write the revolutions that ended by the wall clock; the wall
        seconds until the next one ends (at most :data:`STILL_WAIT_S`)."""
        lidar = self.emulator
        if lidar is None or self._still_since is None:
            return STILL_WAIT_S
        now = self.clock_s()
        lidar.advance(now, self._still_ranges)
        due = lidar.next_revolution_end_s()
        return STILL_WAIT_S if due is None else max(0.0, min(STILL_WAIT_S, due - now))

    def session_starts(self) -> None:
        """The host's HELLO: the scan goes on with the twin's clock."""
        self._still_since = None
        if self.emulator is not None:
            self.emulator.resume(self.twin.t_s)

    def close(self) -> None:
        if self.emulator is not None:
            self.emulator.close()
