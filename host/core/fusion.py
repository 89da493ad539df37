"""The measurement policy: the EKF fed as the sensors' health allows, and its outputs.

Per telemetry frame (docs/host.md, step 2; docs/health.md): the health monitor
(:class:`~jackson.host.health.HealthMonitor`) judges the front end's
:class:`~jackson.host.core.frontend.Measurement` and returns its
:class:`~jackson.host.health.Verdict`, and the filter fuses what the verdict allows: both
wheels' speed and the gyro; or one wheel and the gyro, or the wheels' yaw rate (the verdict's
stand-in) in place of the gyro; or, standing still, a zero-velocity update. Of the monitor
only the verdict is read. Without the monitor (``health.enabled: false``) every measurement
is fused, as the paper's filter does. The filter's outputs are its estimate predicted to every
instant of :class:`~jackson.host.estimation.ekf.OutputClock` (30 Hz of MCU time). The monitor's
transitions are told (events), and a sensor loss that leaves nothing to navigate by is kept as
the reason to brake (:attr:`Fusion.sensors_lost`). A verdict that asks for the gyro's bias to be
measured again is the pipeline's to hand to the front end.
"""

from __future__ import annotations

from collections.abc import Callable

from jackson.host.config import HostConfig
from jackson.host.core.frontend import Measurement
from jackson.host.estimation.ekf import Ekf, EkfState, OutputClock
from jackson.host.health import HealthMonitor, Transition, Verdict

ONE_WHEEL_VARIANCE_SCALE = 4.0  # R of v_x from one wheel and the gyro, relative to two wheels

UNCALIBRATED_HINT = (
    "the host config holds no calibration (imu.calibration is unset): on a robot other than "
    "the one it describes the sensors disagree with it and look faulty; calibrate this robot "
    "first (jackson calibrate, docs/calibration.md)"
)


class Fusion:
    """The EKF, the health monitor and the policy between them (module docstring).

    Parameters
    ----------
    cfg : HostConfig
        ``ekf``, ``health``, ``robot`` and whether ``imu.calibration`` is set.
    tell : callable
        An event for the operator (one line).
    on_transition : callable
        Each health transition, after it is told.
    """

    def __init__(
        self,
        cfg: HostConfig,
        tell: Callable[[str], None],
        on_transition: Callable[[Transition], None],
    ) -> None:
        self.cfg = cfg
        self.ekf = Ekf(cfg.ekf)
        self.clock = OutputClock(cfg.ekf.frequency_hz)
        self.health = HealthMonitor(cfg.health, cfg.robot) if cfg.health.enabled else None
        self.verdict: Verdict | None = None
        self.sensors_lost: str | None = None  # the health policy's reason to brake
        self.outputs = 0  # outputs made
        self.last_output: EkfState | None = None
        self._tell = tell
        self._on_transition = on_transition
        self._hinted = False  # the uncalibrated config's hint was given
        self._told = 0  # health transitions told (the record's count of ever added)

    def outputs_to(self, t_s: float, emit: Callable[[float, EkfState], None]) -> None:
        """The outputs due up to a frame at ``t_s`` (predictions; the filter does not move),
        each to ``emit`` as it is made."""
        for at_s in self.clock.due(t_s):
            if self.ekf.initialized:
                self.outputs += 1
                self.last_output = s = self.ekf.state_at(at_s)
                emit(at_s, s)

    def fuse(
        self, m: Measurement, wheel_cmd: tuple[float, float], commanded_still: bool
    ) -> Verdict | None:
        """This frame's measurements into the filter, as the monitor's verdict allows.

        Parameters
        ----------
        m : Measurement
            The front end's.
        wheel_cmd : tuple of float
            The wheel speeds commanded at the previous frame [rad/s].
        commanded_still : bool
            Braked, or commanded to stand still.

        Returns
        -------
        Verdict or None
            The monitor's verdict (None: the monitor is off), also kept as :attr:`verdict`.
        """
        hm = self.health
        if hm is None:  # the paper's filter: every measurement
            self.ekf.update_wheel(m.t_s, m.odometry.v_m_s, 0.0)
            if m.wz_rad_s is not None:
                self.ekf.update_gyro(m.t_s, m.wz_rad_s)
            return None
        hm.link(m.t_s, m.lost)
        v = self.verdict = hm.update(m.health_input(wheel_cmd, commanded_still))
        self.report_health()
        if v.lost is not None and self.sensors_lost is None:
            self.sensors_lost = v.lost
            if self._hinted:  # a wheel or the gyro was excluded on an uncalibrated config
                self.sensors_lost = f"{v.lost} ({UNCALIBRATED_HINT})"
            self._tell(f"health: braking: {self.sensors_lost}")
        self._update(m, v)
        return v

    def _update(self, m: Measurement, v: Verdict) -> None:
        """The filter's updates the verdict allows."""
        ekf = self.ekf
        t_s, odo, wz = m.t_s, m.odometry, m.wz_rad_s
        ekf.stationary = v.stationary
        if v.stationary:
            ekf.update_zero_velocity(t_s, self.cfg.health.zupt_variance)
            return
        r = self.cfg.robot
        om = m.wheel_rad_s
        if v.use_left and v.use_right:
            ekf.update_wheel(t_s, odo.v_m_s, 0.0)
        elif wz is not None and v.use_gyro and (v.use_left or v.use_right):
            # one wheel and the gyro: v = r_i omega_i -+ wz B / 2
            half = 0.5 * wz * r.wheel_separation_m
            if v.use_left:
                vx = r.wheel_radius_left_m * om[0] + half
            else:
                vx = r.wheel_radius_right_m * om[1] - half
            ekf.update_wheel(t_s, vx, 0.0, variance_scale=ONE_WHEEL_VARIANCE_SCALE)
        if wz is not None and v.use_gyro:
            ekf.update_gyro(t_s, wz)
        elif v.use_left and v.use_right and m.dt_s > 0.0:
            # the wheels' yaw rate through the model learned while the gyro was healthy
            ekf.update_yaw_rate(t_s, v.wheel_yaw_rate_rad_s, v.wheel_yaw_variance)

    def report_health(self) -> None:
        """Tell the monitor's new transitions; with a config that holds no calibration, the
        first exclusion of a wheel or the gyro for disagreeing with the other (not a dead or
        stuck sensor) says so too."""
        hm = self.health
        if hm is None:
            return
        for tr in hm.transitions.since(self._told):
            self._tell(f"health: {tr.sensor} {tr.old.value} -> {tr.new.value}: {tr.reason}")
            self._on_transition(tr)
            if (
                tr.new.value == "excluded"
                and tr.sensor in ("imu", "encoder_left", "encoder_right")
                and "disagree" in tr.reason  # the wheels and the gyro against the config's robot
                and self.cfg.imu.calibration is None
                and not self._hinted
            ):
                self._hinted = True
                self._tell(f"health: {UNCALIBRATED_HINT}")
        self._told = hm.transitions.added
