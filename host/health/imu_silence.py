"""IMU silence: no ``IMU_OK`` for ``imu_silence_s`` is a dead IMU, excluded at once.

Without any model: the MCU sets ``IMU_OK`` on every frame that carries a fresh MPU-6050
sample, so a run of frames without it is a sensor that stopped answering (its bus, its power).
"""

from __future__ import annotations

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import Finding, HealthInput, failing


class ImuSilence:
    """A :class:`~jackson.host.health.check.Check` of frames: the IMU dead (module docstring)."""

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self._ok_s: float | None = None  # the last frame with IMU_OK (or the first frame)

    def observe(self, h: HealthInput) -> list[Finding]:
        t = h.t_s
        if self._ok_s is None:
            self._ok_s = t
        if h.imu_ok:
            self._ok_s = t
            return []
        if t - self._ok_s >= self.cfg.imu_silence_s - 1e-9:
            return [failing("imu", t, f"no IMU_OK for {t - self._ok_s:.2f} s (dead)", exclude=True)]
        return []
