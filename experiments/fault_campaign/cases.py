"""The fault campaign's cases: which fault, on which mission, blaming which sensor."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from jackson.common.errors import JacksonError

if TYPE_CHECKING:  # the twin and the host load when a campaign runs, not for jackson --help
    from jackson.sim.faults import FaultSpec


ONSET_S = 30.0  # [s] MCU time of the square's and the figure-eight's fault onsets
# [s] the maze cases' onset: the maze's navigation drives from 2.05 s to 9.5-10.3 s of MCU time
# (seeds 0-2; the cylinder drops at 2.9 s), so the fault meets the last 5.5-6.3 s of the drive
MAZE_ONSET_S = 4.0
DETECTION_TARGET = 0.95  # a case's detection rate must reach this
CONFIDENCE = 0.95  # one-sided confidence of the false-alarm upper bounds
UNHEALTHY = ("suspect", "excluded")  # states a detection moves a sensor into
SENSORS = ("imu", "encoder_left", "encoder_right")
LIDAR = "lidar"  # the monitor's LiDAR: judged on the maze only (the other missions run without)
WORLDS = {"figure8": "open_floor", "square": "square_room", "maze": "maze"}
# [s] a little under a clean run's driving time, so that a plan of clean runs reaches its hours
PLANNED_DRIVE_S = {"square": 45.0, "figure8": 90.0}
MONITOR_YAML = "host-monitor.yaml"
NO_MONITOR_YAML = "host-no-monitor.yaml"


class FaultCampaignError(JacksonError, RuntimeError):
    """The campaign cannot run its trials: the maze's mapping run did not finish."""


@dataclass(frozen=True)
class FaultCase:
    """One case of the campaign: a mission, the fault injected, the sensor to blame.

    Attributes
    ----------
    name : str
        Its name on the command line (``--case``) and in the report.
    mission : str
        ``figure8``, ``square`` or ``maze`` (the navigation trial).
    fault : str
        The fault as ``KIND@AT_S[+DURATION_S][:key=value,...]`` (:func:`parse_fault`).
    sensor : str
        The health monitor's sensor that should be blamed (``imu``, ``encoder_left``,
        ``encoder_right``, ``lidar``).
    """

    name: str
    mission: str
    fault: str
    sensor: str

    @property
    def spec(self) -> FaultSpec:
        """The fault as the twin takes it."""
        from jackson.sim.faults import parse_fault

        return parse_fault(self.fault)


SLIP = "wheel_slip@30+2:side=right,mu_scale=0.01"  # 0.1 barely slips at 0.08 m/s (docs)
CASES = (
    FaultCase("imu_dead", "figure8", "imu_dead@30", "imu"),
    FaultCase("imu_stuck", "figure8", "imu_stuck@30", "imu"),
    FaultCase("imu_spike", "figure8", "imu_spike@30+30", "imu"),
    FaultCase("imu_bias_step", "figure8", "imu_bias_step@30", "imu"),
    FaultCase("encoder_dropout_left", "figure8", "encoder_dropout@30:side=left", "encoder_left"),
    FaultCase("wheel_slip_right", "figure8", SLIP, "encoder_right"),
    FaultCase("square_imu_bias_step", "square", "imu_bias_step@30", "imu"),
    FaultCase("square_wheel_slip_right", "square", SLIP, "encoder_right"),
    FaultCase("lidar_noise", "maze", "lidar_noise@4:sigma_m=0.05", LIDAR),
    FaultCase("lidar_dropout", "maze", "lidar_dropout@4:probability=0.3", LIDAR),
    FaultCase("lidar_dead", "maze", "lidar_dropout@4:probability=1", LIDAR),
    FaultCase("lidar_garbage", "maze", "lidar_garbage@4", LIDAR),
    FaultCase("lidar_closed", "maze", "lidar_closed@4", LIDAR),
)
"""Every case, in the report's order."""
BLIND_CASES = frozenset({"lidar_dead", "lidar_garbage", "lidar_closed"})
"""Cases whose LiDAR goes blind: the robot must stand within :data:`BLIND_LIMIT_M`."""
BLIND_LIMIT_M = 0.1  # [m] the farthest a navigating robot may drive on its last scans
CASE_NAMES = tuple(c.name for c in CASES)
