"""Isolation: which sensor a disagreement of the wheels and the gyro is charged to.

A dead or stuck IMU, isolated spikes and a disagreement standing still are the gyro's (their
checks say so); a failing sample while one wheel did not count is that wheel's. A lasting
disagreement while driving (:meth:`Isolation.charge`) is a slipping wheel or a gyro bias step.
The accelerometer's lateral force (a_y = v w follows the true yaw rate) is the witness
(:meth:`Isolation._witness`): it sides with the gyro (the wheel that reads more than the gyro
and the other wheel allow is excluded) or with the wheels (the gyro is). When it cannot decide,
the forward speed can (:meth:`Isolation.speed_gap`: a slipping wheel raises the wheels' speed
by half its slip, which the accelerometer's integral does not follow). When neither can tell
them apart the disagreement is ambiguous: both are suspect, the wheels' yaw stands in for the
gyro's (the policy's ``hold_yaw``), and one that outlasts ``ambiguity_s`` is the gyro's; a calm
window for ``recover_s`` ends it (:meth:`Isolation.settle`).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health.config import HealthConfig
from jackson.host.health.types import ENCODERS, Finding, FrameFacts, Health, failing
from jackson.host.health.wheel_yaw import WheelYawModel

SPEED_WITNESS_LEAD_S = 0.5  # [s] the speed witness's reference, before the disagreement was seen
SPEED_WITNESS_FRAMES = 5  # frames averaged for the speed witness's two levels
SPEED_WITNESS_BIAS_S = 1.5  # [s] over which the forward accelerometer's bias is measured
WITNESS_Z = 3.0  # the accelerometer must tell the two hypotheses apart by this many sigma

Sample = tuple[float, float, float, float, float, float, float]  # (t, r, var, om_l, om_r, w_g, v)
Row = tuple[
    float, float, float, float, float, int, int, float
]  # (t, a_y, v, w_g, w_e, n_l, n_r, a_x)


class Isolation:
    """The witnesses and the ambiguity between the wheels and the gyro (module docstring).

    Parameters
    ----------
    cfg : HealthConfig
        ``window_s``, ``ambiguity_s``, ``recover_s``.
    robot : RobotGeometry
        The configured geometry.
    model : WheelYawModel
        The learned wheel yaw model (what the wheels stand for).
    """

    def __init__(self, cfg: HealthConfig, robot: RobotGeometry, model: WheelYawModel) -> None:
        self.cfg = cfg
        self.robot = robot
        self.model = model
        # (t, a_y, v, w_g, w_e, ticks_l, ticks_r, a_x) of the last 3 windows, for the witnesses
        self._hist: deque[Row] = deque()
        self._ambiguous_since: float | None = None  # wheels and gyro disagree, nobody to blame
        self._ambiguous_size = 0.0  # [rad/s] the disagreement that began the ambiguity
        self._calm_since: float | None = None  # the disagreement has been gone since
        self._imu_disagreement = 0.0  # [rad/s] the disagreement that excluded the IMU
        self._last_charge_mean = 0.0

    @property
    def ambiguous(self) -> bool:
        """The wheels and the gyro disagree and neither has been blamed yet."""
        return self._ambiguous_since is not None

    @property
    def ambiguous_size(self) -> float:
        """The disagreement that began the (last) ambiguity [rad/s]."""
        return self._ambiguous_size

    def record(self, f: FrameFacts) -> None:
        """A frame with a live gyro and accelerometer, kept for the witnesses (the last
        3 ``window_s`` and ``ambiguity_s``)."""
        h, t, cfg = f.h, f.h.t_s, self.cfg
        if (
            f.gyro_live
            and h.dt_s > 0.0
            and h.wz_rad_s is not None
            and h.accel_y_m_s2 is not None
            and h.accel_x_m_s2 is not None
        ):
            row = (t, h.accel_y_m_s2, f.speed_m_s, h.wz_rad_s, f.wheel_yaw_rad_s)
            self._hist.append((*row, h.ticks[0], h.ticks[1], h.accel_x_m_s2))
            keep = 3.0 * cfg.window_s + cfg.ambiguity_s  # the witnesses' reach back
            while self._hist and self._hist[0][0] <= t - keep:
                self._hist.popleft()

    def settle(self, t: float, calm: bool) -> None:
        """A window the cross-check passed, ``calm`` when well inside its band and the residual
        under half the disagreement that began the ambiguity: ``recover_s`` of calm windows end
        the ambiguity (a passing slip)."""
        if self._ambiguous_since is not None and calm:
            if self._calm_since is None:
                self._calm_since = t
            if t - self._calm_since >= self.cfg.recover_s - 1e-9:
                self._ambiguous_since = None  # the disagreement ended: a passing slip
        else:
            self._calm_since = None

    def gyro_cleared(self, imu: Health, window_mean: float) -> bool:
        """An excluded IMU may pass only once the disagreement that excluded it has halved
        (the windowed mean residual ``window_mean``); any other state may."""
        if imu is not Health.EXCLUDED:
            self._imu_disagreement = 0.0
            return True
        return not abs(window_mean) >= 0.5 * self._imu_disagreement > 0.0

    def charge(self, t: float, samples: list[Sample], mean: float, span: float) -> list[Finding]:
        """A persistent disagreement while driving, charged (module docstring).

        Parameters
        ----------
        t : float
            Now [s].
        samples : list of tuple
            The failing samples (t, r, sigma_r^2, omega_L, omega_R, w_g, v) it was seen in.
        mean : float
            Their mean residual [rad/s].
        span : float
            The time they cover [s].

        Returns
        -------
        list of Finding
            The sensors failed: one excluded, or, while ambiguous, the IMU and a wheel suspect.
        """
        self._last_charge_mean = mean
        n = len(samples)
        om_l = math.fsum(x[3] for x in samples) / n
        om_r = math.fsum(x[4] for x in samples) / n
        wz = math.fsum(x[5] for x in samples) / n
        v = math.fsum(x[6] for x in samples) / n
        r = self.robot
        head = f"wheel and gyro yaw rates disagree by {mean:+.3f} rad/s over {span:.2f} s"
        # a wheel that made no count all along although the other and the gyro say it turned
        t0 = samples[0][0] - 1e-9
        frames = [x for x in self._hist if x[0] >= t0]
        for i, wheel in enumerate(("left", "right")):
            if frames and all(x[5 + i] == 0 for x in frames):
                return self._exclude(
                    ENCODERS[i],
                    t,
                    f"{head}: the {wheel} wheel made no count (encoder stuck or cut)",
                )
        yaw = self.model.predict(wz, v) * r.wheel_separation_m
        excess_l = abs(om_l) - abs((r.wheel_radius_right_m * om_r - yaw) / r.wheel_radius_left_m)
        excess_r = abs(om_r) - abs((r.wheel_radius_left_m * om_l + yaw) / r.wheel_radius_right_m)
        side = 0 if excess_l >= excess_r else 1
        # the witnesses look at everything since the disagreement began (more with each try)
        since = t0 if self._ambiguous_since is None else self._ambiguous_since
        verdict = self._witness(since)
        axis = "lateral force"
        if verdict == "undecided":
            verdict, slip_side = self._speed_witness(since)
            axis = "forward speed"
            if slip_side is not None:
                side = slip_side
        if verdict != "undecided":
            self._ambiguous_since = None
        if verdict == "wheels right":
            why = f"{head}; the accelerometer's {axis} sides with the wheels (a gyro fault)"
            return self._exclude("imu", t, why)
        if verdict == "undecided":
            if self._ambiguous_since is None:
                self._ambiguous_since = samples[0][0]
                self._ambiguous_size = abs(mean)
            lasted = t - self._ambiguous_since
            if lasted >= self.cfg.ambiguity_s - 1e-9:
                why = (
                    f"{head}, for {lasted:.1f} s: longer than a slipping wheel, so the gyro "
                    "(a bias step; measured again at the next standstill)"
                )
                return self._exclude("imu", t, why)
            why = (
                f"{head}; the accelerometer cannot tell the gyro from the "
                f"{('left', 'right')[side]} wheel: the wheels' yaw rate stands in"
            )
            return [
                failing("imu", t, why, exclude=False),
                failing(ENCODERS[side], t, why, exclude=False),
            ]
        why = (
            f"{head}; the accelerometer's {axis} sides with the gyro: the "
            f"{('left', 'right')[side]} "
            f"wheel reads {max(excess_l, excess_r):.2f} rad/s more than the gyro and the other "
            "wheel allow (slipping)"
        )
        return self._exclude(ENCODERS[side], t, why)

    def _exclude(self, name: str, t: float, why: str) -> list[Finding]:
        if name == "imu":
            self._imu_disagreement = abs(self._last_charge_mean)
        return [failing(name, t, why, exclude=True)]

    def _witness(self, t0: float) -> str:
        """Which of the gyro and the wheels the accelerometer's lateral force agrees with, from
        the change since before the disagreement began: a_y = v w changes with the true yaw
        rate. "gyro right", "wheels right" or "undecided"."""
        before = [x for x in self._hist if t0 - self.cfg.window_s <= x[0] < t0]
        during = [x for x in self._hist if x[0] >= t0]
        if len(before) < 5 or len(during) < 3:
            return "undecided"

        def mean(rows: list[Row], k: int) -> float:
            return math.fsum(x[k] for x in rows) / len(rows)

        v = mean(during, 2)
        d_a = mean(during, 1) - mean(before, 1)
        d_g = v * (mean(during, 3) - mean(before, 3))
        model = self.model
        d_e = v * (
            model.true_rate(mean(during, 4), mean(during, 2))
            - model.true_rate(mean(before, 4), mean(before, 2))
        )
        a_before = [x[1] - x[2] * x[3] for x in before]  # lateral force less v w: its noise
        m = math.fsum(a_before) / len(a_before)
        var = math.fsum((a - m) ** 2 for a in a_before) / (len(a_before) - 1)
        sigma = math.sqrt(var / len(before) + var / len(during))
        if abs(d_g - d_e) < WITNESS_Z * sigma:
            return "undecided"
        return "gyro right" if abs(d_a - d_g) < abs(d_a - d_e) else "wheels right"

    def _speed_witness(self, t0: float) -> tuple[str, int | None]:
        """The forward accelerometer between a slipping wheel and a gyro fault.

        Parameters
        ----------
        t0 : float
            When the disagreement began [s].

        Returns
        -------
        verdict : str
            "gyro right", "wheels right" or "undecided".
        side : int or None
            The slipping wheel (0 left, 1 right) when the verdict is "gyro right".
        """
        gap = self.speed_gap(t0)
        if gap is None:
            return "undecided", None
        g, x_slip, sigma_g = gap
        if abs(x_slip) < WITNESS_Z * sigma_g:
            return "undecided", None
        # nearest of the three: 0 (gyro), +x (right wheel), -x (left wheel)
        d = [abs(g), abs(g - x_slip), abs(g + x_slip)]
        best = int(np.argmin(d))
        if best == 0:
            return "wheels right", None
        return "gyro right", 1 if best == 1 else 0

    def speed_gap(self, t0: float) -> tuple[float, float, float] | None:
        """How far the wheels' forward speed ran from the accelerometer's since a disagreement.

        A wheel that slips by Δ [m/s] raises the wheels' yaw rate by ±Δ/B and their forward
        speed by Δ/2; a gyro fault leaves the wheels' speed true. The wheels' speed less the
        accelerometer's integral drifts with the accelerometer's bias, measured over
        ``SPEED_WITNESS_BIAS_S`` before the reference ``t0 - SPEED_WITNESS_LEAD_S``; the gap's
        change since the reference, less that drift, is compared with 0 (the gyro at fault) and
        ±(w_e - w_g)·B/2 (the right or the left wheel).

        Parameters
        ----------
        t0 : float
            When the disagreement began [s].

        Returns
        -------
        tuple of float or None
            The gap's change g [m/s], the slip x [m/s] the gyro implies (its sign: + for the
            right wheel) and g's standard deviation; None without enough frames.
        """
        # the disagreement is noticed a few frames after it began: the speeds are compared
        # from SPEED_WITNESS_LEAD_S before, the accelerometer's bias measured before that
        t_ref = t0 - SPEED_WITNESS_LEAD_S
        rows = [x for x in self._hist if t_ref - SPEED_WITNESS_BIAS_S <= x[0]]
        n_before = sum(1 for x in rows if x[0] < t_ref)
        n_during = len(rows) - n_before
        if n_before < 10 or n_during < 3 or rows[-1][0] < t0:
            return None
        t = np.array([x[0] for x in rows])
        a_x = np.array([x[7] for x in rows])
        v_e = np.array([x[2] for x in rows])
        # the gap's increments: the wheels' speed change less the accelerometer's (trapezoid)
        d = np.diff(v_e) - 0.5 * (a_x[1:] + a_x[:-1]) * np.diff(t)
        # the noise: the accelerometer's (white; from its successive differences, which the
        # robot's slow accelerations hardly touch) integrated, and the wheels' speed, whose
        # counts telescope: a level over k frames is off by the quantisation of its distance
        dt = float(np.mean(np.diff(t)))
        ab = a_x[:n_before]
        var_a = float(np.mean(np.diff(ab) ** 2)) / 2.0 * dt * dt  # per increment
        r = self.robot
        count = [
            2.0 * math.pi * r.wheel_radius_left_m / r.ticks_per_rev_left / dt,
            2.0 * math.pi * r.wheel_radius_right_m / r.ticks_per_rev_right / dt,
        ]
        var_frame = (count[0] ** 2 + count[1] ** 2) / 24.0  # one frame's speed, both wheels
        k = min(SPEED_WITNESS_FRAMES, n_during, n_before - 1)
        # the gap's level over the last k frames against its level over the k frames before
        # t_ref, less the bias's drift between them (from the levels at the ends of the bias
        # window: [m/s^2] the accelerometer's bias, and scale errors)
        gap = np.concatenate(([0.0], np.cumsum(d)))
        before_at = slice(n_before - k, n_before)
        t_b = float(np.mean(t[before_at]) - np.mean(t[:k]))
        drift = float(np.mean(gap[before_at]) - np.mean(gap[:k])) / t_b
        span = float(np.mean(t[-k:]) - np.mean(t[before_at]))
        g = float(np.mean(gap[-k:]) - np.mean(gap[before_at])) - drift * span
        steps = max(n_during, 1)  # increments between the two levels' frames, about
        var_drift = (2.0 * var_frame / (k * k) + (n_before - k) * var_a) / (t_b * t_b)
        sigma_g = math.sqrt(2.0 * var_frame / (k * k) + steps * var_a + span * span * var_drift)
        # the slip the gyro implies: the change of the wheels' yaw-rate excess since t_ref
        excess = [x[4] - self.model.predict(x[3], x[2]) for x in rows]
        now = math.fsum(excess[-k:]) / k
        ref = math.fsum(excess[n_before - k : n_before]) / k
        x_slip = (now - ref) * 0.5 * self.robot.wheel_separation_m
        return g, x_slip, sigma_g
