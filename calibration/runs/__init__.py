"""Recording the runs each calibration needs, and reading run folders back.

Every run is an ordinary run folder of the host (``log.jrec``, ``odometry.csv``, ``ekf.csv``,
``commands.csv``, ``config.yaml``, ``meta.json``; see docs/host.md), plus ``calibration.json``
with what the user measured (the tape distance, the true number of turns). Runs are recorded
through the host's own classes, on the robot or on the twin alike:

- **Velocity runs** (straight runs, in-place rotations, standing still, spins, excitation
  profiles) are the daemon itself (:class:`~jackson.host.daemon.Daemon` over
  :class:`~jackson.host.transport.SerialTransport` and the PCA9685) driving a small
  calibration mission: the EKF, the limits and the deadband compensation act as in any run.
  Missions steer by the EKF (whose yaw is the gyro's) and wait for its start-up gyro bias.
- **Raw duty runs** (deadband staircases, the step characterisation) must bypass the host's
  deadband compensation: the same daemon with the script as its command source
  (:class:`~jackson.host.core.DutySource`), whose duties go straight to the PCA9685
  (:class:`~jackson.host.actuation.output.Pca9685Output`); the run folder records the frames
  received and the raw duties in ``commands.csv`` (``v_cmd`` and ``w_cmd`` are 0 there). One
  per-frame loop serves every run.

:func:`load_run` turns a folder into a :class:`~jackson.calibration.procedures.RunData`;
on the twin, :func:`truth_reference` takes a run's true poses from the ground-truth file of
``jackson sim --truth`` (the tape measure a command-line user cannot hold to the twin).
"""

from __future__ import annotations

from jackson.calibration.runs.duty import (
    DeadbandScript,
    DutyScript,
    StepScript,
    duty_run,
    record_deadband_run,
    record_step_run,
    record_wheel_step_run,
)
from jackson.calibration.runs.folders import (
    CALIBRATION_SETTLE_FRAMES,
    NOTES_FILE,
    RunError,
    load_reference,
    load_run,
    run_boot_ids,
    write_notes,
)
from jackson.calibration.runs.link import (
    Link,
)
from jackson.calibration.runs.truth import (
    load_twin_truth,
    truth_distance_m,
    truth_reference,
    truth_rotation_rad,
)
from jackson.calibration.runs.velocity import (
    CalibrationMission,
    Measure,
    ProfileMission,
    RotationMission,
    StraightMission,
    drive_run,
    record_excitation_run,
    record_imu_runs,
    record_rotation_runs,
    record_straight_runs,
)

__all__ = [
    "CALIBRATION_SETTLE_FRAMES",
    "NOTES_FILE",
    "CalibrationMission",
    "DeadbandScript",
    "DutyScript",
    "Link",
    "Measure",
    "ProfileMission",
    "RotationMission",
    "RunError",
    "StepScript",
    "StraightMission",
    "drive_run",
    "duty_run",
    "load_reference",
    "load_run",
    "load_twin_truth",
    "record_deadband_run",
    "record_excitation_run",
    "record_imu_runs",
    "record_rotation_runs",
    "record_step_run",
    "record_straight_runs",
    "record_wheel_step_run",
    "run_boot_ids",
    "truth_distance_m",
    "truth_reference",
    "truth_rotation_rad",
    "write_notes",
]
