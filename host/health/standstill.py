"""Standing still: commanded still and neither wheel counting for ``zupt_after_s``.

Not a check of any sensor but a fact the others read: the gyro must then read zero
(:mod:`jackson.host.health.still_bias`), the cross-check has nothing to compare, and the policy
gives the EKF zero-velocity updates, so a parked robot's covariance stays bounded.
"""

from __future__ import annotations

from jackson.host.health.config import HealthConfig
from jackson.host.health.types import HealthInput


class Standstill:
    """Whether the robot stands still, frame by frame (module docstring)."""

    def __init__(self, cfg: HealthConfig) -> None:
        self.cfg = cfg
        self._since_s: float | None = None  # commanded still without a count since

    def observe(self, h: HealthInput) -> bool:
        """This frame: standing still for at least ``zupt_after_s``."""
        if h.commanded_still and h.ticks == (0, 0):
            if self._since_s is None:
                self._since_s = h.t_s
        else:
            self._since_s = None
        return self._since_s is not None and h.t_s - self._since_s >= self.cfg.zupt_after_s
