"""The LiDAR's intake in the host's core: bytes as read, judged scans at the next telemetry frame.

The daemon hands over the LiDAR's bytes as it reads them (they are logged raw, so ``jackson
replay`` rebuilds the same scans); the revolutions they complete wait for the next telemetry
frame and are stamped with its MCU time (the twin writes a revolution before the frame that
follows its end, so in lockstep the pairing is exact). With the sensor health monitor on, the
LiDAR's checks run here (:class:`~jackson.host.health.lidar.LidarHealth`): the bytes read and
the decoder's malformed bytes between two frames, each revolution (whether it may be used),
and the port failing. Their silence on every frame is judged with the monitor's other checks:
after bytes that complete no revolution (judged first: garbage, not silence), and knowing when
the daemon itself stalled (its silence, not the LiDAR's).
"""

from __future__ import annotations

from jackson.host.health.lidar import LidarHealth
from jackson.host.health.lidar_silence import LIDAR_SILENCE_PERIODS
from jackson.host.lidar.rplidar import Revolution, RevolutionAssembler
from jackson.host.nav.types import Scan


class ScanIntake:
    """Bytes in, judged :class:`~jackson.host.nav.types.Scan` s out (module docstring).

    Parameters
    ----------
    health : LidarHealth or None
        The health monitor's LiDAR checks (None: the monitor is off, every scan is used).
    """

    # no revolution since this frame's MCU time (None: none yet; class default: a core pickled
    # before it was kept restores without it)
    _waiting_s: float | None = None

    def __init__(self, health: LidarHealth | None = None) -> None:
        self.assembler = RevolutionAssembler(streaming=True)
        self.health = health
        self.scans = 0  # scans taken
        self.last_scan: Scan | None = None
        self._revolutions: list[Revolution] = []
        self._received = 0  # bytes read since the last report
        self._malformed_seen = 0  # the decoder's malformed bytes at the last report

    def feed(self, data: bytes) -> None:
        """Bytes read from the LiDAR's port."""
        self._received += len(data)
        self._revolutions += self.assembler.feed(data)

    @property
    def pending(self) -> bool:
        """Revolutions wait for the next frame."""
        return bool(self._revolutions)

    def bytes_report(self) -> tuple[int, int] | None:
        """(bytes read, malformed bytes) since the last report, or None when none were read."""
        if not self._received:
            return None
        malformed = self.assembler.decoder.malformed_bytes
        report = (self._received, malformed - self._malformed_seen)
        self._malformed_seen = malformed
        self._received = 0
        return report

    def unpaired(self, t_s: float) -> None:
        """The telemetry frame of MCU time ``t_s`` before its checks, when no revolution waits:
        bytes read for :data:`~jackson.host.health.lidar_silence.LIDAR_SILENCE_PERIODS`
        revolutions (the shortest silence judged) without completing one are judged now, and at
        every frame after until a revolution comes: random bytes instead of revolutions are
        garbage, told before the silence they would otherwise look like. A healthy stream
        completes a revolution every 2 or 3 frames and is never judged here.
        """
        if self.health is None or self._revolutions or not self._received:
            return
        if self._waiting_s is None:
            self._waiting_s = t_s  # bytes before any revolution
        waited = t_s - self._waiting_s
        if waited < self.health.silence.revolutions_s(LIDAR_SILENCE_PERIODS) - 1e-9:
            return
        report = self.bytes_report()
        if report is not None:
            self.health.bytes_read(t_s, *report)

    def host_stalled(self, t_s: float, stalled_s: float) -> None:
        """The daemon did not run for ``stalled_s`` wall seconds after the frame of MCU time
        ``t_s``: the LiDAR's checks do not blame it for the silence that makes."""
        if self.health is not None:
            self.health.host_stalled(t_s, stalled_s)

    def take(self, t_s: float, needed: bool) -> list[Revolution]:
        """The revolutions completed since the last frame, for the frame at MCU time ``t_s``.

        With the LiDAR's checks, the bytes read since the last report are judged first
        (garbage on the line), then the checks learn whether a mission navigates by the scans
        (``needed``: a LiDAR lost then stops it, a silence holds it).
        """
        revolutions, self._revolutions = self._revolutions, []
        self._waiting_s = t_s
        if self.health is not None:
            report = self.bytes_report()
            if report is not None:
                self.health.bytes_read(t_s, *report)
            self.health.needed = needed
        return revolutions

    def scan(self, t_s: float, rev: Revolution) -> tuple[Scan, bool]:
        """A revolution as the scan of the frame at MCU time ``t_s``, counted and judged; and
        whether it may be used (navigated by): not when too noisy to trust, not a turn, while
        garbage arrives or the LiDAR is excluded (it is published all the same)."""
        scan = Scan(t_s, rev.angles_rad, rev.ranges_m)
        self.scans += 1
        self.last_scan = scan
        if self.health is None:
            return scan, True
        return scan, self.health.scan(t_s, rev.ranges_m, rev.angles_rad)

    def gone(self, t_s: float, why: str) -> None:
        """The LiDAR's port failed at MCU time ``t_s`` (a read error: unplugged): its checks
        exclude it at once."""
        if self.health is not None:
            self.health.gone(t_s, why)
