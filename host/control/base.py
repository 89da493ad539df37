"""What a mission sees and returns."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TypeGuard, runtime_checkable

from jackson.common.geometry import wrap_angle as wrap_angle  # re-exported
from jackson.host.nav.types import Scan

if TYPE_CHECKING:
    from jackson.host.actuation.limiter import LimiterConfig


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


@runtime_checkable
class TimedMission(Mission, Protocol):
    """A mission whose time limit depends on what it was given (a navigation: its route,
    :func:`jackson.host.control.guard.route_timeout_s`) [s of MCU time]."""

    timeout_s: float


@runtime_checkable
class LimitedMission(Mission, Protocol):
    """A mission that plans within the daemon's speed and acceleration limits (a navigation):
    told when they change at run time (:mod:`jackson.host.core.settings`)."""

    def set_limits(self, limits: LimiterConfig) -> None:
        """The bounds to plan within from the next control tick on."""
        ...


@runtime_checkable
class ServiceMission(ScanMission, Protocol):
    """A mission that lasts as long as the daemon and takes requests from other threads (the
    navigation service, :mod:`jackson.host.service.navigation`). It is never ``done``; the
    command arbiter gives velocity commands precedence over it and holds it braked while
    ``idle``."""

    @property
    def idle(self) -> bool:
        """No goal is active: the robot is held braked."""
        ...

    @property
    def navigating(self) -> bool:
        """A goal is active: the LiDAR is needed."""
        ...

    def take_requests(self) -> Sequence[Any]:
        """The requests the coming telemetry frame applies (each has ``encode() -> bytes``,
        which the run's log keeps)."""
        ...

    def external(self, t_s: float, live: bool) -> None:
        """Whether velocity commands are in force at this frame."""
        ...

    def sensors(self, t_s: float, lost: str | None) -> None:
        """The health policy's reason to brake at this frame, or None."""
        ...

    def lidar_lost(self, reason: str) -> None:
        """The LiDAR's port failed."""
        ...


_CONFORMS: dict[tuple[type, type], bool] = {}  # (a mission's class, protocol) -> conforms


def _conforms(mission: object, protocol: type) -> bool:
    """``isinstance(mission, protocol)`` for a runtime-checkable protocol, asked once per class:
    the check looks up every member of the protocol (about 10 us), and the frame loop asks it
    several times a frame. A mission's members are its class's methods and the attributes its
    constructor sets, the same for every instance of the class."""
    key = (type(mission), protocol)
    hit = _CONFORMS.get(key)
    if hit is None:
        hit = _CONFORMS[key] = isinstance(mission, protocol)
    return hit


def is_service(mission: object) -> TypeGuard[ServiceMission]:
    """Whether ``mission`` is a :class:`ServiceMission` (cached per class)."""
    return _conforms(mission, ServiceMission)


def is_scan(mission: object) -> TypeGuard[ScanMission]:
    """Whether ``mission`` is a :class:`ScanMission` (cached per class)."""
    return _conforms(mission, ScanMission)
