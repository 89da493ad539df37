"""When a mission must stop: a time limit, and an estimate that can no longer be trusted.

A mission steers by the EKF. When a sensor behind the estimate falls silent the estimate goes on
predicting (the yaw freezes with a dead gyro) and the mission can chase a goal it never reaches.
:class:`MissionGuard` watches, on MCU time, what the estimate rests on and names the first
reason to abort; the host then brakes and exits non-zero with that reason. Rules:

- **timeout**: the mission has run ``timeout_s`` since its first command (default per mission:
  :data:`MISSION_TIMEOUT_S`, about three times its nominal duration; a navigation's from its
  route, :func:`route_timeout_s`);
- **no gyro bias**: the IMU gave no usable sample for ``bias_wait_s`` after the start, so the
  gyro bias (and the yaw rate) cannot be measured;
- **IMU silent**: no frame with ``IMU_OK`` for ``imu_silence_s``;
- **encoder silent**: a wheel commanded faster than ``driven_wheel_rad_s`` reported no tick for
  ``encoder_silence_s`` (a stalled wheel, a cut encoder wire).

The last two apply only with the sensor health monitor off (``health.enabled: false``): with it
on, :mod:`jackson.host.health` excludes a silent IMU or encoder and its policy decides
whether the mission goes on in a degraded mode or stops.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

MISSION_TIMEOUT_S = {"square": 150.0, "figure8": 300.0, "navigate": 180.0}  # [s] of MCU time
DEFAULT_TIMEOUT_S = 600.0  # [s] a mission not in the table
ROUTE_SPEED_M_S = 0.25  # [m/s] a navigation's average along its route (surveys: 0.26)
ROUTE_MARGIN = 3.0  # a route's limit: this many times its straight-line length at that speed


def route_timeout_s(points: Sequence[tuple[float, float]]) -> float:
    """The limit of a navigation through ``points`` (the start, then each goal) [s of MCU
    time]: :data:`ROUTE_MARGIN` times the straight-line route at :data:`ROUTE_SPEED_M_S`, and
    never below the Stage 3 navigation's 180 s; a survey of a whole floor gets the time it
    needs (a 64 m ring: 768 s), where a fixed 180 s stopped it a third of the way round."""
    route = sum(math.dist(a, b) for a, b in itertools.pairwise(points))
    return max(MISSION_TIMEOUT_S["navigate"], ROUTE_MARGIN * route / ROUTE_SPEED_M_S)


@dataclass(frozen=True)
class GuardConfig:
    """Thresholds of :class:`MissionGuard` (MCU time)."""

    imu_silence_s: float = 0.5  # [s] 10 frames at 20 Hz
    bias_wait_s: float = 10.0  # [s] the gyro bias needs ~1 s of standing still
    encoder_silence_s: float = 1.0  # [s]
    driven_wheel_rad_s: float = 2.0  # [rad/s] ~7 cm/s of wheel: ~10 ticks per 50 ms frame


class MissionGuard:
    """Names the first reason a mission must stop, or None while it may go on."""

    def __init__(
        self,
        name: str,
        timeout_s: float | None = None,
        cfg: GuardConfig | None = None,
        *,
        sensor_rules: bool = True,
    ):
        self.cfg = cfg or GuardConfig()
        self.sensor_rules = sensor_rules  # False: the health monitor judges IMU and encoders
        self.timeout_s = timeout_s or MISSION_TIMEOUT_S.get(name, DEFAULT_TIMEOUT_S)
        self.name = name
        self._start_s: float | None = None
        self._imu_ok_s: float | None = None
        self._last_counts: tuple[int, int] | None = None
        self._moved_s: list[float] = [0.0, 0.0]  # per wheel: last tick, or last time not driven

    def check(
        self,
        t_s: float,
        imu_ok: bool,
        bias_known: bool,
        counts: tuple[int, int],
        wheel_cmd_rad_s: tuple[float, float],
    ) -> str | None:
        """Feed one telemetry frame; the reason to abort, or None.

        ``wheel_cmd_rad_s`` is the wheel speed commanded over the frame interval that ends here.
        """
        c = self.cfg
        if self._start_s is None:
            self._start_s = t_s
            self._moved_s = [t_s, t_s]
        if imu_ok:
            self._imu_ok_s = t_s
        elapsed = t_s - self._start_s
        if elapsed > self.timeout_s:
            return f"timeout: {elapsed:.1f} s of MCU time, the limit is {self.timeout_s:.0f} s"
        if not bias_known:
            if elapsed > c.bias_wait_s:
                return (
                    f"no gyro bias after {elapsed:.1f} s: the IMU gave no usable sample "
                    "(is the MPU-6050 connected?)"
                )
            return None
        if not self.sensor_rules:
            return None
        if self._imu_ok_s is None or t_s - self._imu_ok_s > c.imu_silence_s:
            silent = t_s - (self._imu_ok_s if self._imu_ok_s is not None else self._start_s)
            return f"IMU silent for {silent:.2f} s: the yaw estimate cannot be trusted"
        last = self._last_counts
        self._last_counts = counts
        for i, side in enumerate(("left", "right")):
            driven = abs(wheel_cmd_rad_s[i]) > c.driven_wheel_rad_s
            if not driven or (last is not None and counts[i] != last[i]):
                self._moved_s[i] = t_s
            elif t_s - self._moved_s[i] > c.encoder_silence_s:
                return (
                    f"{side} encoder silent for {t_s - self._moved_s[i]:.2f} s while its wheel "
                    f"is driven at {wheel_cmd_rad_s[i]:+.1f} rad/s (stalled wheel or cut wire)"
                )
        return None
