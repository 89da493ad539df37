"""The LiDAR's intake in the host's core: bytes as read, scans at the next telemetry frame.

The daemon hands over the LiDAR's bytes as it reads them (they are logged raw, so ``jackson
replay`` rebuilds the same scans); the revolutions they complete wait for the next telemetry
frame and are stamped with its MCU time (the twin writes a revolution before the frame that
follows its end, so in lockstep the pairing is exact). The health monitor gets the bytes read
and the decoder's malformed bytes between two frames.
"""

from __future__ import annotations

from jackson.host.lidar.rplidar import Revolution, RevolutionAssembler
from jackson.host.nav.types import Scan


class ScanIntake:
    """Bytes in, :class:`~jackson.host.nav.types.Scan` s out (module docstring)."""

    def __init__(self) -> None:
        self.assembler = RevolutionAssembler(streaming=True)
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

    def take(self) -> list[Revolution]:
        """The revolutions completed since the last frame."""
        revolutions, self._revolutions = self._revolutions, []
        return revolutions

    def scan(self, t_s: float, rev: Revolution) -> Scan:
        """A revolution as the scan of the frame at MCU time ``t_s``, counted."""
        scan = Scan(t_s, rev.angles_rad, rev.ranges_m)
        self.scans += 1
        self.last_scan = scan
        return scan
