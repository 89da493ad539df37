"""Encoder stuck: a wheel with no count for ``encoder_stuck_s`` while the other wheel and the
gyro (or, without a gyro, the command) say it turns is a cut wire or a dead encoder, excluded
at once; an excluded wheel is back once it counts and agrees with them again.

A wheel "must turn" when it is expected faster than ``driven_wheel_rad_s`` or to make
:data:`~jackson.host.health.wheels.SILENT_TICKS` counts in the frame. Judged by the command
alone, two silent wheels are a drive that does not move (the interlock, a stall, the motor
supply), not two cut encoders.
"""

from __future__ import annotations

import math

from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health.config import HealthConfig
from jackson.host.health.states import SensorStates
from jackson.host.health.types import (
    ENCODERS,
    Finding,
    FrameFacts,
    Health,
    HealthInput,
    failing,
    passing,
)
from jackson.host.health.wheel_yaw import WheelYawModel
from jackson.host.health.wheels import SILENT_TICKS, expected_wheel, quantisation_variance


class EncoderStuck:
    """A :class:`~jackson.host.health.check.Check` of frames: each encoder counting when its
    wheel turns (module docstring)."""

    def __init__(self, cfg: HealthConfig, robot: RobotGeometry, model: WheelYawModel) -> None:
        self.cfg = cfg
        self.robot = robot
        self.model = model
        self._moved_s: list[float] | None = None  # each wheel's last count (or idle frame)

    def observe(self, f: FrameFacts) -> list[Finding]:
        cfg, h, t, wz = self.cfg, f.h, f.h.t_s, f.trusted_wz
        if self._moved_s is None:
            self._moved_s = [t, t]
        found = []
        for i in range(2):
            expected = expected_wheel(self.robot, self.model, i, h, wz)
            tpr = (self.robot.ticks_per_rev_left, self.robot.ticks_per_rev_right)[i]
            expected_ticks = abs(expected) * h.dt_s * tpr / (2.0 * math.pi)
            driven = abs(expected) > cfg.driven_wheel_rad_s or expected_ticks >= SILENT_TICKS
            if wz is None and h.ticks[1 - i] == 0:
                # judged by the command alone, two silent wheels are a drive that does not
                # move (the interlock, a stall, the motor supply), not two cut encoders
                driven = False
            if h.ticks[i] != 0 or not driven:
                self._moved_s[i] = t
            elif t - self._moved_s[i] >= cfg.encoder_stuck_s - 1e-9:
                why = (
                    f"no count for {t - self._moved_s[i]:.2f} s while the wheel should turn at "
                    f"{expected:+.1f} rad/s (stuck or cut)"
                )
                found.append(failing(ENCODERS[i], t, why, exclude=True))
        return found

    def passes(self, f: FrameFacts, states: SensorStates, charged: set[str]) -> list[Finding]:
        """The encoders that passed this frame: counted (or were not driven) and not charged
        by the cross-check; an excluded one only once it counts and agrees again."""
        h, t = f.h, f.h.t_s
        found = []
        for i, name in enumerate(ENCODERS):
            if self._moved_s is None or self._moved_s[i] != t or name in charged:
                continue
            if states[name] is Health.EXCLUDED:
                if h.ticks[i] != 0 and self._agrees(i, h, f.trusted_wz):
                    found.append(passing(name, t))
            else:
                found.append(passing(name, t))
        return found

    def _agrees(self, i: int, h: HealthInput, wz: float | None) -> bool:
        """An excluded wheel's speed agrees with the other wheel and the gyro again."""
        if wz is None or h.dt_s <= 0.0:
            return True
        expected = expected_wheel(self.robot, self.model, i, h, wz)
        r = self.robot
        sigma_yaw = math.sqrt(self.cfg.gyro_variance + quantisation_variance(r, h.dt_s))
        tol = (
            3.0
            * sigma_yaw
            * r.wheel_separation_m
            / min(r.wheel_radius_left_m, r.wheel_radius_right_m)
        )
        return abs(h.wheel_rad_s[i] - expected) <= tol + self.cfg.scale_tolerance * abs(expected)
