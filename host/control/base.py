"""What a mission sees and returns."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from jackson.common.geometry import wrap_angle as wrap_angle  # re-exported
from jackson.host.nav.types import Scan


@dataclass(frozen=True)
class NavState:
    """The estimate a mission steers by (the EKF's, in the odom frame)."""

    t_s: float
    x_m: float
    y_m: float
    yaw_rad: float
    v_m_s: float
    w_rad_s: float


class Mission(Protocol):
    """A source of velocity commands that knows when it has finished."""

    name: str
    done: bool

    def command(self, s: NavState) -> tuple[float, float]:
        """(v [m/s], w [rad/s]) for this control tick."""
        ...


@runtime_checkable
class ScanMission(Mission, Protocol):
    """A mission that also takes the LiDAR's scans (Stage 3)."""

    def on_scan(self, scan: Scan, s: NavState) -> None:
        """One revolution, with the estimate at its MCU time."""
        ...
