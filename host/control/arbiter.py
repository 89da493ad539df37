"""Command arbitration: which velocity command a telemetry frame gets.

A mission's command when the daemon runs one, held at zero (braked) while the mission's guard
or the sensors forbid it; otherwise the newest external command (``/cmd_vel``, submitted from
any thread and taken at the next telemetry frame, stamped on MCU time), braked once it is older
than the watchdog (``cmd_vel_timeout_s``, 0.6 s) or when the sensors are lost. The rules are in
:meth:`CommandArbiter.command`; docs/host.md, "What happens per telemetry frame", step 3.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from jackson.host.actuation.watchdog import CommandWatchdog
from jackson.host.control.base import Mission, NavState, ServiceMission, TimedMission, is_service
from jackson.host.control.guard import MissionGuard


@dataclass(frozen=True)
class Conditions:
    """What the sensors allow at this frame.

    Attributes
    ----------
    imu_ok : bool
        The frame carries an IMU sample.
    bias_known : bool
        The gyro bias is known (or the IMU is excluded: wheel-only yaw).
    counts : tuple of int
        The frame's encoder counts as sent (the guard's stall test).
    wheel_cmd : tuple of float
        The wheel speeds commanded at the previous frame [rad/s].
    sensors_lost : str or None
        The health policy's reason to brake.
    lidar_blind : bool
        No usable scan for too long (a navigation waits, braked).
    """

    imu_ok: bool
    bias_known: bool
    counts: tuple[int, int]
    wheel_cmd: tuple[float, float]
    sensors_lost: str | None
    lidar_blind: bool


class CommandArbiter:
    """The command of each frame (module docstring).

    Parameters
    ----------
    watchdog_s : float
        An external command's lifetime [s].
    mission : Mission or None
        The mission the daemon runs.
    mission_timeout_s : float or None
        The mission guard's time limit (None: the mission's own).
    sensor_rules : bool
        The guard applies its own sensor rules (when the health monitor is off).
    """

    def __init__(
        self,
        watchdog_s: float,
        mission: Mission | None,
        mission_timeout_s: float | None,
        sensor_rules: bool,
    ) -> None:
        self.mission = mission
        # a service's goals have their own timeout and end, not the process
        if mission_timeout_s is None and isinstance(mission, TimedMission):
            mission_timeout_s = mission.timeout_s
        self.guard = (
            MissionGuard(mission.name, mission_timeout_s, sensor_rules=sensor_rules)
            if mission is not None and not isinstance(mission, ServiceMission)
            else None
        )
        self.watchdog = CommandWatchdog(watchdog_s)
        self.external: tuple[float, float] = (0.0, 0.0)  # the newest external command in force
        self._pending: tuple[float, float, int] | None = None  # submitted, not yet taken
        self._taken: tuple[float, float, int] | None = None  # taken at this frame
        # the last frame's command was an external one (the wheel-speed loop's rule)
        self.external_in_force = False

    def __getstate__(self) -> dict[str, object]:
        """The arbiter's state for a core's snapshot (docs/recording.md): a command submitted
        and not yet taken stays out (the next frame takes it, logged in the next run folder)."""
        state = dict(self.__dict__)
        state["_pending"] = None
        return state

    def submit(self, v_m_s: float, w_rad_s: float, host_time_ns: int) -> None:
        """An external velocity command; safe from another thread. A NaN is dropped: it must
        never become a duty."""
        if math.isfinite(v_m_s) and math.isfinite(w_rad_s):
            self._pending = (v_m_s, w_rad_s, host_time_ns)

    def take(self, telemetry: bool) -> tuple[float, float, int] | None:
        """At each frame, on the core's thread: the submitted command a telemetry frame takes
        (logged before the frame that applies it, so a replay applies it to the same frame)."""
        self._taken = None
        if telemetry and self._pending is not None:
            self._taken, self._pending = self._pending, None
        return self._taken

    def command(
        self,
        t_s: float,
        c: Conditions,
        abort_reason: str | None,
        abort: Callable[[str], None],
        nav_state: Callable[[], NavState],
    ) -> tuple[float, float, bool]:
        """(v [m/s], w [rad/s], brake) for the frame at MCU time ``t_s``.

        Parameters
        ----------
        t_s : float
            MCU time [s].
        c : Conditions
            What the sensors allow.
        abort_reason : str or None
            The mission was aborted (braked for good).
        abort : callable
            Aborts the mission, naming why.
        nav_state : callable
            The estimate a mission steers by.
        """
        if self._taken is not None:
            self.external = (self._taken[0], self._taken[1])
            self._taken = None
            self.watchdog.feed(t_s)
        self.external_in_force = False
        mission = self.mission
        if is_service(mission):
            return self._serve(mission, t_s, c, nav_state)
        if mission is not None:
            if abort_reason is not None:
                return 0.0, 0.0, True
            if c.sensors_lost is not None:
                abort(c.sensors_lost)
                return 0.0, 0.0, True
            if self.guard is not None and not mission.done:
                reason = self.guard.check(t_s, c.imu_ok, c.bias_known, c.counts, c.wheel_cmd)
                if reason is not None:
                    abort(reason)
                    return 0.0, 0.0, True
            if not c.bias_known:
                return 0.0, 0.0, True  # stand still until the gyro bias is known
            v, w = mission.command(nav_state())
            if mission.done:
                # the stop is shaped by the limiter's deceleration like any command, and
                # braked once the wheels are commanded still
                return 0.0, 0.0, c.wheel_cmd == (0.0, 0.0)
            if c.lidar_blind:
                return 0.0, 0.0, True  # no usable scan for too long: braked until one comes
            return v, w, False
        if self.watchdog.expired(t_s) or c.sensors_lost is not None:
            return 0.0, 0.0, True
        self.external_in_force = True
        return self.external[0], self.external[1], False

    def _serve(
        self, service: ServiceMission, t_s: float, c: Conditions, nav_state: Callable[[], NavState]
    ) -> tuple[float, float, bool]:
        """The navigation service's frame (as twist_mux in a Nav2 bringup): velocity commands
        in force win and end an active goal; lost sensors brake and end it; else the service's
        command, braked while it is idle (once the limiter has ramped the wheels to zero)."""
        external = not self.watchdog.expired(t_s) and c.sensors_lost is None
        service.sensors(t_s, c.sensors_lost)
        service.external(t_s, external)
        if not c.bias_known and not external:
            service.command(nav_state())  # the requests are taken; the robot stands still
            return 0.0, 0.0, True
        v, w = service.command(nav_state())
        if c.sensors_lost is not None:
            return 0.0, 0.0, True
        if external:
            self.external_in_force = True
            return self.external[0], self.external[1], False
        if service.idle:
            return 0.0, 0.0, c.wheel_cmd == (0.0, 0.0)
        if c.lidar_blind:
            return 0.0, 0.0, True  # no usable scan for too long: braked until one comes
        return v, w, False
