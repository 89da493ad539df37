"""The health monitor: every check of a telemetry frame in order, their findings applied to
the sensors' states, and the policy's verdict.

Per frame (:meth:`HealthMonitor.update`): standing still; the IMU's silence and freeze; the
encoders; the gyro's bias standing still; the yaw cross-check (with the isolation of what it
finds); the passes of the sensors whose tests ran and passed; the LiDAR's silence; the policy.
Each check's findings are applied before the next check runs, so every check sees the states
the earlier ones left. The LiDAR's bytes and revolutions are judged as they come, by the
LiDAR's intake, through :attr:`HealthMonitor.lidar`; the link's frames by
:meth:`HealthMonitor.link`.
"""

from __future__ import annotations

import math

from jackson.host.estimation.odometry import RobotGeometry
from jackson.host.health.config import HealthConfig
from jackson.host.health.encoder_stuck import EncoderStuck
from jackson.host.health.imu_silence import ImuSilence
from jackson.host.health.imu_stuck import ImuStuck
from jackson.host.health.isolation import Isolation
from jackson.host.health.lidar import LidarHealth
from jackson.host.health.link import LinkCheck
from jackson.host.health.policy import Policy
from jackson.host.health.standstill import Standstill
from jackson.host.health.states import Recent, SensorStates
from jackson.host.health.still_bias import StillBias
from jackson.host.health.types import (
    Finding,
    FrameFacts,
    Health,
    HealthInput,
    LinkInput,
    Transition,
    Verdict,
    passing,
)
from jackson.host.health.wheel_yaw import WheelYawModel, wheel_yaw_prior
from jackson.host.health.wheels import forward_speed, quantisation_variance, wheel_yaw_rate
from jackson.host.health.yaw_check import YawCrossCheck


class HealthMonitor:
    """The health of the IMU, the encoders, the link and the LiDAR, per telemetry frame
    (module docstring).

    Parameters
    ----------
    cfg : HealthConfig
        Thresholds and policy.
    robot : RobotGeometry
        Wheel radii, separation and counts per revolution the host believes.

    Attributes
    ----------
    model : WheelYawModel
        The wheel yaw model learned while every sensor is ok.
    lidar : LidarHealth
        The LiDAR's checks, run by the LiDAR's intake.
    """

    # the last frame's interval and its yaw variance (class defaults: a core pickled before
    # they were kept restores without them)
    _yaw_variance_dt_s = math.nan
    _yaw_variance_value = 0.0

    def __init__(self, cfg: HealthConfig, robot: RobotGeometry) -> None:
        self.cfg = cfg
        self.robot = robot
        self.states = SensorStates(cfg)
        self.model = WheelYawModel(cfg.ratio_time_constant_s, wheel_yaw_prior(cfg, robot))
        self.standstill = Standstill(cfg)
        self.imu_silence = ImuSilence(cfg)
        self.imu_stuck = ImuStuck(cfg)
        self.encoders = EncoderStuck(cfg, robot, self.model)
        self.still_bias = StillBias(cfg)
        self.isolation = Isolation(cfg, robot, self.model)
        self.yaw = YawCrossCheck(cfg, robot, self.model, self.isolation, self.states)
        self.link_check = LinkCheck(cfg)
        self.lidar = LidarHealth(cfg, self.states)
        self.policy = Policy(cfg, self.model)
        self._zupts = 0

    @property
    def sensors(self) -> dict[str, Health]:
        """Each sensor's state now."""
        return self.states.now

    def state(self, sensor: str) -> Health:
        """The state of ``imu``, ``encoder_left``, ``encoder_right``, ``link`` or ``lidar``."""
        return self.states[sensor]

    def reason(self, sensor: str) -> str:
        """Why the sensor entered its current state ('' while it never left ``ok``)."""
        return self.states.reason(sensor)

    @property
    def transitions(self) -> Recent[Transition]:
        """The newest transitions, in order."""
        return self.states.transitions

    @property
    def nis(self) -> dict[str, float]:
        """The last NIS per test ("yaw_rate": per sample, "window": the windowed mean's
        squared z score)."""
        return self.yaw.nis

    @property
    def counts(self) -> dict[str, int]:
        """Failing samples, exclusions, zero-velocity updates and (once any) LiDAR holds."""
        counts = {"gated": self.yaw.gated, "excluded": self.states.excluded, "zupt": self._zupts}
        if self.lidar.silence.blinds:
            counts["blind"] = self.lidar.silence.blinds
        return counts

    @property
    def remeasure_bias(self) -> bool:
        """The last frame found the gyro reading non-zero standing still: measure its bias."""
        return self.still_bias.remeasure

    @property
    def lidar_blind(self) -> bool:
        """Navigating without a usable scan too long: hold the robot (braked)."""
        return self.lidar.blind

    @property
    def lidar_counts(self) -> dict[str, int]:
        """LiDAR scans judged and not used."""
        return self.lidar.counts

    @property
    def lidar_roughness_m(self) -> float:
        """The last scan's estimated range noise [m]."""
        return self.lidar.roughness_m

    @property
    def lidar_missing(self) -> float:
        """Fraction of the LiDAR's revolutions missing over the last window."""
        return self.lidar.missing

    def link(self, t_s: float, lost: int) -> None:
        """One telemetry frame received, ``lost`` frames missing before it (by SEQ)."""
        self._judge(self.link_check.observe(LinkInput(t_s, lost)))

    def update(self, h: HealthInput) -> Verdict:
        """Judge one frame; the new transitions are appended to :attr:`transitions`."""
        out: list[Transition] = []
        states, robot = self.states, self.robot
        still = self.standstill.observe(h)
        states.apply(self.imu_silence.observe(h), out)
        states.apply(self.imu_stuck.observe(h), out)
        gyro_live = h.imu_ok and not self.imu_stuck.frozen and h.wz_rad_s is not None
        om_l, om_r = h.wheel_rad_s
        f = FrameFacts(
            h,
            still,
            gyro_live,
            trusted_wz=h.wz_rad_s if gyro_live and states["imu"].usable else None,
            wheel_yaw_rad_s=wheel_yaw_rate(robot, om_l, om_r),
            speed_m_s=forward_speed(robot, om_l, om_r),
            yaw_variance=self._yaw_variance(h.dt_s),
        )
        states.apply(self.encoders.observe(f), out)
        bias = self.still_bias.observe(f)
        states.apply(bias, out)
        states.apply(self.yaw.observe(f), out)
        self._passes(f, bool(bias), out)
        states.apply(self.lidar.frame(h.t_s, f.speed_m_s), out)
        hold = self.isolation.ambiguous and states["imu"] is not Health.EXCLUDED
        states.commit(out)
        if self.cfg.zupt and still:
            self._zupts += 1
        return self.policy.verdict(
            states,
            f,
            spike=self.yaw.spike,
            skip=self.yaw.skip,
            hold=hold,
            lidar_needed=self.lidar.needed,
            remeasure=self.still_bias.remeasure,
        )

    def _yaw_variance(self, dt_s: float) -> float:
        """R_wz + sigma_q^2 of a frame of ``dt_s``, kept for the next frame of the same dt."""
        if dt_s != self._yaw_variance_dt_s:
            self._yaw_variance_dt_s = dt_s
            self._yaw_variance_value = self.cfg.gyro_variance + quantisation_variance(
                self.robot, dt_s
            )
        return self._yaw_variance_value

    def _passes(self, f: FrameFacts, bias: bool, out: list[Transition]) -> None:
        """The sensors whose tests ran and passed this frame: the gyro where a test could check
        it (an excluded one only with both wheels live or standing still), each encoder that
        counted or was not driven."""
        imu = self.states["imu"]
        ok = self.yaw.gyro_passes(imu, f.gyro_live) and not bias
        if ok and (imu is not Health.EXCLUDED or self.yaw.wheels_live or f.still):
            self.states.apply([passing("imu", f.h.t_s)], out)
        self.states.apply(self.encoders.passes(f, self.states, self.yaw.charged), out)

    def _judge(self, found: list[Finding]) -> None:
        out: list[Transition] = []
        self.states.apply(found, out)
        self.states.commit(out)
