"""LiDAR garbage: bytes that are not a healthy RPLIDAR's stream (a loose cable, another baud
rate, another device on the port).

More than ``lidar_garbage_fraction`` of the bytes of the last ``lidar_garbage_s`` malformed
(check bits or start flags wrong), or :data:`LIDAR_JUNK_TURNS` "revolutions" in that time that
are not a turn (random bytes that pass the node checks: a real sensor sends none covering less
than :data:`LIDAR_MIN_SPAN_RAD`), make the LiDAR ``suspect`` and its scans unused; garbage
that lasts ``lidar_garbage_s`` excludes it. It is gone once no such revolution is left in the
window and at most half the fraction of the bytes are malformed.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import ByteCount, Finding, ScanInput, failing

LIDAR_MIN_SPAN_RAD = math.pi  # a revolution covering less than this is not a turn (garbage)
LIDAR_JUNK_TURNS = 3  # that many such revolutions within lidar_garbage_s: garbage on the line


class LidarGarbage:
    """A :class:`~jackson.host.health.check.Check` of the LiDAR's bytes, and of each
    revolution's span (module docstring).

    Attributes
    ----------
    since : float or None
        Garbage on the line since [s] (None: none now): scans decoded meanwhile are not used.
    """

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self.since: float | None = None
        self._bytes: deque[tuple[float, int, int]] = deque()  # (t, bytes, malformed)
        self._junk: deque[float] = deque()  # when revolutions that are not a turn came

    def observe(self, x: ByteCount) -> list[Finding]:
        cfg, t_s, window = self.cfg, x.t_s, self._bytes
        window.append((t_s, x.received, x.malformed))
        while window and window[0][0] <= t_s - cfg.lidar_garbage_s + 1e-9:
            window.popleft()
        total = sum(b for _, b, _ in window)
        bad = sum(m for _, _, m in window)
        junk = self._junk
        while junk and junk[0] <= t_s - cfg.lidar_garbage_s + 1e-9:
            junk.popleft()
        # garbage: too many bytes failing the node checks, or "revolutions" decoded from random
        # bytes that pass them (a real sensor sends none that cover less than half a turn)
        many_junk = len(junk) >= LIDAR_JUNK_TURNS
        if (total >= 50 and bad > cfg.lidar_garbage_fraction * total) or many_junk:
            if self.since is None:
                self.since = t_s
            lasted = t_s - self.since
            exclude = lasted >= cfg.lidar_garbage_s - 1e-9
            # (the decoder may count bytes of an earlier read, held for a sync, as malformed now)
            why = (
                f"{min(bad, total)} of its {total} bytes malformed and {len(junk)} revolutions "
                f"that are not a turn in {cfg.lidar_garbage_s:g} s: garbage on the line (a loose "
                "cable, another baud rate, another device?)"
            )
            return [failing("lidar", t_s, why, exclude=exclude)]
        if not junk and (total < 50 or bad <= 0.5 * cfg.lidar_garbage_fraction * total):
            self.since = None
        return []

    def turn(self, x: ScanInput) -> list[Finding]:
        """A revolution spanning less than :data:`LIDAR_MIN_SPAN_RAD` is not a turn (decoded
        garbage): counted towards garbage, the LiDAR ``suspect``."""
        angles = x.angles_rad
        if angles is None or len(angles) <= 1:
            return []
        a = np.mod(np.asarray(angles, dtype=float), 2.0 * math.pi)
        gaps = np.diff(np.sort(a))
        span = 2.0 * math.pi - max(float(gaps.max()), 2.0 * math.pi - float(a.max() - a.min()))
        if span >= LIDAR_MIN_SPAN_RAD:
            return []
        self._junk.append(x.t_s)
        why = f"a revolution spanning {math.degrees(span):.0f} deg: not a turn"
        return [failing("lidar", x.t_s, why, exclude=False)]
