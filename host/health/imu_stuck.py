"""IMU stuck: raw registers frozen for ``stuck_s`` are a stuck IMU, excluded at once.

A live MPU-6050's noise changes the low bits of its accelerometer, gyro or temperature
registers on every sample; the same seven registers frame after frame are a sensor that
stopped converting (or a bus that returns its last read), whatever ``IMU_OK`` says.
"""

from __future__ import annotations

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import Finding, HealthInput, failing


class ImuStuck:
    """A :class:`~jackson.host.health.check.Check` of frames: the IMU frozen (module docstring).

    Attributes
    ----------
    frozen : bool
        The last frame's registers had been frozen for ``stuck_s``: its sample is not live.
    """

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self.frozen = False
        self._raw: tuple[int, ...] | None = None  # the registers as they last changed
        self._since_s: float | None = None  # since when they read so

    def observe(self, h: HealthInput) -> list[Finding]:
        t = h.t_s
        if self._since_s is None:
            self._since_s = t
        self.frozen = False
        if not h.imu_ok:
            self._raw, self._since_s = None, t
            return []
        if h.imu_raw != self._raw:
            self._raw, self._since_s = h.imu_raw, t
        self.frozen = t - self._since_s >= self.cfg.stuck_s - 1e-9
        if self.frozen:
            why = f"registers frozen for {t - self._since_s:.2f} s (stuck)"
            return [failing("imu", t, why, exclude=True)]
        return []
