"""The yaw cross-check: the wheels' yaw rate against the gyro's, through the wheel yaw model.

The wheels give a yaw rate of their own, w_e = (r_R omega_R - r_L omega_L) / B. A healthy
robot's is w_e = s w_g + c v (:class:`~jackson.host.health.wheel_yaw.WheelYawModel`, learned
here while every sensor is ok). The residual r = w_e - (s w_g + c v) has the variance

    sigma_r^2 = R_wz + sigma_q^2 + (dw_e / 2)^2 + (kappa_a v alpha)^2 + (kappa w_g)^2
                + (kappa_v v)^2 + P_s w_g^2 + P_c (v - rho w_g)^2

with R_wz the gyro's variance (``gyro_noise_rad_s``^2, not the EKF's tuning), sigma_q^2 the
encoders' quantisation (one count of each wheel over the frame, a triangular error of 1/6
count^2 per wheel), dw_e / 2 the lag of the wheels' frame mean behind the gyro's sample under
angular acceleration, kappa_a v alpha the tyres' creep while the yaw rate changes at speed
(alpha the smaller of the wheels' and the gyro's change of yaw rate over the last 0.25 s, per
second; ``creep_tolerance_s``; one sign through a turn-in, so the windowed test counts its
mean as a model error that does not average down), kappa, kappa_v how much s and c vary on
a healthy robot (``scale_tolerance``, ``straight_tolerance_rad_m``), and P_s, P_c the model's
own variances (:meth:`~jackson.host.health.wheel_yaw.WheelYawModel.variance`: P_s once s is
identified, c's prior variance with the lever v - rho w_g until c is).

**Tests.** Per frame, the normalised innovation squared NIS = r^2 / sigma_r^2 against the
chi-square(1) quantile of ``gate_probability``: a failing sample is not fused (a spike);
``spikes_to_exclude`` of them in ``window_s`` exclude the IMU, and as many in a row, or always
of one sign, are a persistent disagreement that the isolation
(:mod:`jackson.host.health.isolation`) charges. Over the last ``window_s`` the mean residual
against its standard deviation, the random part averaged down and the model's errors not, at
the normal quantile of ``window_probability``: a slow fault (a bias step, a slipping wheel)
that no single sample shows, charged the same way. A failing sample while one wheel did not
count is that wheel's, and only that sample of it is not fused.
"""

from __future__ import annotations

import math
from collections import deque

from jackson.common.window import SummedWindow
from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health.config import HealthConfig
from jackson.host.health.isolation import Isolation, Sample
from jackson.host.health.states import SensorStates
from jackson.host.health.types import ENCODERS, Finding, FrameFacts, Health, failing
from jackson.host.health.wheel_yaw import WheelYawModel
from jackson.host.health.wheels import SILENT_TICKS, expected_ticks

RECOVER_Z_FRACTION = 0.5  # a sensor out of ok passes the windowed test only within half its band
CREEP_MEMORY_S = 0.25  # [s] the creep term's yaw acceleration is the change over this span
SPIKE_AFTERMATH = 0.25  # a spike ends with a residual below half the gate's (NIS a quarter)
UNLEARNED_SCALE_TOLERANCE = 0.15  # kappa before s is learned: scrub of up to 15 % in turns


class MeanWindow:
    """The windowed test's samples over the last ``window_s``: their sums kept exactly as
    samples come and go (the same sums as :func:`math.fsum`'s, without re-summing the window
    each frame), and the creep of each, whose mean does not average down.

    Attributes
    ----------
    judged : bool
        The last test had enough samples to judge (five, over 0.8 ``window_s``).
    mean : float
        The last judged mean residual [rad/s].
    """

    def __init__(self) -> None:
        # (t, res, var, om_l, om_r, wz, v); sums of res, |wz|, |v|, var, wz, v
        self.samples: SummedWindow[Sample] = SummedWindow(
            ((1, False), (5, True), (6, True), (2, False), (5, False), (6, False))
        )
        self.creep: SummedWindow[tuple[float, float]] = SummedWindow(((1, False),))
        self.judged = False
        self.mean = 0.0

    def add(self, sample: Sample, creep: float, window_s: float) -> None:
        """One passing sample with its creep term; those older than ``window_s`` leave."""
        t = sample[0]
        self.samples.append(sample)
        self.creep.append((t, creep))
        while self.samples and self.samples[0][0] <= t - window_s + 1e-9:
            self.samples.popleft()
        while self.creep and self.creep[0][0] <= t - window_s + 1e-9:
            self.creep.popleft()

    def clear(self) -> None:
        self.samples.clear()
        self.creep.clear()


class YawCrossCheck:
    """A :class:`~jackson.host.health.check.Check` of frames: the wheels' yaw rate against the
    gyro's (module docstring).

    Parameters
    ----------
    cfg : HealthConfig
        The gates, windows and tolerances.
    robot : RobotGeometry
        The configured geometry.
    model : WheelYawModel
        The wheel yaw model it judges by and teaches.
    isolation : Isolation
        Charges a persistent disagreement.
    states : SensorStates
        Read only: whether both wheels are usable, whether every sensor is ok.

    Attributes
    ----------
    nis : dict of str to float
        The last NIS per test ("yaw_rate": per sample, "window": the windowed mean's squared
        z score).
    gated : int
        Failing samples so far.
    spike, charged, skip, wheels_live
        Of the last frame: a sample beyond the gate (not fused); the sensors it charged (not
        passed); each wheel's sample not to fuse; both wheels usable.
    """

    def __init__(
        self,
        cfg: HealthConfig,
        robot: RobotGeometry,
        model: WheelYawModel,
        isolation: Isolation,
        states: SensorStates,
    ) -> None:
        self.cfg = cfg
        self.robot = robot
        self.model = model
        self.isolation = isolation
        self.states = states
        self.nis = {"yaw_rate": 0.0, "window": 0.0}
        self.gated = 0
        self.spike = False
        self.charged: set[str] = set()
        self.skip = [False, False]
        self.wheels_live = False
        self._gate = cfg.gate_nis
        self._z = cfg.window_z
        self._prev_we: float | None = None  # the wheels' last rate (for the lag)
        self._prev_wz: float | None = None  # the gyro's last live rate (for steadiness)
        # (t, w_e, w_g) over the last CREEP_MEMORY_S: the yaw acceleration, for the creep term
        self._alpha: deque[tuple[float, float, float]] = deque()
        self._window = MeanWindow()
        self._fails: deque[Sample] = deque()  # failing samples of the last window
        self._run: list[Sample] = []  # failing in a row
        self._run_nis = 0.0

    def observe(self, f: FrameFacts) -> list[Finding]:
        h, w_e, wz = f.h, f.wheel_yaw_rad_s, f.h.wz_rad_s
        prev_we, self._prev_we = self._prev_we, (w_e if h.dt_s > 0.0 else None)
        prev_wz, self._prev_wz = self._prev_wz, (wz if f.gyro_live else None)
        self.isolation.record(f)
        self.charged, self.skip, self.spike = set(), [False, False], False
        st = self.states
        self.wheels_live = st["encoder_left"].usable and st["encoder_right"].usable and h.dt_s > 0.0
        if f.gyro_live and self.wheels_live and wz is not None and not f.still:
            # learned only from a robot healthy for a while: a slow fault must not be learned
            # as the robot's geometry between two alarms
            healthy = st.quiet(h.t_s) and st.all_ok()
            return self._judge(f, wz, prev_we, prev_wz, healthy)
        if not f.gyro_live or not self.wheels_live:
            self._window.clear()
        return []

    def gyro_passes(self, imu: Health, gyro_live: bool) -> bool:
        """Whether the gyro passed this frame's tests: live, not charged, no spike, and, out of
        ``ok``, back well inside the windowed test's band and (excluded) the disagreement that
        excluded it gone."""
        ok = gyro_live and "imu" not in self.charged and not self.spike
        if imu is not Health.OK and self.nis["window"] >= (RECOVER_Z_FRACTION * self._z) ** 2:
            ok = False  # hysteresis: back in only well inside the band
        if not self.isolation.gyro_cleared(imu, self._window.mean):
            ok = False  # and only once the disagreement that excluded it has gone
        return ok

    def _kappa(self) -> float:
        """The scale tolerance: the prior's until the robot's scale s has been learned."""
        if self.model.scale_learned:
            return self.cfg.scale_tolerance
        return max(self.cfg.scale_tolerance, UNLEARNED_SCALE_TOLERANCE)

    def _judge(
        self,
        f: FrameFacts,
        wz: float,
        prev_we: float | None,
        prev_wz: float | None,
        healthy: bool,
    ) -> list[Finding]:
        """One sample of a live gyro and two live wheels while driving: the gate, the spikes,
        the window, and (healthy) the model's learning."""
        cfg, h, t = self.cfg, f.h, f.h.t_s
        w_e, v_now, var = f.wheel_yaw_rad_s, f.speed_m_s, f.yaw_variance
        om_l, om_r = h.wheel_rad_s
        # the wheels' rate is the frame's mean, the gyro's a sample: under angular
        # acceleration they differ by up to half the change over the frame (the wheels'
        # change: a gyro spike must not widen its own gate)
        lag = 0.5 * (w_e - prev_we) if prev_we is not None else 0.0
        creep = self._creep(t, w_e, wz, v_now)
        lag2 = lag * lag + creep * creep
        var_r = (
            var
            + lag2
            + (self._kappa() * abs(wz)) ** 2
            + (cfg.straight_tolerance_rad_m * v_now) ** 2
            + self.model.variance(wz, v_now, prior=False)
        )
        res = w_e - self.model.predict(wz, v_now)
        nis = res * res / var_r
        self.nis["yaw_rate"] = nis
        found = self._spikes(f, wz, nis, (t, res, var_r, om_l, om_r, wz, v_now))
        if self.spike or any(self.skip) or self.charged:
            return found
        self._window.add((t, res, var + lag * lag, om_l, om_r, wz, v_now), creep, cfg.window_s)
        found += self._window_test(t)
        self.charged |= {x.sensor for x in found}
        judged = self._window.judged  # a sample the windowed test could not judge yet
        if not self.charged and healthy and judged and not self.isolation.ambiguous:
            steady = (
                prev_wz is not None and abs(wz - prev_wz) <= WheelYawModel.STEADY_ALPHA * h.dt_s
            )
            noise = (
                var
                + lag2
                + (cfg.scale_tolerance * wz) ** 2
                + (cfg.straight_tolerance_rad_m * v_now) ** 2
            )
            known = list(self.model.identified)
            self.model.learn(w_e, wz, v_now, h.dt_s, noise, steady)
            if self.model.identified != known:
                # the window's residuals were the prior's, its variance now the
                # posterior's: judge the identified model on residuals of its own
                self._window.clear()
        return found

    def _creep(self, t: float, w_e: float, wz: float, v: float) -> float:
        """kappa_a |v| alpha: the tyres creep while the yaw rate changes at speed; alpha is the
        smaller of the wheels' and the gyro's change over the last CREEP_MEMORY_S (a fault in
        one of them does not widen its own gate; the span keeps their noise out of it, and the
        creep outlasts the push a little)."""
        self._alpha.append((t, w_e, wz))
        while self._alpha and self._alpha[0][0] < t - CREEP_MEMORY_S - 1e-9:
            self._alpha.popleft()
        t_a, we_a, wz_a = self._alpha[0]
        alpha = 0.0
        if t - t_a > 0.5 * CREEP_MEMORY_S:
            alpha = min(abs(w_e - we_a), abs(wz - wz_a)) / (t - t_a)
        return self.cfg.creep_tolerance_s * abs(v) * alpha

    def _spikes(self, f: FrameFacts, wz: float, nis: float, sample: Sample) -> list[Finding]:
        """The per-sample gate: a silent wheel's failing sample, spikes, and failures that go
        on frame after frame (a persistent disagreement, charged)."""
        cfg, h, t = self.cfg, f.h, f.h.t_s
        found: list[Finding] = []
        spike = nis >= self._gate
        while self._fails and self._fails[0][0] <= t - cfg.window_s + 1e-9:
            self._fails.popleft()
        silent = [
            i
            for i in range(2)
            if h.ticks[i] == 0 and expected_ticks(self.robot, self.model, i, h, wz) >= SILENT_TICKS
        ]
        if spike and len(silent) == 1:  # a wheel that should turn and did not count
            i = silent[0]
            why = f"yaw-rate NIS {nis:.1f}: the wheel did not count"
            found.append(failing(ENCODERS[i], t, why, exclude=False))
            self.charged.add(ENCODERS[i])
            self.skip[i] = True
            spike = False
        elif spike:
            self.gated += 1
            self._fails.append(sample)
            self._run.append(sample)
            self._run_nis = nis
            if len(self._run) >= cfg.spikes_to_exclude:
                # failing frame after frame: not spikes but a persistent disagreement
                mean = math.fsum(x[1] for x in self._run) / len(self._run)
                span = self._run[-1][0] - self._run[0][0] + h.dt_s
                found += self._charge(t, list(self._run), mean, span)
                self._run.clear()
                self._fails.clear()
            else:
                self.charged.add("imu")  # not fused; judged when the run of failures ends
        fails = list(self._fails)
        if (
            not spike
            and self._run
            and len(fails) >= cfg.spikes_to_exclude
            and (all(x[1] > 0.0 for x in fails) or all(x[1] < 0.0 for x in fails))
        ):
            # failing often, and always the same way: a disagreement that the frames'
            # quantisation lets through now and then (a slow slip), not spikes
            mean = math.fsum(x[1] for x in fails) / len(fails)
            span = fails[-1][0] - fails[0][0] + h.dt_s
            found += self._charge(t, fails, mean, span)
            self._run.clear()
            self._fails.clear()
        if not spike and self._run and nis >= SPIKE_AFTERMATH * self._gate:
            # the residual is still large after the failing samples: not a spike but the
            # onset of a disagreement that only just passes now (the failing samples stay
            # in the window's count, and were not fused)
            self._run.clear()
        if not spike and self._run:  # a run shorter than a persistent one: spikes
            exclude = len(self._fails) >= cfg.spikes_to_exclude
            why = (
                f"{len(self._fails)} yaw-rate samples beyond the gate in "
                f"{cfg.window_s:.1f} s (spikes)"
                if exclude
                else f"yaw-rate NIS {self._run_nis:.1f} beyond the gate {self._gate:.1f} (a spike)"
            )
            found.append(failing("imu", self._run[-1][0], why, exclude=exclude))
            self.charged.add("imu")
            self._run.clear()
        self.spike = spike
        return found

    def _charge(self, t: float, samples: list[Sample], mean: float, span: float) -> list[Finding]:
        """A persistent disagreement, charged by the isolation; its sensors are charged here."""
        found = self.isolation.charge(t, samples, mean, span)
        self.charged |= {x.sensor for x in found}
        return found

    def _window_test(self, t: float) -> list[Finding]:
        """The windowed mean of the residual; the sensor it charges, if it fails."""
        cfg, w = self.cfg, self._window
        window = w.samples
        n = len(window)
        span = window[-1][0] - window[0][0] if n else 0.0
        w.judged = not (n < 5 or span < 0.8 * cfg.window_s)
        if n < 5 or span < 0.8 * cfg.window_s:
            self.nis["window"] = 0.0
            w.mean = 0.0 if n < 5 else w.mean
            return []
        mean = window.sum(0) / n
        # the random part averages down; the scale disagreement (scrub) does not
        rate = window.sum(1) / n
        speed = window.sum(2) / n
        var_mean = window.sum(3) / (n * n)
        var_mean += (self._kappa() * rate) ** 2 + (cfg.straight_tolerance_rad_m * speed) ** 2
        # the creep of a turn-in has one sign all along: it does not average down either
        creep = w.creep.sum(0) / max(len(w.creep), 1)
        var_mean += creep * creep
        # the learned model's own error does not average down either: P_s mean(w_g)^2 +
        # P_c mean(v)^2 of the terms identified
        var_mean += self.model.variance(
            window.sum(4) / n,
            window.sum(5) / n,
            prior=False,
        )
        z2 = mean * mean / var_mean
        self.nis["window"] = z2
        w.mean = mean
        if z2 < self._z**2:
            calm = z2 < (RECOVER_Z_FRACTION * self._z) ** 2
            # where the test is blunt (a fast turn) a calm window is not enough: the residual
            # itself must have gone, to half the disagreement that began the ambiguity
            calm = calm and abs(mean) < 0.5 * self.isolation.ambiguous_size
            self.isolation.settle(t, calm)
            return []
        found = self.isolation.charge(t, list(window), mean, span)
        w.clear()
        return found
