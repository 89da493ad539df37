"""Still bias: standing still, the gyro must read zero; a mean rate the noise cannot explain
is a bias, which excludes the IMU and has the bias measured again.

Over the last ``window_s`` of a standstill (at least five samples over 0.45 of it) the mean
yaw rate m of n samples against its standard deviation: m^2 / (R_wz / n) beyond the windowed
test's z^2 (``window_probability``).
"""

from __future__ import annotations

import math
from collections import deque

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import Finding, FrameFacts, failing


class StillBias:
    """A :class:`~jackson.host.health.check.Check` of frames: the gyro's bias standing still
    (module docstring).

    Attributes
    ----------
    remeasure : bool
        The last frame found a bias: the gyro's bias is to be measured again.
    """

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self.gyro_variance = cfg.gyro_variance
        self._z = cfg.window_z
        self.remeasure = False
        self._still: deque[tuple[float, float]] = deque()  # (t, w_g) standing still

    def observe(self, f: FrameFacts) -> list[Finding]:
        t, wz = f.h.t_s, f.h.wz_rad_s
        self.remeasure = False
        if not (f.gyro_live and f.still and wz is not None):
            self._still.clear()
            return []
        self._still.append((t, wz))
        while self._still and self._still[0][0] <= t - self.cfg.window_s + 1e-9:
            self._still.popleft()
        n = len(self._still)
        if n >= 5 and self._still[-1][0] - self._still[0][0] >= 0.45 * self.cfg.window_s:
            mean = math.fsum(x[1] for x in self._still) / n
            if mean * mean / (self.gyro_variance / n) >= self._z**2:
                self.remeasure = True
                self._still.clear()
                why = f"reads {mean:+.4f} rad/s standing still (bias)"
                return [failing("imu", t, why, exclude=True)]
        return []
