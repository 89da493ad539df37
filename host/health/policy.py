"""The degraded-mode policy: from the sensors' states to what the EKF may use at a frame.

``imu_lost``, ``encoder_lost`` (``continue`` or ``stop``): with the IMU excluded the EKF takes
the yaw rate from the wheels through the learned model, with its variance sigma_r^2 (honestly
larger); with one encoder excluded, the forward speed from the other wheel and the gyro,
v = r_i omega_i -+ w_g B / 2; with the IMU and an encoder, or both encoders, lost the robot
brakes (the mission is aborted); so does a navigation mission with the LiDAR excluded
(``lidar_lost``), which has nothing left to see obstacles with. **Zero-velocity updates**: when
the robot is commanded still and neither wheel has counted for ``zupt_after_s``, it stands
still: the EKF fuses zero velocities and adds no process noise to the pose, so a parked robot's
covariance stays bounded.
"""

from __future__ import annotations

from jackson.host.health.config import HealthConfig
from jackson.host.health.states import SensorStates
from jackson.host.health.types import ENCODERS, FrameFacts, Health, Verdict
from jackson.host.health.wheel_yaw import WheelYawModel


class Policy:
    """The :class:`~jackson.host.health.types.Verdict` of a frame (module docstring).

    Parameters
    ----------
    cfg : HealthConfig
        The policies, tolerances and ``zupt``.
    model : WheelYawModel
        What the wheels' yaw rate stands for, and its variance.
    """

    def __init__(self, cfg: HealthConfig, model: WheelYawModel) -> None:
        self.cfg = cfg
        self.model = model

    def lost(self, states: SensorStates, lidar_needed: bool) -> str | None:
        """Why the robot must stop (None: it may go on)."""
        cfg = self.cfg
        imu_out = not states["imu"].usable
        enc_out = [not states[n].usable for n in ENCODERS]
        if lidar_needed and states["lidar"] is Health.EXCLUDED and cfg.lidar_lost == "stop":
            return f"the LiDAR excluded ({states.reason('lidar')}): no obstacle detection"
        if all(enc_out):
            return "both encoders excluded: no odometry"
        if imu_out and any(enc_out):
            return "the IMU and an encoder excluded: no yaw rate and no forward speed"
        if imu_out and cfg.imu_lost == "stop":
            return f"the IMU excluded ({states.reason('imu')}) and health.imu_lost is stop"
        if any(enc_out) and cfg.encoder_lost == "stop":
            side = "left" if enc_out[0] else "right"
            return f"the {side} encoder excluded and health.encoder_lost is stop"
        return None

    def verdict(
        self,
        states: SensorStates,
        f: FrameFacts,
        *,
        spike: bool,
        skip: list[bool],
        hold: bool,
        lidar_needed: bool,
        remeasure: bool,
    ) -> Verdict:
        """The frame's verdict.

        Parameters
        ----------
        states : SensorStates
            The sensors' states after every check of the frame.
        f : FrameFacts
            The frame.
        spike : bool
            The gyro's sample failed its gate.
        skip : list of bool
            Each wheel's sample is not to be fused (it did not count when it should have).
        hold : bool
            The wheels and the gyro disagree and neither is blamed yet.
        lidar_needed : bool
            A mission navigates by the LiDAR.
        remeasure : bool
            The gyro's bias is to be measured again.
        """
        cfg, model = self.cfg, self.model
        w_e, v_now, var = f.wheel_yaw_rad_s, f.speed_m_s, f.yaw_variance
        stationary = cfg.zupt and f.still
        return Verdict(
            use_gyro=f.gyro_live and not spike and states["imu"].usable and not hold,
            use_left=states["encoder_left"].usable and not skip[0],
            use_right=states["encoder_right"].usable and not skip[1],
            stationary=bool(stationary),
            wheel_yaw_variance=var
            + (cfg.scale_tolerance * abs(w_e)) ** 2
            + (cfg.straight_tolerance_rad_m * v_now) ** 2
            + model.variance(w_e, v_now),
            lost=self.lost(states, lidar_needed),
            hold_yaw=hold,
            wheel_yaw_rate_rad_s=model.true_rate(w_e, v_now),
            remeasure_gyro_bias=remeasure,
        )
