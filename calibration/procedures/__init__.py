"""The calibration maths: pure functions over recorded runs (Appendix A and B of the paper).

Every function here takes recorded data (a :class:`RunData` per run folder, or plain arrays)
and returns a small frozen result; nothing reads files, talks to the robot or prints. The
recorders live in :mod:`jackson.calibration.runs`, the command line in
:mod:`jackson.calibration.cli`.

1. **Encoder resolution** per wheel from straight runs and a tape measurement (Eq. A4, A6):
   ``C_cal = C_0 d_odom / d_meas``.
2. **Wheel separation** from in-place rotations (Eq. A12): ``B = r (dphi_R - dphi_L) / dtheta``.
3. **IMU static profile**: gyro bias, accelerometer gravity scale ``9.81 / |mean a|``, the
   REP-103 yaw-sign audit against wheel odometry, and the datasheet noise sigmas of Sec. 2.2.4.
4. **PWM deadband** per wheel and direction from slow duty staircases, and the step
   **characterisation** (top speed, time to 90 %, stopping distance).
5. **Step response**: a first-order model per wheel and direction (gain K, time constant,
   dead time) from duty steps, and the deadband compensation's per-wheel, per-direction gains
   that make every wheel reach the same commanded speed.
6. **Twin fit**: effective wheel radius, wheel separation and IMU yaw scale (the paper's
   V16/V17 values) by least squares of dead-reckoned against reference trajectories.

Every failure a user can cause (a robot that did not move, a zero tape measurement) raises
:class:`CalibrationError` with one line naming the run.
"""

from __future__ import annotations

from jackson.calibration.procedures.base import (
    ACCEL_DENSITY_UG_RT_HZ,
    DLPF_BANDWIDTH_HZ,
    FIRST_ORDER_NOISE_FACTOR,
    GYRO_DENSITY_DEG_S_RT_HZ,
    MIN_TRAVEL_TICKS,
    MOTION_MARGIN_FRAMES,
    PAPER_ACCEL_SCALE,
    PAPER_STATIC_GRAVITY_M_S2,
    STANDARD_GRAVITY_M_S2,
    CalibrationError,
    FloatArray,
    IntArray,
    RunData,
    check_frames,
    wheel_angle_rad,
    wheel_travel_m,
)
from jackson.calibration.procedures.characterise import (
    Characterisation,
    braking_distance,
    characterise,
)
from jackson.calibration.procedures.deadband import (
    Bracket,
    DeadbandCalibration,
    Ramp,
    breakaway_bracket,
    calibrate_deadband,
    combine_brackets,
    find_ramps,
)
from jackson.calibration.procedures.encoders import (
    EncoderCalibration,
    StraightRun,
    calibrate_encoders,
    encoder_resolution,
    straight_run,
)
from jackson.calibration.procedures.imu import (
    DatasheetNoise,
    ImuProfile,
    YawAudit,
    datasheet_noise,
    imu_profile,
    noise_sigma,
    odometry_yaw_rate,
    rotation_matrix,
    yaw_sign_audit,
)
from jackson.calibration.procedures.step import (
    DutyStep,
    HostGains,
    StepIdentification,
    WheelModel,
    WheelStep,
    WheelStepScript,
    find_steps,
    fit_wheel,
    identify_steps,
    step_angle,
    step_plan,
)
from jackson.calibration.procedures.track import (
    RotationRun,
    TrackCalibration,
    calibrate_track,
    rotation_run,
    wheel_separation,
)
from jackson.calibration.procedures.twin_fit import (
    DeadReckoning,
    FitSegment,
    Heading,
    Reference,
    TwinFit,
    dead_reckon,
    fit_segment,
    fit_twin,
)

__all__ = [
    "ACCEL_DENSITY_UG_RT_HZ",
    "DLPF_BANDWIDTH_HZ",
    "FIRST_ORDER_NOISE_FACTOR",
    "GYRO_DENSITY_DEG_S_RT_HZ",
    "MIN_TRAVEL_TICKS",
    "MOTION_MARGIN_FRAMES",
    "PAPER_ACCEL_SCALE",
    "PAPER_STATIC_GRAVITY_M_S2",
    "STANDARD_GRAVITY_M_S2",
    "Bracket",
    "CalibrationError",
    "Characterisation",
    "DatasheetNoise",
    "DeadReckoning",
    "DeadbandCalibration",
    "DutyStep",
    "EncoderCalibration",
    "FitSegment",
    "FloatArray",
    "Heading",
    "HostGains",
    "ImuProfile",
    "IntArray",
    "Ramp",
    "Reference",
    "RotationRun",
    "RunData",
    "StepIdentification",
    "StraightRun",
    "TrackCalibration",
    "TwinFit",
    "WheelModel",
    "WheelStep",
    "WheelStepScript",
    "YawAudit",
    "braking_distance",
    "breakaway_bracket",
    "calibrate_deadband",
    "calibrate_encoders",
    "calibrate_track",
    "characterise",
    "check_frames",
    "combine_brackets",
    "datasheet_noise",
    "dead_reckon",
    "encoder_resolution",
    "find_ramps",
    "find_steps",
    "fit_segment",
    "fit_twin",
    "fit_wheel",
    "identify_steps",
    "imu_profile",
    "noise_sigma",
    "odometry_yaw_rate",
    "rotation_matrix",
    "rotation_run",
    "step_angle",
    "step_plan",
    "straight_run",
    "wheel_angle_rad",
    "wheel_separation",
    "wheel_travel_m",
    "yaw_sign_audit",
]
